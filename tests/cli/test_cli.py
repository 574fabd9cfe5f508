"""End-to-end tests of the gipdyn command line: train, predict, evaluate, and bad input."""
import json
import os
import re
import subprocess

import numpy as np
import pytest

from conftest import model_header, two_link_torques, write_dataset


def run(binary, *args):
    return subprocess.run([binary, *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def trained(tmp_path_factory, gipdyn_bin):
    d = tmp_path_factory.mktemp("cli")
    write_dataset(d / "train.csv", 150, seed=1, shuffle_columns=True)
    test = write_dataset(d / "test.csv", 200, seed=2)
    r = run(gipdyn_bin, "train", "--data", str(d / "train.csv"), "--joints", "RR", "--out", str(d / "m.gipdyn"),
            "--max-iter", "80")
    assert r.returncode == 0, r.stderr
    return d, test, r.stdout


def test_train_reports_progress_and_writes_model(trained):
    d, _, out = trained
    assert "joint 1" in out and "joint 2" in out and "NLL" in out
    assert "saved gip model to" in out
    assert (d / "m.gipdyn").stat().st_size > 1000


def test_version_is_the_projects_and_model_files_record_it(trained, gipdyn_bin):
    # The version CMake's project() declares, printed by --version and recorded in every model file.
    cmake = open(os.path.join(os.path.dirname(__file__), "..", "..", "CMakeLists.txt")).read()
    declared = cmake.split("project(gipdyn VERSION ")[1].split()[0]
    r = run(gipdyn_bin, "--version")
    assert r.returncode == 0 and r.stdout.startswith(f"gipdyn {declared} (model file format "), r.stdout
    # It also says whether --distributed can work (tests/cli/test_distributed.py relies on it).
    assert ", distributed training: MPI)" in r.stdout or ", distributed training: not built)" in r.stdout, r.stdout
    # And how it was compiled, for bug reports: the instruction set and Eigen's layout (16 bytes, that of
    # Debian's libraries gipdyn shares Eigen objects with; include/gipdyn/eigen_abi.hpp).
    build = r.stdout.splitlines()[1]
    assert build.startswith("built for x86-64") and "; Eigen 3." in build, build
    assert "16-byte alignment" in build and "AVX" not in build.split(";")[0], build
    d, _, _ = trained
    assert model_header(d / "m.gipdyn")["written_by"] == f"gipdyn {declared}"


def test_predict_writes_means_and_stds(trained, gipdyn_bin):
    d, test, _ = trained
    r = run(gipdyn_bin, "predict", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"), "--out",
            str(d / "pred.csv"))
    assert r.returncode == 0, r.stderr
    with open(d / "pred.csv") as f:
        header = f.readline().strip().split(",")
    assert header == ["tau1_hat", "tau2_hat", "tau1_std", "tau2_std"]
    pred = np.loadtxt(d / "pred.csv", delimiter=",", skiprows=1)
    assert pred.shape == (200, 4)
    nmse = ((pred[:, :2] - test[:, 8:10]) ** 2).mean(0) / test[:, 8:10].var(0)
    assert (nmse < 1e-2).all(), nmse
    assert (pred[:, 2:] > 0).all()


def test_evaluate_prints_table_and_json(trained, gipdyn_bin):
    d, test, _ = trained
    r = run(gipdyn_bin, "evaluate", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"), "--json",
            str(d / "report.json"))
    assert r.returncode == 0, r.stderr
    assert "nMSE" in r.stdout and "GMSE" in r.stdout and "noise-free" in r.stdout
    report = json.loads((d / "report.json").read_text())
    assert set(["nmse", "mse", "gmse"]) <= set(report)
    assert len(report["nmse"]) == 2 and len(report["mse"]) == 2
    assert abs(report["gmse"] - sum(report["mse"])) < 1e-12
    # The JSON agrees with an nMSE computed here from `predict`'s output.
    run(gipdyn_bin, "predict", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"), "--out",
        str(d / "p2.csv"), "--no-std")
    pred = np.loadtxt(d / "p2.csv", delimiter=",", skiprows=1)
    nmse = ((pred - test[:, 8:10]) ** 2).mean(0) / test[:, 8:10].var(0)
    assert np.allclose(report["nmse"], nmse, rtol=1e-9)


def test_evaluate_warns_about_joints_predicted_worse_than_their_mean(trained, tmp_path, gipdyn_bin):
    d, test, _ = trained
    r = run(gipdyn_bin, "evaluate", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"))
    assert r.returncode == 0 and "worse than their own mean" not in r.stderr, r.stderr
    # Joint 1's torque turned over: the model's predictions are now worse than that torque's own mean.
    flipped = test.copy()
    flipped[:, [6, 8]] *= -1
    names = ["q1", "q2", "qd1", "qd2", "qdd1", "qdd2", "tau1", "tau2", "tau1_true", "tau2_true"]
    path = tmp_path / "flipped.csv"
    np.savetxt(path, flipped, delimiter=",", header=",".join(names), comments="")
    r = run(gipdyn_bin, "evaluate", "--model", str(d / "m.gipdyn"), "--data", str(path))
    assert r.returncode == 0, r.stderr
    warning = [line for line in r.stderr.splitlines() if "worse than their own mean" in line]
    assert len(warning) == 1 and re.search(r"joint\(s\) 1 \(nMSE [3-5](\.\d+)?\)", warning[0]), r.stderr
    assert "2 (nMSE" not in warning[0] and f"--test {path}" in warning[0], warning[0]


def test_quiet_and_subsample(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "t.csv", 100, seed=3)
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "t.csv"), "--joints", "RR", "--out",
            str(tmp_path / "m"), "--quiet", "--max-iter", "10")
    assert r.returncode == 0 and r.stdout == "" and r.stderr == ""
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "t.csv"), "--joints", "RR", "--out",
            str(tmp_path / "m"), "--subsample", "30", "--max-iter", "10", "--model", "rbf", "--optimizer", "adam")
    assert r.returncode == 0, r.stderr
    assert "30 of 100 rows" in r.stdout


@pytest.mark.parametrize("command, flags", [
    ("train", ["--data", "--joints", "--model", "--out"]),
    ("predict", ["--model", "--data", "--out"]),
    ("evaluate", ["--model", "--data", "--json", "--plots"]),
    ("simulate", ["--robot", "--samples", "--seed", "--out"]),
    ("preprocess", ["--data", "--out", "--cutoff"]),
    ("inspect", ["--data", "--joints", "--test", "--radius", "--out", "--plot"]),
])
def test_help(gipdyn_bin, command, flags):
    r = run(gipdyn_bin, command, "--help")
    assert r.returncode == 0
    missing = [f for f in flags if f not in r.stdout]
    assert not missing, f"{command} --help lacks {missing}"


def test_a_mistyped_or_missing_command_is_named_with_the_closest_one(gipdyn_bin):
    r = run(gipdyn_bin, "trian", "--data", "x.csv")
    assert r.returncode != 0
    assert "unknown command 'trian' for gipdyn (did you mean 'train'?)" in r.stderr, r.stderr
    assert "commands: simulate, preprocess, train" in r.stderr
    r = run(gipdyn_bin, "experiment", "acuracy")
    assert r.returncode != 0 and "did you mean 'accuracy'?" in r.stderr, r.stderr
    r = run(gipdyn_bin, "frobnicate")
    assert r.returncode != 0 and "did you mean" not in r.stderr and "unknown command 'frobnicate'" in r.stderr
    r = run(gipdyn_bin, "experiment")
    assert r.returncode != 0 and "gipdyn experiment needs a command: accuracy, data-efficiency, real, control" in r.stderr
    r = run(gipdyn_bin)  # no command at all: the overview of the commands, as --help prints it
    assert r.returncode == 0 and "Subcommands:" in r.stdout and "train" in r.stdout
    assert run(gipdyn_bin, "experiment", "real", "--help").returncode == 0


