#!/usr/bin/env python3
"""Our RBF GP's NLL per joint under restarts of several spreads, on the rows bench/rbf_vs_sklearn.py fits.

    PYTHONPATH=build/python /usr/bin/python3 bench/rbf_restart_spread.py TRAIN.csv JOINTS \
        [--rows 500] [--searches 1:0,1:5,2:5,3:5,2:5:0]

Each search SPREAD:RESTARTS[:SCREENING] fits, per joint, the ARD RBF plus white noise on the same constant-step
subsample of TRAIN's rows with standardised torques (as bench/rbf_vs_sklearn.py, so that the NLLs compare
with its scikit-learn column), RESTARTS restarts drawn from N(start, SPREAD^2) in log space
(SearchSettings::restart_spread), every start screened at SCREENING evaluations
(SearchSettings::start_screening_evaluations; 0: every start runs to convergence; default: the library's).
Prints one line per search: each joint's NLL (lower is better) and the time.
"""
import argparse
import time
import warnings

import numpy as np

import gipdyn
from gipdyn import _core

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("train")
parser.add_argument("joints")
parser.add_argument("--rows", type=int, default=500, help="training rows, a constant-step subsample (default 500)")
parser.add_argument("--searches", default="1:0,1:5,2:5,3:5", help="SPREAD:RESTARTS[:SCREENING], comma-separated")
args = parser.parse_args()

train = gipdyn.read_log(args.train, args.joints)
n = len(train["X"])
rows = (np.arange(args.rows) * n) // args.rows if args.rows < n else np.arange(n)
X, Y = np.asfortranarray(train["X"][rows]), train["tau"][rows]
Ys = np.asfortranarray((Y - Y.mean(axis=0)) / Y.std(axis=0))
for search in args.searches.split(","):
    fields = search.split(":")
    spread, restarts = float(fields[0]), int(fields[1])
    est = gipdyn.InverseDynamicsGP(joints=args.joints, model="rbf", teacher="none", scaling="none",
                                   restarts=restarts, random_state=0, n_jobs=1)
    options = est.estimator_options()
    options.search.restart_spread = spread
    if len(fields) > 2:
        options.search.start_screening_evaluations = int(fields[2])
    start = time.time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = _core.fit(X, Ys, args.joints, options, None, False)
    nll = [r["nll"] for r in fit["model"].training_report]
    screening = f", screening {fields[2]}" if len(fields) > 2 else ""
    print(f"spread {spread:g}, {restarts} restarts{screening}: NLL " + ", ".join(f"{v:.1f}" for v in nll) +
          f" ({time.time() - start:.0f} s)", flush=True)
