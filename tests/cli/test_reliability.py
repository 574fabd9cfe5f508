"""Bad input that used to lose data or answer with garbage: every case exits
non-zero with one line naming the problem, and leaves every file as it was."""
import struct

import pytest

from conftest import write_dataset
from test_cli import run


def snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def fails_with(r, *words):
    assert r.returncode != 0, r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for w in words:
        assert w in lines[0], lines[0]


@pytest.fixture()
def folder(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "d.csv", 40, seed=1)
    # No teacher: the model's training rows are d.csv's (a test below evaluates on them).
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "d.csv"), "--joints", "RR", "--max-iter", "5", "--quiet",
            "--teacher", "none", "--out", str(tmp_path / "m.gipdyn"))
    assert r.returncode == 0, r.stderr
    return tmp_path


@pytest.mark.parametrize("args, flags", [
    (["train", "--data", "{d}/d.csv", "--joints", "RR", "--out", "{d}/d.csv"], ["--out", "--data"]),
    (["predict", "--model", "{d}/m.gipdyn", "--data", "{d}/d.csv", "--out", "{d}/d.csv"], ["--out", "--data"]),
    (["predict", "--model", "{d}/m.gipdyn", "--data", "{d}/d.csv", "--out", "{d}/m.gipdyn"], ["--out", "--model"]),
    (["evaluate", "--model", "{d}/m.gipdyn", "--data", "{d}/d.csv", "--json", "{d}/d.csv"], ["--json", "--data"]),
    (["physics", "--model", "{d}/m.gipdyn", "--data", "{d}/d.csv", "--out", "{d}/./d.csv"], ["--out", "--data"]),
    (["inspect", "--data", "{d}/d.csv", "--joints", "RR", "--out", "{d}/d.csv"], ["--out", "--data"]),
])
def test_an_output_never_overwrites_an_input(folder, gipdyn_bin, args, flags):
    before = snapshot(folder)
    fails_with(run(gipdyn_bin, *[a.format(d=folder) for a in args]), "same file", *flags)
    assert snapshot(folder) == before


@pytest.mark.parametrize("args, flags", [
    (["train", "--data", "{d}/d.csv", "--joints", "RR", "--teacher", "lip", "--out", "{d}/s.gipdyn",
      "--teacher-out", "{d}/./s.gipdyn"], ["--teacher-out and --out"]),
    (["simulate", "--robot", "scara", "--model", "{d}/m.gipdyn", "--out", "{d}/s.csv", "--plot", "{d}/s.csv"],
     ["--plot and --out"]),
    (["inspect", "--data", "{d}/d.csv", "--joints", "RR", "--out", "{d}/r.json", "--plot", "{d}/r.json"],
     ["--plot and --out"]),
    # Another name of an existing file: a symbolic link to it.
    (["inspect", "--data", "{d}/d.csv", "--joints", "RR", "--out", "{d}/old.json", "--plot", "{d}/link.png"],
     ["--plot and --out"]),
])
def test_two_outputs_never_share_a_file(folder, gipdyn_bin, args, flags):
    (folder / "old.json").write_text("{}")
    (folder / "link.png").symlink_to(folder / "old.json")
    before = snapshot(folder)
    fails_with(run(gipdyn_bin, *[a.format(d=folder) for a in args]), "name the same file", *flags)
    assert snapshot(folder) == before


