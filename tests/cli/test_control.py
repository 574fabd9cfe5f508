"""`experiment control`: closed-loop tracking with each model's feed-forward."""
import csv

from test_cli import run
from test_experiments import is_png


def test_control_experiment_ranks_controllers_and_writes_its_files(tmp_path, gipdyn_bin):
    train, fe = tmp_path / "train.csv", tmp_path / "fe.gipdyn"
    assert run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "300", "--dt", "0.1", "--seed", "11",
               "--quiet", "--out", str(train)).returncode == 0
    assert run(gipdyn_bin, "train", "--data", str(train), "--joints", "RRPR", "--model", "fe", "--robot", "scara",
               "--quiet", "--out", str(fe)).returncode == 0
    out = tmp_path / "ctl"
    r = run(gipdyn_bin, "experiment", "control", "--robot", "scara", "--models", str(fe), "--seconds", "1",
            "--seed", "12", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(out / "tracking.csv")))
    assert {x["controller"] for x in rows} == {"pd-only", "true-model", "fe", "true-model-ct", "fe-ct"}
    rms = {(x["controller"], x["joint"]): float(x["rms_error"]) for x in rows}
    for j in "1234":
        assert rms[("true-model", j)] < 0.1 * rms[("pd-only", j)]
        assert rms[("true-model-ct", j)] < 0.1 * rms[("pd-only", j)]
        # the exact regressor, fitted to noisy torques, as feed-forward and in computed torque
        assert rms[("fe", j)] < 0.2 * rms[("pd-only", j)]
        assert rms[("fe-ct", j)] < 0.2 * rms[("pd-only", j)]
    assert "| true-model |" in (out / "summary.md").read_text()
    assert is_png(out / "tracking.png")
    header = open(out / "errors.csv").readline().strip().split(",")
    assert header[0] == "t" and "fe_e4" in header


def test_control_experiment_refuses_a_model_of_another_robot(tmp_path, gipdyn_bin):
    train, model = tmp_path / "train.csv", tmp_path / "m.gipdyn"
    assert run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "60", "--seed", "1", "--quiet",
               "--out", str(train)).returncode == 0
    assert run(gipdyn_bin, "train", "--data", str(train), "--joints", "RRPR", "--max-iter", "3", "--quiet",
               "--out", str(model)).returncode == 0
    r = run(gipdyn_bin, "experiment", "control", "--robot", "ur10", "--models", str(model), "--out", str(tmp_path / "o"))
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "is for joints RRPR" in lines[0], r.stderr
    assert not (tmp_path / "o").exists()


def test_control_experiment_with_sensor_noise(tmp_path, gipdyn_bin):
    out, clean = tmp_path / "noisy", tmp_path / "clean"
    args = ["experiment", "control", "--robot", "scara", "--seconds", "0.5", "--seed", "3", "--quiet"]
    assert run(gipdyn_bin, *args, "--out", str(clean)).returncode == 0
    r = run(gipdyn_bin, *args, "--position-noise", "1e-2", "--velocity-noise", "0.1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rms = lambda d: {(x["controller"], x["joint"]): float(x["rms_error"]) for x in csv.DictReader(open(d / "tracking.csv"))}
    noisy, base = rms(out), rms(clean)
    for j in "1234":
        assert noisy[("true-model", j)] > 1.1 * base[("true-model", j)]
    assert "sensor noise (std 0.01 on positions, 0.1 on velocities" in (out / "summary.md").read_text()
    r = run(gipdyn_bin, *args, "--velocity-noise", "-1", "--out", str(tmp_path / "bad"))
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "--velocity-noise must be" in lines[0], r.stderr
    assert not (tmp_path / "bad").exists()


def test_control_experiment_names_its_flags_in_errors(tmp_path, gipdyn_bin):
    args = ["experiment", "control", "--robot", "scara", "--seconds", "0.2", "--seed", "3", "--quiet"]
    r = run(gipdyn_bin, *args, "--bandwidth", "-1", "--out", str(tmp_path / "bad"))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1 and "--bandwidth must be > 0" in lines[0], r.stderr
    assert not (tmp_path / "bad").exists()
    # Gains far too stiff for 1 ms steps: every controller loses the robot, and the advice names the flags.
    r = run(gipdyn_bin, *args, "--bandwidth", "1e5", "--out", str(tmp_path / "stiff"))
    assert r.returncode == 1, r.stderr  # the other controllers stand
    assert "lower the gains (--bandwidth) or the control period (--dt)" in r.stderr, r.stderr
    assert "TrackingOptions" not in r.stderr
    summary = (tmp_path / "stiff" / "summary.md").read_text()
    assert "| true-model | diverged |" in summary and "lower the gains (--bandwidth)" in summary
    assert "TrackingOptions" not in summary


def test_contacts_push_every_controller_alike_and_are_written_beside(tmp_path, gipdyn_bin):
    args = ["experiment", "control", "--robot", "scara", "--seconds", "1", "--seed", "4", "--quiet"]
    free, pushed = tmp_path / "free", tmp_path / "pushed"
    assert run(gipdyn_bin, *args, "--out", str(free)).returncode == 0
    r = run(gipdyn_bin, *args, "--contacts", "2", "--contact-size", "0.3", "--contact-joint", "1",
            "--out", str(pushed))
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(pushed / "external.csv")))
    assert len(rows) == 1000 and list(rows[0]) == ["t", "ext1", "ext2", "ext3", "ext4"]
    on = [x for x in rows if float(x["ext1"]) != 0.0]
    assert 2 * 48 <= len(on) <= 2 * 52  # two pushes of 50 ms at 1 kHz, on joint 1 alone
    assert all(float(x[f"ext{j}"]) == 0.0 for x in rows for j in (2, 3, 4))
    # The push acts on the robot and no controller knows it: every one tracks joint 1 worse than without.
    worst = lambda d: {(x["controller"], x["joint"]): float(x["max_error"]) for x in csv.DictReader(open(d / "tracking.csv"))}
    before, after = worst(free), worst(pushed)
    for controller in ("true-model", "true-model-ct"):  # PD alone lags far more than any push moves it
        assert after[(controller, "1")] > 2 * before[(controller, "1")], controller
    summary = (pushed / "summary.md").read_text()
    assert "2 contacts of 0.05 s push the robot" in summary and "on joint 1" in summary
    assert "Largest position error per joint" in summary
    assert not (free / "external.csv").exists()
    r = run(gipdyn_bin, "experiment", "control", "--robot", "scara", "--seconds", "0.1", "--contacts", "3",
            "--out", str(tmp_path / "short"))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1 and "--contacts (3) contacts of --contact-duration (0.05 s) need a motion of at least" in lines[0], r.stderr
    assert not (tmp_path / "short").exists()
