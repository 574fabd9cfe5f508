#!/usr/bin/env python3
"""Builds the C and C++ API reference with Doxygen and checks that it documents the headers.

    check_api_docs.py DOXYGEN DOXYFILE OUTPUT_DIR SOURCE_DIR

Fails (exit 1, naming what is wrong) when Doxygen fails or warns, when a public
header's own comment is missing from its page, or when a class or struct that a
public header defines has no page or lacks the comment written above it: what
the reference would lose if the input filter (docs/api/doxygen_filter.py) or a
header's comments broke.
"""
import html
import pathlib
import re
import subprocess
import sys

doxygen, doxyfile, out_dir, source = sys.argv[1], sys.argv[2], pathlib.Path(sys.argv[3]), pathlib.Path(sys.argv[4])
run = subprocess.run([doxygen, doxyfile], capture_output=True, text=True)
if run.returncode != 0:
    sys.exit(f"doxygen failed (exit {run.returncode}): {run.stderr.strip()}")
warnings = (out_dir / "warnings.log").read_text().strip()
if warnings:
    sys.exit(f"doxygen warned; fix the comments it names (or docs/api/doxygen_filter.py):\n{warnings}")


def words(text):
    return " ".join(text.split())


def page_text(path):
    inline_links = re.sub(r"</?a\b[^>]*>", "", path.read_text(encoding="utf-8"))
    return words(html.unescape(re.sub(r"<[^>]+>", " ", inline_links)))


def comment_lines(lines, end):
    """The // comment lines right above line `end` (exclusive), as text."""
    block = []
    i = end - 1
    while i >= 0 and re.match(r"^\s*//(?!/)", lines[i]):
        block.insert(0, re.sub(r"^\s*//\s?", "", lines[i]))
        i -= 1
    return block


html_dir = out_dir / "html"
file_pages = " ".join(page_text(p) for p in html_dir.glob("*_8h*.html") if not p.name.endswith("_source.html"))
problems, classes = [], 0
headers = [h for h in sorted((source / "include" / "gipdyn").rglob("*.h*")) if "detail" not in h.parts]
for header in headers:
    name = header.relative_to(source)
    lines = header.read_text(encoding="utf-8").split("\n")
    if "#pragma once" in lines:
        first = lines.index("#pragma once") + 1
        own = [re.sub(r"^//\s?", "", l) for l in lines[first:first + 1] if l.startswith("//")]
        if own and words(own[0]) not in file_pages:
            problems.append(f"{name}: its comment ({own[0][:60]!r}) is not on its file page")
    depth = 0
    for n, line in enumerate(lines):
        m = re.match(r"^(class|struct) (?:GIPDYN_\w+ )?(\w+)\b(?!.*;\s*$)", line)
        if m and depth == 1:
            kind, cls = m.groups()
            classes += 1
            page = html_dir / f"{kind}gipdyn_1_1{cls}.html"
            if not page.exists():
                problems.append(f"{name}:{n + 1}: {kind} {cls} has no page ({page.name})")
                continue
            above = comment_lines(lines, n)
            if above and words(above[0])[:50] not in page_text(page):
                problems.append(f"{name}:{n + 1}: the comment above {cls} ({above[0][:50]!r}) is not on its page")
        if line.startswith("namespace gipdyn {"):
            depth += 1
        elif line.startswith("}  // namespace gipdyn"):
            depth -= 1
if classes == 0:
    problems.append("no class or struct found in the public headers: the check itself is broken")
if problems:
    sys.exit("API reference incomplete:\n" + "\n".join(problems))
print(f"API reference: {len(headers)} headers, {classes} classes and structs documented in {html_dir}")
