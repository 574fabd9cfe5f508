"""The Python estimators as scikit-learn users expect them: its own estimator checks, its parameter names,
pickling, tables with named columns, and no guessed joint types."""
import os
import pickle
import re
import warnings

import numpy as np
import pytest

import gipdyn

sklearn = pytest.importorskip("sklearn")
from sklearn.base import clone  # noqa: E402
from sklearn.utils.estimator_checks import check_estimator  # noqa: E402

# The checks that feed X of 2, 4, 5 or 10 columns: an estimator's input width is three per joint (q, qd, qdd),
# fixed by its joints, so they fail with the width error and nothing else (asserted below). Every other check
# of scikit-learn's runs and passes.
INPUT_WIDTH_FIXED_BY_THE_JOINTS = {
    "check_dtype_object", "check_estimators_dtypes", "check_estimators_fit_returns_self",
    "check_estimators_overwrite_params", "check_fit2d_1sample", "check_fit_check_is_fitted", "check_fit_idempotent",
    "check_n_features_in", "check_non_transformer_estimators_n_iter", "check_regressor_data_not_an_array",
    "check_regressor_multioutput", "check_regressors_int", "check_regressors_no_decision_function",
    "check_regressors_train", "check_requires_y_none",
}
# InverseDynamicsGP has partial_fit, whose check also feeds 2 columns.
PARTIAL_FIT_WIDTH = {"check_estimators_partial_fit_n_features"}


def run_checks(estimator):
    """{check name: None (passed) or the exception it raised}, over every check scikit-learn runs."""
    outcome = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for est, check in check_estimator(estimator, generate_only=True):
            name = getattr(check, "func", check).__name__
            try:
                check(est)
                outcome.setdefault(name, None)
            except Exception as error:  # noqa: BLE001 - recorded and asserted on below
                outcome[name] = error
    return outcome


@pytest.mark.parametrize("estimator, expected_width_failures", [
    (gipdyn.InverseDynamicsGP(joints="R"), INPUT_WIDTH_FIXED_BY_THE_JOINTS | PARTIAL_FIT_WIDTH),
    (gipdyn.InverseDynamicsGP(joints="P", model="rbf", max_iter=30), INPUT_WIDTH_FIXED_BY_THE_JOINTS | PARTIAL_FIT_WIDTH),
    (gipdyn.LagrangianGP(joints="R", max_iter=30), INPUT_WIDTH_FIXED_BY_THE_JOINTS),
    (gipdyn.InverseDynamics(joints="R", model="chain"), INPUT_WIDTH_FIXED_BY_THE_JOINTS),
], ids=["gip", "rbf", "lip", "inverse-dynamics-chain"])
def test_scikit_learns_estimator_checks_pass_but_for_the_input_width(estimator, expected_width_failures):
    outcome = run_checks(estimator)
    assert len(outcome) > 35  # the checks ran
    failed = {name: error for name, error in outcome.items() if error is not None}
    assert set(failed) == expected_width_failures, {k: str(v)[:200] for k, v in failed.items()}
    for name, error in failed.items():  # our width error, raised as it is or quoted by the check that expected another
        assert isinstance(error, (ValueError, AssertionError)), (name, error)
        assert "but must have 3 (q, qd, qdd of joints=" in str(error), (name, error)


def test_scikit_learns_parameter_names_and_old_names_refused():
    params = gipdyn.InverseDynamicsGP(joints="RR").get_params()
    assert "random_state" in params and "n_jobs" in params and "seed" not in params and "threads" not in params
    assert "random_state" in gipdyn.LagrangianGP(joints="RR").get_params()
    assert {"random_state", "n_jobs"} <= set(gipdyn.InverseDynamics(joints="RR").get_params())
    assert gipdyn.InverseDynamics(joints="RR", random_state=7).estimator_options().search.seed == 7
    with pytest.raises(TypeError, match=r"seed= is now called random_state="):
        gipdyn.InverseDynamicsGP(joints="RR", seed=3)
    with pytest.raises(TypeError, match=r"threads= is now called n_jobs="):
        gipdyn.InverseDynamicsGP(joints="RR", threads=1)
    with pytest.raises(TypeError, match=r"the parameter kernel= is now called model= \(as the command line's train --model\)"):
        gipdyn.InverseDynamicsGP(joints="R", kernel="rbf")
    with pytest.raises(TypeError, match=r"LagrangianGP: the parameter seed= is now called random_state="):
        gipdyn.LagrangianGP(joints="RR", seed=3)
    o = gipdyn.InverseDynamicsGP(joints="RR", random_state=7, n_jobs=2).estimator_options()
    assert o.search.seed == 7 and o.search.threads == 2
    assert gipdyn.InverseDynamicsGP(joints="RR", n_jobs=-1).estimator_options().search.threads == 0
    assert gipdyn.InverseDynamicsGP(joints="RR", random_state=None).estimator_options().search.seed == 0
    drawn = gipdyn.InverseDynamicsGP(joints="RR", random_state=np.random.RandomState(5)).estimator_options().search.seed
    assert drawn == np.random.RandomState(5).randint(2**31)
    for bad, message in [(dict(n_jobs=0), "n_jobs must be a positive"), (dict(random_state=-1), "random_state must be >= 0"),
                         (dict(random_state="x"), "random_state must be an int")]:
        with pytest.raises(ValueError, match=message):
            gipdyn.InverseDynamicsGP(joints="RR", **bad).estimator_options()


