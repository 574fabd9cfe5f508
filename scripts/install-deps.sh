#!/usr/bin/env bash
# Installs the Debian 12 packages gipdyn needs to build, test and plot.
# Run as root (or with sudo) on a fresh Debian bookworm machine.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  libeigen3-dev libopenblas-dev liblapacke-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev nlohmann-json3-dev
  libnlopt-cxx-dev
  liborocos-kdl-dev liburdfdom-dev liburdfdom-headers-dev libkdl-parser-dev libconsole-bridge-dev
  libmatio-dev
  libopenmpi-dev libscalapack-openmpi-dev openmpi-bin
  libtorch-dev
  pybind11-dev python3-dev python3-numpy python3-pytest python3-sklearn
  python3-scipy python3-matplotlib python3-pandas
  python3-pip python3-setuptools python3-wheel
  # the C and C++ API reference (docs/api)
  doxygen
  # tests/abi/other_cpu_test.sh runs the build on emulated CPUs
  qemu-user
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
