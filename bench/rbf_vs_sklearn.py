#!/usr/bin/env python3
"""gipdyn's RBF GP against scikit-learn's, on the same rows: is our baseline at its optimum?

    PYTHONPATH=build/python /usr/bin/python3 bench/rbf_vs_sklearn.py TRAIN.csv TEST.csv JOINTS \
        [--rows 500] [--restarts 5] [--out table.md]

Both fit, per joint, an ARD RBF times a constant plus white noise with a zero
mean, by maximum marginal likelihood, on the same constant-step subsample of
TRAIN's rows, whose torques are standardised once here (so that both models see
the same targets and their negative log marginal likelihoods compare as they
are). scikit-learn's GaussianProcessRegressor starts from length scales equal to
the columns' standard deviations and restarts --restarts times from random
points; gipdyn runs its default search (`InverseDynamicsGP(model="rbf")`, with
the RBF's own restarts) and the same with --restarts restarts. Prints, per joint, each NLL (lower is
better) and the nMSE on TEST's rows, as a Markdown table (bench/RESULTS.md).
"""
import argparse
import time
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning as SklearnConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

import gipdyn

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("train")
parser.add_argument("test")
parser.add_argument("joints")
parser.add_argument("--rows", type=int, default=500, help="training rows, a constant-step subsample (default 500)")
parser.add_argument("--restarts", type=int, default=5, help="restarts of both searches (default 5)")
parser.add_argument("--out", help="also write the table to this file")
args = parser.parse_args()

train, test = gipdyn.read_log(args.train, args.joints), gipdyn.read_log(args.test, args.joints)
rows = (np.arange(args.rows) * len(train["X"])) // args.rows if args.rows < len(train["X"]) else np.arange(len(train["X"]))
X, Y = train["X"][rows], train["tau"][rows]
offset, scale = Y.mean(axis=0), Y.std(axis=0)
Ys = (Y - offset) / scale


def nmse(pred_scaled, j):
    truth = test["tau"][:, j]
    return float(np.mean((pred_scaled * scale[j] + offset[j] - truth) ** 2) / np.var(truth))


def ours(restarts):
    t0 = time.time()
    est = gipdyn.InverseDynamicsGP(joints=args.joints, model="rbf", teacher="none", scaling="none",
                                   restarts=restarts, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est.fit(X, Ys)
    pred = est.predict(test["X"])
    return ([r["nll"] for r in est.training_report_], [nmse(pred[:, j], j) for j in range(Ys.shape[1])],
            time.time() - t0)


def reference(j):
    kernel = (ConstantKernel(1.0, (1e-5, 1e5)) * RBF(np.maximum(X.std(axis=0), 1e-3), (1e-3, 1e5)) +
              WhiteKernel(1e-2, (1e-9, 1e1)))
    gpr = GaussianProcessRegressor(kernel, normalize_y=False, n_restarts_optimizer=args.restarts, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SklearnConvergenceWarning)
        gpr.fit(X, Ys[:, j])
    return -gpr.log_marginal_likelihood_value_, nmse(gpr.predict(test["X"]), j)


default_nll, default_nmse, default_s = ours(None)
restart_nll, restart_nmse, restart_s = ours(args.restarts)
t0 = time.time()
ref = [reference(j) for j in range(Ys.shape[1])]
ref_s = time.time() - t0
lines = [f"{args.train}: {len(rows)} training rows, {len(test['X'])} test rows, joints {args.joints}; "
         f"fit seconds: gipdyn's default {default_s:.0f} (restarts {args.restarts}: {restart_s:.0f}), "
         f"scikit-learn {ref_s:.0f}", "",
         f"| joint | NLL gipdyn | NLL gipdyn, {args.restarts} restarts | NLL scikit-learn, {args.restarts} restarts "
         f"| test nMSE gipdyn | test nMSE gipdyn, restarts | test nMSE scikit-learn |",
         "|---|---|---|---|---|---|---|"]
for j, (ref_nll, ref_nmse) in enumerate(ref):
    lines.append(f"| {j + 1} | {default_nll[j]:.1f} | {restart_nll[j]:.1f} | {ref_nll:.1f} | {default_nmse[j]:.3g} | "
                 f"{restart_nmse[j]:.3g} | {ref_nmse:.3g} |")
lines.append(f"| mean | | | | {np.mean(default_nmse):.3g} | {np.mean(restart_nmse):.3g} | "
             f"{np.mean([r[1] for r in ref]):.3g} |")
print("\n".join(lines))
if args.out:
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
