"""`gipdyn train --inducing M`: a sparse GP from the command line, its model file
in predict/evaluate, and the refusals."""
import numpy as np

from conftest import model_header, write_dataset
from test_cli import run


def test_sparse_training_predicts_with_its_inducing_rows_only(tmp_path, gipdyn_bin):
    train, test = tmp_path / "train.csv", tmp_path / "test.csv"
    write_dataset(train, 600, seed=11)
    truth = write_dataset(test, 200, seed=12)
    model = tmp_path / "m.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--inducing", "120", "--out", str(model))
    assert r.returncode == 0, r.stderr
    assert "sparse GP with 120 inducing rows" in r.stdout
    assert "sparse GP: 120 inducing rows for 600 training rows" in r.stdout
    h = model_header(model)
    assert h["format_version"] == 3 and h["approximation"] == "vfe"
    assert h["num_training_samples"] == 120 and h["num_data_rows"] == 600
    assert {"name": "posterior_factor2", "rows": 120, "cols": 120} in h["arrays"]

    out = tmp_path / "p.csv"
    r = run(gipdyn_bin, "predict", "--model", str(model), "--data", str(test), "--out", str(out))
    assert r.returncode == 0, r.stderr
    p = np.genfromtxt(out, delimiter=",", names=True)
    for j in range(2):
        err = p[f"tau{j + 1}_hat"] - truth[:, 8 + j]
        nmse = np.mean(err**2) / np.var(truth[:, 8 + j])
        assert nmse < 1e-2, (j, nmse)
        # The predictive std covers the error on most rows (a calibrated posterior).
        assert np.mean(np.abs(err) < 3 * p[f"tau{j + 1}_std"] + 0.03) > 0.9


def test_sparse_training_refuses_bad_sizes_and_updates(tmp_path, gipdyn_bin):
    data = tmp_path / "d.csv"
    write_dataset(data, 50, seed=13)
    for value, words in [("51", "--inducing (51) exceeds the 50 training rows"), ("-2", "--inducing must be >= 0")]:
        out = tmp_path / f"x{value}.gipdyn"
        r = run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--inducing", value, "--out", str(out))
        assert r.returncode != 0
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], r.stderr
        assert not out.exists()
    model = tmp_path / "m.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--inducing", "20", "--max-iter", "10",
               "--quiet", "--out", str(model)).returncode == 0
    # New rows enter through the fixed inducing rows; a window would need the old rows.
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(data), "--window", "60",
            "--out", str(tmp_path / "u.gipdyn"))
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "sparse model keeps only its 20 inducing rows" in lines[0], r.stderr
    assert not (tmp_path / "u.gipdyn").exists()
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(data), "--out", str(tmp_path / "u.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "100 data rows" in r.stdout, r.stdout
    h = model_header(tmp_path / "u.gipdyn")
    assert h["num_data_rows"] == 100 and h["num_training_samples"] == 20, h


def test_hyperparameter_rows_learn_on_a_subsample_and_keep_every_row(tmp_path, gipdyn_bin):
    train = tmp_path / "train.csv"
    write_dataset(train, 400, seed=13)
    model = tmp_path / "m.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--inducing", "60",
            "--hyperparameter-rows", "100", "--max-iter", "30", "--out", str(model))
    assert r.returncode == 0, r.stderr
    assert "hyperparameters learned on 100 rows (a constant-step subsample)" in r.stdout
    h = model_header(model)
    assert h["num_data_rows"] == 400
    assert all(j["training"]["hyperparameter_rows"] == 100 for j in h["joint_models"]), h["joint_models"]
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--hyperparameter-rows", "-1",
            "--out", str(tmp_path / "bad.gipdyn"))
    assert r.returncode == 1 and "--hyperparameter-rows must be >= 0" in r.stderr, r.stderr
    # The subsample's exact NLL instead of the bound; it needs the subsample.
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--inducing", "60",
            "--hyperparameter-rows", "100", "--hyperparameter-objective", "exact", "--max-iter", "30",
            "--out", str(tmp_path / "exact.gipdyn"))
    assert r.returncode == 0, r.stderr
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--inducing", "60",
            "--hyperparameter-objective", "exact", "--out", str(tmp_path / "bad.gipdyn"))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1 and "needs --hyperparameter-rows" in lines[0], r.stderr
    assert not (tmp_path / "bad.gipdyn").exists()