def test_train_help_groups_the_options_of_each_estimator(gipdyn_bin, tmp_path):
    # Forty options in one list hide the few a newcomer needs: those come first,
    # each estimator's own under its heading.
    out = run(gipdyn_bin, "train", "--help").stdout
    headings = [line for line in out.splitlines() if line and not line.startswith(" ")][2:]
    assert [h.split(" (")[0] for h in headings] == [
        "Options:", "Teacher", "Model-based estimators", "Advanced: GP hyperparameter search", "Advanced: LIP search",
        "Advanced: serial chain identified from the log", "Advanced: neural network training", "Models"], headings
    # The estimators' list is the library's table, as the error for an unknown name gives it.
    listed = [line.split()[0] for line in out[out.index("Models (--model):"):].splitlines()[1:] if line.strip()]
    (tmp_path / "log.csv").write_text("q1\n0\n")
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--model", "bogus", "--out",
            str(tmp_path / "m.gipdyn"))
    assert r.returncode != 0 and "chain" in listed
    assert listed == r.stderr.split("choose one of: ")[1].strip().rstrip(".").split(", "), r.stderr

    def section_of(flag):
        before = out[:out.index("  " + flag + " ")]
        return [h for h in headings if h in before][-1]

    for flag in ("--data", "--joints", "--model", "--preset", "--out", "--seed"):
        assert section_of(flag) == "Options:", flag
    assert section_of("--teacher-states").startswith("Teacher")
    assert section_of("--max-iter").startswith("Advanced: GP hyperparameter search")
    assert section_of("--robot").startswith("Model-based")
    assert section_of("--no-serial-chain").startswith("Advanced: LIP")
    assert section_of("--chain-starts").startswith("Advanced: serial chain")
    assert section_of("--nn-epochs").startswith("Advanced: neural network")


def write_text(path, text):
    path.write_text(text)
    return str(path)


HEADER = "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n"
ROWS = "".join(f"{0.1 * k},{0.2 * k},1,2,3,4,5,{k}\n" for k in range(10))


@pytest.mark.parametrize(
    "case, content, joints, extra, message",
    [
        ("missing column", "q1,q2,qd1,qd2,qdd1,tau1,tau2\n1,2,3,4,5,6,7\n", "RR", [], "no column 'qdd2'"),
        ("non-numeric", HEADER + "1,2,3,four,5,6,7,8\n" + ROWS, "RR", [], "'four' is not a number"),
        ("nan", HEADER + "1,2,3,nan,5,6,7,8\n" + ROWS, "RR", [], "NaN"),
        ("inf", HEADER + ROWS + "1,2,3,4,5,6,-inf,8\n", "RR", [], "NaN or Inf"),
        ("a torque whose square overflows", HEADER + ROWS + "1,2,3,4,5,6,-1e300,8\n", "RR", [],
         "training torques column 1 holds -1e+300 (row 11): beyond 1e150 their squares overflow; rescale the data"),
        ("an input whose square overflows", HEADER + ROWS + "1,2,3,4,2e160,6,7,8\n", "RR", [],
         "training inputs column 5 holds 2e+160 (row 11)"),
        ("a corrupted sample", HEADER + ROWS + "1,2,1e100,4,5,6,7,8\n", "RR", [],
         "training input qd1 holds 1e+100 (row 11): no joint position (rad, m), velocity or acceleration reaches 1e6"),
        ("too few rows", HEADER + "1,2,3,4,5,6,7,8\n1,2,3,4,5,6,7,9\n", "RR", [], "at least"),
        ("no rows", HEADER, "RR", [], "no data rows"),
        ("joint mismatch", HEADER + ROWS, "RRR", [], "joint string of length 2"),
        ("another spelling of the velocities", HEADER.replace("qd1,qd2", "dq1,dq2") + ROWS, "RR", [],
         "no column 'qd1' (its column 'dq1' looks like it: rename it)"),
        ("joints counted from 0", HEADER.replace("1", "0").replace("2", "1") + ROWS, "RR", [],
         "its joints are counted from 0, gipdyn's from 1"),
        ("a .mat file", "MATLAB 5.0 MAT-file, Platform: GLNXA64\n" + "x" * 200, "RR", [],
         "is a MATLAB .mat file, not a CSV; convert it to a CSV"),
        ("bad joint string", HEADER + ROWS, "RX", [], "'X'"),
        ("unknown estimator", HEADER + ROWS, "RR", ["--model", "matern"], "unknown estimator"),
        ("unknown optimizer", HEADER + ROWS, "RR", ["--optimizer", "sgd"], "--optimizer 'sgd' is unknown; choose lbfgs or adam"),
        ("no L-BFGS memory", HEADER + ROWS, "RR", ["--lbfgs-memory", "0"], "--lbfgs-memory must be at least 1"),
        ("a teacher that needs a robot", HEADER + ROWS, "RR", ["--teacher", "fe"], "--teacher: 'fe' needs a nominal robot"),
        ("an unknown teacher", HEADER + ROWS, "RR", ["--teacher", "lap"], "unknown teacher 'lap'"),
        ("too few teacher states", HEADER + ROWS, "RR", ["--teacher", "lip", "--teacher-states", "2"],
         "--teacher-states must be at least 5"),
        ("a GP mean lip cannot honour", HEADER + ROWS, "RR", ["--model", "lip", "--mean", "linear"],
         "lip: --mean must be zero"),
        ("a prior lip cannot honour", HEADER + ROWS, "RR", ["--model", "lip+friction", "--prior", "lognormal"],
         "lip+friction: --prior is not supported"),
    ],
)
def test_train_bad_input(tmp_path, gipdyn_bin, case, content, joints, extra, message):
    data = write_text(tmp_path / "bad.csv", content)
    out = tmp_path / "m.gipdyn"
    r = run(gipdyn_bin, "train", "--data", data, "--joints", joints, "--out", str(out), "--max-iter", "5", *extra)
    assert r.returncode != 0, case
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert message in lines[0], r.stderr
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["bad.csv"]  # no temporary left behind


def test_train_warns_about_positions_that_look_like_degrees(tmp_path, gipdyn_bin):
    # Joint 1 logged in degrees (0-90), joint 2 in radians; the prismatic joint 3 may span metres.
    rows = "".join(f"{9.0 * k},{0.1 * k},{2.0 * k},1,2,3,4,5,6,{k},{2 * k},{3 * k}\n" for k in range(11))
    data = write_text(tmp_path / "deg.csv", "q1,q2,q3,qd1,qd2,qd3,qdd1,qdd2,qdd3,tau1,tau2,tau3\n" + rows)
    r = run(gipdyn_bin, "train", "--data", data, "--joints", "RRP", "--out", str(tmp_path / "m.gipdyn"),
            "--max-iter", "3")
    assert r.returncode == 0, r.stderr
    warned = [line for line in r.stderr.splitlines() if "more than two turns" in line]
    assert len(warned) == 1 and "column q1 of" in warned[0] and "spans 90 rad" in warned[0], r.stderr
    assert "convert q, qd and qdd to radians" in warned[0]


