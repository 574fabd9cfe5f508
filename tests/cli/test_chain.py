"""The chain estimator from the command line: a serial chain's geometry identified from the log, then least squares
on its regressor (docs/method.md section 16). The reference is the 2R arm's closed-form dynamics of conftest.py, whose
gravity lies in the plane of motion: perpendicular to the first joint's axis, so the chain must learn its direction."""
import numpy as np
import pytest

from conftest import model_header, write_dataset
from test_cli import run


def nmse_of(gipdyn_bin, d, model, test):
    """predict's torques for test.csv against the closed-form noise-free torques."""
    out = d / (model + ".csv")
    r = run(gipdyn_bin, "predict", "--model", str(d / model), "--data", str(d / "test.csv"), "--out", str(out))
    assert r.returncode == 0, r.stderr
    pred = np.loadtxt(out, delimiter=",", skiprows=1)
    return ((pred[:, :2] - test[:, 8:10]) ** 2).mean(0) / test[:, 8:10].var(0)


@pytest.fixture(scope="module")
def chain_model(tmp_path_factory, gipdyn_bin):
    d = tmp_path_factory.mktemp("chain")
    write_dataset(d / "train.csv", 200, seed=11)
    test = write_dataset(d / "test.csv", 300, seed=12)
    r = run(gipdyn_bin, "train", "--data", str(d / "train.csv"), "--joints", "RR", "--model", "chain",
            "--chain-starts", "16", "--seed", "3", "--out", str(d / "chain.gipdyn"))
    assert r.returncode == 0, r.stderr
    return d, test, r.stdout


def test_chain_learns_the_arm_and_the_direction_of_gravity(chain_model, gipdyn_bin):
    d, test, out = chain_model
    assert "chain identification: converged" in out, out
    assert model_header(d / "chain.gipdyn")["estimator"] == "chain"
    nmse = nmse_of(gipdyn_bin, d, "chain.gipdyn", test)
    assert (nmse < 1e-4).all(), nmse


def test_chain_teaches_gip(chain_model, gipdyn_bin):
    d, test, _ = chain_model
    r = run(gipdyn_bin, "train", "--data", str(d / "train.csv"), "--joints", "RR", "--teacher", "chain",
            "--teacher-states", "500", "--out", str(d / "taught.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert model_header(d / "taught.gipdyn")["teacher"]["estimator"] == "chain"
    nmse = nmse_of(gipdyn_bin, d, "taught.gipdyn", test)
    assert (nmse < 1e-3).all(), nmse


@pytest.mark.parametrize("args, says", [
    (["--chain-starts", "0"], "--chain-starts must be at least 1"),
    (["--chain-rows", "1"], "use more rows (--chain-rows"),
    (["--chain-length-scale", "-1"], "--chain-length-scale must be a positive length"),
])
def test_bad_chain_options_are_one_line_errors(chain_model, gipdyn_bin, args, says):
    d, _, _ = chain_model
    out = d / "bad.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(d / "train.csv"), "--joints", "RR", "--model", "chain", *args,
            "--out", str(out))
    assert r.returncode != 0
    assert says in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not out.exists()
