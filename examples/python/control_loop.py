"""A learned model in a control loop, from Python: the twin of examples/c/control_loop.c.

Loads a model file (or trains a small SCARA model when none is given), queries
the feed-forward torque once per 1 kHz tick along a smooth motion and reports
the latency distribution of those queries (p50, p99, max); gravity and the
inertia diagonal at one state when the model has the rigid-body structure.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/control_loop.py [MODEL] [--calls N]

The Python call adds the interpreter's overhead (a few microseconds) to the
library's query; a 1 kHz loop in Python fits in its budget, a hard real-time
loop belongs in C or C++ (examples/c/control_loop.c).
"""
import argparse
import time

import numpy as np

import gipdyn


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", nargs="?", help="a gipdyn model file (default: train a small SCARA model)")
    parser.add_argument("--calls", type=int, default=100000, help="number of torque queries (default 100000)")
    args = parser.parse_args()
    if args.calls < 1:
        parser.error("--calls must be at least 1")

    if args.model:
        model = gipdyn.InverseDynamicsGP.load(args.model)
    else:
        train = gipdyn.simulate("scara", samples=300, seed=1, dt=0.05)
        model = gipdyn.InverseDynamicsGP(joints="RRPR").fit(train["X"], train["tau"])
    n = len(model.joints)

    latency = np.empty(args.calls)
    checksum = 0.0
    x = np.empty(3 * n)
    w = 0.5 + 0.1 * np.arange(n)
    for k in range(args.calls):
        t = 0.001 * k  # 1 kHz ticks
        x[:n] = 0.5 * np.sin(w * t + np.arange(n))
        x[n:2 * n] = 0.5 * w * np.cos(w * t + np.arange(n))
        x[2 * n:] = -0.5 * w * w * np.sin(w * t + np.arange(n))
        start = time.perf_counter_ns()
        tau = model.predict_one(x)
        latency[k] = time.perf_counter_ns() - start
        checksum += tau[0]
    p50, p99 = np.percentile(latency, [50, 99]) / 1e3
    print(f"{args.calls} torque queries, {n} joints: p50 {p50:.1f} us, p99 {p99:.1f} us, "
          f"max {latency.max() / 1e3:.1f} us (checksum {checksum:.6g})")

    try:
        q = np.full((1, n), 0.3)
        g, M = model.gravity(q)[0], model.inertia(q)[0]
        print("gravity at q = 0.3:", " ".join(f"{v:.4g}" for v in g))
        print("inertia diagonal at q = 0.3:", " ".join(f"{v:.4g}" for v in np.diag(M)))
    except ValueError as e:  # a model without rigid-body structure (rbf, gip-envelope, ...)
        print(f"no physics from this model: {e}")


if __name__ == "__main__":
    main()
