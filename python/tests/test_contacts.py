"""gipdyn.ContactDetector over the Python estimators, against the simulator's true external torque."""
import warnings

import numpy as np
import pytest

import gipdyn


@pytest.fixture(scope="module")
def scara():
    train = gipdyn.simulate("scara", samples=400, dt=0.1, seed=1)
    model = gipdyn.InverseDynamicsGP(joints="RRPR", model="gip", teacher="none").fit(train["X"], train["tau"])
    contacts = gipdyn.simulate("scara", samples=3000, dt=0.001, seed=4, contacts=4)
    calibration = gipdyn.simulate("scara", samples=2000, dt=0.001, seed=5)
    return model, contacts, calibration


def test_simulate_returns_the_true_external_torque(scara):
    _, d, calibration = scara
    assert d["external"].shape == (3000, 4) and "external" not in calibration
    rigid = gipdyn.Robot.load("scara").inverse_dynamics(d["q"], d["qd"], d["qdd"])
    np.testing.assert_allclose(rigid, d["tau_true"] + d["external"], atol=1e-8)
    assert len(d["metadata"]["contacts"]["drawn"]) == 4


@pytest.mark.parametrize("method", ["residual", "momentum"])
def test_detector_finds_the_contacts_the_cli_finds(scara, method):
    model, d, calibration = scara
    detector = gipdyn.ContactDetector(model, sample_time=0.001, method=method).calibrate(calibration["X"],
                                                                                         calibration["tau"])
    r = detector.detect(d["X"], d["tau"])
    assert r.method == method and r.noise_source == "calibration"
    assert r.external_torque.shape == r.contact.shape == r.threshold.shape == (3000, 4)
    score = gipdyn.score_contacts(r, d["external"], 0.001)
    large = sum(abs(c["torque"]) >= 0.1 for c in d["metadata"]["contacts"]["drawn"])
    assert score.detected >= large and score.false_alarms == 0, r.brief_report()
    assert score.max_delay <= 0.02
    np.testing.assert_array_equal(detector.external_torque(d["X"], d["tau"]), r.external_torque)


def test_detector_explains_what_it_cannot_do(scara):
    model, d, _ = scara
    with pytest.raises(gipdyn.GipdynError, match="false_alarm_rate must lie in"):
        gipdyn.ContactDetector(model, sample_time=0.001, false_alarm_rate=2.0)
    with pytest.raises(gipdyn.GipdynError, match="sample_time must be"):
        gipdyn.ContactDetector(model, sample_time=0.0)
    with pytest.raises(gipdyn.GipdynError, match="choose residual or momentum"):
        gipdyn.ContactDetector(model, sample_time=0.001, method="kalman")
    with pytest.raises(gipdyn.NotFittedError):
        gipdyn.ContactDetector(gipdyn.InverseDynamicsGP(joints="RRPR"), sample_time=0.001)
    with pytest.raises(ValueError, match="12 columns"):
        gipdyn.ContactDetector(model, sample_time=0.001).detect(d["X"][:, :8], d["tau"])
    with warnings.catch_warnings():  # a short fit: only its kind matters here
        warnings.simplefilter("ignore")
        rbf = gipdyn.InverseDynamicsGP(joints="RRPR", model="rbf", max_iter=20).fit(d["X"][:200], d["tau"][:200])
    with pytest.raises(gipdyn.GipdynError, match="cannot give gravity, inertia"):
        gipdyn.ContactDetector(rbf, sample_time=0.001, method="momentum")


def test_any_estimators_model_detects_once_calibrated(scara):
    # A model of another family than the GPs and LIP (here the identified chain) has no predictive standard
    # deviation: it detects after calibrate() and says so before.
    _, d, calibration = scara
    train = gipdyn.simulate("scara", samples=400, dt=0.1, seed=1)
    chain = gipdyn.InverseDynamics(joints="RRPR", model="chain").fit(train["X"], train["tau"])
    detector = gipdyn.ContactDetector(chain, sample_time=0.001, method="momentum")
    with pytest.raises(gipdyn.GipdynError, match=r"'chain' model gives no predictive standard deviation: calibrate"):
        detector.detect(d["X"], d["tau"])
    r = detector.calibrate(calibration["X"], calibration["tau"]).detect(d["X"], d["tau"])
    score = gipdyn.score_contacts(r, d["external"], 0.001)
    large = sum(abs(c["torque"]) >= 0.1 for c in d["metadata"]["contacts"]["drawn"])
    assert score.detected >= large, r.brief_report()
