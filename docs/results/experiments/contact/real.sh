#!/bin/bash
# False alarms of `gipdyn detect` on the shared real logs, which have no contacts (docs/results/experiments/contact).
#   bash real.sh [gipdyn binary] [shared data folder] [output folder]
# Each log is split by time: the model (train --preset real) learns the first part, detect is calibrated on
# the first half of the rest and counts alarms on its second half, where every alarm is a false one.
set -euo pipefail
G=$(realpath "${1:-build/gipdyn}")
DATA=$(realpath "${2:-../shared/data}")
OUT=${3:-contact-real}
mkdir -p "$OUT" && cd "$OUT"
rows() {  # log first last out: data rows first..last (1-based) under the log's header
  head -1 "$1" > "$4" && sed -n "$(($2 + 1)),$(($3 + 1))p" "$1" >> "$4"
}
# UR10: the reference split (train 1-6340); the test rows' first half calibrates, the second is scored.
UR10=$DATA/ur10-pick-and-place/urPicknPlace.csv
rows "$UR10" 1 6340 ur_train.csv && rows "$UR10" 6341 9344 ur_calibration.csv && rows "$UR10" 9345 12349 ur_free.csv
# SARCOS: every tenth row of its recording, so consecutive rows are 10 samples apart; train on rows 1-3114.
SARCOS=$DATA/sarcos-inverse/sarcos_inv_test.csv
rows "$SARCOS" 1 3114 sa_train.csv && rows "$SARCOS" 3115 3782 sa_calibration.csv && rows "$SARCOS" 3783 4449 sa_free.csv
# --dt: UR10 logs at 8 ms; SARCOS's period is not recorded, and the residual method needs it only to turn
# --min-duration into rows (here one row for both).
for case in "ur RRRRRR 0.008" "sa RRRRRRR 0.008"; do
  set -- $case
  [ -f "$1.gipdyn" ] || $G train --data "$1_train.csv" --joints "$2" --preset real --quiet --out "$1.gipdyn"
  for sigma in model noise; do
    extra=(); [ "$sigma" = noise ] && extra=(--noise-only)
    for rate in 1e-6 1e-3; do
      # sigma from the model's predictive standard deviation and the noise it learned (model), or from the
      # noise measured on the calibration rows alone (noise).
      $G detect --model "$1.gipdyn" --data "$1_free.csv" --dt "$3" --false-alarm-rate "$rate" "${extra[@]}" \
        --calibration "$1_calibration.csv" --quiet --out "$1_${sigma}_$rate.csv"
    done
  done
done
# Alarms (rises of a joint's contact flag) against what the requested rate allows: at most rate x rows x joints.
/usr/bin/python3 - "$PWD" <<'PY'
import csv, glob, os, sys
os.chdir(sys.argv[1])
print("| log | sigma | requested rate | alarms per joint | alarms | at most expected | rows flagged |")
print("|---|---|---|---|---|---|---|")
for path in sorted(glob.glob("*_*_1e-*.csv")):
    log, sigma, rate = os.path.basename(path)[:-4].split("_")
    rows = list(csv.DictReader(open(path)))
    joints = sorted(int(k[len("contact"):]) for k in rows[0] if k.startswith("contact"))
    alarms, flagged = [], 0
    for j in joints:
        flags = [r[f"contact{j}"] == "1" for r in rows]
        alarms.append(sum(1 for a, b in zip([False] + flags, flags) if b and not a))
        flagged += sum(flags)
    cells = len(rows) * len(joints)
    print(f"| {log}, {len(rows)} rows | {sigma} | {rate} | {' '.join(map(str, alarms))} | {sum(alarms)} | "
          f"{float(rate) * cells:.3g} | {flagged / cells:.3%} |")
PY