def test_train_predict_and_evaluate_read_a_mat_file(tmp_path, gipdyn_bin):
    # A MATLAB matrix's columns are q, qd, qdd, tau by position; the same numbers as a CSV give the same model.
    scipy_io = pytest.importorskip("scipy.io")
    data = write_dataset(tmp_path / "log.csv", 80, 1)
    test = write_dataset(tmp_path / "test.csv", 40, 2)
    scipy_io.savemat(tmp_path / "log.mat", {"train": data[:, :8], "test": test[:, :8], "states": test[:, :6]})
    mat = str(tmp_path / "log.mat")
    for name, source in [("csv", ["--data", str(tmp_path / "log.csv")]),
                         ("mat", ["--data", mat, "--mat-variable", "train"])]:
        r = run(gipdyn_bin, "train", *source, "--joints", "RR", "--out", str(tmp_path / f"{name}.gipdyn"),
                "--max-iter", "40", "--quiet")
        assert r.returncode == 0, r.stderr
    model = str(tmp_path / "mat.gipdyn")
    r = run(gipdyn_bin, "predict", "--model", model, "--data", mat, "--mat-variable", "states", "--out",
            str(tmp_path / "p.csv"), "--no-std")
    assert r.returncode == 0, r.stderr
    r = run(gipdyn_bin, "predict", "--model", str(tmp_path / "csv.gipdyn"), "--data", str(tmp_path / "test.csv"),
            "--out", str(tmp_path / "q.csv"), "--no-std")
    assert r.returncode == 0, r.stderr
    p, q = (np.genfromtxt(tmp_path / f, delimiter=",", names=True) for f in ("p.csv", "q.csv"))
    assert np.allclose(p["tau1_hat"], q["tau1_hat"], rtol=1e-6, atol=1e-9)
    r = run(gipdyn_bin, "evaluate", "--model", model, "--data", mat, "--mat-variable", "test")
    assert r.returncode == 0 and "40 test rows, target measured tau" in r.stdout, r.stderr
    # A matrix of another arm is not read shifted: 8 columns are q, qd, qdd, tau of 2 joints, not of 1.
    r = run(gipdyn_bin, "train", "--data", mat, "--mat-variable", "train", "--joints", "R", "--out",
            str(tmp_path / "one.gipdyn"))
    assert r.returncode != 0 and "has 8 columns, those of 2 joints (q, qd, qdd, tau), but joints R are 1" in r.stderr
    r = run(gipdyn_bin, "train", "--data", mat, "--mat-variable", "nope", "--joints", "RR", "--out",
            str(tmp_path / "nope.gipdyn"))
    assert r.returncode != 0 and "has no variable 'nope'; it holds: " in r.stderr
    assert not (tmp_path / "one.gipdyn").exists() and not (tmp_path / "nope.gipdyn").exists()


def test_train_taught_by_lip_keeps_a_constant_joint(tmp_path, gipdyn_bin):
    # A joint that never moves its torque (a locked joint, a dead sensor) has no nMSE on the log: it is recorded as
    # null, and the model is written (the model file refused the NaN before).
    data = write_dataset(tmp_path / "log.csv", 60, 1)
    rows = "".join(",".join(repr(float(v)) for v in list(r[:7]) + [0.0]) + "\n" for r in data)
    log = write_text(tmp_path / "locked.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n" + rows)
    out = tmp_path / "m.gipdyn"
    r = run(gipdyn_bin, "train", "--data", log, "--joints", "RR", "--out", str(out), "--teacher", "lip",
            "--teacher-states", "100", "--teacher-hyperparameter-rows", "0", "--max-iter", "30", "--quiet")
    assert r.returncode == 0 and out.exists(), r.stderr
    log_nmse = model_header(out)["teacher"]["log_nmse"]
    assert log_nmse["teacher"][1] is None and log_nmse["student"][1] is None
    assert all(isinstance(v, float) and np.isfinite(v) for v in (log_nmse["teacher"][0], log_nmse["student"][0]))


def test_train_by_default_keeps_lips_teaching_only_where_the_taught_model_fits_the_log(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "log.csv", 80, 1)
    log = str(tmp_path / "log.csv")
    common = ["--joints", "RR", "--teacher-hyperparameter-rows", "0", "--max-iter", "60", "--seed", "4"]
    # The default is --teacher auto: on this short clean log the model taught by LIP fits the log as LIP does.
    default = tmp_path / "default.gipdyn"
    r = run(gipdyn_bin, "train", "--data", log, "--joints", "RR", "--max-iter", "60", "--seed", "4", "--out",
            str(default))
    assert r.returncode == 0, r.stderr
    assert "taught by lip" in r.stdout and "(--teacher auto; none: no teacher)" in r.stdout
    assert "student gip on the teacher's torques" in r.stdout
    # A log that simulate did not write may be a robot's: the recommendation for those is said before LIP's fit.
    assert r.stdout.index("note: on a real robot's log, --preset real is the recommendation") < r.stdout.index("lip on")
    header = model_header(default)
    assert header["teacher"]["mode"] == "automatic" and header["teacher"]["outcome"] == "taught"
    assert header["num_training_samples"] == 2000  # TeacherOptions::states, not the log's 80 rows
    # Where the taught model misses the log (ten drawn states), gip learns from the log itself: no warning.
    missed = tmp_path / "missed.gipdyn"
    r = run(gipdyn_bin, "train", "--data", log, *common, "--teacher", "auto", "--teacher-states", "10", "--out",
            str(missed))
    assert r.returncode == 0, r.stderr
    assert "gip learned from the log: the model taught by lip fitted the logged rows far worse" in r.stdout
    assert "far worse" not in r.stderr
    header = model_header(missed)
    assert header["teacher"]["outcome"] == "student missed the log" and header["num_training_samples"] == 80
    log_nmse = header["teacher"]["log_nmse"]
    assert max(s - t for t, s in zip(log_nmse["teacher"], log_nmse["student"])) > 0.1
    # ... the model trained without a teacher, as --teacher none trains it.
    none = tmp_path / "none.gipdyn"
    r = run(gipdyn_bin, "train", "--data", log, *common, "--teacher", "none", "--out", str(none))
    assert r.returncode == 0, r.stderr
    assert "--teacher-hyperparameter-rows has no effect: --teacher none trains without a teacher" in r.stderr
    # gip alone on a log that may be a robot's: the recommendation for those, with what gip does there.
    assert "--preset real is the recommendation" in r.stdout and "gip alone extrapolates" in r.stdout
    # Not on a log that simulate wrote, nor where a preset is given.
    simulated = tmp_path / "simulated.csv"
    assert run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "40", "--out", str(simulated)).returncode == 0
    for args in (["--data", str(simulated), "--teacher", "none"], ["--data", log, "--joints", "RR", "--preset", "real"]):
        r = run(gipdyn_bin, "train", *args, "--max-iter", "3", "--out", str(tmp_path / "quiet.gipdyn"))
        assert r.returncode == 0, r.stderr
        assert "--preset real is the recommendation" not in r.stdout, args
    assert "teacher" not in model_header(none)
    test = write_dataset(tmp_path / "test.csv", 30, 2)
    predictions = []
    for model in (missed, none):
        r = run(gipdyn_bin, "predict", "--model", str(model), "--data", str(tmp_path / "test.csv"), "--out",
                str(model) + ".csv")
        assert r.returncode == 0, r.stderr
        predictions.append(np.loadtxt(str(model) + ".csv", delimiter=",", skiprows=1))
    np.testing.assert_allclose(predictions[0], predictions[1], rtol=1e-10, atol=1e-12)


def test_train_writes_the_teacher_and_notes_the_joints_it_fits_far_better(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "log.csv", 80, 1)
    log = str(tmp_path / "log.csv")
    student, teacher = tmp_path / "student.gipdyn", tmp_path / "teacher.gipdyn"
    # 25 drawn states teach GIP the two-link log well enough to pass, and LIP fits it far better.
    setup = ["--data", log, "--joints", "RR", "--teacher-states", "25", "--teacher-hyperparameter-rows", "0",
             "--max-iter", "60", "--seed", "4"]
    common = setup + ["--teacher", "lip"]
    r = run(gipdyn_bin, "train", *common, "--teacher-out", str(teacher), "--out", str(student))
    assert r.returncode == 0, r.stderr
    assert "far worse" not in r.stderr
    assert model_header(teacher)["estimator"] == "lip" and model_header(student)["estimator"] == "gp"
    log_nmse = model_header(student)["teacher"]["log_nmse"]
    assert all(s >= 10 * t and s > 1e-3 for t, s in zip(log_nmse["teacher"], log_nmse["student"])), log_nmse
    assert re.search(r"note: the teacher lip fits the logged rows of joint 1 \([-0-9.e]+ against [-0-9.e]+\), 2 "
                     r"\([-0-9.e]+ against [-0-9.e]+\) ten times better or more than its student: .* \(written to " +
                     re.escape(str(teacher)), r.stdout), r.stdout
    assert f"saved the teacher's lip model to {teacher}" in r.stdout
    # The file is the teacher whose residual the student's header records: its nMSE on the log is the teacher's.
    r = run(gipdyn_bin, "predict", "--model", str(teacher), "--data", log, "--out", str(tmp_path / "p.csv"))
    assert r.returncode == 0, r.stderr
    predicted = np.loadtxt(tmp_path / "p.csv", delimiter=",", skiprows=1)[:, :2]
    measured = np.loadtxt(log, delimiter=",", skiprows=1)[:, 7:9]
    nmse = ((predicted - measured) ** 2).mean(axis=0) / measured.var(axis=0)
    np.testing.assert_allclose(nmse, log_nmse["teacher"], rtol=1e-6)
    # Without --teacher-out the note says how to keep the teacher.
    r = run(gipdyn_bin, "train", *common, "--out", str(tmp_path / "again.gipdyn"))
    assert r.returncode == 0 and "--teacher-out FILE writes it beside the student" in r.stdout, r.stdout
    # No teacher, or one file for both: a one-line error, nothing written.
    for extra, message in (
            (["--teacher", "none", "--teacher-out", str(tmp_path / "t2.gipdyn"), "--out", str(tmp_path / "s2.gipdyn")],
             "--teacher-out writes a teacher's model, and --teacher none trains without one"),
            (["--teacher-out", str(tmp_path / "s3.gipdyn"), "--out", str(tmp_path / "s3.gipdyn")],
             "--teacher-out and --out name the same file")):
        r = run(gipdyn_bin, "train", *setup, *(extra if "none" in extra else ["--teacher", "lip", *extra]))
        assert r.returncode != 0 and message in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not any((tmp_path / f).exists() for f in ("t2.gipdyn", "s2.gipdyn", "s3.gipdyn"))


