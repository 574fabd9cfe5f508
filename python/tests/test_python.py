"""Tests of the gipdyn Python module: estimator API, agreement with the CLI,
model files across C++ and Python, pickling, scikit-learn integration, input
validation, robots, simulation and the examples."""
import json
import os
import pickle
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import gipdyn

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
DATA = os.path.join(ROOT, "tests", "data")
CLI = os.environ.get("GIPDYN_BIN")


def write_csv(path, d):
    n = d["q"].shape[1]
    names = ([f"q{i}" for i in range(1, n + 1)] + [f"qd{i}" for i in range(1, n + 1)] +
             [f"qdd{i}" for i in range(1, n + 1)] + [f"tau{i}" for i in range(1, n + 1)])
    np.savetxt(path, np.hstack([d["X"], d["tau"]]), delimiter=",", header=",".join(names), comments="", fmt="%.17g")


@pytest.fixture(scope="module")
def scara():
    # dt = 0.1 s: 200 samples span 20 s of motion, as 2000 samples at the default 0.01 s.
    return (gipdyn.simulate("scara", samples=200, seed=1, dt=0.1),
            gipdyn.simulate("scara", samples=300, seed=2, dt=0.1))


@pytest.fixture(scope="module")
def fitted(scara):
    train, _ = scara
    return gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=40).fit(train["X"], train["tau"])


def test_fit_predict_and_attributes(scara, fitted):
    _, test = scara
    pred, std = fitted.predict(test["X"], return_std=True)
    assert pred.shape == (300, 4) and std.shape == (300, 4) and (std >= 0).all()
    e = fitted.nmse(test["X"], test["tau_true"])
    # About three times what 40 L-BFGS evaluations on 200 samples reach (2e-3, 1e-2, 5e-5, 6e-2).
    assert e.shape == (4,) and (e < [8e-3, 4e-2, 2e-4, 0.2]).all(), e
    # score() is scikit-learn's: higher is better, the mean over joints of 1 - nMSE, i.e. the mean R^2.
    from sklearn.metrics import r2_score
    assert fitted.score(test["X"], test["tau_true"]) == pytest.approx(1.0 - e.mean())
    assert fitted.score(test["X"], test["tau_true"]) == pytest.approx(r2_score(test["tau_true"], pred))
    assert len(fitted.hyperparameters_) == 4
    assert "joint2.cs.factor1.l_sin" in fitted.hyperparameters_[0]
    assert "noise.variance" in fitted.hyperparameters_[3]
    assert fitted.log_marginal_likelihood_.shape == (4,)
    assert np.allclose(fitted.predict_one(test["X"][5]), pred[5], rtol=1e-7, atol=1e-9)


def test_sparse_gp_from_python(scara, tmp_path):
    train, test = scara
    est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", inducing=60, max_iter=40).fit(train["X"], train["tau"])
    assert est.estimator_options().sparse.inducing_points == 60
    assert est.model_.is_sparse and est.model_.num_training_samples == 60 and est.model_.num_data_rows == 200
    pred, std = est.predict(test["X"], return_std=True)
    assert (std >= 0).all()
    # The same order of accuracy as the exact fit of the fixture above (its bounds).
    assert (est.nmse(test["X"], test["tau_true"]) < [2e-2, 8e-2, 4e-4, 0.4]).all()
    again = pickle.loads(pickle.dumps(est))
    assert np.allclose(again.predict(test["X"]), pred, rtol=1e-10, atol=1e-12)
    # Online rows through the fixed inducing rows: one at a time as in one batch.
    batch = pickle.loads(pickle.dumps(est)).partial_fit(test["X"][:20], test["tau"][:20])
    for i in range(20):
        est.partial_fit(test["X"][i:i + 1], test["tau"][i:i + 1])
    assert est.model_.num_data_rows == 220 and est.model_.num_training_samples == 60
    assert not np.allclose(est.predict(test["X"]), pred, rtol=1e-6, atol=1e-9)
    # To 1e-5 of each joint's scale: A's condition number amplifies the rounding of sums in another order.
    from_batch = batch.predict(test["X"])
    assert (np.abs(est.predict(test["X"]) - from_batch).max(axis=0) <= 1e-5 * np.abs(from_batch).max(axis=0)).all()
    with pytest.raises(ValueError, match="window"):
        est.partial_fit(test["X"][:5], test["tau"][:5], window=100)
    with pytest.raises(ValueError, match="inducing"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", inducing=-1).fit(train["X"], train["tau"])


def test_hyperparameters_from_a_subsample_and_the_model_from_every_row(scara):
    train, _ = scara
    est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", inducing=60, hyperparameter_rows=100, max_iter=30)
    est.fit(train["X"], train["tau"])
    assert est.estimator_options().search.hyperparameter_rows == 100
    assert all(r["hyperparameter_rows"] == 100 for r in est.training_report_)
    assert est.model_.num_data_rows == 200
    with pytest.raises(ValueError, match="hyperparameter_rows must be 0 or at least"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", hyperparameter_rows=2).fit(train["X"], train["tau"])
    # The subsample's exact NLL instead of the bound: other hyperparameters, the same rows in the model.
    exact = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", inducing=60, hyperparameter_rows=100, max_iter=30,
                                     hyperparameter_objective="exact").fit(train["X"], train["tau"])
    assert exact.estimator_options().sparse.hyperparameter_objective == "exact"
    assert exact.model_.num_data_rows == 200
    assert exact.hyperparameters_ != est.hyperparameters_
    with pytest.raises(ValueError, match="hyperparameter_objective: unknown objective 'fast'"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", hyperparameter_objective="fast").fit(train["X"], train["tau"])
    with pytest.raises(ValueError, match="needs hyperparameter_rows"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", inducing=60, hyperparameter_objective="exact").fit(train["X"], train["tau"])


def test_partial_fit_with_refit_reoptimises_from_the_current_hyperparameters(scara):
    train, test = scara
    est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=40).fit(train["X"][:100], train["tau"][:100])
    before = [dict(h) for h in est.hyperparameters_]
    est.partial_fit(train["X"][100:], 1.2 * train["tau"][100:], window=100, refit=True)
    assert est.model_.num_training_samples == 100
    assert [dict(h) for h in est.hyperparameters_] != before
    assert all(r["evaluations"] > 0 for r in est.training_report_)


def test_fit_trajectory_equals_fit(scara):
    train, test = scara
    a = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=10).fit(train["X"], train["tau"])
    b = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=10).fit_trajectory(train["q"], train["qd"], train["qdd"],
                                                                            train["tau"])
    assert np.array_equal(a.predict(test["X"]), b.predict(test["X"]))


@pytest.mark.skipif(CLI is None, reason="GIPDYN_BIN not set")
def test_matches_cli_and_model_files_cross_languages(scara, tmp_path):
    train, test = scara
    write_csv(tmp_path / "train.csv", train)
    write_csv(tmp_path / "test.csv", test)
    subprocess.run([CLI, "train", "--data", str(tmp_path / "train.csv"), "--joints", "RRPR", "--max-iter", "25",
                    "--seed", "3", "--out", str(tmp_path / "cli.gipdyn"), "--quiet"], check=True)
    subprocess.run([CLI, "predict", "--model", str(tmp_path / "cli.gipdyn"), "--data", str(tmp_path / "test.csv"),
                    "--out", str(tmp_path / "cli_pred.csv"), "--no-std"], check=True)
    cli_pred = np.loadtxt(tmp_path / "cli_pred.csv", delimiter=",", skiprows=1)
    # Same data (read back from the same CSV), same options, same seed, each front end's default teacher: the
    # same model, taught by the same rule (the library's choose_teacher).
    csv = np.loadtxt(tmp_path / "train.csv", delimiter=",", skiprows=1)
    py = gipdyn.InverseDynamicsGP(joints="RRPR", max_iter=25, random_state=3).fit(csv[:, :12], csv[:, 12:])
    assert py.teaching_ == "taught"
    X_test = np.loadtxt(tmp_path / "test.csv", delimiter=",", skiprows=1)[:, :12]
    assert np.array_equal(py.predict(X_test), cli_pred)
    # C++: the library's EstimatorOptions and choose_teacher alone, no front end (tests/front_end_fit.cpp).
    cpp = os.environ.get("GIPDYN_FRONT_END_FIT")
    if cpp:
        r = subprocess.run([cpp, str(tmp_path / "train.csv"), "RRPR", "25", "3", str(tmp_path / "test.csv"),
                            str(tmp_path / "cpp_pred.csv")], capture_output=True, text=True, check=True)
        assert r.stdout.strip() == "taught"
        assert np.array_equal(np.loadtxt(tmp_path / "cpp_pred.csv", delimiter=",", skiprows=1), cli_pred)
    # CLI model -> Python.
    loaded = gipdyn.InverseDynamicsGP.load(tmp_path / "cli.gipdyn")
    assert loaded.joints == "RRPR" and loaded.model == "gip"
    assert np.array_equal(loaded.predict(X_test), cli_pred)
    # It comes back with the parameters the command line trained it with, which are Python's for these options.
    expected = {k: v for k, v in py.get_params().items() if k not in ("model", "n_jobs")}
    assert {k: loaded.get_params()[k] for k in expected} == expected
    # Python model -> CLI.
    py.save(tmp_path / "py.gipdyn")
    subprocess.run([CLI, "predict", "--model", str(tmp_path / "py.gipdyn"), "--data", str(tmp_path / "test.csv"),
                    "--out", str(tmp_path / "py_pred.csv"), "--no-std"], check=True)
    assert np.array_equal(np.loadtxt(tmp_path / "py_pred.csv", delimiter=",", skiprows=1), cli_pred)
    # The same model-file metadata: the teacher block the library writes, whichever front end trained.
    records = [json.loads(gipdyn.InverseDynamicsGP.load(tmp_path / f).model_.teaching_record)
               for f in ("cli.gipdyn", "py.gipdyn")]
    for r in records:
        assert r["outcome"] == "taught" and r["mode"] == "automatic" and r.pop("seconds") > 0
    assert records[0] == records[1]


