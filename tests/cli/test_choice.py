"""train --model auto: the estimator chosen by evidence, the comparison printed and recorded in the model file."""
import subprocess

from conftest import model_header, write_dataset


def run(binary, *args):
    return subprocess.run([binary, *map(str, args)], capture_output=True, text=True, timeout=600)


def test_auto_compares_the_candidates_on_the_held_out_rows_and_records_the_choice(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "train.csv", 120, seed=5)
    r = run(gipdyn_bin, "train", "--data", tmp_path / "train.csv", "--joints", "RR", "--model", "auto",
            "--max-iter", "60", "--teacher-states", "300", "--out", tmp_path / "m.gipdyn")
    assert r.returncode == 0, r.stderr
    assert "choice by evidence: each candidate fitted on the log's first 90 rows, scored on its last 30" in r.stdout
    header = model_header(tmp_path / "m.gipdyn")
    selection = header["selection"]
    names = [c["name"] for c in selection["candidates"]]
    assert names == ["gip", "chain", "lip", "gip-envelope+friction", "rbf"]
    scored = {c["name"]: c["mean_nmse"] for c in selection["candidates"] if c["status"] == "scored"}
    assert selection["best"] == min(scored, key=scored.get)
    assert scored[selection["chosen"]] <= scored[selection["best"]] * (1 + selection["tie_tolerance"])
    # The model written is the chosen one, and the report says so.
    chosen = selection["chosen"]
    assert f"chose {chosen}" in r.stdout and f"saved {chosen} model to" in r.stdout
    assert header.get("kernel", header["estimator"]) == chosen


def test_options_that_choose_part_of_the_model_are_refused_beside_auto(tmp_path, gipdyn_bin):
    write_dataset(tmp_path / "train.csv", 60, seed=6)
    for extra in (["--preset", "real"], ["--teacher", "lip"], ["--inducing", "20"]):
        r = run(gipdyn_bin, "train", "--data", tmp_path / "train.csv", "--joints", "RR", "--model", "auto", *extra,
                "--out", tmp_path / "m.gipdyn")
        assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1, (extra, r.stderr)
        assert f"{extra[0]} chooses part of the model, and --model auto chooses the whole model" in r.stderr
        assert not (tmp_path / "m.gipdyn").exists()
    r = run(gipdyn_bin, "train", "--data", tmp_path / "train.csv", "--joints", "RR", "--model", "auto",
            "--subsample", "30", "--out", tmp_path / "m.gipdyn")
    assert r.returncode == 1 and "a log of 30 rows is too short to choose an estimator by evidence" in r.stderr