def test_train_by_default_learns_from_the_log_where_the_teacher_cannot_start(tmp_path, gipdyn_bin):
    # LIP on 2330 rows of a 6-joint arm (13980 torques, taught by default) is one 13980-square system in kernel
    # space (its features outnumber the torques), 1.5 GiB: more than a 1.5 GB address space leaves.
    # The teacher nobody asked for must not stop a fit GIP alone can make (it stopped train with an error).
    log = tmp_path / "log.csv"
    assert run(gipdyn_bin, "simulate", "--robot", "ur10", "--samples", "2330", "--seed", "3", "--out", str(log),
               "--quiet").returncode == 0
    out = tmp_path / "m.gipdyn"
    command = [gipdyn_bin, "train", "--data", str(log), "--joints", "RRRRRR", "--max-iter", "2", "--threads", "1",
               "--out", str(out)]
    teacher = tmp_path / "teacher.gipdyn"
    r = subprocess.run(["bash", "-c", 'ulimit -v 1500000 && exec "$@"', "bash", *command, "--teacher-out",
                        str(teacher)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert f"no teacher model written to {teacher}: the teacher lip failed to fit the log" in r.stderr
    assert not teacher.exists()
    assert "the teacher lip failed: lip on 2330 rows of 6 joints" in r.stdout and "needs about 1.5 GiB" in r.stdout
    assert "gip learned from the log: the teacher lip failed to fit it" in r.stdout
    header = model_header(out)
    assert header["teacher"]["outcome"] == "teacher failed" and header["num_training_samples"] == 2330
    # Asked for by name, the teacher's failure is the command's.
    r = subprocess.run(["bash", "-c", 'ulimit -v 1500000 && exec "$@"', "bash", *command[:-2], "--teacher", "lip",
                        "--out", str(tmp_path / "named.gipdyn")], capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and "needs about 1.5 GiB" in r.stderr
    assert not (tmp_path / "named.gipdyn").exists()


def test_train_lip_records_the_serial_chain_and_no_serial_chain_turns_it_off(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "log.csv", 40, 1)
    for flags, expected in [([], True), (["--no-serial-chain"], False)]:
        out = tmp_path / f"lip{len(flags)}.gipdyn"
        r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--model", "lip",
                "--max-iter", "20", "--out", str(out), *flags)
        assert r.returncode == 0, r.stderr
        assert model_header(out)["serial_chain"] is expected


def test_train_taught_by_lip_learns_from_drawn_states(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "log.csv", 80, 1)
    out = tmp_path / "m.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--out", str(out), "--teacher",
            "lip", "--teacher-states", "150", "--teacher-hyperparameter-rows", "0", "--student-hyperparameter-rows", "100",
            "--max-iter", "60", "--seed", "4")
    assert r.returncode == 0, r.stderr
    assert ("taught by lip (hyperparameters on all rows) at 150 states drawn from the log's box (the student's "
            "hyperparameters on 100 of them)") in r.stdout
    assert "teacher lip: fit" in r.stdout and "student gip on the teacher's torques" in r.stdout
    noise = [float(v) for v in re.search(r"label noise .*per joint: (.*)", r.stdout).group(1).split()]
    assert len(noise) == 2 and all(0.005 < v < 0.02 for v in noise), r.stdout  # the log's noise is 0.01
    header = model_header(out)
    assert header["kernel"] == "gip" and header["num_training_samples"] == 150  # the drawn states, not the 80 rows
    teacher = header["teacher"]
    assert teacher["estimator"] == "lip" and teacher["states"] == 150 and teacher["seed"] == 4
    assert teacher["student_hyperparameter_rows"] == 100
    assert [j["training"]["hyperparameter_rows"] for j in header["joint_models"]] == [100, 100]
    assert teacher["label_noise_std"] == pytest.approx(noise, rel=1e-2)
    # Both fits' nMSE on the logged rows, printed and recorded; the student fits the log as its teacher does.
    printed = re.search(r"nMSE on the logged rows, per joint, teacher / student: (.*)", r.stdout).group(1).split()
    pairs = [[float(v) for v in p.split("/")] for p in printed]
    assert [p[0] for p in pairs] == pytest.approx(teacher["log_nmse"]["teacher"], rel=1e-2)
    assert [p[1] for p in pairs] == pytest.approx(teacher["log_nmse"]["student"], rel=1e-2)
    assert all(s - t < 0.1 for t, s in pairs), r.stdout
    assert "fits the logged rows far worse" not in r.stderr
    # The teacher's warnings are told apart from the student's.
    assert all(line.startswith("gipdyn: warning: ") for line in r.stderr.splitlines()), r.stderr
    # Ten drawn states teach the student too little to fit the log: warned, the model still written.
    few = tmp_path / "few.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--out", str(few), "--teacher",
            "lip", "--teacher-states", "10", "--teacher-hyperparameter-rows", "0", "--max-iter", "60", "--seed", "4")
    assert r.returncode == 0 and few.exists(), r.stderr
    assert "gipdyn: warning: the model taught by lip fits the logged rows far worse than its teacher" in r.stderr
    log_nmse = model_header(few)["teacher"]["log_nmse"]
    assert max(s - t for t, s in zip(log_nmse["teacher"], log_nmse["student"])) > 0.1
    # The seed draws the states: the same seed, the same model.
    again = tmp_path / "again.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--out", str(again), "--teacher",
            "lip", "--teacher-states", "150", "--teacher-hyperparameter-rows", "0", "--student-hyperparameter-rows", "100",
            "--max-iter", "60", "--seed", "4", "--quiet")
    assert r.returncode == 0, r.stderr
    predictions = []
    for model in (out, again):
        csv = tmp_path / (model.stem + ".csv")
        r = run(gipdyn_bin, "predict", "--model", str(model), "--data", str(tmp_path / "log.csv"), "--out", str(csv),
                "--no-std")
        assert r.returncode == 0, r.stderr
        predictions.append(csv.read_text())
    assert predictions[0] == predictions[1]
    # The teacher's options where the default teacher does not teach: one line that says why, and no model.
    lone = tmp_path / "lone.gipdyn"
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--out", str(lone),
            "--model", "rbf", "--teacher-states", "100")
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "--teacher-states sets up a teacher, and --teacher auto does not teach rbf" in r.stderr, r.stderr
    assert not lone.exists()
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "log.csv"), "--joints", "RR", "--out", str(lone),
            "--teacher", "lip", "--student-hyperparameter-rows", "-1")
    assert r.returncode != 0 and not lone.exists()
    assert len(r.stderr.strip().splitlines()) == 1 and "--student-hyperparameter-rows must be >= 0" in r.stderr, r.stderr


