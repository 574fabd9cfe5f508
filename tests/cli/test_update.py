"""`gipdyn update`: new samples into a GP model, hyperparameters fixed."""

import numpy as np

from conftest import model_header, write_dataset
from test_cli import run


def predict(gipdyn_bin, model, data, out):
    r = run(gipdyn_bin, "predict", "--model", str(model), "--data", str(data), "--no-std", "--out", str(out))
    assert r.returncode == 0, r.stderr
    return np.genfromtxt(out, delimiter=",", names=True)


def test_update_learns_the_new_rows_and_keeps_the_hyperparameters(tmp_path, gipdyn_bin):
    old, new = tmp_path / "old.csv", tmp_path / "new.csv"
    write_dataset(old, 60, seed=1)
    write_dataset(new, 30, seed=2)
    model, updated, window = tmp_path / "m.gipdyn", tmp_path / "u.gipdyn", tmp_path / "w.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(old), "--joints", "RR", "--max-iter", "30", "--quiet",
               "--out", str(model)).returncode == 0
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--out", str(updated))
    assert r.returncode == 0, r.stderr
    assert "90 training rows" in r.stdout
    truth = np.genfromtxt(new, delimiter=",", names=True)
    before = predict(gipdyn_bin, model, new, tmp_path / "p0.csv")
    after = predict(gipdyn_bin, updated, new, tmp_path / "p1.csv")
    err = lambda p: np.mean((p["tau1_hat"] - truth["tau1_true"]) ** 2)
    assert err(after) < 0.5 * err(before)  # the new rows are now training rows
    assert model_header(updated)["joint_models"][0]["log_params"] == model_header(model)["joint_models"][0]["log_params"]
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--window", "40", "--out", str(window))
    assert r.returncode == 0, r.stderr
    assert "40 training rows, window 40" in r.stdout


def test_update_refuses_what_it_cannot_do(tmp_path, gipdyn_bin):
    data = tmp_path / "d.csv"
    write_dataset(data, 40, seed=3)
    model = tmp_path / "m.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--max-iter", "5", "--quiet",
               "--out", str(model)).returncode == 0
    before = model.read_bytes()
    for extra, words in [
        (["--out", str(model)], "--out"),
        (["--out", str(tmp_path / "x.gipdyn"), "--window", "-1"], "--window must be >= 0"),
        (["--out", str(tmp_path / "x.gipdyn"), "--window", "2"], "window must be 0 or at least"),
    ]:
        r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(data), *extra)
        assert r.returncode != 0
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], r.stderr
    assert model.read_bytes() == before
    assert not (tmp_path / "x.gipdyn").exists()


def test_update_refit_reoptimises_the_hyperparameters(tmp_path, gipdyn_bin):
    old, new = tmp_path / "old.csv", tmp_path / "new.csv"
    write_dataset(old, 60, seed=4)
    write_dataset(new, 40, seed=5)
    model, refit = tmp_path / "m.gipdyn", tmp_path / "r.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(old), "--joints", "RR", "--max-iter", "20", "--quiet",
               "--out", str(model)).returncode == 0
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--refit", "--max-iter", "40",
            "--out", str(refit))
    assert r.returncode == 0, r.stderr
    assert "refitting the hyperparameters on 100 rows" in r.stdout and "NLL" in r.stdout

    h = model_header(refit)
    assert h["num_training_samples"] == 100
    assert h["joint_models"][0]["log_params"] != model_header(model)["joint_models"][0]["log_params"]
    assert h["joint_models"][0]["training"]["evaluations"] > 0
