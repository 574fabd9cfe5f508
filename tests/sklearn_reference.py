#!/usr/bin/env python3
"""Writes a small RBF-GP problem and scikit-learn's answers for it.

Usage: sklearn_reference.py OUTDIR
The C++ test test_sklearn_crosscheck reads OUTDIR and compares gipdyn's
posterior mean, variance and log marginal likelihood with these.
"""
import json
import os
import sys

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

out = sys.argv[1]
os.makedirs(out, exist_ok=True)
rng = np.random.default_rng(7)
D, N, M = 4, 60, 25
X = rng.uniform(-2.0, 2.0, size=(N, D))
y = np.sin(X[:, 0]) * np.cos(X[:, 1]) + 0.3 * X[:, 2] - 0.2 * X[:, 3] ** 2 + 0.05 * rng.standard_normal(N)
Xs = rng.uniform(-2.5, 2.5, size=(M, D))
variance, lengthscales, noise = 1.7, [0.7, 1.3, 2.0, 0.9], 0.05

kernel = ConstantKernel(variance, "fixed") * RBF(lengthscales, "fixed")
gpr = GaussianProcessRegressor(kernel=kernel, alpha=noise, optimizer=None, normalize_y=False)
gpr.fit(X, y)
mean, std = gpr.predict(Xs, return_std=True)

np.savetxt(os.path.join(out, "train.csv"), np.column_stack([X, y]), delimiter=",")
np.savetxt(os.path.join(out, "test.csv"), Xs, delimiter=",")
np.savetxt(os.path.join(out, "expected.csv"), np.column_stack([mean, std ** 2]), delimiter=",")
with open(os.path.join(out, "expected.json"), "w") as f:
    json.dump({"log_marginal_likelihood": float(gpr.log_marginal_likelihood_value_), "variance": variance,
               "lengthscales": lengthscales, "noise": noise}, f)
print(f"wrote scikit-learn reference to {out}")