def test_preprocess_refuses_to_overwrite_its_log(tmp_path, gipdyn_bin):
    log = tmp_path / "log.csv"
    log.write_text("t,q1,tau1\n" + "".join(f"{k * 0.01},{k * 0.001},{k}\n" for k in range(50)))
    (tmp_path / "link.csv").symlink_to(log)
    before = snapshot(tmp_path)
    fails_with(run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(tmp_path / "link.csv")),
               "same file", "--data")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("content, words", [
    ("q1,q2,qd1,qd2,qdd1,qdd2,tau1,q1\n" + "0,0,0,0,0,0,0,0\n" * 10, ["names column 'q1' twice", "columns 1 and 8"]),
    ("q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n" + "0,0,0,0,0,0,0,0\n" * 3 + "0,0,0,0,0,0,0,0,9\n" + "0,0,0,0,0,0,0,0\n" * 6,
     ["line 5 has 9 cells but the header has 8"]),
    ("q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n" + "0,0,0,0,0,0,0,0\n" * 3 + "0,0,1e400,0,0,0,0,0\n" + "0,0,0,0,0,0,0,0\n" * 6,
     ["line 5", "'qd1'", "outside the range of a double"]),
])
def test_malformed_csv_is_named(tmp_path, gipdyn_bin, content, words):
    (tmp_path / "bad.csv").write_text(content)
    fails_with(run(gipdyn_bin, "train", "--data", str(tmp_path / "bad.csv"), "--joints", "RR", "--out",
                   str(tmp_path / "m.gipdyn")), *words)
    assert not (tmp_path / "m.gipdyn").exists()


def test_non_finite_results_are_never_written(folder, gipdyn_bin, tmp_path):
    huge = tmp_path / "huge.csv"
    huge.write_text("q1,q2,qd1,qd2,qdd1,qdd2\n0.1,0.2,0.3,0.4,0.5,0.6\n0.1,0.2,1e300,0.4,0.5,0.6\n")
    fails_with(run(gipdyn_bin, "predict", "--model", str(folder / "m.gipdyn"), "--data", str(huge), "--out",
                   str(tmp_path / "p.csv")), "non-finite", "data row 2")
    assert not (tmp_path / "p.csv").exists()
    fails_with(run(gipdyn_bin, "simulate", "--robot", "scara", "--samples", "5", "--dt", "1e308", "--out",
                   str(tmp_path / "s.csv")), "non-finite")
    assert not (tmp_path / "s.csv").exists() and not (tmp_path / "s.csv.json").exists()


def rewrite_model(path, edit):
    """Applies edit(bytearray) and fixes the FNV-1a checksum, as a careless tool would."""
    data = bytearray(path.read_bytes())
    edit(data)
    h = 1469598103934665603  # the container's offset basis (docs/model-format.md)
    for b in data[:-8]:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    data[-8:] = struct.pack("<Q", h)
    path.write_bytes(bytes(data))


def test_models_with_nan_or_version_zero_are_rejected(folder, gipdyn_bin):
    nan_model = folder / "nan.gipdyn"
    nan_model.write_bytes((folder / "m.gipdyn").read_bytes())
    rewrite_model(nan_model, lambda d: d.__setitem__(slice(-16, -8), struct.pack("<d", float("nan"))))
    fails_with(run(gipdyn_bin, "predict", "--model", str(nan_model), "--data", str(folder / "d.csv"), "--out",
                   str(folder / "p.csv")), "non-finite number", "array")
    v0 = folder / "v0.gipdyn"
    v0.write_bytes((folder / "m.gipdyn").read_bytes())
    rewrite_model(v0, lambda d: d.__setitem__(slice(8, 12), struct.pack("<I", 0)))
    fails_with(run(gipdyn_bin, "predict", "--model", str(v0), "--data", str(folder / "d.csv"), "--out",
                   str(folder / "p.csv")), "format version 0")
    assert not (folder / "p.csv").exists()


def test_evaluate_checks_all_its_options_before_writing(folder, gipdyn_bin):
    fails_with(run(gipdyn_bin, "evaluate", "--model", str(folder / "m.gipdyn"), "--data", str(folder / "d.csv"),
                   "--json", str(folder / "r.json"), "--plots", str(folder / "plots"), "--plot-window", "0"),
               "--plot-window")
    assert not (folder / "r.json").exists()


