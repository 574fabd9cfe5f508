#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds a project outside
# the source tree against it with find_package(gipdyn); runs the result. The
# same project compiled with AVX2 (Eigen then lays its objects out otherwise
# than gipdyn and Debian's liborocos-kdl) must fail to compile, in one line
# that names the fix.
# Usage: install_test.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/include/gipdyn/gipdyn.hpp"
test -x "$work/prefix/bin/gipdyn"
test -f "$work/prefix/share/doc/gipdyn/LICENSE"
test -f "$work/prefix/share/doc/gipdyn/CITATION.cff"
# Internal headers (detail/ folders) are not part of the installed API, and no installed header needs one.
if find "$work/prefix/include/gipdyn" -type d -name detail | grep -q .; then
  echo "install_test: detail/ headers were installed" >&2
  exit 1
fi
if grep -rl '#include "gipdyn/\(.*/\)\?detail/' "$work/prefix/include/gipdyn" | grep -q .; then
  echo "install_test: an installed header includes a detail/ header" >&2
  exit 1
fi
# The nn estimator's libtorch plugin is installed, the installed command starts
# without libtorch, and it trains a network with the plugin installed beside it,
# not the build tree's (the dynamic loader's log names the file it opened).
if [ -f "$build/libgipdyn_torch.so" ]; then
  plugin=$(find "$work/prefix" -name libgipdyn_torch.so)
  if [ -z "$plugin" ]; then
    echo "install_test: libgipdyn_torch.so was not installed" >&2
    exit 1
  fi
  if ldd "$work/prefix/bin/gipdyn" | grep -q libtorch; then
    echo "install_test: the installed gipdyn links libtorch; only its plugin should" >&2
    exit 1
  fi
  "$work/prefix/bin/gipdyn" simulate --robot scara --samples 200 --seed 3 --out "$work/nn.csv" --quiet
  LD_DEBUG=files "$work/prefix/bin/gipdyn" train --data "$work/nn.csv" --joints RRPR --model nn --nn-epochs 2 \
    --out "$work/nn.gipdyn" --quiet 2> "$work/nn-loading.log"
  test -s "$work/nn.gipdyn"
  if ! grep -q "file=$plugin " "$work/nn-loading.log"; then
    echo "install_test: the installed gipdyn did not open the installed plugin $plugin:" >&2
    grep "libgipdyn_torch" "$work/nn-loading.log" >&2 || true
    exit 1
  fi
fi
cmake -S "$here/consumer" -B "$work/consumer" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/configure.log"
cmake --build "$work/consumer" -j"$(nproc)" > "$work/build.log"
"$work/consumer/consumer"
"$work/consumer/c_consumer"
if [ -x "$work/consumer/distributed_consumer" ]; then "$work/consumer/distributed_consumer"; fi

cmake -S "$here/consumer" -B "$work/consumer-avx2" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_CXX_FLAGS=-march=x86-64-v3 > "$work/configure-avx2.log"
if cmake --build "$work/consumer-avx2" --target consumer > "$work/build-avx2.log" 2>&1; then
  echo "install_test: a consumer compiled with -march=x86-64-v3 built; gipdyn/eigen_abi.hpp should refuse it" >&2
  exit 1
fi
if ! grep -q "error: #error \"gipdyn: Eigen is compiled with another alignment" "$work/build-avx2.log"; then
  echo "install_test: the AVX2 consumer failed without gipdyn's message:" >&2
  cat "$work/build-avx2.log" >&2
  exit 1
fi
