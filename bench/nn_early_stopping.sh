#!/usr/bin/env bash
# The network baseline with and without early stopping, on several logs: test
# nMSE per joint, the mean, the epochs run and kept, and the training time.
# Each case trains on a constant-step subsample of ROWS rows of TRAIN (the
# subsample keeps the time order, so the held-out rows are stretches of the
# motion) and is tested on TEST. Writes a Markdown table to stdout.
#   bash bench/nn_early_stopping.sh [build dir] [name:TRAIN:TEST:JOINTS:ROWS ...]
# Default: simulated SCARA and UR10 motions of 2000 rows at dt 0.1 s (new
# motions as tests). Each setting is a line of SETTINGS below (about 2 min a
# fit on one core at 2000 rows of a 6-joint arm).
set -euo pipefail
BUILD=${1:-build}
shift || true
G=$(realpath "$BUILD")/gipdyn
CASES=("$@")
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
if [ ${#CASES[@]} -eq 0 ]; then
  for robot in scara:RRPR ur10:RRRRRR; do
    IFS=: read -r name joints <<<"$robot"
    "$G" simulate --robot "$name" --samples 2000 --dt 0.1 --seed 11 --out "$WORK/$name-train.csv" --quiet
    "$G" simulate --robot "$name" --samples 1000 --dt 0.1 --seed 12 --noise 0 --out "$WORK/$name-test.csv" --quiet
    CASES+=("$name:$WORK/$name-train.csv:$WORK/$name-test.csv:$joints:2000")
  done
fi
# label|options
SETTINGS=(
  "every row, 300 epochs|--nn-validation 0"
  "early stopping (default)|"
)
SEEDS=${SEEDS:-"0 1"}
printf '| log | rows | training | seed | nMSE per joint | mean nMSE | epochs run (kept) | train s |\n|---|---|---|---|---|---|---|---|\n'
for case in "${CASES[@]}"; do
  IFS=: read -r name train test joints rows <<<"$case"
  for setting in "${SETTINGS[@]}"; do
    label=${setting%%|*}
    opts=${setting#*|}
    for seed in $SEEDS; do
      start=$(date +%s.%N)
      # shellcheck disable=SC2086
      "$G" train --data "$train" --joints "$joints" --model nn --subsample "$rows" --seed "$seed" $opts \
        --out "$WORK/m.gipdyn" >"$WORK/train.log" 2>&1
      secs=$(echo "$(date +%s.%N) - $start" | bc)
      "$G" evaluate --model "$WORK/m.gipdyn" --data "$test" >"$WORK/eval.log" 2>&1
      nmse=$(awk 'NR > 2 && $1 ~ /^[0-9]+$/ && NF == 3 {printf "%s%.2g", (c++ ? ", " : ""), $3}' "$WORK/eval.log")
      mean=$(awk '/mean nMSE/ {print $NF}' "$WORK/eval.log")
      # The fit's report line: "nn: kept epoch K of E, ..." or "nn: E epochs on every row ...".
      epochs=$(sed -n 's/.*nn: kept epoch \([0-9]*\) of \([0-9]*\).*/\2 (\1)/p; s/.*nn: \([0-9]*\) epochs on every row.*/\1 (\1)/p' \
        "$WORK/train.log" | head -1)
      printf '| %s | %s | %s | %s | %s | %.3g | %s | %.0f |\n' "$name" "$rows" "$label" "$seed" "$nmse" "$mean" \
        "$epochs" "$secs"
    done
  done
done