def test_the_same_random_state_gives_the_same_model_and_another_may_not():
    d = gipdyn.simulate("scara", samples=80, seed=2, dt=0.1)
    kwargs = dict(joints="RRPR", model="rbf", restarts=2, max_iter=15, start_screening=0)
    a = gipdyn.InverseDynamicsGP(random_state=4, **kwargs).fit(d["X"], d["tau"])
    b = gipdyn.InverseDynamicsGP(random_state=4, **kwargs).fit(d["X"], d["tau"])
    c = gipdyn.InverseDynamicsGP(random_state=5, **kwargs).fit(d["X"], d["tau"])
    np.testing.assert_array_equal(a.predict(d["X"]), b.predict(d["X"]))
    assert not np.array_equal(a.predict(d["X"]), c.predict(d["X"]))
    # The same for every random process of a fit, a network's initialisation among them.
    a, b, c = (gipdyn.InverseDynamics(joints="RRPR", model="nn", random_state=seed).fit(d["X"], d["tau"])
               for seed in (4, 4, 5))
    np.testing.assert_array_equal(a.predict(d["X"]), b.predict(d["X"]))
    assert not np.array_equal(a.predict(d["X"]), c.predict(d["X"]))


def test_joint_types_are_never_guessed():
    d = gipdyn.simulate("scara", samples=30, seed=1)
    for est in (gipdyn.InverseDynamicsGP(), gipdyn.LagrangianGP(), gipdyn.InverseDynamics()):
        with pytest.raises(ValueError) as err:
            est.fit(d["X"], d["tau"])
        message = str(err.value)
        assert "\n" not in message and "joints=" in message and "robot=" in message and "read_log" in message
        assert not hasattr(est, "model_")


def test_a_table_with_named_columns_is_read_by_name(tmp_path):
    pd = pytest.importorskip("pandas")
    d = gipdyn.simulate("scara", samples=60, seed=4, dt=0.1)
    names = [f"{p}{i}" for p in ("q", "qd", "qdd") for i in range(1, 5)]
    X = pd.DataFrame(d["X"], columns=names)
    Y = pd.DataFrame(d["tau"], columns=[f"tau{i}" for i in range(1, 5)])
    shuffled = X[list(reversed(names))].assign(time=np.arange(60))  # any order, other columns ignored
    kwargs = dict(joints="RRPR", model="rbf", teacher="none", max_iter=10)
    from_table = gipdyn.InverseDynamicsGP(**kwargs).fit(shuffled, Y)
    from_arrays = gipdyn.InverseDynamicsGP(**kwargs).fit(d["X"], d["tau"])
    np.testing.assert_array_equal(from_table.predict(X), from_arrays.predict(d["X"]))
    np.testing.assert_array_equal(from_table.nmse(shuffled, Y), from_arrays.nmse(d["X"], d["tau"]))
    with pytest.raises(ValueError, match=r"X has no column 'qdd4'.*rename its columns"):
        from_table.predict(X.drop(columns="qdd4"))


def test_predictions_take_the_shape_of_the_target_fit_was_given():
    rng = np.random.default_rng(2)
    X = rng.uniform(-1, 1, (40, 3))
    y = np.sin(X[:, 0]) + 0.3 * X[:, 2]
    for est in (gipdyn.InverseDynamicsGP(joints="R", model="rbf", max_iter=10), gipdyn.LagrangianGP(joints="R", max_iter=10)):
        mean, std = est.fit(X, y).predict(X[:5], return_std=True)
        assert mean.shape == (5,) and std.shape == (5,)
        assert est.fit(X, y[:, None]).predict(X[:5]).shape == (5, 1)
        with pytest.raises(ValueError, match="Reshape your data"):
            est.predict(X[0])
        assert est.predict_one(X[0]).shape == (1,)