@pytest.mark.skipif(CLI is None, reason="GIPDYN_BIN not set")
def test_the_choice_by_evidence_is_the_same_from_every_front_end(tmp_path):
    # train --model auto, InverseDynamics(model="auto") and the library's fit_selected_estimator: the same
    # candidates, scores and choice, and the same model.
    # A two-link arm: every candidate, the chain's geometry search among them, in seconds.
    robot = os.path.join(DATA, "two_link.json")
    train = gipdyn.simulate(robot, samples=100, seed=3, dt=0.15)
    test = gipdyn.simulate(robot, samples=50, seed=4, dt=0.15)
    write_csv(tmp_path / "train.csv", train)
    write_csv(tmp_path / "test.csv", test)
    subprocess.run([CLI, "train", "--data", str(tmp_path / "train.csv"), "--joints", "RR", "--model", "auto",
                    "--max-iter", "10", "--seed", "2", "--out", str(tmp_path / "cli.gipdyn"), "--quiet"], check=True)
    subprocess.run([CLI, "predict", "--model", str(tmp_path / "cli.gipdyn"), "--data", str(tmp_path / "test.csv"),
                    "--out", str(tmp_path / "cli_pred.csv"), "--no-std"], check=True)
    cli_pred = np.loadtxt(tmp_path / "cli_pred.csv", delimiter=",", skiprows=1)
    csv = np.loadtxt(tmp_path / "train.csv", delimiter=",", skiprows=1)
    X_test = np.loadtxt(tmp_path / "test.csv", delimiter=",", skiprows=1)[:, :6]
    py = gipdyn.InverseDynamics(joints="RR", model="auto", max_iter=10, random_state=2).fit(csv[:, :6], csv[:, 6:])
    assert np.array_equal(py.predict(X_test), cli_pred)
    assert "choice by evidence" in py.selection_report_ and py.chosen_ in py.selection_report_
    # The selection block the library writes, whichever front end trained (but the seconds each fit took).
    loaded = gipdyn.InverseDynamics.load(tmp_path / "cli.gipdyn")
    assert loaded.model == "auto" and loaded.chosen_ == py.chosen_
    assert np.array_equal(loaded.predict(X_test), cli_pred)
    for record in (py.selection_, loaded.selection_):
        for c in record["candidates"]:
            c.pop("seconds")
    assert py.selection_ == loaded.selection_ and len(py.selection_["candidates"]) >= 4
    cpp = os.environ.get("GIPDYN_FRONT_END_FIT")
    if cpp:
        r = subprocess.run([cpp, str(tmp_path / "train.csv"), "RR", "10", "2", str(tmp_path / "test.csv"),
                            str(tmp_path / "cpp_pred.csv"), "auto"], capture_output=True, text=True, check=True)
        assert r.stdout.strip() == py.chosen_
        assert np.array_equal(np.loadtxt(tmp_path / "cpp_pred.csv", delimiter=",", skiprows=1), cli_pred)
    # A Python model, read by the command line.
    py.save(tmp_path / "py.gipdyn")
    subprocess.run([CLI, "predict", "--model", str(tmp_path / "py.gipdyn"), "--data", str(tmp_path / "test.csv"),
                    "--out", str(tmp_path / "py_pred.csv"), "--no-std"], check=True)
    assert np.array_equal(np.loadtxt(tmp_path / "py_pred.csv", delimiter=",", skiprows=1), cli_pred)


def test_inverse_dynamics_fits_any_estimator_with_its_physics_and_files(scara, tmp_path):
    train, test = scara
    chain = gipdyn.InverseDynamics(joints="RRPR", model="chain").fit(train["X"], train["tau"])
    assert chain.chosen_ == "chain" and chain.selection_ is None and chain.model_.gives_rigid_body_terms
    assert np.all(chain.nmse(test["X"], test["tau_true"]) < 1e-2)
    # Its rigid-body terms are the simulated robot's.
    q = test["q"][:20]
    true_gravity = gipdyn.Robot.load("scara").inverse_dynamics(q, 0 * q, 0 * q)
    np.testing.assert_allclose(chain.gravity(q), true_gravity, atol=1e-2 * np.abs(true_gravity).max())
    np.testing.assert_allclose(chain.predict_one(test["X"][0]), chain.predict(test["X"][:1])[0], rtol=1e-12, atol=1e-12)
    chain.save(tmp_path / "chain.gipdyn")
    loaded = gipdyn.InverseDynamics.load(tmp_path / "chain.gipdyn")
    assert loaded.model == "chain" and np.array_equal(loaded.predict(test["X"]), chain.predict(test["X"]))
    with pytest.raises(gipdyn.GipdynError, match=r"holds a 'chain' model, not a GP kernel's: load it with InverseDynamics.load"):
        gipdyn.InverseDynamicsGP.load(tmp_path / "chain.gipdyn")
    with pytest.warns(gipdyn.ConvergenceWarning, match=r"stopped at the evaluation limit.*raise max_iter"):
        rbf = gipdyn.InverseDynamics(joints="RRPR", model="rbf", max_iter=10).fit(train["X"], train["tau"])
    with pytest.raises(gipdyn.GipdynError, match=r"a 'rbf' model cannot give gravity.*not affine in the accelerations"):
        rbf.gravity(q)
    with pytest.raises(ValueError, match=r"predicts means only: for a predictive standard deviation fit InverseDynamicsGP"):
        rbf.predict(test["X"], return_std=True)


def test_pickle_round_trip(scara, fitted):
    _, test = scara
    clone = pickle.loads(pickle.dumps(fitted))
    assert np.array_equal(clone.predict(test["X"]), fitted.predict(test["X"]))
    assert clone.get_params() == fitted.get_params()


def test_lagrangian_gp_pickles_before_and_after_fit_and_has_no_partial_fit(scara):
    # As scikit-learn's tools expect of an estimator (joblib, GridSearchCV(n_jobs > 1)).
    train, test = scara
    unfitted = pickle.loads(pickle.dumps(gipdyn.LagrangianGP(joints="RRPR", friction=True, max_iter=20)))
    assert unfitted.get_params()["friction"] and not hasattr(unfitted, "model_")
    fitted = unfitted.fit(train["X"][:40], train["tau"][:40])
    clone = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(clone.predict(test["X"][:10]), fitted.predict(test["X"][:10]))
    np.testing.assert_array_equal(clone.kinetic_energy(test["X"][:10]), fitted.kinetic_energy(test["X"][:10]))
    assert clone.get_params() == fitted.get_params()
    assert not hasattr(fitted, "partial_fit") and hasattr(gipdyn.InverseDynamicsGP(), "partial_fit")
    with pytest.raises(ValueError, match="not lip"):  # a GP model's bytes
        gipdyn._core.LagrangianModel.from_bytes(pickle.loads(pickle.dumps(gipdyn.InverseDynamicsGP(
            joints="RRPR", teacher="none", max_iter=3).fit(train["X"][:30], train["tau"][:30]))).model_.to_bytes())