def test_lbfgs_memory_reaches_the_optimiser(trained, tmp_path, gipdyn_bin):
    # One correction pair makes L-BFGS take another path than the default 40 on the same data and start.
    d, _, _ = trained
    evaluations = {}
    for memory in ["1", "40"]:
        out = tmp_path / f"m{memory}.gipdyn"
        r = run(gipdyn_bin, "train", "--data", str(d / "train.csv"), "--joints", "RR", "--out", str(out),
                "--max-iter", "80", "--lbfgs-memory", memory, "--quiet")
        assert r.returncode == 0, r.stderr
        evaluations[memory] = [j["training"]["evaluations"] for j in model_header(out)["joint_models"]]
    default = [j["training"]["evaluations"] for j in model_header(d / "m.gipdyn")["joint_models"]]
    assert evaluations["40"] == default
    assert evaluations["1"] != default


def test_missing_data_file(tmp_path, gipdyn_bin):
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "none.csv"), "--joints", "RR", "--out", str(tmp_path / "m"))
    assert r.returncode != 0
    assert "none.csv" in r.stderr


def test_bad_model_files(trained, tmp_path, gipdyn_bin):
    d, _, _ = trained
    good = (d / "m.gipdyn").read_bytes()
    cases = {
        "truncated": (good[: len(good) // 2], "truncated"),
        "corrupted": (good[:-40] + bytes([good[-40] ^ 0xFF]) + good[-39:], "corrupted"),
        "not a model": (b"q1,q2\n1,2\n" * 10, "not a gipdyn model"),
    }
    for case, (content, message) in cases.items():
        model = tmp_path / "bad.gipdyn"
        model.write_bytes(content)
        out = tmp_path / "pred.csv"
        r = run(gipdyn_bin, "predict", "--model", str(model), "--data", str(d / "test.csv"), "--out", str(out))
        assert r.returncode != 0, case
        assert message in r.stderr and len(r.stderr.strip().splitlines()) == 1, (case, r.stderr)
        assert not out.exists()
        r = run(gipdyn_bin, "evaluate", "--model", str(model), "--data", str(d / "test.csv"))
        assert r.returncode != 0 and message in r.stderr, case


def test_predict_evaluate_and_update_reject_data_for_another_robot(trained, tmp_path, gipdyn_bin):
    # The joint types come from the model, so the error asks for the model's robot's file, not for other joint types.
    d, _, _ = trained
    model = str(d / "m.gipdyn")
    data = write_text(tmp_path / "three.csv", "q1,q2,q3,qd1,qd2,qd3,qdd1,qdd2,qdd3,tau1,tau2,tau3\n"
                      + "1,2,3,4,5,6,7,8,9,1,2,3\n")
    out = tmp_path / "out"
    for command, extra in [("predict", ["--out", str(out)]), ("evaluate", ["--json", str(out)]),
                           ("update", ["--out", str(out)]), ("physics", ["--out", str(out)])]:
        r = run(gipdyn_bin, command, "--model", model, "--data", data, *extra)
        assert r.returncode != 0, command
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1, r.stderr
        assert f"has joint columns q1..q3 but the model '{model}' is for 2 joints" in lines[0], r.stderr
        assert "give it a file of the same robot: joint columns q1..q2" in lines[0], r.stderr
        assert not out.exists(), command


def test_evaluate_needs_torques(trained, tmp_path, gipdyn_bin):
    d, _, _ = trained
    data = write_text(tmp_path / "x.csv", "q1,q2,qd1,qd2,qdd1,qdd2\n1,2,3,4,5,6\n")
    r = run(gipdyn_bin, "evaluate", "--model", str(d / "m.gipdyn"), "--data", data, "--json", str(tmp_path / "r.json"))
    assert r.returncode != 0 and "tau1" in r.stderr
    assert not (tmp_path / "r.json").exists()


def test_simulate_writes_data_and_sidecar(tmp_path, gipdyn_bin):
    out = tmp_path / "scara.csv"
    r = run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "300", "--seed", "4", "--out", str(out),
            "--perturb-kinematics", "--friction")
    assert r.returncode == 0, r.stderr
    with open(out) as f:
        header = f.readline().strip().split(",")
    n = 4
    expected = ([f"q{i}" for i in range(1, n + 1)] + [f"qd{i}" for i in range(1, n + 1)] +
                [f"qdd{i}" for i in range(1, n + 1)] + [f"tau{i}" for i in range(1, n + 1)] +
                [f"tau{i}_true" for i in range(1, n + 1)])
    assert header == expected
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (300, 5 * n)
    noise = data[:, 12:16] - data[:, 16:20]
    assert 0.005 < noise.std() < 0.02
    meta = json.loads((tmp_path / "scara.csv.json").read_text())
    assert meta["seed"] == 4 and meta["robot"] == "scara" and meta["friction"] is True
    assert len(meta["perturbation"]) == 4
    # Same seed, same file.
    again = tmp_path / "again.csv"
    run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "300", "--seed", "4", "--out", str(again),
        "--perturb-kinematics", "--friction")
    assert again.read_bytes() == out.read_bytes()


def test_simulate_from_files_and_bad_robots(tmp_path, gipdyn_bin):
    data_dir = os.path.join(os.path.dirname(__file__), "..", "data")
    for robot, joints in [("rpr_arm.urdf", 3), ("two_link.json", 2)]:
        out = tmp_path / (robot + ".csv")
        r = run(gipdyn_bin, "simulate", "--robot", os.path.join(data_dir, robot), "--samples", "50", "--out", str(out))
        assert r.returncode == 0, r.stderr
        assert np.loadtxt(out, delimiter=",", skiprows=1).shape == (50, 5 * joints)
    for robot, message in [("puma", "unknown robot"), (os.path.join(data_dir, "floating_arm.urdf"), "floating"),
                           (os.path.join(data_dir, "spherical_arm.urdf"), "unknown joint type"),
                           (os.path.join(data_dir, "bad_robot_negative_mass.json"), "mass")]:
        out = tmp_path / "bad.csv"
        r = run(gipdyn_bin, "simulate", "--robot", robot, "--samples", "50", "--out", str(out))
        assert r.returncode != 0 and message in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
        assert not out.exists() and not (tmp_path / "bad.csv.json").exists()


def test_friction_on_a_robot_without_friction_is_refused(tmp_path, gipdyn_bin):
    # A description without friction coefficients: --friction would add nothing, silently.
    robot = json.load(open(os.path.join(os.path.dirname(__file__), "..", "data", "two_link.json")))
    for joint in robot["joints"]:
        joint.pop("friction", None)
    path = write_text(tmp_path / "frictionless.json", json.dumps(robot))
    out = tmp_path / "f.csv"
    for args, output in [(["simulate", "--samples", "20", "--out", str(out)], out),
                         (["experiment", "control", "--seconds", "0.1", "--out", str(tmp_path / "ctl")], tmp_path / "ctl")]:
        r = run(gipdyn_bin, *args, "--robot", path, "--friction")
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 1 and len(lines) == 1, r.stderr
        assert "--friction asks for friction, but robot" in lines[0] and "has none" in lines[0], r.stderr
        assert not output.exists()
    assert run(gipdyn_bin, "simulate", "--samples", "20", "--out", str(out), "--robot", path, "--quiet").returncode == 0


