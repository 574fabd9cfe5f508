#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds a project outside
# the source tree against it with find_package(gipdyn); runs the result.
# Usage: install_test.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/include/gipdyn/gipdyn.hpp"
test -x "$work/prefix/bin/gipdyn"
cmake -S "$here/consumer" -B "$work/consumer" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/configure.log"
cmake --build "$work/consumer" -j"$(nproc)" > "$work/build.log"
"$work/consumer/consumer"
"$work/consumer/c_consumer"
if [ -x "$work/consumer/distributed_consumer" ]; then "$work/consumer/distributed_consumer"; fi