def test_sklearn_cross_validation_and_grid_search(scara):
    from sklearn.model_selection import GridSearchCV, KFold, cross_val_score

    train, _ = scara
    est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=10)
    scores = cross_val_score(est, train["X"], train["tau"], cv=KFold(3))
    assert scores.shape == (3,) and np.isfinite(scores).all()
    # score() (the default scoring) is 1 - mean nMSE: higher is better, and it ranks
    # candidates exactly as the nMSE scorer does.
    results = {}
    for name, scoring in (("score", None), ("neg_nmse", gipdyn.neg_nmse_scorer)):
        grid = GridSearchCV(est, {"model": ["rbf", "gip"]}, cv=KFold(2, shuffle=True, random_state=0),
                            scoring=scoring)
        grid.fit(train["X"], train["tau"])
        results[name] = (grid.best_params_["model"], grid.cv_results_["mean_test_score"])
    assert results["score"][0] == results["neg_nmse"][0]
    np.testing.assert_allclose(results["score"][1], 1.0 + results["neg_nmse"][1], rtol=1e-12)
    assert est.set_params(model="rbf") is est and est.model == "rbf"
    with pytest.raises(ValueError):
        est.set_params(colour="red")


@pytest.mark.parametrize("X, Y, message", [
    (np.zeros((10, 11)), np.zeros((10, 4)), "must have 12"),
    (np.zeros((10, 12)), np.zeros((10, 3)), "4 columns"),
    (np.zeros((10, 12)), np.zeros((9, 4)), "rows"),
    (np.zeros(12), np.zeros(4), None),
    (np.full((10, 12), np.nan), np.zeros((10, 4)), "NaN"),
    (np.array([["a"] * 12] * 10), np.zeros((10, 4)), "numeric"),
    (np.zeros((3, 12)), np.zeros((3, 4)), "at least"),
    (np.zeros((10, 12)), np.zeros(10), "Y must be a 2-D array (rows x 4 columns), got shape (10,)"),
])
def test_bad_input_raises_value_error(X, Y, message):
    with pytest.raises(ValueError) as err:
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=2).fit(X, Y)
    if message:
        assert message in str(err.value)


def test_inputs_of_another_joint_count_name_the_joints_and_the_fix():
    # A 6R arm's 18 columns read against a SCARA's joints: the error says so and how to fix it.
    X, Y = np.zeros((10, 18)), np.zeros((10, 6))
    with pytest.raises(ValueError) as err:
        gipdyn.InverseDynamicsGP(joints="RRPR", max_iter=2).fit(X, Y)
    assert "X has 18 columns (n_features=18) but must have 12 (q, qd, qdd of joints='RRPR')" in str(err.value)
    assert "18 columns are 6 joints, e.g. joints='RRRRRR'" in str(err.value)
    d = gipdyn.simulate("scara", samples=40, seed=3)
    m = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=2).fit(d["X"], d["tau"])
    with pytest.raises(ValueError, match="the model was trained on these joints"):
        m.predict(X)
    assert m.predict(d["X"][:1]).shape == (1, 4) and m.predict_one(d["X"][0]).shape == (4,)


def test_a_robot_gives_the_joint_types_when_joints_is_not_given():
    # pp on a UR10 log with robot="ur10" alone: the robot's RRRRRR, not the SCARA's default.
    d = gipdyn.simulate("ur10", samples=60, seed=3)
    m = gipdyn.InverseDynamicsGP(model="pp", robot="ur10", max_iter=5).fit(d["X"], d["tau"])
    assert m.model_.joints == "RRRRRR" and m.predict_one(d["X"][0]).shape == (6,)
    # A robot of another joint count than X: the message names the robot.
    with pytest.raises(ValueError) as err:
        gipdyn.InverseDynamicsGP(model="pp", robot="scara", max_iter=5).fit(d["X"], d["tau"])
    assert "X has 18 columns (n_features=18) but must have 12 (q, qd, qdd of joints='RRPR')" in str(err.value)
    assert "they are the joints of robot='scara'" in str(err.value)
    with pytest.raises(ValueError, match="they are the joints of robot='scara'"):  # a Robot object, by its name
        gipdyn.InverseDynamicsGP(model="pp", robot=gipdyn.Robot.load("scara"), max_iter=5).fit(d["X"], d["tau"])
    # joints, when given, wins; a refit after set_params reads X against the new joints, not the fitted model's.
    s = gipdyn.simulate("scara", samples=40, seed=3)
    m.set_params(model="rbf", robot=None, joints="RRPR")
    assert m.fit(s["X"], s["tau"]).model_.joints == "RRPR"


def test_one_joint_takes_a_1d_target_like_scikit_learn():
    # A pendulum's torque as a 1-D y: one value per row, the same model as with a column.
    rng = np.random.default_rng(3)
    X = np.column_stack([rng.uniform(-2, 2, 60), rng.uniform(-1, 1, 60), rng.uniform(-1, 1, 60)])
    tau = 0.2 * X[:, 2] + 1.5 * np.cos(X[:, 0]) + 0.001 * rng.standard_normal(60)
    as_vector = gipdyn.InverseDynamicsGP(joints="R", teacher="none").fit(X, tau)
    as_column = gipdyn.InverseDynamicsGP(joints="R", teacher="none").fit(X, tau[:, None])
    # The same model; predictions in the shape of the target, as scikit-learn's regressors give them.
    np.testing.assert_array_equal(as_vector.predict(X[:5]), as_column.predict(X[:5])[:, 0])
    assert as_vector.predict(X[:5]).shape == (5,) and as_column.predict(X[:5]).shape == (5, 1)
    assert gipdyn.nmse(tau[:, None], as_vector.predict(X)[:, None]).max() < 1e-3


def test_read_log_reads_what_the_command_line_reads(tmp_path):
    # A CSV in simulate's layout, the same numbers as numpy.savetxt's default and as a .mat variable read alike.
    data = gipdyn.simulate("scara", samples=40, seed=3)
    csv = tmp_path / "log.csv"
    columns = [f"{k}{j}" for k in ("q", "qd", "qdd", "tau") for j in range(1, 5)]
    np.savetxt(csv, np.hstack([data["X"], data["tau"], data["tau_true"]]), delimiter=",", comments="", fmt="%.17g",
               header=",".join(columns + [f"tau{j}_true" for j in range(1, 5)]))
    log = gipdyn.read_log(csv, "RRPR")
    np.testing.assert_array_equal(log["X"], data["X"])
    np.testing.assert_array_equal(log["tau"], data["tau"])
    np.testing.assert_array_equal(log["tau_true"], data["tau_true"])
    np.testing.assert_array_equal(log["qd"], data["qd"])
    np.savetxt(tmp_path / "saved.txt", np.hstack([data["X"], data["tau"]]), header=" ".join(columns))
    saved = gipdyn.read_log(tmp_path / "saved.txt", "RRPR")
    np.testing.assert_array_equal(saved["X"], data["X"])
    assert saved["tau_true"] is None
    assert gipdyn.read_log(tmp_path / "saved.txt", "RRPR", torques=False)["tau"] is None
    scipy_io = pytest.importorskip("scipy.io")
    scipy_io.savemat(tmp_path / "log.mat", {"log": np.hstack([data["X"], data["tau"]])})
    mat = gipdyn.read_log(tmp_path / "log.mat", "RRPR", mat_variable="log")
    np.testing.assert_array_equal(mat["tau"], data["tau"])
    with pytest.raises(gipdyn.GipdynError, match="has joint columns q1..q4 but the joint types RRPRRR name 6 joints"):
        gipdyn.read_log(csv, "RRPRRR")
    with pytest.raises(gipdyn.GipdynError, match=r"read it with gipdyn.read_log\(path, joints, mat_variable=NAME\)"):
        gipdyn.read_log(tmp_path / "log.mat", "RRPR")
    # Without joints: those the CSV's sidecar records, as gipdyn simulate writes it.
    with pytest.raises(ValueError, match="joints is required for"):
        gipdyn.read_log(csv)
    (tmp_path / "log.csv.json").write_text('{"generator": "gipdyn simulate", "joints": "RRPR"}')
    assert log["joints"] == "RRPR" and gipdyn.read_log(csv)["joints"] == "RRPR"
    np.testing.assert_array_equal(gipdyn.read_log(csv)["X"], data["X"])
    (tmp_path / "log.csv.json").write_text('{"joints": "RRXR"}')
    with pytest.raises(gipdyn.GipdynError, match="log.csv.json' of .* records bad joint types"):
        gipdyn.read_log(csv)
    # A ROS joint_states export (joints counted from 0) by its own names, from a dict of patterns.
    ros_names = {"q": "position_{i0}", "qd": "velocity_{i0}", "qdd": "acceleration_{i0}", "tau": "effort_{i0}"}
    ros = [ros_names[k].replace("{i0}", str(j - 1)) for k in ("q", "qd", "qdd", "tau") for j in range(1, 5)]
    np.savetxt(tmp_path / "ros.csv", np.hstack([data["X"], data["tau"]]), delimiter=",", comments="", fmt="%.17g",
               header=",".join(ros))
    from_ros = gipdyn.read_log(tmp_path / "ros.csv", "RRPR", columns=ros_names)
    np.testing.assert_array_equal(from_ros["X"], data["X"])
    np.testing.assert_array_equal(from_ros["tau"], data["tau"])
    with pytest.raises(gipdyn.GipdynError, match=r'columns\["q"\] \(\'position\'\) must hold exactly one'):
        gipdyn.read_log(tmp_path / "ros.csv", "RRPR", columns={"q": "position"})


