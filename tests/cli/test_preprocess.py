"""`gipdyn preprocess` against SciPy: the same zero-phase Butterworth filter
(scipy.signal.butter + sosfiltfilt), numpy.gradient derivatives and
numpy.interp resampling, plus the sidecar report and the errors."""
import json
import subprocess

import numpy as np
import pytest


def run(binary, *args):
    return subprocess.run([binary, *args], capture_output=True, text=True, timeout=120)


def write_log(path, columns):
    names = list(columns)
    np.savetxt(path, np.column_stack([columns[k] for k in names]), delimiter=",", header=",".join(names),
               comments="", fmt="%.17g")


def read(path):
    return np.genfromtxt(path, delimiter=",", names=True)


def test_matches_scipy_filter_numpy_gradient_and_interp(tmp_path, gipdyn_bin):
    signal = pytest.importorskip("scipy.signal")
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.8e-3, 1.2e-3, 3000))  # irregular, about 1 kHz
    q = np.column_stack([np.sin(2.0 * t), 0.5 * np.cos(3.0 * t)]) + 1e-3 * rng.standard_normal((t.size, 2))
    tau = 3.0 * q + 0.2 * rng.standard_normal((t.size, 2))
    log = tmp_path / "log.csv"
    write_log(log, {"time": t, "q1": q[:, 0], "q2": q[:, 1], "tau1": tau[:, 0], "tau2": tau[:, 1]})
    out = tmp_path / "data.csv"
    r = run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(out), "--dt", "0.002", "--cutoff", "15",
            "--order", "3", "--filter-torque")
    assert r.returncode == 0, r.stderr

    # The same steps with NumPy/SciPy.
    dt, fs = 0.002, 500.0
    grid = t[0] + dt * np.arange(int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1)
    sos = signal.butter(3, 15.0, fs=fs, output="sos")
    expect = {}
    for name, x in (("q", q), ("tau", tau)):
        resampled = np.column_stack([np.interp(grid, t, x[:, j]) for j in range(2)])
        expect[name] = signal.sosfiltfilt(sos, resampled, axis=0)
    expect["qd"] = np.gradient(expect["q"], dt, axis=0, edge_order=2)
    expect["qdd"] = np.gradient(expect["qd"], dt, axis=0, edge_order=2)

    d = read(out)
    assert list(d.dtype.names) == ["t", "q1", "q2", "qd1", "qd2", "qdd1", "qdd2", "tau1", "tau2"]
    np.testing.assert_allclose(d["t"], grid, rtol=0, atol=1e-12)
    for name in ("q", "qd", "qdd", "tau"):
        got = np.column_stack([d[f"{name}1"], d[f"{name}2"]])
        scale = np.abs(expect[name]).max()
        np.testing.assert_allclose(got, expect[name], rtol=0, atol=1e-9 * scale, err_msg=name)

    report = json.loads((tmp_path / "data.csv.json").read_text())
    assert report["input_rows"] == 3000 and report["output_rows"] == grid.size
    assert [s["step"] for s in report["steps"]] == ["resample", "low-pass", "derivatives"]
    assert report["steps"][1]["cutoff_hz"] == 15.0 and report["steps"][1]["order_per_pass"] == 3
    assert "d/dt of the filtered q" in report["steps"][2]["qd"]

    # The result trains a model directly.
    r = run(gipdyn_bin, "train", "--data", str(out), "--joints", "RR", "--out", str(tmp_path / "m.gipdyn"),
            "--max-iter", "5", "--subsample", "200")
    assert r.returncode == 0, r.stderr


