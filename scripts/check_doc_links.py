#!/usr/bin/python3
"""Checks that every relative link in README.md and docs/ resolves.

A link is a Markdown inline link or image, [text](target) or ![alt](target).
Links to the web (http:, https:, mailto:) are not followed. A relative target
must name a file or folder of the repository; with a #fragment, the file must
be Markdown and hold a heading whose anchor (GitHub's rule: lower case, spaces
to hyphens, punctuation dropped) is that fragment. Text inside code spans and
fenced code blocks is not a link. Exits 1 and lists every broken link with its
file and line.

Usage: scripts/check_doc_links.py [repository root]
"""
import os
import re
import sys

LINK = re.compile(r"!?\[(?:[^\]\\]|\\.)*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^\s*(```|~~~)")
CODE_SPAN = re.compile(r"`+[^`]*`+")
EXTERNAL = ("http://", "https://", "mailto:", "ftp://")


def markdown_files(root):
    yield os.path.join(root, "README.md")
    for folder, _, files in os.walk(os.path.join(root, "docs")):
        for name in sorted(files):
            if name.endswith(".md"):
                yield os.path.join(folder, name)


def prose_lines(path, keep_code_spans=False):
    """(line number, text) of the lines outside fenced code, code spans removed unless kept."""
    fenced = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if FENCE.match(line):
                fenced = not fenced
                continue
            if not fenced:
                yield number, line if keep_code_spans else CODE_SPAN.sub("", line)


def anchor(heading):
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors_of(path, cache={}):
    if path not in cache:
        found, counts = set(), {}
        for _, line in prose_lines(path, keep_code_spans=True):  # a heading's anchor keeps its code's text
            m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
            if not m:
                continue
            a = anchor(m.group(1))
            n = counts.get(a, 0)
            counts[a] = n + 1
            found.add(a if n == 0 else f"{a}-{n}")
        cache[path] = found
    return cache[path]


def broken_links(root):
    for path in markdown_files(root):
        if not os.path.exists(path):
            continue
        for number, line in prose_lines(path):
            for m in LINK.finditer(line):
                target = m.group(1)
                if target.startswith(EXTERNAL):
                    continue
                file_part, _, fragment = target.partition("#")
                resolved = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) if file_part else path
                where = f"{os.path.relpath(path, root)}:{number}: {target}"
                if not os.path.exists(resolved):
                    yield f"{where}: no file {os.path.relpath(resolved, root)}"
                elif fragment and resolved.endswith(".md") and fragment not in anchors_of(resolved):
                    yield f"{where}: no heading with anchor #{fragment} in {os.path.relpath(resolved, root)}"


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    broken = list(broken_links(root))
    for b in broken:
        print(b)
    if broken:
        print(f"{len(broken)} broken link(s): fix the target, or the heading it points to")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
