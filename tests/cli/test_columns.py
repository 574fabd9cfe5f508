"""Logs whose columns have other names than gipdyn's (a ROS joint_states export): --columns reads them as
the same log under gipdyn's names, in every command that reads a log, and bad patterns are refused in one line."""
import json
import subprocess

import numpy as np

from conftest import write_dataset

ROS = "q=position_{i0},qd=velocity_{i0},qdd=acceleration_{i0},tau=effort_{i0}"
RENAMES = {"q": "position_", "qd": "velocity_", "qdd": "acceleration_", "tau": "effort_"}


def run(binary, *args):
    return subprocess.run([binary, *map(str, args)], capture_output=True, text=True, timeout=300)


def as_ros_export(source, target):
    """The log with each joint column renamed as ROS names it (joints counted from 0); other columns as they are."""
    lines = open(source).read().splitlines()
    names = []
    for name in lines[0].split(","):
        for quantity in ("qdd", "qd", "q", "tau"):
            number = name[len(quantity):]
            if name.startswith(quantity) and number.isdigit():
                name = f"{RENAMES[quantity]}{int(number) - 1}"
                break
        names.append(name)
    open(target, "w").write("\n".join([",".join(names)] + lines[1:]) + "\n")
    return names


def test_a_ros_export_trains_evaluates_predicts_and_detects_as_the_same_log_under_gipdyns_names(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "train.csv", 60, seed=1)
    write_dataset(tmp_path / "test.csv", 30, seed=2)
    names = as_ros_export(tmp_path / "train.csv", tmp_path / "train_ros.csv")
    as_ros_export(tmp_path / "test.csv", tmp_path / "test_ros.csv")
    assert "position_0" in names and "q1" not in names
    common = ["--joints", "RR", "--model", "rbf", "--teacher", "none", "--max-iter", "20", "--quiet"]
    assert run(gipdyn_bin, "train", "--data", tmp_path / "train.csv", "--out", tmp_path / "a.gipdyn", *common).returncode == 0
    r = run(gipdyn_bin, "train", "--data", tmp_path / "train_ros.csv", "--columns", ROS, "--out", tmp_path / "b.gipdyn", *common)
    assert r.returncode == 0, r.stderr
    for model in ("a", "b"):
        r = run(gipdyn_bin, "predict", "--model", tmp_path / f"{model}.gipdyn", "--data", tmp_path / "test_ros.csv",
                "--columns", ROS, "--out", tmp_path / f"{model}.csv")
        assert r.returncode == 0, r.stderr
    a, b = (np.genfromtxt(tmp_path / f"{m}.csv", delimiter=",", names=True) for m in "ab")
    assert a.dtype.names == b.dtype.names and all(np.array_equal(a[c], b[c]) for c in a.dtype.names)
    # The same patterns from a JSON file, in evaluate; and physics reads positions by the log's names.
    (tmp_path / "ros.json").write_text(json.dumps({k: v + "{i0}" for k, v in RENAMES.items()}))
    evaluations = [run(gipdyn_bin, "evaluate", "--model", tmp_path / "b.gipdyn", "--data", data, *columns).stdout
                   for data, columns in ((tmp_path / "test.csv", ()), (tmp_path / "test_ros.csv", ("--columns", tmp_path / "ros.json")))]
    assert evaluations[0] and evaluations[0] == evaluations[1]
    r = run(gipdyn_bin, "inspect", "--data", tmp_path / "train_ros.csv", "--joints", "RR", "--columns", ROS)
    assert r.returncode == 0, r.stderr


def test_preprocess_reads_a_raw_export_by_its_names(tmp_path, gipdyn_bin):
    t = np.arange(400) * 0.004
    q = np.column_stack([np.sin(t), np.cos(2 * t)])
    tau = 2.0 * q
    header = "time,position_0,position_1,effort_0,effort_1"
    np.savetxt(tmp_path / "raw.csv", np.column_stack([t, q, tau]), delimiter=",", header=header, comments="")
    r = run(gipdyn_bin, "preprocess", "--data", tmp_path / "raw.csv", "--out", tmp_path / "data.csv", "--quiet",
            "--columns", "q=position_{i0},tau=effort_{i0}")
    assert r.returncode == 0, r.stderr
    out = np.genfromtxt(tmp_path / "data.csv", delimiter=",", names=True)
    np.testing.assert_allclose(out["q2"], q[:, 1], atol=1e-12)
    np.testing.assert_allclose(out["qd1"][5:-5], np.cos(t)[5:-5], atol=1e-4)  # qd computed from q
    # Without --columns the error says the joints are counted from 0 and which pattern reads them.
    r = run(gipdyn_bin, "preprocess", "--data", tmp_path / "raw.csv", "--out", tmp_path / "x.csv")
    assert r.returncode == 1 and "--columns, e.g. q=position_{i0}" in r.stderr and len(r.stderr.splitlines()) == 1


def test_bad_patterns_are_refused_in_one_line_naming_the_option(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "train.csv", 20, seed=3)
    for columns, message in [("q=position", "--columns q ('position') must hold exactly one {i}"),
                             ("torque=effort_{i}", "unknown quantity 'torque'"),
                             ("q=pos{i}", "has a column 'q1', gipdyn's name of a joint's q, but --columns q says"),
                             ("tau=effort_{i}", "has a column 'tau1', gipdyn's name of a joint's tau"),
                             (str(tmp_path / "missing.json"), "nor a readable file")]:
        r = run(gipdyn_bin, "train", "--data", tmp_path / "train.csv", "--joints", "RR", "--columns", columns,
                "--out", tmp_path / "m.gipdyn")
        assert r.returncode == 1 and message in r.stderr and len(r.stderr.strip().splitlines()) == 1, (columns, r.stderr)
        assert not (tmp_path / "m.gipdyn").exists()
