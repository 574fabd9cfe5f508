#!/usr/bin/env bash
# Packaging test: build the wheel offline with Debian's pip/setuptools
# (--no-build-isolation), unpack it and use it from outside the source tree.
# Argument: the _core extension of the project's build, which the wheel packages
# (setup.py's GIPDYN_PREBUILT_CORE) instead of compiling the library again;
# setup.py's CMake configuration still runs.
set -euo pipefail
core=${1:?usage: python_wheel_test.sh PATH/TO/_core.so, the extension of the project build}
source_dir=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$source_dir"
GIPDYN_PREBUILT_CORE="$core" /usr/bin/python3 -m pip wheel --no-build-isolation --no-deps --quiet -w "$work/wheel" .
/usr/bin/python3 -m zipfile -e "$work"/wheel/gipdyn-*.whl "$work/site"
cd "$work"
PYTHONPATH="$work/site" /usr/bin/python3 - <<'PY'
import gipdyn, numpy as np
assert gipdyn.__file__.startswith(__import__("os").getcwd()), gipdyn.__file__
d = gipdyn.simulate("scara", samples=100, seed=1, dt=0.1)
m = gipdyn.InverseDynamicsGP(joints="RRPR", max_iter=5).fit(d["X"], d["tau"])
assert m.predict(d["X"]).shape == (100, 4)
print("wheel OK:", gipdyn.__file__)
PY
