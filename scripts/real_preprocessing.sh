#!/usr/bin/env bash
# How each preprocessing step changes the real-log results (docs/results/real-robots.md):
# the UR10 reference split (train rows 1-6340, test 6341-12349) as logged, then
# low-passed at 5 Hz zero phase over the whole log, zero phase per segment
# (train and test filtered apart), causal per segment, and zero phase with the
# torques filtered too. Every variant trains the given estimators on the same
# constant-step subsample and prints each summary table.
#   bash scripts/real_preprocessing.sh [build dir] [UR10 csv] [estimators] [rows] [out dir]
set -euo pipefail
BUILD=${1:-build}
UR10=${2:-../shared/data/ur10-pick-and-place/urPicknPlace.csv}
ESTIMATORS=${3:-gip-envelope,rbf}
ROWS=${4:-500}
OUT=${5:-real-preprocessing}
G=$(realpath "$BUILD")/gipdyn
mkdir -p "$OUT"
declare -A VARIANTS=(
  [zero-phase-whole]="--cutoff 5"
  [zero-phase-segments]="--cutoff 5 --segment-starts 6341"
  [causal-segments]="--cutoff 5 --causal --segment-starts 6341"
  [zero-phase-torque-filtered]="--cutoff 5 --segment-starts 6341 --filter-torque"
)
run() {  # name data
  "$G" experiment real --data "$2" --joints RRRRRR --train-rows 1-6340 --test-rows 6341-12349 \
    --max-train "$ROWS" --models "$ESTIMATORS" --threads 1 --out "$OUT/$1" --quiet
  echo "## $1"
  grep '^| ' "$OUT/$1/summary.md"
}
run as-logged "$UR10"
for name in zero-phase-whole zero-phase-segments causal-segments zero-phase-torque-filtered; do
  # shellcheck disable=SC2086
  "$G" preprocess --data "$UR10" --log-period 0.008 ${VARIANTS[$name]} --out "$OUT/$name.csv" --quiet
  run "$name" "$OUT/$name.csv"
done
