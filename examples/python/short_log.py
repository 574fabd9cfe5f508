#!/usr/bin/env python3
"""One short log: LIP for accuracy, and a fast GIP model that learns from LIP.

On one 20 s motion, GIP's own marginal-likelihood optimum picks monomials the
robot does not have and extrapolates badly to a new motion; LIP, whose torques
come from two shared energies, does not (docs/results/training.md, "What one 20 s
motion lacks"). A LIP query takes microseconds on a SCARA (weight space,
docs/method.md section 11) but a quarter of a millisecond on a 6R arm. This
example trains GIP on one short simulated SCARA log, then GIP taught by LIP
(teacher="lip"): LIP is fitted on the log and GIP learns from LIP's torques at
states drawn uniformly from the log's box (q, qd, qdd per joint): a GIP model,
microseconds a query, that extrapolates like LIP. The teacher is kept as
teacher_ and compared too. `gipdyn train --teacher lip` does the same. The
recipe is for a short, clean log: on a real robot's log the drawn states are
mostly extrapolation for LIP and its labels are noisy, and the taught model is
far worse than GIP (docs/results/real-robots.md); use preset="real" there.

    python3 examples/python/short_log.py [SAMPLES] [HYPERPARAMETER_ROWS] [VIRTUAL] [MAX_ITER]

Defaults 2000, 300, 2000 and the library's cap: about 1.5 minutes on 2 cores
(GIP on the log 51 s, GIP taught by LIP 35 s with LIP's starts side by side,
on the idle AMD EPYC machine of bench/RESULTS.md).
VIRTUAL is the number of drawn states (teacher_states).
"""
import sys
import time
import warnings

import numpy as np

import gipdyn

samples = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
hyperparameter_rows = int(sys.argv[2]) if len(sys.argv) > 2 else 300
virtual = int(sys.argv[3]) if len(sys.argv) > 3 else 2000
max_iter = int(sys.argv[4]) if len(sys.argv) > 4 else gipdyn.SearchSettings().optimizer.max_iterations
if max_iter < gipdyn.SearchSettings().optimizer.max_iterations:
    warnings.simplefilter("ignore", gipdyn.ConvergenceWarning)  # a short smoke run stops at its cap

# One 20 s motion at 100 Hz to learn from, another to test on.
train = gipdyn.simulate("scara", samples=samples, seed=1)
test = gipdyn.simulate("scara", samples=samples, seed=2)


def fitted(name, model, X, Y):
    start = time.perf_counter()
    model.fit(X, Y)
    print(f"{name}: trained in {time.perf_counter() - start:.0f} s")
    return model


def p50_query_us(model, X):
    times = []
    for x in X[:200]:
        start = time.perf_counter()
        model.predict_one(x)
        times.append(time.perf_counter() - start)
    return 1e6 * float(np.median(times))


gip = fitted("GIP on the log", gipdyn.InverseDynamicsGP(joints="RRPR", max_iter=max_iter, teacher="none"), train["X"], train["tau"])
taught = fitted(f"GIP taught by LIP (LIP's hyperparameters on {hyperparameter_rows} rows, {virtual} drawn states)",
                gipdyn.InverseDynamicsGP(joints="RRPR", max_iter=max_iter, teacher="lip", teacher_states=virtual,
                                         teacher_hyperparameter_rows=hyperparameter_rows),
                train["X"], train["tau"])
lip = taught.teacher_
print("label noise (LIP's RMS residual on the log), per joint:", " ".join(f"{s:.3g}" for s in taught.label_noise_std_))

print("\nnMSE on a new 20 s motion (noise-free torque), and one query's p50 on one core:")
for name, model in (("GIP on the log", gip), ("LIP", lip), ("GIP taught by LIP", taught)):
    errors = " ".join(f"{e:9.2e}" for e in model.nmse(test["X"], test["tau_true"]))
    print(f"  {name:18s} joints 1-4: {errors}   p50 {p50_query_us(model, test['X']):8.1f} us")