def test_evaluate_writes_diagnostic_plots(trained, gipdyn_bin):
    d, test, _ = trained
    out = d / "diag"
    r = run(gipdyn_bin, "evaluate", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"),
            "--plots", str(out), "--plot-window", "50")
    assert r.returncode == 0, r.stderr
    for png in ("torque_time.png", "residuals.png", "noise_ratio.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", png
    diag = json.loads((out / "diagnostics.json").read_text())
    assert set(diag) >= {"nmse", "mse", "residual_mean", "residual_std", "noise_ratio"}
    # The training torques carry noise of std 0.01: the learned noise share is about 0.01^2 / var(tau).
    train = np.genfromtxt(d / "train.csv", delimiter=",", names=True)
    for j, ratio in enumerate(diag["noise_ratio"], start=1):
        expected = 0.01**2 / np.var(train[f"tau{j}"])
        assert expected / 5 < ratio < expected * 5, (j, ratio, expected)
    window = np.genfromtxt(out / "torque_window.csv", delimiter=",", names=True)
    assert len(window) == 50


def test_evaluate_plots_a_joint_whose_training_torque_is_constant(tmp_path, gipdyn_bin):
    # Its learned noise share has no variance to compare with: null in the JSON, "n/a" in the plot, no failure.
    data = write_dataset(tmp_path / "log.csv", 60, 1)
    rows = "".join(",".join(repr(float(v)) for v in list(r[:7]) + [0.0]) + "\n" for r in data)
    log = write_text(tmp_path / "locked.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n" + rows)
    model = str(tmp_path / "m.gipdyn")
    assert run(gipdyn_bin, "train", "--data", log, "--joints", "RR", "--out", model, "--max-iter", "30",
               "--quiet").returncode == 0
    out = tmp_path / "diag"
    r = run(gipdyn_bin, "evaluate", "--model", model, "--data", log, "--plots", str(out))
    assert r.returncode == 0, r.stderr
    assert f"warning: joint(s) 2: the target torque is constant in {log}, so nMSE" in r.stderr
    assert (out / "noise_ratio.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ratios = json.loads((out / "diagnostics.json").read_text())["noise_ratio"]
    assert isinstance(ratios[0], float) and ratios[1] is None


@pytest.mark.parametrize("python_says, advice", [
    ("ModuleNotFoundError: No module named 'matplotlib'", "install python3-matplotlib"),
    ("TypeError: unsupported operand type(s)", "the plotting script failed on its input (TypeError"),
])
def test_a_plot_that_fails_says_why(trained, tmp_path, gipdyn_bin, python_says, advice):
    # A python without matplotlib is the user's to fix; a script that fails on its data is ours, and installing
    # matplotlib would not help.
    d, _, _ = trained
    python = tmp_path / "python"
    python.write_text(f"#!/bin/sh\ncat > /dev/null\necho 'Traceback (most recent call last):' >&2\n"
                      f"echo \"{python_says}\" >&2\nexit 1\n")  # python's errors go to stderr
    python.chmod(0o755)
    out = tmp_path / "diag"
    r = subprocess.run([gipdyn_bin, "evaluate", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"),
                        "--plots", str(out)], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "GIPDYN_PYTHON": str(python)})
    assert r.returncode == 1, r.stderr  # the numbers are written; only the plots are missing
    warnings = [line for line in r.stderr.splitlines() if "no plot" in line]
    assert len(warnings) == 3 and all(advice in w for w in warnings), r.stderr
    other = "the plotting script failed" if advice.startswith("install") else "install python3-matplotlib"
    assert not any(other in w for w in warnings), r.stderr
    assert "Traceback" not in r.stderr  # python's own output stays out of the terminal
    assert (out / "diagnostics.json").exists() and not list(out.glob("*.png"))


def two_link_terms(q, qd):
    """Gravity, inertia and Coriolis of conftest's 2R arm, from its torque formula."""
    zero = np.zeros_like(q)
    g = two_link_torques(q, zero, zero)
    M = np.stack([two_link_torques(q, zero, np.tile(np.eye(2)[j], (len(q), 1))) - g for j in range(2)], axis=2)
    return g, M, two_link_torques(q, qd, zero) - g


def read_table(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_physics_gives_gravity_inertia_and_coriolis(trained, gipdyn_bin, tmp_path):
    d, test, _ = trained
    r = run(gipdyn_bin, "physics", "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"), "--out",
            str(tmp_path / "physics.csv"))
    assert r.returncode == 0, r.stderr
    assert "not positive definite" in r.stdout
    header, table = read_table(tmp_path / "physics.csv")
    assert header == ["g1", "g2", "M1_1", "M1_2", "M2_1", "M2_2", "coriolis1", "coriolis2", "friction1", "friction2",
                      "M_asymmetry", "M_min_eigenvalue"]
    g, M, c = two_link_terms(test[:, 0:2], test[:, 2:4])
    col = {name: k for k, name in enumerate(header)}
    rel = lambda a, b: np.linalg.norm(a - b) / np.linalg.norm(b)
    # About three times what GIP reaches from 150 noisy samples (9e-4, 5.6e-3, 1.5e-2).
    assert rel(table[:, [col["g1"], col["g2"]]], g) < 3e-3
    assert rel(table[:, col["M1_1"]:col["M2_2"] + 1].reshape(-1, 2, 2), M) < 1.7e-2
    assert rel(table[:, [col["coriolis1"], col["coriolis2"]]], c) < 4.5e-2
    assert np.abs(table[:, [col["friction1"], col["friction2"]]]).max() < 1e-9
    assert (table[:, col["M_min_eigenvalue"]] > 0).all()
    # M is written symmetric; the asymmetry is that of the rows the two joints' GPs learned.
    np.testing.assert_array_equal(table[:, col["M1_2"]], table[:, col["M2_1"]])
    assert (table[:, col["M_asymmetry"]] > 0).all()
    # Positions only: no velocity terms.
    qonly = tmp_path / "q.csv"
    qonly.write_text("q1,q2\n0.1,0.2\n0.3,-0.4\n")
    r = run(gipdyn_bin, "physics", "--model", str(d / "m.gipdyn"), "--data", str(qonly), "--out",
            str(tmp_path / "p2.csv"))
    assert r.returncode == 0, r.stderr
    assert read_table(tmp_path / "p2.csv")[0][-3:] == ["M2_2", "M_asymmetry", "M_min_eigenvalue"]


def test_lip_trains_and_gives_energies(tmp_path, gipdyn_bin):
    # LIP on 100 rows of the 2R arm: torques, terms and energies from the model file.
    write_dataset(tmp_path / "t.csv", 100, seed=3)
    test = write_dataset(tmp_path / "test.csv", 30, seed=4, noise=0.0)
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "t.csv"), "--joints", "RR", "--model", "lip",
            "--out", str(tmp_path / "lip.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "estimator lip" in r.stdout and "saved lip model" in r.stdout
    r = run(gipdyn_bin, "physics", "--model", str(tmp_path / "lip.gipdyn"), "--data", str(tmp_path / "test.csv"),
            "--out", str(tmp_path / "physics.csv"))
    assert r.returncode == 0, r.stderr
    assert "potential and kinetic energy" in r.stdout
    header, table = read_table(tmp_path / "physics.csv")
    assert header[-2:] == ["potential_energy", "kinetic_energy"]
    q, qd = test[:, 0:2], test[:, 2:4]
    g, M, c = two_link_terms(q, qd)
    col = {name: k for k, name in enumerate(header)}
    rel = lambda a, b: np.linalg.norm(a - b) / np.linalg.norm(b)
    assert rel(table[:, [col["g1"], col["g2"]]], g) < 1e-3
    assert rel(table[:, col["M1_1"]:col["M2_2"] + 1].reshape(-1, 2, 2), M) < 1e-2
    T_true = 0.5 * np.einsum("ri,rij,rj->r", qd, M, qd)
    assert rel(table[:, col["kinetic_energy"]], T_true) < 1e-2
    # dV/dq = g: V = (m1 lc1 + m2 l1) g sin q1 + m2 lc2 g sin(q1 + q2), known up to a constant.
    V_true = (1.0 * 0.25 + 0.8 * 0.5) * 9.81 * np.sin(q[:, 0]) + 0.8 * 0.2 * 9.81 * np.sin(q[:, 0] + q[:, 1])
    V = table[:, col["potential_energy"]]
    assert rel(V - V.mean(), V_true - V_true.mean()) < 1e-3
    r = run(gipdyn_bin, "evaluate", "--model", str(tmp_path / "lip.gipdyn"), "--data", str(tmp_path / "test.csv"))
    assert r.returncode == 0, r.stderr
    # Predictions with standard deviations, which grow away from the training states.
    r = run(gipdyn_bin, "predict", "--model", str(tmp_path / "lip.gipdyn"), "--data", str(tmp_path / "test.csv"),
            "--out", str(tmp_path / "p.csv"))
    assert r.returncode == 0, r.stderr
    header, table = read_table(tmp_path / "p.csv")
    assert header == ["tau1_hat", "tau2_hat", "tau1_std", "tau2_std"]
    assert np.all(table[:, 2:] > 0)
    # Hyperparameters from 50 of the 100 rows, the model on all of them.
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "t.csv"), "--joints", "RR", "--model", "lip",
            "--hyperparameter-rows", "50", "--out", str(tmp_path / "lip50.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "learned on 50 rows" in r.stdout, r.stdout
    # With each joint's friction beside the energies: named as such in the file, physics and energies still there.
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "t.csv"), "--joints", "RR", "--model", "lip+friction",
            "--hyperparameter-rows", "50", "--out", str(tmp_path / "lipf.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "saved lip+friction model" in r.stdout, r.stdout
    r = run(gipdyn_bin, "physics", "--model", str(tmp_path / "lipf.gipdyn"), "--data", str(tmp_path / "test.csv"),
            "--out", str(tmp_path / "physics_f.csv"))
    assert r.returncode == 0, r.stderr
    header, table = read_table(tmp_path / "physics_f.csv")
    assert "friction1" in header and header[-2:] == ["potential_energy", "kinetic_energy"]
    assert rel(table[:, [col["g1"], col["g2"]]], g) < 1e-2


def test_evaluate_compares_physics_with_the_robot(tmp_path, gipdyn_bin):
    for name, seed, rows in [("train", 1, 80), ("test", 2, 30)]:
        r = run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", str(rows), "--dt", "0.1", "--seed", str(seed),
                "--quiet", "--out", str(tmp_path / f"{name}.csv"))
        assert r.returncode == 0, r.stderr
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "train.csv"), "--joints", "RRPR", "--model", "lip",
            "--quiet", "--out", str(tmp_path / "lip.gipdyn"))
    assert r.returncode == 0, r.stderr
    r = run(gipdyn_bin, "evaluate", "--model", str(tmp_path / "lip.gipdyn"), "--data", str(tmp_path / "test.csv"),
            "--physics", "scara", "--json", str(tmp_path / "e.json"), "--plots", str(tmp_path / "plots"))
    assert r.returncode == 0, r.stderr
    assert "relative error against scara: gravity" in r.stdout
    errors = json.loads((tmp_path / "e.json").read_text())["physics_relative_error"]
    assert errors["gravity"] < 1e-2 and errors["inertia"] < 0.1, errors
    assert (tmp_path / "plots" / "physics.png").stat().st_size > 0
    header, table = read_table(tmp_path / "plots" / "physics.csv")
    assert header[:8] == ["g1", "g2", "g3", "g4", "g1_true", "g2_true", "g3_true", "g4_true"] and len(table) == 30
    # The wrong robot is named, with nothing written.
    r = run(gipdyn_bin, "evaluate", "--model", str(tmp_path / "lip.gipdyn"), "--data", str(tmp_path / "test.csv"),
            "--physics", "ur10", "--json", str(tmp_path / "bad.json"))
    assert r.returncode == 1 and not (tmp_path / "bad.json").exists()
    assert len(r.stderr.strip().splitlines()) == 1 and "has joints RRRRRR but the model has RRPR" in r.stderr


