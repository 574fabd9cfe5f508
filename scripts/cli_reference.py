#!/usr/bin/python3
"""Writes, or checks, the command-line reference: every command's own --help.

The reference (docs/reference/cli.md) is generated from the program, so it
cannot drift from it: the overview, then one section per command and per
subcommand of `experiment`, each the text `gipdyn ... --help` prints, with the
program's path written as `gipdyn`.

Usage:
  scripts/cli_reference.py GIPDYN_BIN --write docs/reference/cli.md
  scripts/cli_reference.py GIPDYN_BIN --check docs/reference/cli.md
--check exits 1, with a diff and the command that regenerates the file, when
the file differs from what the program prints.
"""
import difflib
import re
import subprocess
import sys

HEADER = """# Command-line reference

Every command of `gipdyn` and its options, as `gipdyn COMMAND --help` prints
them. Options take a value unless the help shows none (flags); `=VALUE` is the
default. The options a user needs first come first; each model's search
settings follow under an "Advanced" heading. Where to
start: the [tutorial](../tutorial.md) walks through the commands in order, and
[choosing a model](../choosing-a-model.md) says which estimator suits which
log.

This page is generated from the program (`scripts/cli_reference.py`); a test
checks that it matches.

## Exit codes

| Code | Meaning |
|------|---------|
| 0 | Everything asked for was done (and `gipdyn` alone, which prints the overview below). |
| 1 | Anything else went wrong: bad data, a value the command refuses (a negative count), a fit that failed, a plot not drawn (its numbers are written), an experiment with failed fits (the others stand). |
| 2 | The command line itself: an unknown command or option, an option's old name (the error gives the new one: `train --kernel` is `--model`, `experiment --estimators` is `--models`), a value not of the option's type, a required option missing, a file an option names that does not exist. |

Every error is one line on stderr, `gipdyn: error: ...`, naming the problem
and the fix; warnings are lines starting `gipdyn: warning:`.
"""


def help_text(binary, words):
    run = subprocess.run([binary, *words, "--help"], capture_output=True, text=True, check=False)
    if run.returncode != 0:
        sys.exit(f"cli_reference: `gipdyn {' '.join(words)} --help` exited with {run.returncode}: {run.stderr.strip()}")
    # The usage line names the program as it was called; the reference names it gipdyn.
    return re.sub(r"^Usage: \S+", "Usage: gipdyn", run.stdout.rstrip(), flags=re.MULTILINE) + "\n"


def subcommands(text):
    """The names listed under "Subcommands:" in a help text."""
    names, listing = [], False
    for line in text.splitlines():
        if line.startswith("Subcommands:"):
            listing = True
        elif listing and re.match(r"^  \S", line):
            names.append(line.split()[0])
        elif listing and line and not line.startswith(" "):
            listing = False
    return names


def reference(binary):
    sections = []

    def add(words):
        text = help_text(binary, words)
        title = " ".join(["gipdyn", *words])
        sections.append(f"## {title}\n\n```text\n{text}```\n")
        for name in subcommands(text):
            add([*words, name])

    add([])
    return HEADER + "\n" + "\n".join(sections)


def main():
    if len(sys.argv) != 4 or sys.argv[2] not in ("--write", "--check"):
        sys.exit(__doc__.strip())
    binary, mode, path = sys.argv[1:]
    generated = reference(binary)
    if mode == "--write":
        with open(path, "w", encoding="utf-8") as f:
            f.write(generated)
        return 0
    with open(path, encoding="utf-8") as f:
        stored = f.read()
    if stored == generated:
        return 0
    sys.stdout.writelines(difflib.unified_diff(stored.splitlines(True), generated.splitlines(True), path, "gipdyn --help"))
    print(f"\n{path} differs from the program's help: regenerate it with "
          f"scripts/cli_reference.py {binary} --write {path}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