def test_unfitted_and_fitted_estimators_pickle_and_clone():
    from sklearn.base import clone
    d = gipdyn.simulate("scara", samples=50, seed=6, dt=0.1)
    for est in (gipdyn.InverseDynamicsGP(joints="RRPR", model="rbf", max_iter=5, random_state=3),
                gipdyn.LagrangianGP(joints="RRPR", max_iter=5), gipdyn.InverseDynamics(joints="RRPR", model="chain")):
        unfitted = pickle.loads(pickle.dumps(est))
        assert unfitted.get_params() == est.get_params() and not hasattr(unfitted, "model_")
        fitted = unfitted.fit(d["X"], d["tau"])
        again = pickle.loads(pickle.dumps(fitted))
        np.testing.assert_array_equal(again.predict(d["X"]), fitted.predict(d["X"]))
        assert clone(fitted).get_params() == fitted.get_params() and not hasattr(clone(fitted), "model_")


def test_docstrings_are_numpydoc_and_their_examples_run():
    import doctest
    import inspect
    for cls in (gipdyn.InverseDynamics, gipdyn.InverseDynamicsGP, gipdyn.LagrangianGP, gipdyn.ContactDetector):
        doc = inspect.getdoc(cls)
        for section in ("Parameters\n----------", "Examples\n--------") if cls is not gipdyn.ContactDetector else (
                "Parameters\n----------",):
            assert section in doc, (cls.__name__, section)
        for name in inspect.signature(cls.__init__).parameters:  # every parameter under its own or a shared entry
            if name != "self":
                assert re.search(rf"^{name}\b|, {name}\b", doc, re.M), (cls.__name__, name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = doctest.testmod(gipdyn, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 8 and result.failed == 0, result


def test_the_choice_by_evidence_is_inverse_dynamics_and_the_gp_class_points_there():
    d = gipdyn.simulate("scara", samples=40, seed=1)
    with pytest.raises(ValueError, match=r"model='auto' \(the choice by evidence .*use InverseDynamics\(model='auto'\)"):
        gipdyn.InverseDynamicsGP(joints="RRPR", model="auto").fit(d["X"], d["tau"])
    for params, message in [(dict(preset="real"), r"preset= chooses part of the model, and model='auto'"),
                            (dict(teacher="lip"), r"model='auto' chooses its teachers itself"),
                            (dict(robot=os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "two_link.json")), r"robot= chooses part of the model")]:
        with pytest.raises(ValueError, match=message):
            gipdyn.InverseDynamics(joints="RRPR", model="auto", **params).fit(d["X"], d["tau"])
    with pytest.raises(ValueError, match=r"unknown estimator 'gipp'; one of gip, "):
        gipdyn.InverseDynamics(joints="RRPR", model="gipp").fit(d["X"], d["tau"])


def test_load_restores_the_parameters_that_made_the_model(tmp_path):
    # The model file's options block gives back every parameter that shapes the model: a clone of the loaded
    # estimator, fitted on the same rows, is the same model.
    s = gipdyn.simulate("scara", samples=150, seed=1)
    params = dict(joints="RRPR", model="rbf", teacher="none", optimizer="lbfgs", max_iter=12, restarts=1,
                  random_state=5, scaling="center", min_noise=1e-6, mean="constant", prior="lognormal",
                  prior_width=1.5, gradient_tolerance=1e-4, start_screening=5, hyperparameter_rows=100)
    est = gipdyn.InverseDynamicsGP(**params).fit(s["X"], s["tau"])
    est.save(tmp_path / "m.gipdyn")
    loaded = gipdyn.InverseDynamicsGP.load(tmp_path / "m.gipdyn")
    got = loaded.get_params()
    assert {k: got[k] for k in params} == params
    again = clone(loaded).fit(s["X"], s["tau"])
    assert np.array_equal(again.predict(s["X"]), est.predict(s["X"]))
    # The same for the Lagrangian estimator.
    lip_params = dict(joints="RRPR", friction=True, max_iter=6, random_state=2, hyperparameter_rows=60,
                      serial_chain=False, min_noise=1e-6)
    lip = gipdyn.LagrangianGP(**lip_params).fit(s["X"][:80], s["tau"][:80])
    lip.save(tmp_path / "lip.gipdyn")
    loaded = gipdyn.LagrangianGP.load(tmp_path / "lip.gipdyn")
    got = loaded.get_params()
    assert {k: got[k] for k in lip_params} == lip_params
    again = clone(loaded).fit(s["X"][:80], s["tau"][:80])
    assert np.array_equal(again.predict(s["X"]), lip.predict(s["X"]))
