#!/usr/bin/env bash
# The main job end to end on a fresh Debian 12 machine (as root): install the
# dependencies, build, simulate a SCARA (train and test trajectories of 2000
# samples, 0.01 N m noise), train a GIP model and print its accuracy.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build -j"$(nproc)" --target gipdyn_cli
out=${OUT:-out/demo}
mkdir -p "$out"
./build/gipdyn simulate --robot scara --samples 2000 --seed 1 --out "$out/scara_train.csv"
./build/gipdyn simulate --robot scara --samples 2000 --seed 2 --out "$out/scara_test.csv"
./build/gipdyn train --data "$out/scara_train.csv" --joints RRPR --model gip --out "$out/scara_gip.gipdyn"
./build/gipdyn evaluate --model "$out/scara_gip.gipdyn" --data "$out/scara_test.csv" --json "$out/scara_gip_report.json"
