"""docs/tutorial.md and README's tour work as written: their shell blocks run in order in one shell, their Python
blocks after them, and what they promise holds (a model that predicts the new motion, its files, the control
loop's report)."""
import csv
import os
import pathlib
import re
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "tutorial.md"


def blocks(language, page=TUTORIAL, after=""):
    text = page.read_text()
    return re.findall(r"```" + language + r"\n(.*?)```", text[text.index(after):], re.S)


def read_columns(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {name: np.array([float(r[name]) for r in rows]) for name in rows[0]}


def test_tutorial_runs_as_written(tmp_path, gipdyn_bin):
    build = pathlib.Path(gipdyn_bin).resolve().parent
    if not (build / "control_loop").exists() or not (build / "python" / "gipdyn").exists():
        pytest.skip("the tutorial needs the examples and the Python module built beside gipdyn")
    # The tutorial's paths are those of a folder beside build/: give it one.
    (tmp_path / "build").symlink_to(build)
    shell = "set -euo pipefail\ncd " + str(tmp_path) + "\n" + "\n".join(blocks("bash"))
    r = subprocess.run(["bash", "-c", shell], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    work = tmp_path / "my-first-model"
    # What the tutorial says each step leaves behind.
    for name in ("train.csv", "train.csv.json", "test.csv", "scara.gipdyn", "diag/torque_time.png",
                 "diag/residuals.png", "predicted.csv", "physics.csv"):
        assert (work / name).exists(), name
    assert "p50" in r.stdout and "p99" in r.stdout and "gravity at q" in r.stdout, r.stdout[-2000:]
    # The model predicts the motion it never saw: each joint's nMSE against the noise-free torque.
    predicted, test = read_columns(work / "predicted.csv"), read_columns(work / "test.csv")
    for j in range(1, 5):
        truth = test[f"tau{j}_true"]
        nmse = np.mean((predicted[f"tau{j}_hat"] - truth) ** 2) / np.var(truth)
        assert nmse < 0.05, (j, nmse)
        assert np.all(predicted[f"tau{j}_std"] > 0), j
    (python_block,) = blocks("python")
    env = dict(os.environ, PYTHONPATH=str(build / "python"))
    r = subprocess.run(["/usr/bin/python3", "-c", python_block], cwd=work, env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0 and "nMSE per joint on the measured torques:" in r.stdout, r.stdout + r.stderr


def test_readme_tour_runs_as_written(tmp_path, gipdyn_bin):
    build = pathlib.Path(gipdyn_bin).resolve().parent
    if not (build / "python" / "gipdyn").exists():
        pytest.skip("README's Python block needs the Python module built beside gipdyn")
    (tmp_path / "build").symlink_to(build)
    readme = ROOT / "README.md"
    tour = blocks("bash", readme, "## A five-minute tour")[0]
    r = subprocess.run(["bash", "-c", "set -euo pipefail\n" + tour], cwd=tmp_path, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    for name in ("scara.gipdyn", "diag/torque_time.png", "predicted.csv", "physics.csv"):
        assert (tmp_path / name).exists(), name
    assert "mean nMSE" in r.stdout, r.stdout[-2000:]
    (python_block,) = blocks("python", readme)
    (tmp_path / "scara.gipdyn").unlink()
    env = dict(os.environ, PYTHONPATH=str(build / "python"))
    r = subprocess.run(["/usr/bin/python3", "-c", python_block], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0 and (tmp_path / "scara.gipdyn").exists(), r.stdout + r.stderr