def test_version_is_the_projects():
    # CMake's project version is the one source; pyproject.toml (the wheel's) must say the same.
    cmake = open(os.path.join(ROOT, "CMakeLists.txt")).read()
    assert gipdyn.__version__ == cmake.split("project(gipdyn VERSION ")[1].split()[0]
    pyproject = open(os.path.join(ROOT, "pyproject.toml")).read()
    assert f'\nversion = "{gipdyn.__version__}"' in pyproject


def test_the_license_and_the_citation_are_named_where_packages_read_them():
    # LICENSE is BSD-3-Clause; the wheel's metadata and CITATION.cff say so, and the citation is of this version.
    assert open(os.path.join(ROOT, "LICENSE")).read().startswith("BSD 3-Clause License\n")
    assert '\nlicense = {text = "BSD-3-Clause"}' in open(os.path.join(ROOT, "pyproject.toml")).read()
    citation = open(os.path.join(ROOT, "CITATION.cff")).read()
    assert "\nlicense: BSD-3-Clause\n" in citation and f"\nversion: {gipdyn.__version__}\n" in citation
    assert 'doi: "10.1109/LRA.2019.2945240"' in citation  # the GIP paper, the preferred citation


def test_build_info_is_the_command_lines():
    # How the library was compiled, for bug reports: the line `gipdyn --version` prints, and Eigen's layout,
    # which must be Debian's 16 bytes (include/gipdyn/eigen_abi.hpp).
    info = gipdyn.build_info()
    assert info["version"] == gipdyn.__version__
    assert info["eigen_static_align_bytes"] == 16 and info["eigen_heap_align_bytes"] == 16
    assert info["instruction_set"].startswith("x86-64") and "AVX" not in info["instruction_set"]
    assert info["summary"].startswith("built for " + info["instruction_set"] + "; Eigen " + info["eigen_version"])
    gipdyn_bin = os.environ.get("GIPDYN_BIN")
    if gipdyn_bin:
        out = subprocess.run([gipdyn_bin, "--version"], capture_output=True, text=True, check=True).stdout
        assert out.splitlines()[1] == info["summary"]


def test_is_a_scikit_learn_regressor():
    from sklearn.base import BaseEstimator, RegressorMixin, clone, is_regressor

    est = gipdyn.InverseDynamicsGP(joints="RR", teacher="none", model="rbf", min_noise=1e-6)
    assert isinstance(est, BaseEstimator) and isinstance(est, RegressorMixin) and is_regressor(est)
    copy = clone(est)
    assert copy is not est and copy.get_params() == est.get_params()


def test_training_report_and_convergence_warning(scara):
    train, _ = scara
    with pytest.warns(gipdyn.ConvergenceWarning, match="raise max_iter") as caught:
        est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=3).fit(train["X"], train["tau"])
    report = est.training_report_
    # The library's lines, in Python's keywords, naming every joint that stopped early.
    lines = [str(w.message) for w in caught if w.category is gipdyn.ConvergenceWarning]
    assert lines == est.model_.convergence_warnings and not any("::" in line for line in lines), lines
    named = {int(j) for line in lines for j in re.match(r"joint\(s\) ([\d, ]+) ", line).group(1).split(",")}
    assert named == {1, 2, 3, 4}, lines
    assert [r["joint"] for r in report] == [1, 2, 3, 4]
    assert all(r["status"] in ("max-iter", "stalled") and r["evaluations"] <= 3 and r["noise_variance"] > 0
               for r in report), report
    assert [r["nll"] for r in report] == pytest.approx(-est.log_marginal_likelihood_)


def test_noise_warning_names_a_joint_whose_torque_is_below_the_noise(scara):
    train, _ = scara
    tau = train["tau_true"] * np.array([1.0, 1.0, 1.0, 1e-3]) + 0.01 * np.random.default_rng(3).standard_normal((200, 4))
    with pytest.warns(gipdyn.NoiseWarning, match=r"joint\(s\) 4 \(\d+ %\): the fit calls most of the torque noise"):
        est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none").fit(train["X"], tau)
    shares = [r["noise_share"] for r in est.training_report_]
    assert shares[3] >= gipdyn._core.NOISE_SHARE_WARNING and max(shares[:3]) < 0.01, shares


def test_gravity_inertia_and_coriolis_match_the_robot(scara):
    # pp on the true robot is exact up to the noise of 200 samples: every term within 0.1 % of the robot's.
    train, test = scara
    robot = gipdyn.Robot.load("scara")
    est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model="pp", robot="scara", max_iter=30).fit(train["X"], train["tau"])
    q, qd = test["q"][:20], test["qd"][:20]
    zero = np.zeros_like(q)

    def relative_error(a, b):
        return np.linalg.norm(a - b) / np.linalg.norm(b)

    g_true = robot.inverse_dynamics(q, zero, zero)
    assert relative_error(est.gravity(q), g_true) < 1e-3
    M = est.inertia(q)
    assert M.shape == (20, 4, 4)
    M_true = np.stack([robot.inverse_dynamics(q, zero, np.tile(np.eye(4)[j], (20, 1))) - g_true for j in range(4)],
                      axis=2)
    assert relative_error(M, M_true) < 1e-3
    # The default is the symmetric part of the rows the joints' GPs learned.
    M_learned = est.inertia(q, symmetric=False)
    assert np.abs(M_learned - M_learned.transpose(0, 2, 1)).max() > 0
    np.testing.assert_allclose(M, 0.5 * (M_learned + M_learned.transpose(0, 2, 1)), rtol=0, atol=1e-12)
    assert relative_error(est.coriolis(q, qd), robot.inverse_dynamics(q, qd, zero) - g_true) < 1e-3
    np.testing.assert_allclose(est.friction(q, qd), 0.0, atol=1e-9)  # no friction columns: nothing odd in qd
    with pytest.raises(ValueError, match="cannot give gravity"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model="rbf", max_iter=2).fit(train["X"], train["tau"]).gravity(q)


def test_estimator_options_are_the_librarys_own():
    o = gipdyn.InverseDynamicsGP(joints="RR", teacher="none", model="rbf", optimizer="adam", max_iter=7, restarts=2, random_state=5,
                                 scaling="center", min_noise=1e-6, mean="linear", prior="lognormal",
                                 prior_width=1.5).estimator_options()
    assert isinstance(o, gipdyn.EstimatorOptions)
    assert (o.name, o.search.optimizer.kind, o.search.optimizer.max_iterations, o.search.restarts,
            o.search.seed) == ("rbf", "adam", 7, 2, 5)
    assert (o.gp.scaling, o.gp.mean, o.search.min_noise_fraction) == ("center", "linear", 1e-6)
    assert o.gp.prior.enabled and o.gp.prior.width == 1.5
    o.validate()
    assert o.gp.noise_std_floor.size == 0  # set only for a teacher's labels, known to its residual
    o.gp.noise_std_floor = np.array([0.01, -1.0])
    with pytest.raises(ValueError, match="noise_std_floor must hold finite values >= 0"):
        o.validate()


@pytest.mark.parametrize("params, message", [
    ({"min_noise": -1.0}, "min_noise must be > 0"),
    ({"restarts": -1}, "restarts must be between 0 and 1000"),
    ({"max_iter": 0}, "max_iter must be at least 1"),
    ({"warm_start_rows": -1}, "warm_start_rows must be >= 0"),
    ({"teacher": "lip", "start_screening": -1}, "start_screening must be >= 0"),
    ({"gradient_tolerance": -1.0}, "gradient_tolerance must be >= 0"),
    ({"prior": "lognormal", "prior_width": 0.0}, "prior_width must be > 0"),
    ({"model": "pp"}, "needs the nominal robot (robot)"),
    ({"scaling": "zscore"}, "scaling 'zscore' is unknown"),
])
def test_option_errors_name_the_keyword(params, message):
    X, Y = np.random.default_rng(0).normal(size=(20, 12)), np.zeros((20, 4))
    with pytest.raises(ValueError) as err:
        gipdyn.InverseDynamicsGP(**{"joints": "RRPR", "teacher": "none", **params}).fit(X, Y)
    assert message in str(err.value)
    assert "Options::" not in str(err.value) and "--" not in str(err.value)


