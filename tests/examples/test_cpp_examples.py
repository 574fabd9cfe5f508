"""The C++ examples (examples/cpp/) end to end, on small logs the command line simulates.

GIPDYN_EXAMPLES_DIR holds the built examples, GIPDYN_BIN the command line.
"""
import json
import math
import os
import subprocess

import numpy as np
import pytest

EXAMPLES = os.environ.get("GIPDYN_EXAMPLES_DIR")
GIPDYN = os.environ.get("GIPDYN_BIN")
pytestmark = pytest.mark.skipif(EXAMPLES is None or GIPDYN is None, reason="GIPDYN_EXAMPLES_DIR and GIPDYN_BIN not set")


def run(*args, timeout=300):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=timeout)


def example(name):
    return os.path.join(EXAMPLES, name)


def simulated_log(path, samples, seed=3):
    r = run(GIPDYN, "simulate", "--robot", "scara", "--samples", samples, "--seed", seed, "--out", path, "--quiet")
    assert r.returncode == 0, r.stderr
    return path


def assert_one_line_error(r, *words):
    assert r.returncode != 0 and r.stdout == "", (r.returncode, r.stdout)
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    for word in words:
        assert word in r.stderr, r.stderr


def test_quickstart_runs():
    r = run(example("quickstart"), 200, 20)
    assert r.returncode == 0, r.stderr
    assert "joint 4  nMSE" in r.stdout and "one sample" in r.stdout


def test_control_loop_queries_the_model_as_predict_does_without_allocating(tmp_path):
    log = simulated_log(tmp_path / "d.csv", 150)
    model = tmp_path / "m.gipdyn"
    assert run(GIPDYN, "train", "--data", log, "--max-iter", "20", "--teacher", "none", "--quiet", "--out",
               model).returncode == 0
    calls = 500
    r = run(example("control_loop_cpp"), model, calls)
    assert r.returncode == 0, r.stderr
    first = r.stdout.splitlines()[0]
    assert first.startswith(f"{calls} torque queries, 4 joints (gip, allocation-free): p50 "), r.stdout
    assert "gravity at q = 0.3:" in r.stdout and "inertia diagonal at q = 0.3:" in r.stdout
    # The example's motion, predicted by the command line: the same sum of joint 1's torques.
    t = 0.001 * np.arange(calls)[:, None]
    i = np.arange(4)[None, :]
    w = 0.5 + 0.1 * i
    states = np.hstack([0.5 * np.sin(w * t + i), 0.5 * w * np.cos(w * t + i), -0.5 * w * w * np.sin(w * t + i)])
    header = ",".join(f"{c}{j}" for c in ("q", "qd", "qdd") for j in range(1, 5))
    np.savetxt(tmp_path / "states.csv", states, delimiter=",", header=header, comments="", fmt="%.17g")
    r2 = run(GIPDYN, "predict", "--model", model, "--data", tmp_path / "states.csv", "--no-std", "--out",
             tmp_path / "tau.csv")
    assert r2.returncode == 0, r2.stderr
    predicted = np.loadtxt(tmp_path / "tau.csv", delimiter=",", skiprows=1)
    checksum = float(first.split("checksum ")[1].rstrip(")"))
    assert math.isclose(checksum, predicted[:, 0].sum(), rel_tol=1e-5, abs_tol=1e-6), (checksum, predicted[:, 0].sum())
    # A model without the rigid-body structure says so instead of printing physics.
    rbf = tmp_path / "rbf.gipdyn"
    assert run(GIPDYN, "train", "--data", log, "--model", "rbf", "--max-iter", "20", "--quiet", "--out",
               rbf).returncode == 0
    r = run(example("control_loop_cpp"), rbf, 100)
    assert r.returncode == 0, r.stderr
    assert "no gravity or inertia from a rbf model" in r.stdout and "gravity at" not in r.stdout
    # A missing or truncated model file, and a bad count: one line and a non-zero exit.
    assert_one_line_error(run(example("control_loop_cpp"), tmp_path / "none.gipdyn"), "none.gipdyn")
    (tmp_path / "cut.gipdyn").write_bytes(model.read_bytes()[:200])
    assert_one_line_error(run(example("control_loop_cpp"), tmp_path / "cut.gipdyn"), "cut.gipdyn")
    assert_one_line_error(run(example("control_loop_cpp"), model, 0), "CALLS must be at least 1")


