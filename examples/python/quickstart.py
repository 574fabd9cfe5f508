#!/usr/bin/env python3
"""Quickstart (Python): simulate a SCARA, train a GIP model, report the nMSE and
predict one sample. Its C++ twin is examples/cpp/quickstart.cpp.

    python3 examples/python/quickstart.py [SAMPLES] [MAX_ITER]
"""
import sys

import gipdyn

samples = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
max_iter = int(sys.argv[2]) if len(sys.argv) > 2 else gipdyn.SearchSettings().optimizer.max_iterations

train = gipdyn.simulate("scara", samples=samples, seed=1)
test = gipdyn.simulate("scara", samples=samples, seed=2)

model = gipdyn.InverseDynamicsGP(joints="RRPR", model="gip", max_iter=max_iter)
model.fit(train["X"], train["tau"])

print(f"GIP on a simulated SCARA, {samples} training samples")
for j, e in enumerate(model.nmse(test["X"], test["tau_true"]), start=1):
    print(f"  joint {j}  nMSE {e:.3g}")

tau = model.predict_one(test["X"][0])
print("one sample: predicted tau =", tau.round(4), " true =", test["tau_true"][0].round(4))
