"""`gipdyn inspect`: torques at revisited states, within a log and between training and test rows."""
import json
import subprocess

import numpy as np
import pytest

from conftest import two_link_torques


def run(binary, *args):
    return subprocess.run([binary, *args], capture_output=True, text=True, timeout=300)


def periodic_log(path, seconds, seed, payload=0.0, noise=0.01):
    """A 2R arm on a 10 s periodic motion, sampled at 100 Hz; payload adds torque on joint 2 only."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, seconds, 0.01)
    w = 2 * np.pi / np.array([5.0, 10.0])
    q = np.sin(np.outer(t, w)) + 0.3 * np.sin(3 * np.outer(t, w) + [0, 1])
    qd = w * np.cos(np.outer(t, w)) + 0.9 * w * np.cos(3 * np.outer(t, w) + [0, 1])
    qdd = -w**2 * np.sin(np.outer(t, w)) - 2.7 * w**2 * np.sin(3 * np.outer(t, w) + [0, 1])
    tau = two_link_torques(q, qd, qdd)
    tau[:, 1] += payload * 9.81 * 0.5 * np.cos(q[:, 0] + q[:, 1])
    tau += noise * rng.standard_normal(tau.shape)
    header = "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2"
    np.savetxt(path, np.column_stack([q, qd, qdd, tau]), delimiter=",", header=header, comments="")


def test_inspect_flags_a_test_log_with_another_payload(tmp_path, gipdyn_bin):
    periodic_log(tmp_path / "train.csv", 30, seed=1)
    periodic_log(tmp_path / "same.csv", 20, seed=2)
    periodic_log(tmp_path / "payload.csv", 20, seed=3, payload=2.0)
    same = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "train.csv"), "--joints", "RR",
               "--test", str(tmp_path / "same.csv"), "--out", str(tmp_path / "same.json"))
    assert same.returncode == 0, same.stderr
    assert "another function" not in same.stdout
    report = json.loads((tmp_path / "same.json").read_text())
    assert report["within_training"]["status"] == "ok"
    assert max(report["training_to_test"]["neighbour_nmse"]) < 0.05

    changed = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "train.csv"), "--joints", "RR",
                  "--test", str(tmp_path / "payload.csv"), "--out", str(tmp_path / "payload.json"),
                  "--plot", str(tmp_path / "payload.png"))
    assert changed.returncode == 0, changed.stderr
    assert "joint 2: at states both logs visit" in changed.stdout
    assert "joint 1: at states" not in changed.stdout
    report = json.loads((tmp_path / "payload.json").read_text())
    nmse = report["training_to_test"]["neighbour_nmse"]
    assert nmse[0] < 0.05 and nmse[1] > 1.0
    assert (tmp_path / "payload.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_inspect_compares_revolute_positions_on_the_circle(tmp_path, gipdyn_bin):
    # The test log is the same motion with joint 1 one turn further on (a continuous joint, unwrapped): for the
    # 2R arm's dynamics the same states, so the test rows find their neighbours and agree with them.
    periodic_log(tmp_path / "train.csv", 30, seed=1)
    periodic_log(tmp_path / "test.csv", 20, seed=2)
    data = np.loadtxt(tmp_path / "test.csv", delimiter=",", skiprows=1)
    data[:, 0] += 2 * np.pi
    np.savetxt(tmp_path / "turned.csv", data, delimiter=",", header="q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2", comments="")
    r = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "train.csv"), "--joints", "RR",
            "--test", str(tmp_path / "turned.csv"), "--out", str(tmp_path / "turned.json"))
    assert r.returncode == 0, r.stderr
    assert "revolute positions on the circle" in r.stdout
    report = json.loads((tmp_path / "turned.json").read_text())
    assert report["training_to_test"]["status"] == "ok", report["training_to_test"]
    assert max(report["training_to_test"]["neighbour_nmse"]) < 0.05


def test_inspect_rows_of_one_log_and_too_few_pairs(tmp_path, gipdyn_bin):
    periodic_log(tmp_path / "log.csv", 30, seed=4)
    r = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "log.csv"), "--joints", "RR",
            "--train-rows", "1-2000", "--test-rows", "2001-3000", "--min-separation-rows", "1500")
    assert r.returncode == 0, r.stderr
    # 1000 test rows (10 s) hold no pair of rows 1500 apart: the report says so in the command's own terms.
    assert "within test: only 0 of 1000 query rows" in r.stdout
    assert "--radius" in r.stdout and "NeighbourConsistencyOptions" not in r.stdout
    overlap = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "log.csv"), "--joints", "RR",
                  "--train-rows", "1-2000", "--test-rows", "1501-3000")
    assert overlap.returncode == 0 and "500 test rows are also training rows" in overlap.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["--radius", "0"], "--radius must be a finite number > 0"),
        (["--train-rows", "1-2000", "--test-rows", "2001-9000"], "--test-rows 2001-9000: the log has only 3000 data rows"),
        (["--joints", "RRR"], "joint"),
        (["--test-rows", "2001-3000"], "--test-rows needs --train-rows"),
    ],
)
def test_inspect_bad_input(tmp_path, gipdyn_bin, args, message):
    periodic_log(tmp_path / "log.csv", 30, seed=5)
    joints = args[1] if args[0] == "--joints" else "RR"
    extra = [] if args[0] == "--joints" else args
    r = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "log.csv"), "--joints", joints,
            "--out", str(tmp_path / "r.json"), *extra)
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], r.stderr
    assert not (tmp_path / "r.json").exists()


def test_inspect_plot_needs_the_report(tmp_path, gipdyn_bin):
    periodic_log(tmp_path / "log.csv", 30, seed=6)
    r = run(gipdyn_bin, "inspect", "--data", str(tmp_path / "log.csv"), "--joints", "RR",
            "--plot", str(tmp_path / "p.png"))
    assert r.returncode != 0 and "--plot draws the report of --out" in r.stderr
    assert not (tmp_path / "p.png").exists()
