"""The how-to guides' commands run as written: a page's bash blocks run in order in one shell, in a folder beside
build/ (and with build/ on PATH, for pages that call an installed `gipdyn`), then its Python blocks as one script,
at smaller sizes (below); each test checks the files its page says the commands leave. A block preceded by
`<!-- not run by the test: REASON -->` is left out, with its reason on the page, and every other block of every
guide must be one these tests run."""
import os
import pathlib
import re
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
# Every how-to page, and whether a test below runs it.
GUIDES = sorted((DOCS / "guide").glob("*.md")) + [DOCS / "choosing-a-model.md", DOCS / "distributed.md",
                                                   DOCS / "contact-detection.md"]
RUNNABLE = ("bash", "python")

# Smaller sizes, the same commands: option -> the value the test runs with (the smaller of it and the page's).
SMALLER = {"--samples": 1000, "--runs": 1, "--train-samples": 300, "--test-samples": 300, "--seconds": 2,
           "--contacts": 5}
SIZES = "50,100"  # --sizes of a learning curve
EXPERIMENT_SMALLER = {"--samples": 300}  # an experiment trains every model of each run
PYTHON_SAMPLES, PYTHON_CONTACTS = 600, 3  # simulate(samples=..., contacts=...) in a Python block
NOT_RUN = r"<!-- not run by the test: [^>]*-->\n"


def fenced_blocks(page):
    """(language, text, marked not run) of every fenced block of the page, in order."""
    return [(m.group(2), m.group(3), bool(m.group(1)))
            for m in re.finditer(r"(" + NOT_RUN + r")?```(\w*)\n(.*?)```", page.read_text(), re.S)]


def runnable_blocks(page, language="bash"):
    return [text for lang, text, marked in fenced_blocks(page) if lang == language and not marked]


def smaller_python(block):
    """simulate(..., samples=N, contacts=C) at most PYTHON_SAMPLES and PYTHON_CONTACTS."""
    block = re.sub(r"samples=(\d+)", lambda m: f"samples={min(int(m.group(1)), PYTHON_SAMPLES)}", block)
    return re.sub(r"contacts=(\d+)", lambda m: f"contacts={min(int(m.group(1)), PYTHON_CONTACTS)}", block)


def smaller(block):
    lines = []
    for line in re.split(r"(?<!\\)\n", block):  # whole commands, continuation lines included
        for option, value in SMALLER.items():
            if re.match(r"\s*(build/)?gipdyn experiment", line) and option in EXPERIMENT_SMALLER:
                value = EXPERIMENT_SMALLER[option]
            line = re.sub(re.escape(option) + r" (\d+(\.\d+)?)",
                          lambda m: f"{option} {min(float(m.group(1)), value):g}", line)
        line = re.sub(r"--sizes [\d,]+", "--sizes " + SIZES, line)
        lines.append(line.replace("mpirun -np", "mpirun --oversubscribe -np"))  # a machine with fewer cores
    return "\n".join(lines)


def run_page(page, folder, gipdyn_bin, skip_bash=()):
    """Runs the page's bash blocks (but those containing a string of skip_bash), then its Python blocks."""
    build = pathlib.Path(gipdyn_bin).resolve().parent
    (folder / "build").symlink_to(build)
    env = dict(os.environ, PATH=f"{build}:{os.environ['PATH']}", PYTHONPATH=str(build / "python"))
    bash = [smaller(b) for b in runnable_blocks(page) if not any(s in b for s in skip_bash)]
    r = subprocess.run(["bash", "-c", "set -euo pipefail\n" + "\n".join(bash)], cwd=folder, env=env,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    python = runnable_blocks(page, "python")
    if python:
        if not (build / "python" / "gipdyn").exists():
            pytest.skip(f"{page.name}'s Python blocks need the Python module built beside gipdyn")
        r = subprocess.run(["/usr/bin/python3", "-c", "\n".join(smaller_python(b) for b in python)], cwd=folder,
                           env=env, capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return len(bash), len(python)


def expect_files(folder, *names):
    for name in names:
        assert (folder / name).exists(), name


def test_command_line_guide_runs_as_written(tmp_path, gipdyn_bin):
    bash, _ = run_page(DOCS / "guide" / "command-line.md", tmp_path, gipdyn_bin)
    assert bash >= 8, "the guide's bash blocks were not found"
    expect_files(tmp_path, "train.csv.json", "scara.gipdyn", "predicted.csv", "report.json", "diag/torque_time.png",
                 "physics.csv", "motion.csv", "motion.png", "gp-updated.gipdyn", "short.gipdyn", "detected.csv",
                 "detected.png", "data.csv", "data.csv.json", "inspect.json", "inspect.png", "e1/summary.md",
                 "e2/summary.md", "ctl/summary.md", "contact-scara/summary.md")


def test_python_guide_runs_as_written(tmp_path, gipdyn_bin):
    # The quickstart example runs from the repository, in the examples' test.
    _, python = run_page(DOCS / "guide" / "python.md", tmp_path, gipdyn_bin, skip_bash=("examples/",))
    assert python >= 4, "the guide's Python blocks were not found"
    expect_files(tmp_path, "scara.gipdyn", "log.csv")


def test_contact_detection_page_runs_as_written(tmp_path, gipdyn_bin):
    bash, python = run_page(DOCS / "contact-detection.md", tmp_path, gipdyn_bin)
    assert bash >= 1 and python >= 1
    expect_files(tmp_path, "scara.gipdyn", "detected.csv", "detected.png")


def test_distributed_page_runs_as_written(tmp_path, gipdyn_bin):
    version = subprocess.run([gipdyn_bin, "--version"], capture_output=True, text=True).stdout
    if "distributed training: MPI" not in version or not shutil.which("mpirun"):
        pytest.skip("gipdyn built without MPI, or no mpirun on PATH")
    os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    run_page(DOCS / "distributed.md", tmp_path, gipdyn_bin)
    expect_files(tmp_path, "arm.gipdyn")


def test_every_guide_block_is_run_or_says_why_not():
    run_here = {"command-line.md", "python.md", "contact-detection.md", "distributed.md"}
    for page in GUIDES:
        for language, text, marked in fenced_blocks(page):
            if marked:
                continue
            where = f"{page.relative_to(ROOT)}: the block beginning {text[:60]!r}"
            assert language in RUNNABLE, f"{where} is {language or 'unlabelled'}: mark it not run, with why"
            assert page.name in run_here, f"{where} is run by no test: add its page to a test here, or mark it"


def test_the_guides_runnable_blocks_are_the_ones_marked(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```bash\necho a\n```\n<!-- not run by the test: it needs X -->\n```bash\necho b\n```\n"
                    "```python\nx = 1\n```\n")
    assert runnable_blocks(page) == ["echo a\n"] and runnable_blocks(page, "python") == ["x = 1\n"]
    assert [marked for _, _, marked in fenced_blocks(page)] == [False, True, False]
    assert smaller("build/gipdyn simulate --samples 2000 --dt 0.01 --seconds 20 --sizes 100,200,500") == \
        "build/gipdyn simulate --samples 1000 --dt 0.01 --seconds 2 --sizes 50,100"
    assert smaller("build/gipdyn experiment accuracy --runs 20 \\\n  --samples 2000\nx --samples 500") == \
        "build/gipdyn experiment accuracy --runs 1 \\\n  --samples 300\nx --samples 500"
    assert smaller_python('simulate("scara", samples=5000, seed=3, contacts=5)') == \
        'simulate("scara", samples=600, seed=3, contacts=3)'