@pytest.mark.parametrize("args, words", [
    (["simulate", "--robot", "scara", "--samples", "2000000000", "--out", "{d}/s.csv"], ["needs about", "--samples"]),
    (["train", "--data", "{d}/d.csv", "--joints", "RR", "--model", "nn", "--nn-hidden", "2000000000",
      "--out", "{d}/n.gipdyn"], ["needs about", "--nn-hidden"]),
    (["train", "--data", "{d}/d.csv", "--joints", "RR", "--restarts", "5000", "--out", "{d}/r.gipdyn"],
     ["--restarts must be between 0 and 1000"]),
    (["train", "--data", "{d}/d.csv", "--joints", "RR", "--model", "lip", "--start-screening", "-1",
      "--out", "{d}/r.gipdyn"], ["--start-screening must be >= 0"]),
])
def test_sizes_beyond_the_machine_are_refused_before_allocating(folder, gipdyn_bin, args, words):
    before = snapshot(folder)
    fails_with(run(gipdyn_bin, *[a.format(d=folder) for a in args]), *words)
    assert snapshot(folder) == before


def test_memory_estimate_respects_the_address_space_limit(tmp_path, gipdyn_bin):
    # A batch scheduler's `ulimit -v` allows far less than the machine has: the
    # estimate must be checked against the limit, not against MemAvailable.
    import resource
    import subprocess
    write_dataset(tmp_path / "big.csv", 17000, seed=2)
    limit = 3 * 1024**3

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    r = subprocess.run([gipdyn_bin, "train", "--data", str(tmp_path / "big.csv"), "--joints", "RR", "--quiet",
                        "--out", str(tmp_path / "m.gipdyn")], capture_output=True, text=True, preexec_fn=cap,
                       timeout=120)
    fails_with(r, "training on 17000 rows needs about", "available", "fewer rows (a constant-step subsample: train --subsample N")
    assert not (tmp_path / "m.gipdyn").exists()


def test_constant_columns_and_test_rows_from_training_are_warned_about(folder, gipdyn_bin, tmp_path):
    lines = (folder / "d.csv").read_text().splitlines()
    header = lines[0].split(",")
    k = header.index("qd2")
    rows = [l.split(",") for l in lines[1:]]
    for r in rows:
        r[k] = "0.5"
    (tmp_path / "c.csv").write_text("\n".join([lines[0]] + [",".join(r) for r in rows]) + "\n")
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "c.csv"), "--joints", "RR", "--max-iter", "3",
            "--out", str(tmp_path / "c.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "warning: column(s) qd2 of" in r.stderr and "are constant" in r.stderr
    # A joint that never moves: one line naming the joint, not one per column.
    for r in rows:
        r[header.index("q1")], r[header.index("qd1")], r[header.index("qdd1")] = "0.3", "0", "0"
    (tmp_path / "l.csv").write_text("\n".join([lines[0]] + [",".join(r) for r in rows]) + "\n")
    r = run(gipdyn_bin, "train", "--data", str(tmp_path / "l.csv"), "--joints", "RR", "--max-iter", "3",
            "--out", str(tmp_path / "l.gipdyn"))
    assert r.returncode == 0, r.stderr
    assert "warning: joint(s) 1 never move in" in r.stderr and "a locked joint?" in r.stderr
    assert "warning: column(s) qd2 of" in r.stderr and "q1" not in r.stderr.split("column(s)")[1]
    r = run(gipdyn_bin, "evaluate", "--model", str(folder / "m.gipdyn"), "--data", str(folder / "d.csv"))
    assert r.returncode == 0, r.stderr
    assert "warning: 40 of the 40 rows" in r.stderr and "not a test error" in r.stderr
    r = run(gipdyn_bin, "experiment", "real", "--data", str(folder / "d.csv"), "--joints", "RR", "--train-rows",
            "1-30", "--test-rows", "21-40", "--models", "gip", "--max-iter", "3", "--out", str(tmp_path / "e3"))
    assert r.returncode == 0, r.stderr
    assert "warning: 10 of the 20 test rows also appear among the training rows" in r.stderr
