#!/usr/bin/env bash
# False-alarm rate on contact-free simulated motion: exceedance of the threshold against the rate asked for.
set -euo pipefail
G=${G:-gipdyn}
cd "$(dirname "$0")"
for robot in scara ur10; do
  $G simulate --robot $robot --samples 2000 --seed 1 --out $robot-train.csv --quiet
  $G simulate --robot $robot --samples 20000 --dt 0.001 --seed 5 --out $robot-calib.csv --quiet
  $G simulate --robot $robot --samples 60000 --dt 0.001 --seed 6 --out $robot-watch.csv --quiet
  [ -f $robot-chain.gipdyn ] || $G train --data $robot-train.csv --model chain --out $robot-chain.gipdyn --quiet
  for rate in 1e-2 1e-3 1e-4; do
    for method in residual momentum; do
      $G detect --model $robot-chain.gipdyn --data $robot-watch.csv --calibration $robot-calib.csv --method $method \
        --false-alarm-rate $rate --min-duration 0.001 --quiet --out $robot-$method-$rate.csv
      /usr/bin/python3 - "$robot" "$method" "$rate" "$robot-$method-$rate.csv" <<'PY'
import sys, numpy as np, csv
robot, method, rate, path = sys.argv[1:]
with open(path) as f:
    header = f.readline().strip().split(",")
d = np.loadtxt(path, delimiter=",", skiprows=1)
m = d[:, [i for i, h in enumerate(header) if h.startswith("margin")]]
skip = 100  # the observer's start-up
e = (m[skip:] > 1).mean(axis=0)
print(f"{robot} {method} rate {rate}: exceedance per joint {' '.join(f'{x:.2g}' for x in e)}, mean {e.mean():.2g} ({e.mean()/float(rate):.2f}x asked)")
PY
    done
  done
done