def test_bad_options_and_unfitted_model_raise_value_error():
    X, Y = np.random.default_rng(0).normal(size=(20, 12)), np.zeros((20, 4))
    with pytest.raises(ValueError, match="unknown kernel"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model="matern").fit(X, Y)
    with pytest.raises(ValueError, match="'X'"):
        gipdyn.InverseDynamicsGP(joints="RXPR", teacher="none").fit(X, Y)
    # scikit-learn's NotFittedError (a ValueError and an AttributeError), naming the class.
    for unfitted in (gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none"), gipdyn.LagrangianGP(joints="RRPR")):
        with pytest.raises(gipdyn.NotFittedError, match=f"this {type(unfitted).__name__} is not fitted"):
            unfitted.predict(X)
    assert issubclass(gipdyn.NotFittedError, ValueError) and issubclass(gipdyn.NotFittedError, AttributeError)
    try:
        from sklearn.exceptions import NotFittedError
        assert gipdyn.NotFittedError is NotFittedError
    except ImportError:  # pragma: no cover - without scikit-learn, our own
        pass


def test_robot_from_urdf_dynamics_and_regressor():
    robot = gipdyn.Robot.from_urdf(os.path.join(DATA, "rpr_arm.urdf"))
    assert robot.joint_types == "RPR" and robot.num_joints == 3
    rng = np.random.default_rng(1)
    q, qd, qdd = rng.uniform(-1, 1, (3, 5, 3)) * np.array([1, 0.1, 1])
    q[:, 1] = np.abs(q[:, 1])
    tau = robot.inverse_dynamics(q, qd, qdd)
    assert tau.shape == (5, 3)
    Phi = robot.regressor(q[0], qd[0], qdd[0])
    assert Phi.shape == (3, 30)
    assert np.allclose(Phi @ robot.inertial_parameters, tau[0], rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="floating"):
        gipdyn.Robot.from_urdf(os.path.join(DATA, "floating_arm.urdf"))
    # A gripper and a camera off the chain: the chain's last link is named, and their mass loads the arm.
    gripper = os.path.join(DATA, "gripper_arm.urdf")
    with pytest.raises(ValueError, match="branches at link 'l1'"):
        gipdyn.Robot.from_urdf(gripper)
    arm = gipdyn.Robot.from_urdf(gripper, tip_link="tool")
    assert arm.joint_types == "RPR"
    assert np.allclose(gipdyn.Robot.load(gripper + ":tool").inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd))
    assert np.abs(arm.inverse_dynamics(q, qd, qdd) - tau).max() > 0.1


def test_simulate_is_seeded_and_shaped():
    a = gipdyn.simulate("ur10", samples=50, seed=7, perturb_kinematics=True)
    b = gipdyn.simulate(gipdyn.Robot.load("ur10"), samples=50, seed=7, perturb_kinematics=True)
    assert a["q"].shape == (50, 6) and a["X"].shape == (50, 18) and a["tau_true"].shape == (50, 6)
    assert np.array_equal(a["tau"], b["tau"])
    assert a["metadata"]["seed"] == 7 and len(a["metadata"]["perturbation"]) == 6
    with pytest.raises(ValueError, match="unknown robot"):
        gipdyn.simulate("puma")


