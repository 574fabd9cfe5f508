#!/usr/bin/env bash
# The default build on CPUs other than this one, emulated by QEMU (Debian's
# qemu-user): a Haswell (AVX2 and FMA, no AVX-512: the CPU whose -march=native
# build used to crash at the KDL boundary) and a plain x86-64 one (SSE2 only).
# On each: which loops the library picks, the KDL paths (robots, inverse and
# forward dynamics, physics, closed loop), the run-time vector loops against the
# plain one, and simulate + train + predict from the command line, whose log and
# predictions must equal this CPU's to rounding (1e-12 of the largest value).
#
#   other_cpu_test.sh BUILD_DIR
#
# Exits 77 (CTest: skipped) where qemu-x86_64 is missing; install-deps.sh installs it.
set -euo pipefail
build=$(cd "$1" && pwd)
if ! command -v qemu-x86_64 > /dev/null; then
  echo "skipped: qemu-x86_64 not found (apt-get install qemu-user)"
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
gipdyn="$build/gipdyn"
# One OpenBLAS kernel set (SSE3, which every CPU here runs) on every CPU, so that what is
# compared is gipdyn's own arithmetic: OpenBLAS otherwise picks its kernels by CPU.
export OPENBLAS_CORETYPE=Prescott OPENBLAS_NUM_THREADS=1

# Fails unless two CSV files of numbers agree to 1e-12 of their largest value.
same_numbers() {
  local what=$1 a=$2 b=$3 d
  if ! d=$(/usr/bin/python3 -c '
import sys, numpy as np
a, b = (np.loadtxt(f, delimiter=",", skiprows=1) for f in sys.argv[1:3])
d = np.max(np.abs(a - b)) / np.max(np.abs(a))
print(f"{d:.1e}")
sys.exit(0 if d <= 1e-12 else 1)' "$a" "$b"); then
    echo "other_cpu_test: $what differs from this CPU's by $d of its largest value" >&2
    exit 1
  fi
  echo "$what: within $d of this CPU's"
}

# train OUT COMMAND...: a GIP model of the training log, the same options everywhere.
train() {
  local out=$1
  shift
  "$@" train --data "$work/train.csv" --model gip --teacher none --threads 1 --max-iter 15 --quiet --out "$out"
}

# This CPU's run: the reference the emulated CPUs must reproduce.
"$gipdyn" simulate --robot scara --samples 200 --seed 5 --out "$work/train.csv" > /dev/null
train "$work/native.gipdyn" "$gipdyn" > /dev/null
"$gipdyn" predict --model "$work/native.gipdyn" --data "$work/train.csv" --out "$work/native.csv" > /dev/null

# The physics of fe models and the learned robot's forward dynamics; the rest of
# test_physics trains GP models, minutes each under emulation.
physics_filter='Physics.FisherianEstimatorRecoversKdlsTermsIncludingFriction:Physics.ModelsWithoutTheStructureAreRefused:ForwardDynamics.IntegratingTheTorquesReproducesTheMotion'
# The robot tests but the trajectory's finite differences (no KDL, and most of the time), and the
# closed loops that run KDL's dynamics in the shortest loops: a KDL call crashes on its first sample
# where the ABI differs, so a longer loop finds nothing more.
robot_filter='-Trajectory.*'
closed_loop_filter='ClosedLoop.ComputedTorqueWithTheRightModelTracks:ClosedLoop.AnExternalTorqueActsThroughTheDynamicsAndNoControllerSeesIt'
for cpu in Haswell-v4:AVX2 qemu64:SSE2; do
  model=${cpu%%:*}
  loops=${cpu##*:}
  emulated() { qemu-x86_64 -cpu "$model" "$@" 2> >(grep -v "TCG doesn't support requested feature" >&2); }
  echo "== $model"
  version=$(emulated "$gipdyn" --version)
  if [[ "$version" != *"GIP kernel loops in $loops"* ]]; then
    echo "other_cpu_test: on $model the loops should be $loops: $version" >&2
    exit 1
  fi
  emulated "$build/tests/test_kernels" --gtest_brief=1 --gtest_filter='FactorPairProduct.*:*GipKernel*'
  emulated "$build/tests/test_robot" --gtest_brief=1 --gtest_filter="$robot_filter"
  emulated "$build/tests/test_physics" --gtest_brief=1 --gtest_filter="$physics_filter"
  emulated "$build/tests/test_closed_loop" --gtest_brief=1 --gtest_filter="$closed_loop_filter"
  emulated "$gipdyn" simulate --robot scara --samples 200 --seed 5 --out "$work/train_$model.csv" > /dev/null
  same_numbers "simulate's log on $model" "$work/train.csv" "$work/train_$model.csv"
  train "$work/$model.gipdyn" emulated "$gipdyn" > /dev/null
  emulated "$gipdyn" predict --model "$work/$model.gipdyn" --data "$work/train.csv" --out "$work/$model.csv" > /dev/null
  same_numbers "the prediction on $model" "$work/native.csv" "$work/$model.csv"
done
echo "other_cpu_test: a Haswell and a plain x86-64 CPU give this CPU's results"