def test_physics_refuses_models_without_the_structure(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "t.csv", 40, seed=3)
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "t.csv"), "--joints", "RR", "--model", "rbf",
            "--max-iter", "3", "--quiet", "--out", str(tmp_path / "rbf.gipdyn"))
    assert r.returncode == 0, r.stderr
    r = run(gipdyn_bin, "physics", "--model", str(tmp_path / "rbf.gipdyn"), "--data", str(tmp_path / "t.csv"),
            "--out", str(tmp_path / "p.csv"))
    assert r.returncode == 1 and not (tmp_path / "p.csv").exists()
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "a 'rbf' model cannot give gravity" in lines[0], r.stderr


def test_train_preset_real_and_explicit_options_over_it(tmp_path, gipdyn_bin):
    data = tmp_path / "d.csv"
    write_dataset(data, 1200, seed=8)
    r = run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--preset", "real", "--max-iter", "5",
            "--out", str(tmp_path / "real.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "1000 of 1200 rows" in r.stdout and "estimator gip-envelope+friction (preset real)" in r.stdout
    r = run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--preset", "real", "--model", "gip",
            "--subsample", "300", "--max-iter", "5", "--out", str(tmp_path / "over.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "300 of 1200 rows" in r.stdout and "estimator gip (preset real)" in r.stdout
    bad = run(gipdyn_bin, "train", "--data", str(data), "--joints", "RR", "--preset", "fancy",
              "--out", str(tmp_path / "bad.gipdyn"))
    assert bad.returncode != 0 and "unknown preset 'fancy'; choose one of: default, real" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / "bad.gipdyn").exists()


def test_joints_whose_torque_is_below_the_noise_are_named(tmp_path, gipdyn_bin):
    # Joint 2's torque scaled far below the noise: train says the fit calls it noise, evaluate says the
    # noise-free torque is smaller than the noise; joint 1 (torque well above the noise) is named by neither.
    rng = np.random.default_rng(5)
    names = ["q1", "q2", "qd1", "qd2", "qdd1", "qdd2", "tau1", "tau2", "tau1_true", "tau2_true"]
    for name, rows in [("train", 120), ("test", 80)]:
        q, qd, qdd = rng.uniform(-np.pi, np.pi, (rows, 2)), rng.uniform(-2, 2, (rows, 2)), rng.uniform(-3, 3, (rows, 2))
        tau_true = two_link_torques(q, qd, qdd) * np.array([1.0, 1e-3])
        tau = tau_true + 0.05 * rng.standard_normal(tau_true.shape)
        np.savetxt(tmp_path / f"{name}.csv", np.column_stack([q, qd, qdd, tau, tau_true]), delimiter=",",
                   header=",".join(names), comments="")
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "train.csv"), "--joints", "RR", "--teacher", "none", "--out",
            str(tmp_path / "m.gipdyn"))
    assert r.returncode == 0, r.stderr
    noisy = [line for line in r.stderr.splitlines() if "calls most of the torque noise" in line]
    assert len(noisy) == 1 and "joint(s) 2 (" in noisy[0] and "1 (" not in noisy[0], r.stderr
    r = run(gipdyn_bin, "evaluate", "--model", str(tmp_path / "m.gipdyn"), "--data", str(tmp_path / "test.csv"))
    assert r.returncode == 0, r.stderr
    below = [line for line in r.stderr.splitlines() if "varies less than the noise" in line]
    assert len(below) == 1 and "joint(s) 2:" in below[0], r.stderr
    # The measured torque as the target (no *_true columns): nothing to compare, no such warning.
    np.savetxt(tmp_path / "measured.csv", np.loadtxt(tmp_path / "test.csv", delimiter=",", skiprows=1)[:, :8],
               delimiter=",", header=",".join(names[:8]), comments="")
    r = run(gipdyn_bin, "evaluate", "--model", str(tmp_path / "m.gipdyn"), "--data", str(tmp_path / "measured.csv"))
    assert r.returncode == 0 and "varies less" not in r.stderr, r.stderr


def test_predict_and_evaluate_warn_about_states_far_outside_the_training_inputs(trained, gipdyn_bin, tmp_path):
    d, _, _ = trained
    # The test motion of the same distribution: no warning. Velocities four times the training range: one.
    for command in (["predict", "--out", str(tmp_path / "p.csv")], ["evaluate"]):
        r = run(gipdyn_bin, command[0], "--model", str(d / "m.gipdyn"), "--data", str(d / "test.csv"), *command[1:])
        assert r.returncode == 0, r.stderr
        assert "outside the box" not in r.stderr
    write_dataset(tmp_path / "fast.csv", 50, seed=3)
    lines = (tmp_path / "fast.csv").read_text().splitlines()
    header = lines[0].split(",")
    rows = [l.split(",") for l in lines[1:]]
    for row in rows:
        row[header.index("qd2")] = repr(4 * float(row[header.index("qd2")]))
    (tmp_path / "fast.csv").write_text("\n".join([lines[0]] + [",".join(row) for row in rows]) + "\n")
    for command in (["predict", "--out", str(tmp_path / "p.csv")], ["evaluate"]):
        r = run(gipdyn_bin, command[0], "--model", str(d / "m.gipdyn"), "--data", str(tmp_path / "fast.csv"),
                *command[1:])
        assert r.returncode == 0, r.stderr
        warned = [l for l in r.stderr.splitlines() if "outside the box of the model's training inputs" in l]
        assert len(warned) == 1 and "rows of '" in warned[0] and "qd2 farthest" in warned[0], r.stderr