def test_python_quickstart_example_runs():
    r = subprocess.run([sys.executable, os.path.join(ROOT, "examples", "python", "quickstart.py"), "200", "20"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "joint 4  nMSE" in r.stdout and "one sample" in r.stdout


def test_python_short_log_example_runs():
    r = subprocess.run([sys.executable, os.path.join(ROOT, "examples", "python", "short_log.py"), "200", "60", "200",
                        "20"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = [line.split() for line in r.stdout.splitlines() if "joints 1-4:" in line]
    assert len(rows) == 3, r.stdout
    for row in rows:  # four finite nMSE values and a latency per model
        values = [float(v) for v in row[row.index("1-4:") + 1:row.index("1-4:") + 5]]
        assert all(np.isfinite(values)), r.stdout


def test_python_control_loop_example_runs(tmp_path, fitted):
    fitted.save(str(tmp_path / "m.gipdyn"))
    r = subprocess.run([sys.executable, os.path.join(ROOT, "examples", "python", "control_loop.py"),
                        str(tmp_path / "m.gipdyn"), "--calls", "2000"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "2000 torque queries, 4 joints: p50" in r.stdout and "gravity at q = 0.3" in r.stdout


def test_ur10_real_example_runs(tmp_path):
    data = os.path.join(ROOT, "..", "shared", "data", "ur10-pick-and-place", "urPicknPlace.csv")
    if not os.path.exists(data):
        pytest.skip("shared UR10 data not present")
    out = tmp_path / "ur10.png"
    r = subprocess.run([sys.executable, os.path.join(ROOT, "examples", "python", "ur10_real.py"), "--data", data,
                        "--train-rows", "150", "--max-iter", "5", "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "joint 6  nMSE" in r.stdout and "gip-envelope+friction, 150 training rows" in r.stdout
    assert "torque at revisited states, training -> test rows: neighbour nMSE" in r.stdout
    assert out.stat().st_size > 10000 and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_model_based_and_hybrid_kernels(scara, tmp_path):
    train, test = scara
    for kernel in ("pp", "gip+rbf"):
        est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model=kernel, robot="scara", max_iter=30)
        est.fit(train["X"], train["tau"])
        # About three times what each reaches: pp is exact up to the noise, the hybrid as GIP.
        bound = {"pp": [1e-7, 1e-6, 1e-6, 3e-3], "gip+rbf": [6e-3, 3e-2, 2e-4, 0.15]}[kernel]
        e = gipdyn.nmse(test["tau_true"], est.predict(test["X"]))
        assert np.all(e < bound), (kernel, e)
        est.save(tmp_path / "m.gipdyn")
        back = gipdyn.InverseDynamicsGP.load(tmp_path / "m.gipdyn")
        assert back.model == kernel
        np.testing.assert_array_equal(back.predict(test["X"]), est.predict(test["X"]))
    with pytest.raises(ValueError, match="needs the nominal robot"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model="sp").fit(train["X"], train["tau"])


def test_predicting_with_std_leaves_the_estimator_as_it_was(scara, tmp_path):
    # A loaded model has no factors: the first request builds them inside model_, and keeps them, without
    # replacing any attribute (scikit-learn's check_dict_unchanged asks the same of predict).
    train, test = scara
    for cls, kwargs in ((gipdyn.InverseDynamicsGP, {"teacher": "none"}), (gipdyn.LagrangianGP, {})):
        fitted = cls(joints="RRPR", max_iter=10, **kwargs).fit(train["X"][:40], train["tau"][:40])
        fitted.save(tmp_path / "m.gipdyn")
        loaded = cls.load(tmp_path / "m.gipdyn")
        assert not loaded.model_.has_variance
        before = dict(loaded.__dict__)
        first = loaded.predict(test["X"][:5], return_std=True)
        again = loaded.predict(test["X"][:5], return_std=True)
        assert loaded.__dict__.keys() == before.keys() and all(loaded.__dict__[k] is before[k] for k in before)
        assert not loaded.model_.has_variance
        np.testing.assert_array_equal(first[1], again[1])
        np.testing.assert_allclose(first[1], fitted.predict(test["X"][:5], return_std=True)[1], rtol=1e-8)


def test_mean_function_and_map_prior(scara):
    train, test = scara
    est = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model="gip", mean="constant", prior="lognormal", max_iter=30)
    est.fit(train["X"], train["tau"])
    e = gipdyn.nmse(test["tau_true"], est.predict(test["X"]))
    assert np.all(e < [2.5e-2, 3e-2, 2.5e-3, 0.25]), e  # about three times what it reaches
    assert list(est.hyperparameters_[0])[-1] == "mean.constant"
    linear = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", model="rbf", mean="linear", max_iter=5).fit(train["X"], train["tau"])
    names = list(linear.hyperparameters_[0])
    assert names[-13:] == ["mean.constant"] + [f"mean.x{k}" for k in range(1, 13)]
    with pytest.raises(ValueError, match="mean 'quadratic' is unknown"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", mean="quadratic").fit(train["X"], train["tau"])
    with pytest.raises(ValueError, match="lognormal"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", prior="gauss").fit(train["X"], train["tau"])


def test_partial_fit_adds_samples_with_fixed_hyperparameters(scara):
    # Every other row of the motion, then the rows between them: the same motion, so the hyperparameters fit.
    train, test = scara
    first = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=40).fit(train["X"][::2], train["tau"][::2])
    hyper = [dict(h) for h in first.hyperparameters_]
    err_before = first.nmse(test["X"], test["tau_true"]).mean()
    first.partial_fit(train["X"][1::2], train["tau"][1::2], refit=False)
    assert "joint 4:" in first.update_check_ and "no longer fit" not in first.update_check_
    assert first.model_.num_training_samples == 200
    assert first.hyperparameters_ == hyper  # fixed: only the data changed
    assert first.nmse(test["X"], test["tau_true"]).mean() < err_before
    first.partial_fit(train["X"][190:], train["tau"][190:], window=150)
    assert first.model_.num_training_samples == 150
    # An unfitted estimator's first partial_fit is fit.
    fresh = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=5).partial_fit(train["X"][:50], train["tau"][:50])
    assert fresh.model_.num_training_samples == 50
    with pytest.raises(ValueError, match="window"):
        first.partial_fit(train["X"][:5], train["tau"][:5], window=2)


def test_partial_fit_re_learns_hyperparameters_the_new_motion_shows_wrong_or_refuses(scara):
    # Fitted on the first 12 s of the motion, then given the last 8 s: the check names the joints whose new
    # rows the hyperparameters no longer fit; by default they are re-learned, with refit=False it refuses.
    train, test = scara
    kwargs = dict(joints="RRPR", teacher="none", max_iter=40)
    early = gipdyn.InverseDynamicsGP(**kwargs).fit(train["X"][:120], train["tau"][:120])
    with pytest.raises(ValueError, match=r"the new rows of joint\(s\) 1, 2 are .*\(partial_fit with refit=None\)"):
        pickle.loads(pickle.dumps(early)).partial_fit(train["X"][120:], train["tau"][120:], refit=False)
    kept = early.model_.updated(np.asfortranarray(train["X"][120:]), np.asfortranarray(train["tau"][120:]))
    updated = pickle.loads(pickle.dumps(early)).partial_fit(train["X"][120:], train["tau"][120:])
    assert "joint 1:" in updated.update_check_ and "the hyperparameters no longer fit" in updated.update_check_
    assert updated.hyperparameters_[0] != early.hyperparameters_[0]
    full = gipdyn.InverseDynamicsGP(**kwargs).fit(train["X"], train["tau"])
    err = lambda model: gipdyn.nmse(test["tau_true"], model.predict(np.asfortranarray(test["X"]))).mean()
    assert err(updated.model_) < err(kept)  # better than conditioning with the old hyperparameters
    assert err(updated.model_) < 3 * err(full.model_)  # and as good as a training on every row, within 3x


def test_partial_fit_of_a_taught_model_trains_it_again_on_every_row(scara):
    # Its rows are drawn states, not the log: partial_fit fits again on the log it was fitted on and the new rows.
    train, _ = scara
    kwargs = dict(joints="RRPR", teacher="lip", teacher_states=200, student_hyperparameter_rows=100, max_iter=30)
    taught = gipdyn.InverseDynamicsGP(**kwargs).fit(train["X"][:60], train["tau"][:60])
    assert taught.teaching_ == "taught"
    taught.partial_fit(train["X"][60:100], train["tau"][60:100])
    at_once = gipdyn.InverseDynamicsGP(**kwargs).fit(train["X"][:100], train["tau"][:100])
    np.testing.assert_array_equal(taught.predict(train["X"][100:]), at_once.predict(train["X"][100:]))
    assert taught.update_check_ is None and taught.teaching_ == "taught"


def test_lagrangian_gp_energies_physics_and_files(scara, tmp_path):
    # LIP on 100 rows: the terms and the kinetic energy close to the robot's, the same through a model file.
    train, test = scara
    robot = gipdyn.Robot.load("scara")
    est = gipdyn.LagrangianGP(joints="RRPR", max_iter=150).fit(train["X"][::2], train["tau"][::2])
    q, qd = test["q"][:20], test["qd"][:20]
    zero = np.zeros_like(q)

    def relative_error(a, b):
        return np.linalg.norm(a - b) / np.linalg.norm(b)

    g_true = robot.inverse_dynamics(q, zero, zero)
    M_true = np.stack([robot.inverse_dynamics(q, zero, np.tile(np.eye(4)[j], (20, 1))) - g_true for j in range(4)],
                      axis=2)
    assert relative_error(est.gravity(q), g_true) < 1e-3
    assert relative_error(est.inertia(q), M_true) < 2e-2
    T_true = 0.5 * np.einsum("ri,rij,rj->r", qd, M_true, qd)
    T = est.kinetic_energy(np.hstack([q, qd]))
    assert T.shape == (20,)
    assert relative_error(T, T_true) < 2e-2
    np.testing.assert_allclose(est.kinetic_energy(np.hstack([q, zero])), 0.0, atol=1e-12)
    assert est.potential_energy(q).shape == (20,)
    assert est.training_report_[0]["evaluations"] > 0 and len(est.training_report_) == 4
    path = tmp_path / "lip.gipdyn"
    est.save(path)
    loaded = gipdyn.LagrangianGP.load(path)
    np.testing.assert_array_equal(loaded.predict(test["X"][:5]), est.predict(test["X"][:5]))
    with pytest.raises(ValueError, match="not lip"):
        gipdyn.LagrangianGP.load(_gip_model_file(train, tmp_path))
    # Standard deviations: positive, larger far from the training states, the same after loading.
    mean, std = est.predict(test["X"][:5], return_std=True)
    np.testing.assert_array_equal(mean, est.predict(test["X"][:5]))
    assert std.shape == (5, 4) and np.all(std > 0)
    far = test["X"][:5].copy()
    far[:, 4:12] *= 5.0
    assert np.all(est.predict(far, return_std=True)[1] > std)
    np.testing.assert_allclose(loaded.predict(test["X"][:5], return_std=True)[1], std, rtol=1e-8)


def test_lagrangian_gp_with_friction_learns_a_pendulums_friction(tmp_path):
    # A pendulum with viscous and smoothed Coulomb friction: friction=True learns it beside the energies,
    # the plain LIP cannot (friction is not conservative), and the model file keeps the friction term.
    rng = np.random.default_rng(5)

    def pendulum(rows):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, rows), rng.uniform(-2, 2, rows), rng.uniform(-3, 3, rows)
        tau = 0.3 * qdd + 2.0 * np.cos(q) + 0.4 * qd + 0.5 * np.tanh(qd / 0.05)
        return np.column_stack([q, qd, qdd]), tau[:, None]

    X, tau = pendulum(120)
    Xt, taut = pendulum(40)
    tau = tau + 0.01 * rng.standard_normal(tau.shape)
    smooth = gipdyn.LagrangianGP(joints="R", friction=True).fit(X, tau)
    plain = gipdyn.LagrangianGP(joints="R").fit(X, tau)
    assert smooth.model_.estimator == "lip+friction" and plain.model_.estimator == "lip"
    assert "friction.joint1.s_viscous" in smooth.hyperparameters_
    assert not any(name.startswith("friction") for name in plain.hyperparameters_)

    def relative_error(model):
        return np.linalg.norm(model.predict(Xt) - taut) / np.linalg.norm(taut)

    assert relative_error(smooth) < 0.1 * relative_error(plain)
    np.testing.assert_allclose(smooth.gravity(Xt[:, :1]), 2.0 * np.cos(Xt[:, :1]), rtol=0, atol=0.05)
    path = tmp_path / "lip_friction.gipdyn"
    smooth.save(path)
    loaded = gipdyn.LagrangianGP.load(path)
    assert loaded.friction and loaded.model_.estimator == "lip+friction"
    np.testing.assert_array_equal(loaded.predict(Xt), smooth.predict(Xt))


def test_lagrangian_gp_hyperparameters_from_a_subsample(scara):
    # Hyperparameters as a fit on the subsample alone, the model conditioned on every row.
    train, test = scara
    X, tau = train["X"][:90], train["tau"][:90]
    full = gipdyn.LagrangianGP(joints="RRPR", max_iter=20, hyperparameter_rows=30).fit(X, tau)
    sub = gipdyn.LagrangianGP(joints="RRPR", max_iter=20).fit(X[::3], tau[::3])
    assert full.hyperparameters_ == sub.hyperparameters_ and "potential.joint1.bias" in full.hyperparameters_
    assert all(r["hyperparameter_rows"] == 30 for r in full.training_report_)
    assert not np.allclose(full.predict(test["X"][:5]), sub.predict(test["X"][:5]))


def test_lagrangian_gp_serial_chain_is_the_default_and_can_be_turned_off(scara):
    # The library's LagrangianOptions::serial_chain, on by default, reaches LIP and the lip teacher.
    train, test = scara
    assert gipdyn.EstimatorOptions().serial_chain
    assert gipdyn.LagrangianGP().estimator_options().serial_chain
    assert not gipdyn.LagrangianGP(serial_chain=False).estimator_options().serial_chain
    assert not gipdyn.InverseDynamicsGP(serial_chain=False).estimator_options().serial_chain
    # Unset, each estimator's own from the library's table: a screening for lip, every start to its end for rbf.
    assert gipdyn.LagrangianGP().estimator_options().search.start_screening_evaluations is None
    lip, rbf = (gipdyn._core.estimator_search(name, gipdyn.EstimatorOptions().search) for name in ("lip", "rbf"))
    table = {row["name"]: row for row in gipdyn._core.estimator_table()}
    assert lip.start_screening_evaluations == table["lip"]["start_screening"] > 0
    assert rbf.start_screening_evaluations == 0 and rbf.restarts > 0
    assert gipdyn.LagrangianGP(start_screening=0).estimator_options().search.start_screening_evaluations == 0
    assert gipdyn.InverseDynamicsGP(start_screening=5).estimator_options().search.start_screening_evaluations == 5
    X, tau = train["X"][:40], train["tau"][:40]
    chain = gipdyn.LagrangianGP(joints="RRPR", max_iter=20).fit(X, tau)
    full = gipdyn.LagrangianGP(joints="RRPR", max_iter=20, serial_chain=False).fit(X, tau)
    assert not np.allclose(chain.predict(test["X"][:5]), full.predict(test["X"][:5]))
    # The learned inertia's last diagonal entry is a constant on a serial chain only.
    q = test["X"][:5, :4]
    last = [m[3, 3] for m in chain.inertia(q)]
    assert np.ptp(last) < 1e-9 * abs(last[0])
    assert np.ptp([m[3, 3] for m in full.inertia(q)]) > 1e-6 * abs(last[0])


def _gip_model_file(train, tmp_path):
    path = tmp_path / "gip.gipdyn"
    gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=3).fit(train["X"][:50], train["tau"][:50]).save(path)
    return str(path)


def test_preset_real_sets_the_kernel_and_subsample_and_explicit_parameters_override_it():
    assert gipdyn._core.preset_names() == ["default", "real"]
    assert gipdyn.InverseDynamicsGP(preset="real").estimator_options().name == "gip-envelope+friction"
    assert gipdyn.InverseDynamicsGP(preset="real", model="gip").estimator_options().name == "gip"
    assert gipdyn.InverseDynamicsGP(preset="default").estimator_options().name == "gip"
    d = gipdyn.simulate("scara", samples=1200, seed=3, dt=0.05)
    m = gipdyn.InverseDynamicsGP(joints="RRPR", preset="real", max_iter=5).fit(d["X"], d["tau"])
    assert m.model_.num_training_samples == 1000 and m.model_.kernel == "gip-envelope+friction"
    m = gipdyn.InverseDynamicsGP(joints="RRPR", preset="real", subsample=150, max_iter=5).fit(d["X"], d["tau"])
    assert m.model_.num_training_samples == 150
    with pytest.raises(ValueError, match="unknown preset 'fancy'"):
        gipdyn.InverseDynamicsGP(joints="RRPR", preset="fancy").fit(d["X"], d["tau"])
    with pytest.raises(ValueError, match="subsample must be >= 0"):
        gipdyn.InverseDynamicsGP(joints="RRPR", subsample=-1).fit(d["X"], d["tau"])


MPIRUN = __import__("shutil").which("mpirun")


@pytest.mark.skipif(not gipdyn._core.has_mpi or MPIRUN is None, reason="gipdyn built without MPI")
def test_distributed_fit_under_mpirun_gives_the_in_process_model(tmp_path):
    script = tmp_path / "fit.py"
    script.write_text(
        "import sys, numpy as np, gipdyn\n"
        "d = gipdyn.simulate('scara', samples=220, seed=31)\n"
        "est = gipdyn.InverseDynamicsGP(joints='RRPR', max_iter=12, min_noise=1e-3, n_jobs=1, distributed=True,\n"
        "                               teacher='auto')\n"
        "est.fit(d['X'], d['tau'])\n"
        "t = gipdyn.simulate('scara', samples=50, seed=32)\n"
        "if gipdyn.mpi_rank() == 0:\n"
        "    np.save(sys.argv[1], est.predict(t['X']))\n"
        "    print('processes', gipdyn.mpi_size(), 'teaching', est.teaching_)\n")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    out = tmp_path / "pred.npy"
    r = subprocess.run([MPIRUN, "-np", "2", "--oversubscribe", sys.executable, str(script), str(out)],
                       capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stderr
    assert "processes 2 teaching no teacher" in r.stdout  # teacher="auto" chooses none for a distributed fit
    d = gipdyn.simulate("scara", samples=220, seed=31)
    single = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=12, min_noise=1e-3, n_jobs=1).fit(d["X"], d["tau"])
    a = single.predict(gipdyn.simulate("scara", samples=50, seed=32)["X"])
    b = np.load(out)
    assert np.linalg.norm(a - b) < 1e-7 * np.linalg.norm(a)


def test_distributed_options_that_cannot_work_are_refused_by_name():
    d = gipdyn.simulate("scara", samples=60, seed=33)
    with pytest.raises(ValueError, match="teacher is not distributed"):  # before MPI starts
        gipdyn.InverseDynamicsGP(joints="RRPR", distributed=True, teacher="lip").fit(d["X"], d["tau"])
    # In a child process: MPI, once initialised, would stay in this one.
    code = ("import gipdyn\n"
            "d = gipdyn.simulate('scara', samples=60, seed=33)\n"
            "try:\n"
            "    gipdyn.InverseDynamicsGP(joints='RRPR', distributed=True, inducing=20).fit(d['X'], d['tau'])\n"
            "except gipdyn.GipdynError as e:\n"
            "    print(e)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    if gipdyn._core.has_mpi:
        assert "distributed computes the exact GP: set inducing to 0" in r.stdout, r.stdout
    else:
        assert "libscalapack-openmpi-dev" in r.stdout, r.stdout


def test_neighbour_consistency_finds_the_noise_and_a_changed_torque():
    t = np.arange(0, 30, 0.01)
    q = np.column_stack([np.sin(2 * np.pi * t / 5), np.sin(2 * np.pi * t / 10 + 1)])
    qd = np.gradient(q, 0.01, axis=0)
    X = np.hstack([q, qd, np.gradient(qd, 0.01, axis=0)])
    rng = np.random.default_rng(0)
    tau = np.column_stack([3 * np.cos(q[:, 0]), np.sin(q[:, 0] + q[:, 1])]) + 0.05 * rng.standard_normal((len(t), 2))
    within = gipdyn.neighbour_consistency(X, tau, radius=0.02)
    assert within["status"] == "ok" and within["pairs"] > 1000
    share = 0.05**2 / tau.var(axis=0)
    assert np.allclose(within["neighbour_nmse"] / 2, share, rtol=0.25)
    other = tau.copy()
    other[:, 1] = -tau[:, 1]
    across = gipdyn.neighbour_consistency(X, tau, X, other)
    assert across["neighbour_nmse"][0] < 0.1 and across["neighbour_nmse"][1] > 2
    assert gipdyn.neighbour_consistency(X[:100], tau[:100])["status"] == "too-few-pairs"
    with pytest.raises(ValueError, match="radius must be"):
        gipdyn.neighbour_consistency(X, tau, radius=0)
    with pytest.raises(ValueError, match="both X_test and tau_test"):
        gipdyn.neighbour_consistency(X, tau, X_test=X)
    # Joint 1 one turn further on is the same state for revolute joints (joints="RR"), not as logged.
    turned = X.copy()
    turned[:, 0] += 2 * np.pi
    assert gipdyn.neighbour_consistency(X, tau, turned, tau)["status"] == "too-few-pairs"
    on_circle = gipdyn.neighbour_consistency(X, tau, turned, tau, joints="RR")
    assert on_circle["status"] == "ok" and on_circle["neighbour_nmse"][0] < 0.1
    with pytest.raises(ValueError, match="joints names 3 joints but the log has 2"):
        gipdyn.neighbour_consistency(X, tau, joints="RRR")


def test_gip_taught_by_lip_learns_lips_torques_at_drawn_states():
    train = gipdyn.simulate("scara", samples=120, seed=1)
    kwargs = dict(joints="RRPR", max_iter=40, teacher="lip", teacher_states=150, teacher_hyperparameter_rows=0,
                  student_hyperparameter_rows=100, random_state=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gipdyn.ConvergenceWarning)
        taught = gipdyn.InverseDynamicsGP(**kwargs).fit(train["X"], train["tau"])
    assert isinstance(taught.teacher_, gipdyn.LagrangianGP)
    assert taught.model_.num_training_samples == 150  # the drawn states, not the log's 120 rows
    # The student's hyperparameters on 100 of them, then conditioned on all.
    assert [r["hyperparameter_rows"] for r in taught.model_.training_report] == [100] * 4
    residual = train["tau"] - taught.teacher_.predict(train["X"])
    np.testing.assert_allclose(taught.label_noise_std_, np.sqrt((residual ** 2).mean(axis=0)), rtol=1e-10)
    assert [r["joint"] for r in taught.teacher_report_] == [1, 2, 3, 4]
    # The check on the log: both fits' nMSE on the logged rows, no warning when the student fits it as its teacher.
    check = taught.teaching_check_
    np.testing.assert_allclose(check["student_nmse"], gipdyn.nmse(train["tau"], taught.predict(train["X"])), rtol=1e-9)
    np.testing.assert_allclose(check["teacher_nmse"], gipdyn.nmse(train["tau"], taught.teacher_.predict(train["X"])),
                               rtol=1e-9)
    assert check["warning"] == ""
    far_ahead = [j for j, (t, s) in enumerate(zip(check["teacher_nmse"], check["student_nmse"])) if s >= 10 * t and s > 1e-3]
    assert check["teacher_far_ahead"] == far_ahead
    # The student follows its teacher at fresh states of the same box far closer than the torque varies.
    rng = np.random.default_rng(0)
    X_box = rng.uniform(train["X"].min(axis=0), train["X"].max(axis=0), size=(200, 12))
    assert np.all(gipdyn.nmse(taught.teacher_.predict(X_box), taught.predict(X_box)) < 0.05)
    # Pickles with its teacher, both predicting as before.
    again = pickle.loads(pickle.dumps(taught))
    np.testing.assert_array_equal(again.predict(train["X"][:5]), taught.predict(train["X"][:5]))
    np.testing.assert_array_equal(again.teacher_.predict(train["X"][:5]), taught.teacher_.predict(train["X"][:5]))
    # Ten drawn states over a 12-dimensional box teach the student too little to fit the log: warned.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        few = gipdyn.InverseDynamicsGP(**dict(kwargs, teacher_states=10)).fit(train["X"], train["tau"])
    taught_warnings = [w for w in caught if issubclass(w.category, gipdyn.TeachingWarning)]
    assert len(taught_warnings) == 1 and "taught by lip fits the logged rows far worse" in str(taught_warnings[0].message)
    assert np.max(few.teaching_check_["student_nmse"] - few.teaching_check_["teacher_nmse"]) > 0.1
    assert taught.teaching_ == "taught" and few.teaching_ == "taught" and not few.teaching_check_["passed"]
    # teacher="auto" keeps a taught model that fits the log, and learns from the log where it does not (no warning).
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        auto = gipdyn.InverseDynamicsGP(**dict(kwargs, teacher="auto")).fit(train["X"], train["tau"])
        auto_few = gipdyn.InverseDynamicsGP(**dict(kwargs, teacher="auto", teacher_states=10)).fit(train["X"], train["tau"])
        own = gipdyn.InverseDynamicsGP(**dict(kwargs, teacher=None)).fit(train["X"], train["tau"])
    assert not [w for w in caught if issubclass(w.category, gipdyn.TeachingWarning)]
    assert auto.teaching_ == "taught" and auto.model_.num_training_samples == 150
    np.testing.assert_allclose(auto.predict(X_box), taught.predict(X_box), rtol=1e-10, atol=1e-12)
    assert auto_few.teaching_ == "student missed the log" and auto_few.model_.num_training_samples == 120
    np.testing.assert_allclose(auto_few.predict(X_box), own.predict(X_box), rtol=1e-10, atol=1e-12)
    assert own.teaching_ == "no teacher" and auto.teaching_failure_ == "" and auto_few.teaching_failure_ == ""
    # A student that cannot start (an exact GP on more drawn states than any machine's memory): the log's fit, and why.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gipdyn.ConvergenceWarning)
        huge = gipdyn.InverseDynamicsGP(**dict(kwargs, teacher="auto", teacher_states=400000)).fit(train["X"][:60],
                                                                                                   train["tau"][:60])
    assert huge.teaching_ == "student failed" and "needs about" in huge.teaching_failure_, huge.teaching_failure_
    assert huge.model_.num_training_samples == 60 and huge.teacher_ is not None
    with pytest.raises(ValueError, match="teacher_states must be at least"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="lip", teacher_states=2).fit(train["X"], train["tau"])
    with pytest.raises(ValueError, match="student_hyperparameter_rows must be >= 0"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="lip", student_hyperparameter_rows=-1).fit(train["X"], train["tau"])
    with pytest.raises(ValueError, match="needs a nominal robot"):
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="fe").fit(train["X"], train["tau"])


def test_auto_teacher_is_for_the_gip_kernel_alone():
    # The library's choose_teacher: teacher="auto" on another kernel has no teacher and learns from the log, as the
    # CLI's default train does (the teacher that cannot start: tests/cli, under an address-space limit).
    train = gipdyn.simulate("scara", samples=80, seed=2)
    kwargs = dict(joints="RRPR", model="rbf", max_iter=10, random_state=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        auto = gipdyn.InverseDynamicsGP(teacher="auto", **kwargs).fit(train["X"], train["tau"])
        own = gipdyn.InverseDynamicsGP(**kwargs).fit(train["X"], train["tau"])
    assert auto.teaching_ == "no teacher" and own.teaching_ == "no teacher"
    assert auto.teacher_ is None and auto.teaching_check_ is None and auto.model_.num_training_samples == 80
    np.testing.assert_array_equal(auto.predict(train["X"]), own.predict(train["X"]))


def test_positions_that_look_like_degrees_are_warned_about():
    train = gipdyn.simulate("scara", samples=60, seed=2)
    X = train["X"].copy()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=3).fit(X, train["tau"])
    assert not [w for w in caught if issubclass(w.category, gipdyn.DataWarning)]
    X[:, 0] = np.degrees(X[:, 0]) * 10  # joint 1 in (tenths of) degrees: far more than two turns
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=3).fit(X, train["tau"])
    data = [str(w.message) for w in caught if issubclass(w.category, gipdyn.DataWarning)]
    assert len(data) == 1 and "column q1 of X spans" in data[0] and "convert q, qd and qdd to radians" in data[0], data
    X[:, 1], X[:, 5], X[:, 9] = 0.4, 0.0, 0.0  # joint 2 locked
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gipdyn.InverseDynamicsGP(joints="RRPR", teacher="none", max_iter=3).fit(X, train["tau"])
    data = [str(w.message) for w in caught if issubclass(w.category, gipdyn.DataWarning)]
    assert len(data) == 2 and data[0].startswith("joint(s) 2 never move in X"), data


def test_a_long_exact_fit_is_warned_about_before_it_starts():
    # The rule behind the warning fit() gives before the first evaluation (a fit on 8000 rows takes too long to
    # run here): exact GPs on 8000 or more rows; not a sparse one, a subsampled one, pp or a taught one.
    def warned(rows, **params):
        model = gipdyn.InverseDynamicsGP(**{"joints": "RR", "teacher": "none", **params})
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model._warn_about_a_long_exact_fit(model.estimator_options(), model.teacher_options(), rows, model.n_joints)
        return [w for w in caught if issubclass(w.category, gipdyn.LongFitWarning)]

    long = warned(8000)
    assert len(long) == 1 and "8000 x 8000 matrix" in str(long[0].message)
    assert "hyperparameter_rows=2000" in str(long[0].message) and "inducing=500" in str(long[0].message)
    assert warned(7999) == []
    assert warned(20000, inducing=300) == []
    assert warned(20000, hyperparameter_rows=2000) == []
    assert len(warned(20000, hyperparameter_rows=9000)) == 1
    assert warned(8000, teacher="lip") == []  # the student learns on the teacher's 2000 states
    assert len(warned(8000, teacher="auto")) == 1  # 16000 torque values: too long for the automatic teacher
    assert warned(4000, teacher="auto") == []


def test_gip_taught_by_an_identified_chain():
    # teacher="chain": the library's chain estimator (a serial chain's geometry identified from the log, then least
    # squares on its regressor) labels the drawn states. On a SCARA log it is exact to the noise, so the student
    # tracks KDL's torques on a new motion as well as it tracks its teacher.
    train = gipdyn.simulate("scara", samples=300, seed=1, dt=0.05)
    test = gipdyn.simulate("scara", samples=200, seed=2, dt=0.05)
    taught = gipdyn.InverseDynamicsGP(joints="RRPR", teacher="chain", teacher_states=600, random_state=4).fit(
        train["X"], train["tau"])
    assert taught.teaching_ == "taught"
    assert taught.teacher_ is None  # only a LIP teacher is kept as a Python object
    nmse = gipdyn.nmse(test["tau_true"], taught.predict(test["X"]))
    assert np.all(nmse[:3] < 1e-3) and nmse[3] < 5e-2, nmse
    # The teacher misses the log by its noise alone: the chain explains everything else.
    noise_share = ((train["tau"] - train["tau_true"]) ** 2).mean(axis=0) / train["tau"].var(axis=0)
    assert np.all(np.asarray(taught.teaching_check_["teacher_nmse"]) < 1.2 * noise_share)
