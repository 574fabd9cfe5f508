# PNG plots of gipdyn's experiment and evaluation outputs. Embedded in the
# gipdyn executable and run with Debian's /usr/bin/python3 (matplotlib):
#   python3 - KIND INPUT... OUTPUT.png
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def number(s):
    try:
        return float(s)
    except ValueError:
        return math.nan


def ordered(values):
    seen = []
    for v in values:
        if v not in seen:
            seen.append(v)
    return seen


def boxplot(nmse_csv, out):
    rows = read_rows(nmse_csv)
    estimators = ordered(r["estimator"] for r in rows)
    joints = sorted({int(r["joint"]) for r in rows})
    fig, axes = plt.subplots(1, len(joints), figsize=(3.2 * len(joints), 4), squeeze=False)
    for ax, j in zip(axes[0], joints):
        data = []
        for e in estimators:
            v = [number(r["nmse"]) for r in rows if r["estimator"] == e and int(r["joint"]) == j]
            data.append([x for x in v if math.isfinite(x) and x > 0] or [math.nan])
        ax.boxplot(data, labels=estimators, whis=(0, 100) if len(data[0]) < 5 else 1.5)
        ax.set_yscale("log")
        ax.set_title("joint %d" % j)
        ax.axhline(0.01, color="grey", lw=0.8, ls="--")
        ax.tick_params(axis="x", rotation=45)
    axes[0][0].set_ylabel("test nMSE (log scale)")
    fig.suptitle("nMSE per estimator (%d runs; dashed: 1 %%)" % len({r["run"] for r in rows}))
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def gmse(gmse_csv, out):
    rows = read_rows(gmse_csv)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for e in ordered(r["estimator"] for r in rows):
        sizes = sorted({int(r["size"]) for r in rows if r["estimator"] == e})
        med = []
        for s in sizes:
            v = sorted(number(r["gmse"]) for r in rows if r["estimator"] == e and int(r["size"]) == s)
            med.append(v[len(v) // 2])
        ax.plot(sizes, med, marker="o", label=e)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("training samples")
    ax.set_ylabel("test GMSE")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def bars(nmse_csv, out):
    rows = read_rows(nmse_csv)
    estimators = ordered(r["estimator"] for r in rows)
    joints = sorted({int(r["joint"]) for r in rows})
    width = 0.8 / max(1, len(estimators))
    fig, ax = plt.subplots(figsize=(1.2 + 1.1 * len(joints) * max(1, len(estimators)) / 3, 4.5))
    for k, e in enumerate(estimators):
        v = []
        for j in joints:
            m = [number(r["nmse"]) for r in rows if r["estimator"] == e and int(r["joint"]) == j]
            v.append(m[0] if m else math.nan)
        ax.bar([j + (k - (len(estimators) - 1) / 2) * width for j in joints], v, width, label=e)
    ax.set_yscale("log")
    ax.axhline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xticks(joints)
    ax.set_xlabel("joint")
    ax.set_ylabel("test nMSE (log scale; dashed: predicting the mean)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def timeseries(predictions_csv, out):
    """Columns: row, tau1..taun (measured), then EST_tau1..EST_taun per estimator."""
    rows = read_rows(predictions_csv)
    cols = list(rows[0].keys())
    measured = [c for c in cols if c.startswith("tau")]
    estimators = ordered(c.rsplit("_tau", 1)[0] for c in cols if "_tau" in c)
    t = [number(r["row"]) for r in rows]
    fig, axes = plt.subplots(len(measured), 1, figsize=(10, 2.2 * len(measured)), sharex=True, squeeze=False)
    for ax, m in zip(axes[:, 0], measured):
        ax.plot(t, [number(r[m]) for r in rows], color="black", lw=1.4, label="measured")
        for e in estimators:
            ax.plot(t, [number(r[e + "_" + m]) for r in rows], lw=0.9, label=e)
        ax.set_ylabel(m)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=len(estimators) + 1, loc="upper right")
    axes[-1, 0].set_xlabel("data row")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def residuals(predictions_csv, out):
    """Columns: tau1..taun (target) and tau1_hat..taun_hat: one residual histogram per joint."""
    rows = read_rows(predictions_csv)
    joints = [c for c in rows[0].keys() if c.startswith("tau") and not c.endswith("_hat")]
    fig, axes = plt.subplots(1, len(joints), figsize=(3 * len(joints), 3), squeeze=False)
    for ax, c in zip(axes[0], joints):
        r = [number(row[c]) - number(row[c + "_hat"]) for row in rows]
        ax.hist([x for x in r if math.isfinite(x)], bins=50, color="tab:blue")
        ax.set_title(c + " residual")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def motion(motion_csv, out):
    """Columns q1..qn (the true robot) and q1_model..qn_model (the learned robot
    driven by the same torques): positions and their difference over time."""
    rows = read_rows(motion_csv)
    cols = list(rows[0].keys())
    joints = [c for c in cols if c.startswith("q") and c[1:].isdigit() and c + "_model" in cols]
    t = list(range(len(rows)))
    fig, axes = plt.subplots(len(joints), 2, figsize=(11, 2.0 * len(joints)), sharex=True, squeeze=False)
    for (left, right), q in zip(axes, joints):
        true = [number(r[q]) for r in rows]
        model = [number(r[q + "_model"]) for r in rows]
        left.plot(t, true, color="black", lw=1.3, label="true robot")
        left.plot(t, model, color="tab:orange", lw=0.9, label="learned model")
        left.set_ylabel(q)
        right.plot(t, [m - x for m, x in zip(model, true)], color="tab:red", lw=0.9)
        right.set_ylabel(q + " error")
        for ax in (left, right):
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[0, 0].set_title("positions under the same torques")
    axes[0, 1].set_title("learned - true")
    axes[-1, 0].set_xlabel("sample")
    axes[-1, 1].set_xlabel("sample")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def tracking(errors_csv, out):
    """Columns t, then CONTROLLER_e1..CONTROLLER_en per controller: the position
    error of each controller over time, one panel per joint (symlog scale)."""
    rows = read_rows(errors_csv)
    cols = [c for c in rows[0].keys() if c != "t"]
    controllers = ordered(c.rsplit("_e", 1)[0] for c in cols)
    n = len(cols) // len(controllers)
    t = [number(r["t"]) for r in rows]
    fig, axes = plt.subplots(n, 1, figsize=(10, 2.0 * n), sharex=True, squeeze=False)
    for j, ax in enumerate(axes[:, 0]):
        for c in controllers:
            ax.plot(t, [number(r[f"{c}_e{j + 1}"]) for r in rows], lw=0.9, label=c)
        ax.set_yscale("symlog", linthresh=1e-5)
        ax.set_ylabel(f"joint {j + 1} error")
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=min(len(controllers), 4), loc="upper right")
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def noise_ratio(json_path, out):
    import json

    with open(json_path) as f:
        d = json.load(f)
    # null where a joint's training torque is constant (no variance to compare the noise with)
    ratios = [math.nan if r is None else r for r in d["noise_ratio"]]
    fig, ax = plt.subplots(figsize=(1.5 + 0.6 * len(ratios), 3.5))
    ax.bar(range(1, len(ratios) + 1), ratios)
    for j, r in enumerate(ratios, start=1):
        if not math.isfinite(r):
            ax.text(j, 0.02, "n/a", ha="center", fontsize=8)
    ax.set_ylim(0, 1)
    ax.set_xlabel("joint")
    ax.set_ylabel("learned noise variance / output variance")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def physics(physics_csv, out):
    """Columns g1..gn, g1_true..gn_true, M1_1..Mn_n, M1_1_true..: estimated against true, per joint's
    gravity and for every entry of M."""
    rows = read_rows(physics_csv)
    cols = list(rows[0].keys())
    n = sum(1 for c in cols if c.startswith("g") and not c.endswith("_true"))
    fig, axes = plt.subplots(1, n + 1, figsize=(3 * (n + 1), 3.2), squeeze=False)

    def scatter(ax, pairs, title):
        t = [number(r[c + "_true"]) for r in rows for c in pairs]
        e = [number(r[c]) for r in rows for c in pairs]
        ax.plot(t, e, ".", ms=3)
        finite = [v for v in t + e if math.isfinite(v)] or [0.0]
        lo, hi = min(finite), max(finite)
        ax.plot([lo, hi], [lo, hi], color="grey", lw=0.8)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("true")
    for i in range(n):
        scatter(axes[0][i], ["g%d" % (i + 1)], "gravity, joint %d" % (i + 1))
    scatter(axes[0][n], [c for c in cols if c.startswith("M") and not c.endswith("_true")], "inertia matrix entries")
    axes[0][0].set_ylabel("estimated")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def learning_curve(curve_csv, out):
    """Columns estimator, size, repeat, joint, nmse: median nMSE against training rows per joint and
    for the mean over joints, bars from the smallest to the largest repeat."""
    rows = read_rows(curve_csv)
    estimators = ordered(r["estimator"] for r in rows)
    joints = sorted({int(r["joint"]) for r in rows})
    panels = [0] + joints
    cols = min(4, len(panels))
    nrows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(3.6 * cols, 3.0 * nrows), squeeze=False)
    for k, j in enumerate(panels):
        ax = axes[k // cols][k % cols]
        for e in estimators:
            sizes = sorted({int(r["size"]) for r in rows if r["estimator"] == e})
            med, lo, hi = [], [], []
            for s in sizes:
                per_repeat = {}
                for r in rows:
                    if r["estimator"] == e and int(r["size"]) == s and (j == 0 or int(r["joint"]) == j):
                        per_repeat.setdefault(r["repeat"], []).append(number(r["nmse"]))
                v = sorted(sum(x) / len(x) for x in per_repeat.values() if all(math.isfinite(y) for y in x))
                med.append((v[(len(v) - 1) // 2] + v[len(v) // 2]) / 2 if v else math.nan)
                lo.append(v[0] if v else math.nan)
                hi.append(v[-1] if v else math.nan)
            err = [[max(m - a, 0) for m, a in zip(med, lo)], [max(b - m, 0) for m, b in zip(med, hi)]]
            ax.errorbar(sizes, med, yerr=err, marker="o", ms=3, capsize=2, label=e)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.axhline(1.0, color="grey", lw=0.8, ls="--")
        ax.set_title("mean over joints" if j == 0 else "joint %d" % j, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if k % cols == 0:
            ax.set_ylabel("test nMSE")
        if k // cols == nrows - 1:
            ax.set_xlabel("training rows")
    for k in range(len(panels), nrows * cols):
        axes[k // cols][k % cols].axis("off")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("learning curve (median over subsamples, bars: min-max; dashed: predicting the mean)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def consistency(json_path, out):
    import json

    with open(json_path) as f:
        d = json.load(f)
    parts = [(key, label) for key, label in (("within_training", "within training"), ("within_test", "within test"),
                                              ("training_to_test", "training -> test")) if key in d]
    joints = len(d[parts[0][0]]["neighbour_nmse"])
    width = 0.8 / len(parts)
    fig, ax = plt.subplots(figsize=(2.0 + 0.9 * joints, 4.0))
    for k, (key, label) in enumerate(parts):
        v = [math.nan if x is None else x for x in d[key]["neighbour_nmse"]]
        ax.bar([j + 1 + (k - (len(parts) - 1) / 2) * width for j in range(joints)], v, width, label=label)
    ax.axhline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xticks(range(1, joints + 1))
    ax.set_xlabel("joint")
    ax.set_ylabel("neighbour nMSE (dashed: predicting the mean)")
    ax.set_title("torque at revisited states (radius %g, inputs %s)" % (d["radius"], d["inputs"]), fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def contacts(contacts_csv, out):
    """Columns t, ext1..n, contact1..n, threshold1..n and, where known,
    ext1_true..n_true (`gipdyn detect`): per joint, the estimated external
    torque inside its threshold band, flagged rows shaded, the truth dashed."""
    rows = read_rows(contacts_csv)
    cols = list(rows[0].keys())
    joints = [c[3:] for c in cols if c.startswith("ext") and c[3:].isdigit()]
    t = [number(r["t"]) for r in rows]
    fig, axes = plt.subplots(len(joints), 1, figsize=(10, 2.0 * len(joints)), sharex=True, squeeze=False)
    for ax, j in zip(axes[:, 0], joints):
        limit = [number(r["threshold" + j]) for r in rows]
        ax.fill_between(t, [-x for x in limit], limit, color="0.85", lw=0, label="threshold band")
        flagged = [number(r["contact" + j]) > 0 for r in rows]
        start = None
        for k, on in enumerate(flagged + [False]):
            if on and start is None:
                start = k
            elif not on and start is not None:
                ax.axvspan(t[start], t[min(k, len(t) - 1)], color="tab:red", alpha=0.25, lw=0)
                start = None
        if "ext" + j + "_true" in cols:
            ax.plot(t, [number(r["ext" + j + "_true"]) for r in rows], color="black", ls="--", lw=1.0,
                    label="true external torque")
        ax.plot(t, [number(r["ext" + j]) for r in rows], color="tab:blue", lw=0.8, label="estimated")
        ax.set_ylabel("joint " + j)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right", ncol=3)
    axes[0, 0].set_title("external torque (shaded: contact flagged)")
    axes[-1, 0].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


KINDS = {"contacts": contacts, "boxplot": boxplot, "gmse": gmse, "bars": bars, "timeseries": timeseries,
         "residuals": residuals, "noise-ratio": noise_ratio, "motion": motion,
         "tracking": tracking, "physics": physics, "learning_curve": learning_curve,
         "consistency": consistency}

if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in KINDS:
        sys.exit("usage: plots.py {%s} INPUT OUTPUT.png" % ",".join(KINDS))
    KINDS[sys.argv[1]](sys.argv[2], sys.argv[3])
