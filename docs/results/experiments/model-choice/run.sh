#!/bin/bash
# train --model auto against the documented command for each kind of log (docs/results/experiments/model-choice).
#   bash run.sh [gipdyn binary] [shared data folder] [output folder]
set -euo pipefail
G=$(realpath "${1:-build/gipdyn}")
DATA=$(realpath "${2:-../shared/data}")
OUT=${3:-model-choice}
mkdir -p "$OUT" && cd "$OUT"
UR10=$DATA/ur10-pick-and-place/urPicknPlace.csv
SARCOS=$DATA/sarcos-inverse/sarcos_inv_test.csv
split() {  # log first_train last_train prefix: rows are data rows (the header is kept in both files)
  head -1 "$1" > "$4_train.csv" && sed -n "2,$(($3 + 1))p" "$1" >> "$4_train.csv"
  head -1 "$1" > "$4_test.csv" && sed -n "$(($3 + 2)),\$p" "$1" >> "$4_test.csv"
}
split "$UR10" 1 6340 ur
split "$SARCOS" 1 3114 sa
$G simulate --robot ur10 --samples 2000 --seed 1 --out u_train.csv > /dev/null
$G simulate --robot ur10 --samples 2000 --seed 2 --out u_test.csv > /dev/null
timed() {  # name command...: the command's output in NAME.log, its wall time in NAME.time
  local name=$1; shift
  /usr/bin/time -f "%e s" -o "$name.time" "$@" > "$name.log" 2>&1
}
for case in "ur RRRRRR" "sa RRRRRRR"; do
  set -- $case
  timed "$1_auto" $G train --data "$1_train.csv" --joints "$2" --model auto --out "$1_auto.gipdyn"
  timed "$1_real" $G train --data "$1_train.csv" --joints "$2" --preset real --out "$1_real.gipdyn"
  for m in auto real; do $G evaluate --model "$1_$m.gipdyn" --data "$1_test.csv" > "$1_$m.eval" 2>&1; done
done
timed u_auto $G train --data u_train.csv --model auto --out u_auto.gipdyn
timed u_def $G train --data u_train.csv --out u_def.gipdyn
for m in auto def; do $G evaluate --model "u_$m.gipdyn" --data u_test.csv > "u_$m.eval" 2>&1; done
