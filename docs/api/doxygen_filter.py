#!/usr/bin/env python3
"""Doxygen input filter: reads a public header's plain comments as its documentation.

    doxygen_filter.py HEADER   (Doxygen's INPUT_FILTER; prints the filtered header)

The headers state their contracts in ordinary comments (// and /* */), which
Doxygen would skip. This filter hands Doxygen the same text as documentation
comments, leaving the files as they are:
- the comment block right after `#pragma once` documents the file (\\file);
- a comment line or block before a declaration documents it (// -> ///, /* -> /**);
- a comment after a member or enumerator on its line documents that member (///<);
- <name>, #name, A::b and -- in a comment stay text (not an HTML tag, a link or a dash).
"""
import re
import sys

LEADING = re.compile(r"^(\s*)//(?![/!])\s?(.*)$")
TRAILING = re.compile(r"^(?!\s*#)(.*?[;,])(\s+)//(?![/!])\s?(.*)$")
BLOCK = re.compile(r"^(\s*)/\*(?![*!])")
# Comment text that Doxygen would read as markup: <name> as an HTML tag,
# #name and A::b as links to resolve, -- as a dash. Entities and escapes keep
# it text; Doxygen takes "quoted text" as it is already.
MARKUP = [(re.compile(r"<"), "&lt;"), (re.compile(r">"), "&gt;"), (re.compile(r"#(?=\w)"), r"\\#"),
          (re.compile(r"::"), r"\\::"), (re.compile(r"--"), r"\\--")]
QUOTED = re.compile(r'("[^"]*")')


def as_text(comment):
    parts = QUOTED.split(comment)
    for i in range(0, len(parts), 2):  # the parts outside quotes
        for pattern, escaped in MARKUP:
            parts[i] = pattern.sub(escaped, parts[i])
    return "".join(parts)


def filtered(lines):
    out, file_block, after_pragma = [], False, False
    for line in lines:
        leading = LEADING.match(line)
        if after_pragma and leading and not file_block:  # the file's own comment
            out.append("/// \\file")
            file_block = True
        if line.strip() == "#pragma once":
            after_pragma = True
            out.append(line)
            continue
        if leading:
            out.append(f"{leading.group(1)}/// {as_text(leading.group(2))}")
        elif TRAILING.match(line):
            code, space, text = TRAILING.match(line).groups()
            out.append(f"{code}{space}///< {as_text(text)}")
        elif BLOCK.match(line):
            out.append(BLOCK.sub(r"\1/**", line, count=1))
        else:
            out.append(line)
        if not leading:
            after_pragma = after_pragma and line.strip() == ""
    return out


if __name__ == "__main__":
    with open(sys.argv[1], encoding="utf-8") as f:
        sys.stdout.write("\n".join(filtered(f.read().split("\n"))))