def test_train_and_inspect_take_the_joint_types_a_simulated_logs_sidecar_records(gipdyn_bin, tmp_path):
    log = tmp_path / "scara.csv"
    r = run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "80", "--seed", "1", "--out", str(log), "--quiet")
    assert r.returncode == 0, r.stderr
    fit = ("--model", "rbf", "--max-iter", "5")
    r = run(gipdyn_bin, "train", "--data", str(log), *fit, "--out", str(tmp_path / "m.gipdyn"))
    assert r.returncode == 0 and "differs" not in r.stderr, r.stderr
    assert "joints RRPR" in r.stdout and model_header(tmp_path / "m.gipdyn")["joints"] == "RRPR"
    # A simulated log is taught without the note for robots' logs.
    r = run(gipdyn_bin, "train", "--data", str(log), "--max-iter", "5", "--teacher-hyperparameter-rows", "0",
            "--out", str(tmp_path / "g.gipdyn"))
    assert r.returncode == 0 and "taught by lip" in r.stdout, r.stderr
    assert "--preset real" not in r.stdout
    # The teacher's options set up the default teacher (--teacher auto) without naming it.
    assert model_header(tmp_path / "g.gipdyn")["teacher"]["hyperparameter_rows"] == 0
    r = run(gipdyn_bin, "inspect", "--data", str(log))
    assert r.returncode == 0, r.stderr
    # Joint types that contradict the sidecar are used, with a warning (a likely typo, e.g. RRRR for the SCARA).
    r = run(gipdyn_bin, "train", "--data", str(log), "--joints", "RRRR", *fit, "--out", str(tmp_path / "r.gipdyn"))
    assert r.returncode == 0 and "--joints RRRR differs from the joint types RRPR" in r.stderr, r.stderr
    assert model_header(tmp_path / "r.gipdyn")["joints"] == "RRRR"
    # A sidecar that does not fit the log, or is not JSON: one line naming it, and no model.
    for sidecar, expected in (('{"joints": "RRR"}', "records 3 joint types (RRR) but"), ("{", "is not valid JSON")):
        (tmp_path / "scara.csv.json").write_text(sidecar)
        r = run(gipdyn_bin, "train", "--data", str(log), *fit, "--out", str(tmp_path / "bad.gipdyn"))
        assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert expected in r.stderr and "scara.csv.json" in r.stderr, r.stderr
        assert not (tmp_path / "bad.gipdyn").exists()
        # With --joints the sidecar is only a cross-check (this one's RRR is warned about).
        r = run(gipdyn_bin, "inspect", "--data", str(log), "--joints", "RRPR")
        assert r.returncode == 0, r.stderr


def test_a_model_based_estimator_takes_the_joint_types_of_its_robot(gipdyn_bin, tmp_path):
    # A log without a sidecar: --robot knows the joint types (the SCARA's third is prismatic).
    log = tmp_path / "scara.csv"
    r = run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "80", "--seed", "1", "--out", str(log), "--quiet")
    assert r.returncode == 0, r.stderr
    (tmp_path / "scara.csv.json").unlink()
    r = run(gipdyn_bin, "train", "--data", str(log), "--model", "fe", "--robot", "scara", "--out",
            str(tmp_path / "fe.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert model_header(tmp_path / "fe.gipdyn")["joints"] == "RRPR"
    # A robot of another joint count than the log's columns: one line naming both, and no model.
    r = run(gipdyn_bin, "train", "--data", str(log), "--model", "fe", "--robot", "ur10", "--out",
            str(tmp_path / "bad.gipdyn"))
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "--robot ur10 has 6 joints (RRRRRR) but" in r.stderr and "has 4 (q1..q4)" in r.stderr, r.stderr
    assert not (tmp_path / "bad.gipdyn").exists()


def test_train_and_inspect_without_joints_say_how_many_the_log_has(trained, gipdyn_bin, tmp_path):
    d, _, _ = trained
    for command in (["train", "--out", str(tmp_path / "m.gipdyn")], ["inspect"]):
        r = run(gipdyn_bin, command[0], "--data", str(d / "train.csv"), *command[1:])
        assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert "--joints is required" in r.stderr and "has 2 joint(s) (q1..q2), e.g. --joints RR if" in r.stderr
    assert not (tmp_path / "m.gipdyn").exists()


@pytest.mark.parametrize("case, args, code, says", [
    ("the overview", [], 0, "Subcommands:"),
    ("a command's help", ["train", "--help"], 0, "--data"),
    ("an unknown command", ["trian"], 2, "did you mean 'train'?"),
    ("a command without its subcommand", ["experiment"], 2, "needs a command"),
    ("an unknown option", ["simulate", "--robot", "scara", "--out", "{tmp}/s.csv", "--colour"], 2,
     "--colour (gipdyn simulate --help)"),
    ("a value not of the option's type", ["simulate", "--robot", "scara", "--out", "{tmp}/s.csv", "--samples", "many"],
     2, "--samples"),
    ("a required option missing", ["simulate", "--robot", "scara"], 2, "--out is required"),
    ("a file that does not exist", ["predict", "--model", "{tmp}/none.gipdyn", "--data", "{tmp}/none.csv",
                                    "--out", "{tmp}/p.csv"], 2, "File does not exist"),
    ("a value the command refuses", ["simulate", "--robot", "scara", "--out", "{tmp}/s.csv", "--samples", "-5"], 1,
     "--samples"),
    ("a robot that does not exist", ["simulate", "--robot", "puma9000", "--out", "{tmp}/s.csv"], 1, "puma9000"),
    ("an option's old name", ["train", "--data", "{tmp}/log.csv", "--kernel", "rbf", "--out", "{tmp}/m.gipdyn"], 2,
     "gipdyn train --kernel is now --model (same values; gipdyn train --help)"),
    ("an option's old name with its value", ["experiment", "accuracy", "--estimators=gip"], 2,
     "gipdyn experiment --estimators is now --models (same values; gipdyn experiment accuracy --help)"),
])
def test_exit_codes(tmp_path, gipdyn_bin, case, args, code, says):
    # 0: done; 2: the command line (unknown command or option, a value not of its type, a missing required option
    # or file); 1: anything else, with the message naming the problem (docs/reference/cli.md, "Exit codes").
    r = run(gipdyn_bin, *[a.replace("{tmp}", str(tmp_path)) for a in args])
    assert r.returncode == code, (case, r.returncode, r.stdout, r.stderr)
    if code == 0:
        assert says in r.stdout, case
    else:
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("gipdyn: error: ") and says in lines[0], (case, r.stderr)


def test_commands_start_without_libtorch_and_a_missing_plugin_is_named(gipdyn_bin, tmp_path):
    # libtorch is opened only to train a network: loading it cost every command about a second.
    env = dict(os.environ, LD_DEBUG="files")
    r = subprocess.run([gipdyn_bin, "--version"], capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0
    loaded = [line for line in r.stderr.splitlines() if "file=" in line]
    assert loaded and not [line for line in loaded if "libtorch" in line or "gipdyn_torch" in line], loaded
    write_dataset(tmp_path / "train.csv", 60, seed=1)
    env = dict(os.environ, GIPDYN_TORCH_PLUGIN=str(tmp_path / "missing.so"))
    r = subprocess.run([gipdyn_bin, "train", "--data", str(tmp_path / "train.csv"), "--joints", "RR", "--model", "nn",
                        "--out", str(tmp_path / "nn.gipdyn")], capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode != 0 and not (tmp_path / "nn.gipdyn").exists()
    errors = [line for line in r.stderr.splitlines() if "error" in line]
    assert len(errors) == 1 and "missing.so (missing)" in errors[0] and "GIPDYN_TORCH_PLUGIN" in errors[0], r.stderr
