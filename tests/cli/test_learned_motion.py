"""`simulate --model`: a learned robot driven by the true robot's torques, beside
the true motion; refused for models without an inertia matrix."""
import numpy as np

from test_cli import run
from test_experiments import is_png


def read_csv(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return data


def test_learned_robot_follows_the_true_one_with_the_exact_regressor(tmp_path, gipdyn_bin):
    train, model = tmp_path / "train.csv", tmp_path / "fe.gipdyn"
    assert run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "300", "--dt", "0.1", "--noise", "0",
               "--seed", "11", "--quiet", "--out", str(train)).returncode == 0
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RRPR", "--model", "fe", "--robot", "scara",
            "--quiet", "--out", str(model))
    assert r.returncode == 0, r.stderr
    motion, png = tmp_path / "motion.csv", tmp_path / "motion.png"
    r = run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "201", "--dt", "0.005", "--noise", "0",
            "--seed", "13", "--model", str(model), "--plot", str(png), "--out", str(motion))
    assert r.returncode == 0, r.stderr
    assert "max position error per joint" in r.stdout
    d = read_csv(motion)
    for j in range(1, 5):
        true, learned = d[f"q{j}"], d[f"q{j}_model"]
        assert learned[0] == true[0]  # the same start
        # fe is exact: what remains is the torque sampled every 5 ms, felt most by
        # joint 4 (5e-4 kg m^2), and it grows with time.
        assert np.max(np.abs(learned[:21] - true[:21])) < 1e-5, j
        assert np.max(np.abs(learned - true)) < 2e-2, j
    assert is_png(png)


def test_models_without_inertia_and_bad_options_are_refused(tmp_path, gipdyn_bin):
    train = tmp_path / "train.csv"
    assert run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "60", "--seed", "1", "--quiet",
               "--out", str(train)).returncode == 0
    rbf = tmp_path / "rbf.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(train), "--joints", "RRPR", "--model", "rbf", "--max-iter", "3",
               "--quiet", "--out", str(rbf)).returncode == 0
    out = tmp_path / "m.csv"
    cases = [
        (["--model", str(rbf)], "cannot give"),
        (["--plot", str(tmp_path / "p.png")], "give --model too"),
        (["--model", str(rbf), "--integrator", "leapfrog"], "--integrator 'leapfrog'"),
    ]
    for extra, words in cases:
        r = run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "50", "--out", str(out), *extra)
        assert r.returncode != 0
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], r.stderr
        assert not out.exists()
    r = run(gipdyn_bin, "simulate", "--robot", "ur10", "--samples", "50", "--model", str(rbf), "--out", str(out))
    assert r.returncode != 0 and "RRPR model but --robot ur10" in r.stderr