def test_control_loop_trains_its_own_model_without_one(tmp_path):
    r = run(example("control_loop_cpp"), "-", 200)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("200 torque queries, 4 joints (gip, allocation-free): p50 "), r.stdout


def test_short_log_compares_gip_lip_and_the_taught_gip():
    r = run(example("short_log"), 200, 60, 200, 20)
    assert r.returncode == 0, r.stderr
    rows = {line.split("joints 1-4:")[0].strip(): line.split("joints 1-4:")[1].split()
            for line in r.stdout.splitlines() if "joints 1-4:" in line}
    assert list(rows) == ["GIP on the log", "LIP", "GIP taught by LIP"], r.stdout
    for values in rows.values():  # four finite nMSE values, then the query's p50
        assert all(math.isfinite(float(v)) for v in values[:4]) and values[4] == "p50", r.stdout
    noise = r.stdout.split("per joint:")[1].split("\n")[0].split()
    assert len(noise) == 4 and all(0.0 < float(v) < 0.1 for v in noise), r.stdout


def test_real_log_trains_the_preset_as_train_does(tmp_path):
    log = simulated_log(tmp_path / "log.csv", 400)
    r = run(example("real_log"), log, "RRPR", 301, 100, 0, 1)  # rows 1-300 train (100 of them), 301-400 test
    assert r.returncode == 0, r.stderr
    assert "100 training rows, 100 test rows" in r.stdout
    row = next(line for line in r.stdout.splitlines() if "preset real (gip-envelope+friction)" in line)
    example_nmse = [float(v) for v in row.split(")")[1].split()[:4]]
    assert not any(line.strip().startswith("gip ") for line in r.stdout.splitlines())  # SKIP_GIP
    # The same rows through the command line: train --preset real on rows 1-300 keeps 100, evaluate on 301-400
    # against the logged (noisy) torque, as the example does: without the noise-free columns evaluate would prefer.
    data = np.genfromtxt(log, delimiter=",", names=True)
    logged = [c for c in data.dtype.names if not c.endswith("_true")]
    for name, rows in (("train.csv", slice(0, 300)), ("test.csv", slice(300, 400))):
        np.savetxt(tmp_path / name, np.column_stack([data[c][rows] for c in logged]), delimiter=",",
                   header=",".join(logged), comments="", fmt="%.17g")
    model = tmp_path / "real.gipdyn"
    t = run(GIPDYN, "train", "--data", tmp_path / "train.csv", "--joints", "RRPR", "--preset", "real", "--subsample",
            100, "--quiet", "--out", model)
    assert t.returncode == 0, t.stderr
    e = run(GIPDYN, "evaluate", "--model", model, "--data", tmp_path / "test.csv", "--json", tmp_path / "e.json")
    assert e.returncode == 0, e.stderr
    with open(tmp_path / "e.json") as f:
        cli_nmse = json.load(f)["nmse"]
    np.testing.assert_allclose(example_nmse, cli_nmse, rtol=0, atol=6e-4)  # the example prints three decimals
    # Bad arguments: one line naming the problem, a non-zero exit, no table.
    assert_one_line_error(run(example("real_log"), log, "RRX", 301), "'X'")
    assert_one_line_error(run(example("real_log"), log, "RR", 301), "q1..q4", "length 4")
    assert_one_line_error(run(example("real_log"), log, "RRPR", 1), "SPLIT_ROW")
    assert_one_line_error(run(example("real_log"), log, "RRPR", 301, -5), "TRAIN_ROWS")
    assert_one_line_error(run(example("real_log"), tmp_path / "missing.csv", "RRPR", 301), "missing.csv")
