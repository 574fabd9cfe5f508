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
               "--teacher", "none", "--out", str(model)).returncode == 0
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
               "--teacher", "none", "--out", str(model)).returncode == 0
    taught = tmp_path / "t.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--max-iter", "5", "--quiet",
               "--teacher", "lip", "--teacher-states", "100", "--out", str(taught)).returncode == 0
    r = run(gipdyn_bin, "update", "--model", str(taught), "--data", str(data), "--out", str(tmp_path / "x.gipdyn"))
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1
    assert "this model was taught by lip: its rows are the teacher's drawn states" in r.stderr
    assert "train again on every row" in r.stderr
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
               "--teacher", "none", "--out", str(model)).returncode == 0
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--refit", "--max-iter", "40",
            "--out", str(refit))
    assert r.returncode == 0, r.stderr
    assert "re-learned the hyperparameters on every row, from the current ones" in r.stdout and "NLL" in r.stdout

    h = model_header(refit)
    assert h["num_training_samples"] == 100
    assert h["joint_models"][0]["log_params"] != model_header(model)["joint_models"][0]["log_params"]
    assert h["joint_models"][0]["training"]["evaluations"] > 0


def rbf_posterior_mean(header, joint, X_train, y_train, X_query):
    """A plain RBF GP written out here from the model file's hyperparameters and output scaling."""
    jm = header["joint_models"][joint]
    log_params = np.array(jm["log_params"])
    variance, lengthscales = np.exp(log_params[0]), np.exp(log_params[1:])
    def k(A, B):
        d = (A[:, None, :] - B[None, :, :]) / lengthscales
        return variance * np.exp(-0.5 * np.sum(d * d, axis=2))
    y = (y_train - jm["output_offset"]) / jm["output_scale"]
    C = k(X_train, X_train) + np.exp(jm["log_noise_variance"]) * np.eye(len(X_train))
    return jm["output_offset"] + jm["output_scale"] * (k(X_query, X_train) @ np.linalg.solve(C, y))


def test_update_replace_conditions_the_model_hyperparameters_on_the_new_rows_alone(tmp_path, gipdyn_bin):
    old, new, query = tmp_path / "old.csv", tmp_path / "new.csv", tmp_path / "query.csv"
    write_dataset(old, 60, seed=6)
    write_dataset(new, 30, seed=7)
    write_dataset(query, 25, seed=8)
    model, replaced, appended = tmp_path / "m.gipdyn", tmp_path / "r.gipdyn", tmp_path / "a.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(old), "--joints", "RR", "--model", "rbf", "--max-iter", "30",
               "--quiet", "--out", str(model)).returncode == 0
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--replace", "--out", str(replaced))
    assert r.returncode == 0, r.stderr
    assert "on the 30 rows of" in r.stdout and "its own rows dropped" in r.stdout, r.stdout
    assert run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--quiet",
               "--out", str(appended)).returncode == 0
    h = model_header(replaced)
    assert h["num_training_samples"] == 30
    for j in range(2):
        assert h["joint_models"][j]["log_params"] == model_header(model)["joint_models"][j]["log_params"]

    cols = ["q1", "q2", "qd1", "qd2", "qdd1", "qdd2"]
    d_new = np.genfromtxt(new, delimiter=",", names=True)
    d_query = np.genfromtxt(query, delimiter=",", names=True)
    X_new = np.column_stack([d_new[c] for c in cols])
    X_query = np.column_stack([d_query[c] for c in cols])
    got = predict(gipdyn_bin, replaced, query, tmp_path / "pr.csv")
    with_old_rows = predict(gipdyn_bin, appended, query, tmp_path / "pa.csv")
    for j in range(2):
        expected = rbf_posterior_mean(h, j, X_new, d_new[f"tau{j + 1}"], X_query)
        assert np.allclose(got[f"tau{j + 1}_hat"], expected, rtol=1e-7, atol=1e-7 * np.abs(expected).max())
        assert not np.allclose(with_old_rows[f"tau{j + 1}_hat"], expected, rtol=1e-3, atol=1e-3)


def test_update_replace_refuses_a_window_and_a_sparse_model(tmp_path, gipdyn_bin):
    data = tmp_path / "d.csv"
    write_dataset(data, 40, seed=9)
    exact, sparse = tmp_path / "e.gipdyn", tmp_path / "s.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--max-iter", "5", "--quiet",
               "--teacher", "none", "--out", str(exact)).returncode == 0
    assert run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--inducing", "10", "--max-iter", "5",
               "--quiet", "--out", str(sparse)).returncode == 0
    tiny = tmp_path / "tiny.csv"
    tiny.write_text("\n".join(data.read_text().splitlines()[:4]) + "\n")
    for model, rows, extra, words in [(exact, data, ["--window", "30"], "--window excludes --replace"),
                                      (sparse, data, [], "--replace needs an exact GP model"),
                                      (exact, tiny, [], "--replace: the new rows are 3; a model needs at least 5")]:
        out = tmp_path / "x.gipdyn"
        r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(rows), "--replace", *extra, "--out", str(out))
        assert r.returncode != 0
        lines = r.stderr.strip().splitlines()
        assert words in lines[0], r.stderr
        assert not out.exists()


def test_update_re_learns_hyperparameters_that_no_longer_fit_or_refuses_with_keep(tmp_path, gipdyn_bin):
    # A model of a two-link arm, then rows of a heavier one: the check before conditioning says the
    # hyperparameters no longer fit; by default the update re-learns them, with --keep-hyperparameters it refuses.
    old, new = tmp_path / "old.csv", tmp_path / "new.csv"
    write_dataset(old, 60, seed=11)
    write_dataset(new, 40, seed=12)
    heavier = [line.split(",") for line in new.read_text().splitlines()]
    tau2 = heavier[0].index("tau2")
    for row in heavier[1:]:
        row[tau2] = repr(3.0 * float(row[tau2]))
    new.write_text("\n".join(",".join(row) for row in heavier) + "\n")
    model, out = tmp_path / "m.gipdyn", tmp_path / "u.gipdyn"
    assert run(gipdyn_bin, "train", "--data", str(old), "--joints", "RR", "--max-iter", "60", "--quiet",
               "--teacher", "none", "--out", str(model)).returncode == 0
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--keep-hyperparameters", "--out", str(out))
    assert r.returncode == 1 and not out.exists()
    assert "the new rows of joint(s) 2 are" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "re-learn them (update without --keep-hyperparameters), or train on every row" in r.stderr
    r = run(gipdyn_bin, "update", "--model", str(model), "--data", str(new), "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "joint 2:" in r.stdout and "the hyperparameters no longer fit the new rows: re-learned them" in r.stdout
    assert model_header(out)["joint_models"][1]["log_params"] != model_header(model)["joint_models"][1]["log_params"]
