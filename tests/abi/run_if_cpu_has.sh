#!/usr/bin/env bash
# run_if_cpu_has.sh "FLAG ..." PROGRAM [ARGS...]: runs PROGRAM when this CPU has
# every /proc/cpuinfo flag listed, else exits 77, which CTest reports as skipped
# (a program built for an instruction set the CPU lacks would die of SIGILL).
set -euo pipefail
flags=$1
shift
cpu=" $(grep -m1 '^flags' /proc/cpuinfo | cut -d: -f2) "
for f in $flags; do
  if [[ "$cpu" != *" $f "* ]]; then
    echo "skipped: this CPU lacks '$f', which $(basename "$1") was built for"
    exit 77
  fi
done
exec "$@"