def test_logged_velocities_drop_rest_and_errors(tmp_path, gipdyn_bin):
    t = np.arange(2000) * 1e-3
    q = np.where(t < 0.5, 0.0, np.sin(4 * (t - 0.5)))
    qd = np.where(t < 0.5, 0.0, 4 * np.cos(4 * (t - 0.5)))
    log = tmp_path / "log.csv"
    write_log(log, {"t": t, "q1": q, "qd1": qd, "qdd1": np.zeros_like(t), "tau1": q})
    out = tmp_path / "data.csv"
    # --in, the option's older name, still works.
    r = run(gipdyn_bin, "preprocess", "--in", str(log), "--out", str(out), "--drop-rest")
    assert r.returncode == 0, r.stderr
    d = read(out)
    # The first half second at rest is gone; the turning point at t = 0.5 + pi/8, where qd
    # crosses zero for an instant, is kept.
    assert d["t"][0] >= 0.5 and d.size == 1500
    np.testing.assert_allclose(d["qd1"], qd[500:], atol=1e-12)  # logged qd kept (no filter asked)
    np.testing.assert_allclose(d["qdd1"][1:-1], -16 * np.sin(4 * (t[501:-1] - 0.5)), atol=2e-3)  # not the logged 0
    report = json.loads((tmp_path / "data.csv.json").read_text())
    assert report["steps"][-1]["dropped_rows"] == 500 and report["steps"][-1]["stretches_dropped"] == 1
    assert "ignored" in report["steps"][-2]["qdd"]

    bad = run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(tmp_path / "x.csv"), "--cutoff", "600")
    assert bad.returncode == 1 and "Nyquist" in bad.stderr
    assert not (tmp_path / "x.csv").exists() and not (tmp_path / "x.csv.json").exists()
    write_log(tmp_path / "notime.csv", {"clock": t, "q1": q, "tau1": q})
    bad = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "notime.csv"), "--out", str(tmp_path / "y.csv"))
    assert bad.returncode == 1 and "--time-column" in bad.stderr
    ok = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "notime.csv"), "--out", str(tmp_path / "y.csv"),
             "--time-column", "clock", "--quiet")
    assert ok.returncode == 0 and ok.stdout == ""
    # Without a time column, --log-period: rows equally spaced from t = 0.
    write_log(tmp_path / "rows.csv", {"q1": q, "tau1": q})
    ok = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "rows.csv"), "--out", str(tmp_path / "z.csv"),
             "--log-period", "0.001", "--quiet")
    assert ok.returncode == 0, ok.stderr
    z = read(tmp_path / "z.csv")
    np.testing.assert_allclose(z["t"], t, atol=1e-12)
    smooth = np.abs(t - 0.5) > 1.5e-3  # qd jumps at t = 0.5 s
    np.testing.assert_allclose(z["qd1"][smooth], qd[smooth], atol=1e-4)  # from q by central differences
    assert z.size == 2000


def test_causal_mode_matches_scipy_forward_filter_and_reports_its_delay(tmp_path, gipdyn_bin):
    signal = pytest.importorskip("scipy.signal")
    rng = np.random.default_rng(5)
    dt = 0.002
    t = dt * np.arange(2000)
    q = np.column_stack([np.sin(2.0 * t) + 1e-3 * rng.standard_normal(t.size)])
    tau = 3.0 * q[:, 0] + 0.2 * rng.standard_normal(t.size)
    log = tmp_path / "log.csv"
    write_log(log, {"t": t, "q1": q[:, 0], "tau1": tau})
    out = tmp_path / "causal.csv"
    r = run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(out), "--cutoff", "10", "--causal")
    assert r.returncode == 0, r.stderr
    sos = signal.butter(2, 10.0, fs=1.0 / dt, output="sos")
    zi = signal.sosfilt_zi(sos) * q[0, 0]
    qf, _ = signal.sosfilt(sos, q[:, 0], zi=zi)
    qd = np.concatenate([[0.0], np.diff(qf) / dt])
    qdd = np.concatenate([[0.0], np.diff(qd) / dt])
    d = read(out)
    np.testing.assert_allclose(d["q1"], qf, rtol=0, atol=1e-12)
    np.testing.assert_allclose(d["qd1"], qd, rtol=0, atol=1e-9)
    np.testing.assert_allclose(d["qdd1"], qdd, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(d["tau1"], tau)  # targets left as measured by default
    report = json.loads((tmp_path / "causal.csv.json").read_text())
    b, a = signal.sos2tf(sos)
    _, delay = signal.group_delay((b, a), w=[1e-6])
    lowpass = report["steps"][1]
    assert lowpass["filter"].endswith("(causal)") and lowpass["applied_to"] == ["q"]
    assert lowpass["delay_s"] == pytest.approx(delay[0] * dt, rel=1e-6)
    assert report["steps"][2]["delay_s"]["qdd"] == pytest.approx((delay[0] + 1.0) * dt, rel=1e-6)
    # Causal: a change of the input after row k does not change output rows up to k.
    q2 = q[:, 0].copy()
    q2[1500:] += 1.0
    write_log(tmp_path / "log2.csv", {"t": t, "q1": q2, "tau1": tau})
    r = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "log2.csv"), "--out", str(tmp_path / "c2.csv"),
            "--cutoff", "10", "--causal")
    d2 = read(tmp_path / "c2.csv")
    for c in ("q1", "qd1", "qdd1"):
        np.testing.assert_array_equal(d2[c][:1500], d[c][:1500])


