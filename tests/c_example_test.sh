#!/bin/bash
# The C example end to end: a model trained by `gipdyn train`, queried through
# the C API; the example must report its latency distribution and physics.
set -euo pipefail
gipdyn=$1
example=$2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$gipdyn" simulate --robot scara --samples 150 --seed 3 --out "$dir/d.csv" --quiet
"$gipdyn" train --data "$dir/d.csv" --joints RRPR --max-iter 20 --quiet --out "$dir/m.gipdyn"
out=$("$example" "$dir/m.gipdyn" 2000)
echo "$out"
grep -q "2000 torque queries, 4 joints: p50 .* us, p99 .* us, max .* us" <<<"$out"
grep -q "^gravity at q = 0.3:" <<<"$out"
grep -q "^inertia diagonal at q = 0.3:" <<<"$out"
# The contact detector flags the push within 20 ticks (the momentum observer's lag), never before it.
for method in residual momentum; do
  line=$(grep "contact detector steps ($method)" <<<"$out")
  pushed=$(sed 's/.*push at tick \([0-9]*\).*/\1/' <<<"$line")
  flagged=$(sed 's/.*flagged at tick \(-\?[0-9]*\).*/\1/' <<<"$line")
  [ "$flagged" -ge "$pushed" ] && [ "$flagged" -le $((pushed + 20)) ] || { echo "bad detection: $line" >&2; exit 1; }
done
# A missing model: a one-line message and a non-zero exit, no crash.
if err=$("$example" "$dir/none.gipdyn" 2>&1); then
  echo "expected a failure for a missing model" >&2
  exit 1
fi
echo "$err"
[ "$(wc -l <<<"$err")" -eq 1 ]
grep -q "none.gipdyn" <<<"$err"
