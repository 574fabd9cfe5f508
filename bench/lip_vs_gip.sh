#!/usr/bin/env bash
# LIP against GIP at equal training sizes on simulated robots: test nMSE per
# joint, gravity and inertia against the robot's (relative errors on the test
# states), training time and LIP's (N n)^2 system. Writes a table to stdout.
#   bash bench/lip_vs_gip.sh [build dir] [robot:joints:sizes ...]
# Default: scara at 150, 300, 600 rows and ur10 at 150, 300 (about 25 min on 2 cores).
set -euo pipefail
BUILD=${1:-build}
shift || true
G=$(realpath "$BUILD")/gipdyn
CASES=("$@")
[ ${#CASES[@]} -eq 0 ] && CASES=(scara:RRPR:150,300,600 ur10:RRRRRR:150,300)
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
printf '| robot | rows | estimator | system | train s | NLL evals | nMSE per joint | mean nMSE | g error | M error |\n|---|---|---|---|---|---|---|---|---|---|\n'
for case in "${CASES[@]}"; do
  IFS=: read -r robot joints sizes <<<"$case"
  n=${#joints}
  "$G" simulate --robot "$robot" --samples 2000 --seed 11 --out "$WORK/train.csv" --quiet
  "$G" simulate --robot "$robot" --samples 500 --seed 12 --noise 0 --out "$WORK/test.csv" --quiet
  for rows in ${sizes//,/ }; do
    for est in lip gip; do
      start=$(date +%s.%N)
      "$G" train --data "$WORK/train.csv" --joints "$joints" --model "$est" --teacher none --subsample "$rows" \
        --out "$WORK/m.gipdyn" >"$WORK/train.log" 2>&1
      secs=$(echo "$(date +%s.%N) - $start" | bc)
      evals=$(awk '$1 ~ /^[0-9]+$/ && $2 != "" {s += $4} END {print s}' "$WORK/train.log")
      [ "$est" = lip ] && evals=$(awk '$1 == "1" && $3 ~ /^-?[0-9.]+$/ {print $4; exit}' "$WORK/train.log")
      "$G" evaluate --model "$WORK/m.gipdyn" --data "$WORK/test.csv" --physics "$robot" --json "$WORK/e.json" \
        >"$WORK/eval.log" 2>&1
      physics=$(/usr/bin/python3 -c 'import json, sys; e = json.load(open(sys.argv[1]))["physics_relative_error"]
print("%.2g | %.2g" % (e["gravity"], e["inertia"]))' "$WORK/e.json")
      nmse=$(awk 'NR > 2 && $1 ~ /^[0-9]+$/ && NF == 3 {printf "%s%.2g", (c++ ? ", " : ""), $3}' "$WORK/eval.log")
      mean=$(awk '/mean nMSE/ {print $NF}' "$WORK/eval.log")
      system=$([ "$est" = lip ] && echo "$((rows * n))^2" || echo "$n x ${rows}^2")
      printf '| %s | %s | %s | %s | %.0f | %s | %s | %.3g | %s |\n' "$robot" "$rows" "$est" "$system" "$secs" "$evals" \
        "$nmse" "$mean" "$physics"
    done
  done
done