def test_segments_are_processed_apart(tmp_path, gipdyn_bin):
    dt = 0.01
    t = dt * np.arange(600)
    q = np.where(t < 3.0, np.sin(t), 5.0 + np.cos(t))  # a jump at the segment boundary, row 301
    log = tmp_path / "log.csv"
    write_log(log, {"t": t, "q1": q, "tau1": q})
    whole, split = tmp_path / "whole.csv", tmp_path / "split.csv"
    for path, extra in ((whole, []), (split, ["--segment-starts", "301"])):
        r = run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(path), "--cutoff", "5", *extra)
        assert r.returncode == 0, r.stderr
    first = tmp_path / "first.csv"
    write_log(tmp_path / "first_log.csv", {"t": t[:300], "q1": q[:300], "tau1": q[:300]})
    run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "first_log.csv"), "--out", str(first), "--cutoff", "5")
    a, w, f = read(split), read(whole), read(first)
    assert a.size == 600
    # The first segment is exactly what its rows alone give; the whole log's filter smears the jump into them.
    np.testing.assert_allclose(a["q1"][:300], f["q1"], rtol=0, atol=1e-12)
    assert np.abs(w["q1"][290:300] - f["q1"][290:300]).max() > 0.1
    report = json.loads((tmp_path / "split.csv.json").read_text())
    assert report["segments"] == [{"input_rows": [1, 300], "output_rows": 300},
                                  {"input_rows": [301, 600], "output_rows": 300}]
    for bad_rows, message in (("700", "past the log's 600 data rows"), ("1", "increasing data rows > 1"),
                              ("599", "fewer than 3 samples")):
        bad = run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(tmp_path / "bad.csv"),
                  "--segment-starts", bad_rows)
        assert bad.returncode != 0 and message in bad.stderr, bad.stderr
        assert "--segment-starts" in bad.stderr or "segment" in bad.stderr
        assert not (tmp_path / "bad.csv").exists()


def test_a_gap_in_the_log_is_refused_unless_a_segment_starts_there(tmp_path, gipdyn_bin):
    t = np.concatenate([0.01 * np.arange(300), 10.0 + 0.01 * np.arange(300)])  # 7 s pause before row 301
    q = np.sin(t)
    write_log(tmp_path / "gap.csv", {"t": t, "q1": q, "tau1": q})
    bad = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "gap.csv"), "--out", str(tmp_path / "bad.csv"))
    assert bad.returncode != 0 and "gap of 7.01" in bad.stderr and "before data row 301" in bad.stderr
    assert "--segment-starts 301" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "bad.csv").exists()
    ok = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "gap.csv"), "--out", str(tmp_path / "ok.csv"),
             "--segment-starts", "301")
    assert ok.returncode == 0, ok.stderr
    assert read(tmp_path / "ok.csv").size == 600


def test_a_log_with_joints_counted_from_0_is_refused(tmp_path, gipdyn_bin):
    # Reading q1.. of a log whose joints are q0, q1 would take its second joint for the first.
    t = 0.01 * np.arange(100)
    write_log(tmp_path / "zero.csv", {"t": t, "q0": np.sin(t), "q1": np.cos(t), "tau0": t, "tau1": t})
    r = run(gipdyn_bin, "preprocess", "--data", str(tmp_path / "zero.csv"), "--out", str(tmp_path / "out.csv"))
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "has a column 'q0': its joints are counted from 0, gipdyn's from 1" in r.stderr
    assert not (tmp_path / "out.csv").exists()


def test_a_wrapped_angle_is_unwrapped_with_a_warning(tmp_path, gipdyn_bin):
    # numpy.unwrap is the reference: q1 turns at 2 rad/s and is logged within (-pi, pi].
    t = np.arange(2000) * 2e-3
    turning = 2.0 * t + 0.4
    log = tmp_path / "log.csv"
    write_log(log, {"t": t, "q1": np.angle(np.exp(1j * turning)), "q2": 0.2 * np.sin(t), "tau1": np.cos(t),
                    "tau2": np.sin(t)})
    out = tmp_path / "data.csv"
    r = run(gipdyn_bin, "preprocess", "--data", str(log), "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "q1 jumps by more than pi between two rows 1 time(s)" in lines[0], r.stderr
    data = read(out)
    assert np.allclose(data["q1"], np.unwrap(np.angle(np.exp(1j * turning))), atol=1e-12)
    assert np.allclose(data["qd1"][1:-1], 2.0, atol=1e-9)
    report = json.loads((tmp_path / "data.csv.json").read_text())
    assert report["steps"][0] == {"step": "unwrap", "jumps": {"q1": 1}, "rule": report["steps"][0]["rule"]}
