#!/usr/bin/env python3
"""The real preset on the real UR10 pick-and-place log (../shared/data/ur10-pick-and-place):
train on data rows 1-6340 (a constant-step subsample), test on rows 6341-12349
(other motions), print per-joint nMSE and plot predicted vs measured torque.
preset="real" is the recommendation for real logs (docs/results/real-robots.md); --model gip
shows plain GIP on the same rows.

    python3 examples/python/ur10_real.py [--data CSV] [--train-rows N] [--model K] [--max-iter N] [--out PNG]
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gipdyn  # noqa: E402

here = os.path.dirname(os.path.abspath(__file__))
default_data = os.path.join(here, "..", "..", "..", "shared", "data", "ur10-pick-and-place", "urPicknPlace.csv")
parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--data", default=default_data)
parser.add_argument("--train-rows", type=int, default=1000, help="training rows kept (constant step)")
parser.add_argument("--model", default=None, help="override the preset's model (gip-envelope+friction), e.g. gip")
parser.add_argument("--max-iter", type=int, default=None, help="safety cap on NLL evaluations per joint (default: the library's)")
parser.add_argument("--out", default="ur10_real.png")
args = parser.parse_args()

if not os.path.exists(args.data):
    raise SystemExit(f"cannot find {args.data}; pass --data PATH/urPicknPlace.csv")
log = gipdyn.read_log(args.data, "RRRRRR")  # the columns q1..q6, qd1.., qdd1.., tau1.. as the CLI reads them
X, Y = log["X"], log["tau"]
train = slice(0, 6340)  # data rows 1-6340 (the reference protocol in data/README.md)
test = slice(6340, len(Y))
step = max(1, 6340 // args.train_rows)
Xtr, Ytr = X[train][::step][: args.train_rows], Y[train][::step][: args.train_rows]

# Before training: at states both recordings visit, do their torques agree? (`gipdyn inspect`)
check = gipdyn.neighbour_consistency(X[train], Y[train], X[test], Y[test])
if check["status"] == "ok":
    print("torque at revisited states, training -> test rows: neighbour nMSE "
          + " ".join(f"{v:.2f}" for v in check["neighbour_nmse"]) + " (1 or more: the test rows follow another function of the state there)")

options = {} if args.max_iter is None else {"max_iter": args.max_iter}
model = gipdyn.InverseDynamicsGP(joints="RRRRRR", preset="real", model=args.model, **options)
model.fit(Xtr, Ytr)
name = model.model_.kernel
pred = model.predict(X[test])
errors = gipdyn.nmse(Y[test], pred)
print(f"UR10 real data, {name}, {len(Ytr)} training rows, {len(pred)} test rows")
for j, e in enumerate(errors, start=1):
    print(f"  joint {j}  nMSE {e:.3f}")

t = np.arange(len(pred)) * 0.008
window = slice(0, min(1500, len(pred)))
fig, axes = plt.subplots(6, 1, figsize=(10, 12), sharex=True)
for j, ax in enumerate(axes):
    ax.plot(t[window], Y[test][window, j], "k-", lw=1, label="measured")
    ax.plot(t[window], pred[window, j], "r-", lw=1, label=f"{name} (nMSE {errors[j]:.2f})")
    ax.set_ylabel(f"tau{j + 1} [N m]")
    ax.legend(loc="upper right", fontsize=8)
axes[-1].set_xlabel("time in test set [s]")
fig.suptitle("UR10 pick-and-place: predicted vs measured torque (test rows 6341-)")
fig.tight_layout()
fig.savefig(args.out, dpi=100)
print(f"wrote {args.out}")
