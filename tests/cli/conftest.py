import json
import os
import shutil
import struct

import numpy as np
import pytest


def two_link_torques(q, qd, qdd):
    """The 2R arm of tests/test_util.hpp, written again for the CLI tests."""
    m1, m2, l1, lc1, lc2, I1, I2, g = 1.0, 0.8, 0.5, 0.25, 0.2, 0.02, 0.015, 9.81
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    M11 = m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + I1 + I2
    M12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2
    M22 = m2 * lc2**2 + I2
    h = -m2 * l1 * lc2 * s2
    g1 = (m1 * lc1 + m2 * l1) * g * np.cos(q[:, 0]) + m2 * lc2 * g * np.cos(q[:, 0] + q[:, 1])
    g2 = m2 * lc2 * g * np.cos(q[:, 0] + q[:, 1])
    t1 = M11 * qdd[:, 0] + M12 * qdd[:, 1] + h * qd[:, 1] ** 2 + 2 * h * qd[:, 0] * qd[:, 1] + g1
    t2 = M12 * qdd[:, 0] + M22 * qdd[:, 1] - h * qd[:, 0] ** 2 + g2
    return np.stack([t1, t2], 1)


def model_header(path):
    """The JSON header of a model file: magic (8 bytes), format version and reserved (u32 each), the header's length
    (u64, little-endian), then the header (docs/model-format.md). Searching for the first "{" instead failed whenever
    the length held the byte 0x7b: the header holds fit times, so its length varies from run to run."""
    raw = path.read_bytes()
    assert raw[:8] == b"GIPDYNMF", path
    (length,) = struct.unpack("<Q", raw[16:24])
    return json.loads(raw[24:24 + length].decode("utf-8"))


def write_dataset(path, rows, seed, noise=0.01, shuffle_columns=False):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (rows, 2))
    qd = rng.uniform(-2, 2, (rows, 2))
    qdd = rng.uniform(-3, 3, (rows, 2))
    tau_true = two_link_torques(q, qd, qdd)
    tau = tau_true + noise * rng.standard_normal(tau_true.shape)
    names = ["q1", "q2", "qd1", "qd2", "qdd1", "qdd2", "tau1", "tau2", "tau1_true", "tau2_true"]
    data = np.column_stack([q, qd, qdd, tau, tau_true])
    order = list(range(len(names)))
    if shuffle_columns:
        order = order[::-1]
    with open(path, "w") as f:
        f.write("time," + ",".join(names[k] for k in order) + "\n")
        for r in range(rows):
            f.write(f"{r * 0.008:.3f}," + ",".join(repr(float(data[r, k])) for k in order) + "\n")
    return data


@pytest.fixture(scope="session")
def gipdyn_bin():
    path = os.environ.get("GIPDYN_BIN") or shutil.which("gipdyn")
    if not path:
        pytest.fail("set GIPDYN_BIN to the gipdyn executable (ctest does)")
    return path
