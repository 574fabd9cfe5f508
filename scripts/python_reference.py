#!/usr/bin/env python3
"""Writes or checks docs/reference/python.md: the Python module's public API from its own docstrings.

    PYTHONPATH=build/python /usr/bin/python3 scripts/python_reference.py --write docs/reference/python.md
    PYTHONPATH=build/python /usr/bin/python3 scripts/python_reference.py --check docs/reference/python.md

Every name of gipdyn.__all__, in that order: its signature and docstring; for a class, also the methods and
properties it defines itself (not those it inherits from scikit-learn or Python).
"""
import argparse
import inspect
import sys

import gipdyn

HEADER = """# Python reference

The `gipdyn` module's public API, from its own docstrings (`help(gipdyn.NAME)`
prints the same). How to use it: [Python](../guide/python.md); what the
options mean: the library's, whose fields the Python classes bind.

This page is generated from the module (`scripts/python_reference.py`); a
test checks that it matches.
"""


def signature(obj, name):
    try:
        return f"{name}{inspect.signature(obj)}"
    except (TypeError, ValueError):  # compiled functions without a Python signature: their doc's first line
        first = (obj.__doc__ or "").strip().splitlines()
        return first[0] if first and first[0].startswith(name.split(".")[-1] + "(") else name


def doc_of(obj):
    doc = inspect.getdoc(obj) or ""
    # pybind11 puts the signature on the doc's first line: it is the heading already.
    lines = doc.splitlines()
    if lines and "(" in lines[0] and lines[0].split("(")[0].isidentifier() and "->" in lines[0]:
        lines = lines[1:]
    return "\n".join(lines).strip()


def own_members(cls):
    """Public members that cls or its gipdyn bases define (not scikit-learn's or object's)."""
    seen = {}
    for base in reversed(cls.__mro__):
        if base.__module__.split(".")[0] != "gipdyn":
            continue
        for key, value in vars(base).items():
            if not key.startswith("_"):
                seen[key] = value
    return sorted(seen.items())


def section(name, obj):
    out = [f"## {name}", ""]
    if inspect.isclass(obj):
        init = vars(obj).get("__init__")
        out += ["```python", signature(init, name).replace("(self, ", "(").replace("(self)", "()")
                if init is not None and inspect.isfunction(init) else f"class {name}", "```", ""]
    elif callable(obj):
        out += ["```python", signature(obj, name), "```", ""]
    doc = doc_of(obj)
    if doc:
        out += [doc, ""]
    if inspect.isclass(obj):
        for key, member in own_members(obj):
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            if isinstance(member, property) or type(member).__name__ == "property":
                heading = f"`{name}.{key}` (property)"
            elif callable(member):
                heading = (f"`{signature(member, name + '.' + key)}`".replace("(self, ", "(").replace("(self)", "()")
                           .replace("(cls, ", "("))
            else:
                continue
            out += [f"### {heading}", ""]
            member_doc = doc_of(member)
            if member_doc:
                out += [member_doc, ""]
    return out


def render():
    lines = [HEADER]
    for name in gipdyn.__all__:
        lines += section(name, getattr(gipdyn, name))
    return "\n".join(lines).rstrip() + "\n"


parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
group = parser.add_mutually_exclusive_group(required=True)
group.add_argument("--write", metavar="FILE")
group.add_argument("--check", metavar="FILE")
args = parser.parse_args()
text = render()
if args.write:
    with open(args.write, "w") as f:
        f.write(text)
else:
    with open(args.check) as f:
        if f.read() != text:
            sys.exit(f"{args.check} differs from the module's docstrings: regenerate it with "
                     f"scripts/python_reference.py --write {args.check}")
