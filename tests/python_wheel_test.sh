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
# Where the build has the nn estimator's libtorch plugin, the wheel carries it
# and trains a network with its own copy (the dynamic loader's log names the file).
if [ -f "$(dirname "$core")/libgipdyn_torch.so" ]; then
  test -f "$work/site/gipdyn/libgipdyn_torch.so"
  LD_DEBUG=files PYTHONPATH="$work/site" /usr/bin/python3 - 2> "$work/loading.log" <<'PY'
import gipdyn
d = gipdyn.simulate("scara", samples=100, seed=1, dt=0.1)
gipdyn.InverseDynamics(joints="RRPR", model="nn").fit(d["X"], d["tau"])
PY
  if ! grep -q "file=$work/site/gipdyn/libgipdyn_torch.so " "$work/loading.log"; then
    echo "python_wheel_test: the wheel's gipdyn did not open its own libgipdyn_torch.so:" >&2
    grep "libgipdyn_torch" "$work/loading.log" >&2 || true
    exit 1
  fi
  echo "wheel's nn plugin OK"
fi
