"""The how-to guides' commands run as written: every bash block of a guide runs in order in one shell, in a folder
beside build/, at smaller sizes (the sizes below), and leaves the files the guide says it does. A block preceded by
`<!-- not run by the test: REASON -->` is left out, with its reason on the page."""
import os
import pathlib
import re
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# Smaller sizes, the same commands: option -> the value the test runs with (the smaller of it and the page's).
SMALLER = {"--samples": 1000, "--runs": 1, "--train-samples": 300, "--test-samples": 300, "--seconds": 2, "--contacts": 5}
SIZES = "50,100"  # --sizes of a learning curve
EXPERIMENT_SMALLER = {"--samples": 300}  # an experiment trains every model of each run


def runnable_blocks(page, language="bash"):
    text = page.read_text()
    found = []
    for m in re.finditer(r"(<!-- not run by the test: [^>]*-->\n)?```" + language + r"\n(.*?)```", text, re.S):
        if not m.group(1):
            found.append(m.group(2))
    return found


def smaller_python(block):
    """simulate(..., samples=N) at most SMALLER's --samples."""
    return re.sub(r"samples=(\d+)", lambda m: f"samples={min(int(m.group(1)), SMALLER['--samples'])}", block)


def smaller(block):
    lines = []
    for line in re.split(r"(?<!\\)\n", block):  # whole commands, continuation lines included
        for option, value in SMALLER.items():
            if line.lstrip().startswith("build/gipdyn experiment") and option in EXPERIMENT_SMALLER:
                value = EXPERIMENT_SMALLER[option]
            line = re.sub(re.escape(option) + r" (\d+(\.\d+)?)",
                          lambda m: f"{option} {min(float(m.group(1)), value):g}", line)
        lines.append(re.sub(r"--sizes [\d,]+", "--sizes " + SIZES, line))
    return "\n".join(lines)


def test_command_line_guide_runs_as_written(tmp_path, gipdyn_bin):
    build = pathlib.Path(gipdyn_bin).resolve().parent
    (tmp_path / "build").symlink_to(build)
    page = ROOT / "docs" / "guide" / "command-line.md"
    blocks = runnable_blocks(page)
    assert len(blocks) >= 8, "the guide's bash blocks were not found"
    shell = "set -euo pipefail\n" + "\n".join(smaller(b) for b in blocks)
    r = subprocess.run(["bash", "-c", shell], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    # What the guide says the commands leave behind.
    for name in ("train.csv.json", "scara.gipdyn", "predicted.csv", "report.json", "diag/torque_time.png",
                 "physics.csv", "motion.csv", "motion.png", "gp-updated.gipdyn", "short.gipdyn", "detected.csv",
                 "detected.png", "data.csv", "data.csv.json", "inspect.json", "inspect.png", "e1/summary.md",
                 "e2/summary.md", "ctl/summary.md", "contact-scara/summary.md"):
        assert (tmp_path / name).exists(), name


def test_the_guides_runnable_blocks_are_the_ones_marked(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```bash\necho a\n```\n<!-- not run by the test: it needs X -->\n```bash\necho b\n```\n")
    assert runnable_blocks(page) == ["echo a\n"]
    assert smaller("build/gipdyn simulate --samples 2000 --dt 0.01 --seconds 20 --sizes 100,200,500") == \
        "build/gipdyn simulate --samples 1000 --dt 0.01 --seconds 2 --sizes 50,100"
    assert smaller("build/gipdyn experiment accuracy --runs 20 \\\n  --samples 2000\nx --samples 500") == \
        "build/gipdyn experiment accuracy --runs 1 \\\n  --samples 300\nx --samples 500"


def test_python_guide_runs_as_written(tmp_path, gipdyn_bin):
    build = pathlib.Path(gipdyn_bin).resolve().parent
    if not (build / "python" / "gipdyn").exists():
        pytest.skip("the Python guide needs the Python module built beside gipdyn")
    (tmp_path / "build").symlink_to(build)
    page = ROOT / "docs" / "guide" / "python.md"
    # The shell blocks make the files the Python blocks read; the quickstart example runs from the repository.
    shell = "set -euo pipefail\n" + "\n".join(smaller(b) for b in runnable_blocks(page) if "examples/" not in b)
    r = subprocess.run(["bash", "-c", shell], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    python = runnable_blocks(page, "python")
    assert len(python) >= 4, "the guide's Python blocks were not found"
    env = dict(os.environ, PYTHONPATH=str(build / "python"))
    r = subprocess.run(["/usr/bin/python3", "-c", "\n".join(smaller_python(b) for b in python)], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert (tmp_path / "scara.gipdyn").exists()
