"""`gipdyn simulate --contacts` and `gipdyn detect`: contacts that act through a simulated SCARA's dynamics, found
again from its joint torques by a model learned on a contact-free log. The checks here read the CSVs themselves: the
true contacts are the runs of nonzero ext*_true, independent of the detector's own scoring."""
import csv
import json

import numpy as np
import pytest

from test_cli import run


def read(path):
    names = open(path).readline().strip().split(",")
    return names, np.loadtxt(path, delimiter=",", skiprows=1)


def runs(flags):
    """[first, last] row pairs of the runs where flags is true."""
    edges = np.diff(np.concatenate([[0], flags.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


@pytest.fixture(scope="module")
def logs(tmp_path_factory, gipdyn_bin):
    d = tmp_path_factory.mktemp("detect")
    for name, args in {"train": ["--samples", "400", "--dt", "0.1", "--seed", "1"],
                       "calibration": ["--samples", "2000", "--dt", "0.001", "--seed", "5"],
                       "contacts": ["--samples", "3000", "--dt", "0.001", "--seed", "4", "--contacts", "4"]}.items():
        r = run(gipdyn_bin, "simulate", "--robot", "scara", *args, "--out", str(d / (name + ".csv")))
        assert r.returncode == 0, r.stderr
    r = run(gipdyn_bin, "train", "--data", str(d / "train.csv"), "--model", "gip", "--teacher", "none",
            "--out", str(d / "gip.gipdyn"), "--quiet")
    assert r.returncode == 0, r.stderr
    return d


def test_simulated_contacts_are_written_beside_the_log(logs):
    names, data = read(logs / "contacts.csv")
    ext = data[:, [names.index(f"ext{j}_true") for j in range(1, 5)]]
    drawn = json.loads((logs / "contacts.csv.json").read_text())["contacts"]["drawn"]
    assert len(drawn) == 4
    for c in drawn:  # each contact acts on its joint, for 50 ms from its start
        rows = np.flatnonzero(ext[:, c["joint"] - 1] == c["torque"])
        assert abs(rows[0] * 0.001 - c["start_s"]) <= 0.001 and len(rows) == 50, (c, rows)
    # The log stays a log: train reads it (its extra columns ignored).
    assert "tau1" in names and "q4" in names


@pytest.mark.parametrize("method", ["residual", "momentum"])
def test_detect_finds_every_large_contact_and_nothing_else(logs, gipdyn_bin, method):
    out = logs / f"{method}.csv"
    r = run(gipdyn_bin, "detect", "--model", str(logs / "gip.gipdyn"), "--data", str(logs / "contacts.csv"),
            "--method", method, "--calibration", str(logs / "calibration.csv"), "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "noise from calibration" in r.stdout and "contacts detected" in r.stdout, r.stdout
    names, data = read(out)
    assert names[:5] == ["t", "ext1", "ext2", "ext3", "ext4"] and "contact4" in names and "margin1" in names
    assert data.shape[0] == 3000 and abs(data[1, 0] - 0.001) < 1e-12
    col = {n: i for i, n in enumerate(names)}
    for j in range(1, 5):
        truth = data[:, col[f"ext{j}_true"]]
        flagged = data[:, col[f"contact{j}"]] > 0
        contacts = runs(truth != 0)
        for first, last in contacts:
            if abs(truth[first]) < 10 * 0.01:  # below ten times the noise: a wrist's contact may be
                continue
            assert flagged[first:first + 20].any(), (j, first)  # within 20 ms
        # Every flagged run overlaps a true contact (the observer's decay after it included).
        for first, last in runs(flagged):
            assert any(f <= last and first <= l + 100 for f, l in contacts), (j, first, last)
        assert (np.abs(data[:, col[f"ext{j}"]]) > data[:, col[f"threshold{j}"]] - 1e-12).sum() >= flagged.sum()


def test_detect_plots_and_explains_bad_input(logs, gipdyn_bin):
    model, log = str(logs / "gip.gipdyn"), str(logs / "contacts.csv")
    r = run(gipdyn_bin, "detect", "--model", model, "--data", log, "--out", str(logs / "own.csv"),
            "--plot", str(logs / "own.png"))
    assert r.returncode == 0, r.stderr
    assert "noise from model" in r.stdout
    assert (logs / "own.png").read_bytes()[:4] == b"\x89PNG"
    for args, message, code in [
        (["--false-alarm-rate", "1.5"], "--false-alarm-rate must lie in (0, 1)", 1),
        (["--method", "kalman"], "unknown contact detection method 'kalman'; choose residual or momentum", 1),
        (["--method", "momentum", "--momentum-gain", "5000"], "--momentum-gain times --dt is 5", 1),
        (["--dt", "-1"], "--dt must be the rows' sampling period", 1),
    ]:
        r = run(gipdyn_bin, "detect", "--model", model, "--data", log, "--out", str(logs / "bad.csv"), *args)
        assert r.returncode == code and message in r.stderr, (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert not (logs / "bad.csv").exists()
    # A log whose sampling period is unknown: no sidecar.
    bare = logs / "bare.csv"
    bare.write_text((logs / "contacts.csv").read_text())
    r = run(gipdyn_bin, "detect", "--model", model, "--data", str(bare), "--out", str(logs / "bad.csv"))
    assert r.returncode == 1 and "give it with --dt SECONDS" in r.stderr, r.stderr


def test_contact_experiment_scores_every_model_and_method_against_the_true_dynamics(tmp_path, gipdyn_bin):
    out = tmp_path / "contact"
    r = run(gipdyn_bin, "experiment", "contact", "--robot", "scara", "--models", "gip", "--train-samples", "300",
            "--seconds", "3", "--contacts", "4", "--contact-size", "0.3", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rows = {(x["model"], x["method"]): x for x in csv.DictReader(open(out / "contacts.csv"))}
    assert set(rows) == {("true", "residual"), ("true", "momentum"), ("gip", "residual"), ("gip", "momentum")}
    for (model, method), x in rows.items():
        assert int(x["contacts"]) == 4 and 0 <= int(x["detected"]) <= 4
        assert float(x["requested_rate"]) == 1e-6
        assert (out / f"detection_{model}_{method}.png").read_bytes()[:4] == b"\x89PNG"
    # The true dynamics: every contact (30 % of a joint's torque range) found, no false alarm, and the threshold
    # every ratio is measured by.
    for method in ("residual", "momentum"):
        assert float(rows[("true", method)]["threshold_ratio"]) == 1.0
        assert float(rows[("true", method)]["false_alarms_per_minute"]) == 0.0
        assert int(rows[("true", method)]["detected"]) == 4, rows[("true", method)]
    assert "| true | residual |" in (out / "summary.md").read_text()
    assert json.loads((out / "config.json").read_text())["experiment"] == "contact"
