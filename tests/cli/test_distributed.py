"""`mpirun -np P gipdyn train --distributed`: the same model as one process, one
report, and refusals that stop every process with one line. `gipdyn --version`
says whether the binary was built with MPI; the launcher is GIPDYN_MPIEXEC (ctest
sets it) or mpiexec on PATH. Without MPI, --distributed must say how to get it."""
import os
import shutil
import subprocess

import numpy as np
import pytest

from conftest import write_dataset
from test_cli import run


@pytest.fixture(scope="session")
def built_with_mpi(gipdyn_bin):
    r = run(gipdyn_bin, "--version")
    assert r.returncode == 0, r.stderr
    return "distributed training: MPI" in r.stdout


@pytest.fixture
def mpiexec(built_with_mpi):
    launcher = os.environ.get("GIPDYN_MPIEXEC") or shutil.which("mpiexec")
    if not (built_with_mpi and launcher):
        pytest.skip("gipdyn built without MPI, or no mpiexec (GIPDYN_MPIEXEC unset, none on PATH)")
    return launcher


def mpirun(launcher, np_, binary, *args):
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return subprocess.run([launcher, "-np", str(np_), "--oversubscribe", binary, *args], capture_output=True,
                          text=True, timeout=300, env=env)


def predictions(binary, model, data, out):
    r = run(binary, "predict", "--model", str(model), "--data", str(data), "--out", str(out))
    assert r.returncode == 0, r.stderr
    p = np.genfromtxt(out, delimiter=",", names=True)
    return np.column_stack([p["tau1_hat"], p["tau2_hat"]])


def test_distributed_training_gives_the_single_process_model(tmp_path, gipdyn_bin, mpiexec):
    train, test = tmp_path / "train.csv", tmp_path / "test.csv"
    write_dataset(train, 230, seed=21, noise=0.05)
    write_dataset(test, 100, seed=22)
    # A short run with a noise floor: the optimiser walks the same path on both
    # (tests/test_distributed_nll.cpp explains why a floor is needed for that).
    common = ["--data", str(train), "--joints", "RR", "--max-iter", "12", "--min-noise", "1e-3", "--threads", "1"]
    single, dist = tmp_path / "single.gipdyn", tmp_path / "dist.gipdyn"
    r = run(gipdyn_bin, "train", *common, "--teacher", "none", "--out", str(single))  # a teacher is not distributed
    assert r.returncode == 0, r.stderr
    r = mpirun(mpiexec, 2, gipdyn_bin, "train", *common, "--distributed", "--out", str(dist))
    assert r.returncode == 0, r.stderr
    assert "distributed over 2 MPI processes, a 1 x 2 ScaLAPACK grid" in r.stdout
    assert r.stdout.count("saved gip model to") == 1, r.stdout  # only the first process reports
    a = predictions(gipdyn_bin, single, test, tmp_path / "a.csv")
    b = predictions(gipdyn_bin, dist, test, tmp_path / "b.csv")
    assert np.linalg.norm(a - b) < 1e-7 * np.linalg.norm(a)


@pytest.mark.usefixtures("mpiexec")
def test_a_single_process_run_without_mpirun_works(tmp_path, gipdyn_bin):
    train = tmp_path / "train.csv"
    write_dataset(train, 80, seed=23)
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--max-iter", "10", "--distributed",
            "--out", str(tmp_path / "m.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "distributed over 1 MPI process" in r.stdout


@pytest.mark.parametrize("extra, named", [(["--inducing", "20"], "--inducing"), (["--model", "nn"], "nn"),
                                          (["--mean", "linear"], "--mean")])
def test_options_that_cannot_be_distributed_stop_every_process_with_one_line(tmp_path, gipdyn_bin, mpiexec, extra,
                                                                            named):
    train = tmp_path / "train.csv"
    write_dataset(train, 80, seed=24)
    out = tmp_path / "m.gipdyn"
    r = mpirun(mpiexec, 2, gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--distributed", *extra,
               "--out", str(out))
    assert r.returncode != 0
    errors = [line for line in r.stderr.splitlines() if line.startswith("gipdyn: error:")]
    assert len(errors) == 1, r.stderr
    assert named in errors[0], errors[0]
    assert not out.exists()


def test_a_file_only_one_process_cannot_read_is_reported_by_that_process(tmp_path, gipdyn_bin, mpiexec):
    # Every process reads --data itself; here the file differs per rank through
    # OpenMPI's rank variable, as a node with a stale copy would see it.
    train, stale = tmp_path / "train.csv", tmp_path / "stale.csv"
    write_dataset(train, 80, seed=25)
    stale.write_text("q1,q2,qd1,qd2,qdd1,qdd2\n0,0,0,0,0,0\n")
    wrapper = tmp_path / "run.sh"
    wrapper.write_text(f'#!/bin/sh\nd={train}\n[ "$OMPI_COMM_WORLD_RANK" = 1 ] && d={stale}\n'
                       f'exec {gipdyn_bin} "$@" --data "$d"\n')
    wrapper.chmod(0o755)
    out = tmp_path / "m.gipdyn"
    r = mpirun(mpiexec, 2, str(wrapper), "train", "--joints", "RR", "--distributed", "--out", str(out))
    assert r.returncode != 0
    errors = [line for line in r.stderr.splitlines() if line.startswith("gipdyn: error:")]
    assert len(errors) == 1, r.stderr
    assert "MPI process 1 of 2" in errors[0] and "tau1" in errors[0], errors[0]
    assert not out.exists()


def test_without_mpi_distributed_says_how_to_get_it(tmp_path, gipdyn_bin, built_with_mpi):
    if built_with_mpi:
        pytest.skip("gipdyn built with MPI")
    train = tmp_path / "train.csv"
    write_dataset(train, 40, seed=26)
    r = run(gipdyn_bin, "train", "--data", str(train), "--joints", "RR", "--distributed", "--out",
            str(tmp_path / "m.gipdyn"))
    assert r.returncode == 1
    assert "libscalapack-openmpi-dev" in r.stderr
