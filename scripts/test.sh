#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine (as root), builds gipdyn and runs every test
# (C++ unit tests, the scikit-learn cross-check and the CLI end-to-end tests).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)"
