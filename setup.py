"""Builds the gipdyn Python package with the project's CMake build.

`pip install --no-build-isolation .` (Debian's setuptools, no network) runs
CMake for the `_core` extension and packages python/gipdyn with it.

GIPDYN_PREBUILT_CORE=PATH packages the `_core` extension at PATH, built by the
project's own CMake build, instead of compiling the library a second time (five
minutes on two cores). The CMake configuration still runs and must offer the
`_core` target (CMake's file API lists the targets). The nn estimator's
libtorch plugin beside it (the gipdyn_torch target's file) is packaged too. The packaging
test (tests/python_wheel_test.sh) uses it.
"""
import glob
import json
import os
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


def configured_targets(build_dir):
    """The targets of a configured build tree and their file names (None for a
    target without a file), from CMake's file API reply."""
    reply = os.path.join(build_dir, ".cmake", "api", "v1", "reply")
    with open(max(glob.glob(os.path.join(reply, "index-*.json")))) as f:
        codemodel = json.load(f)["reply"]["codemodel-v2"]["jsonFile"]
    with open(os.path.join(reply, codemodel)) as f:
        targets = [t for c in json.load(f)["configurations"] for t in c["targets"]]
    files = {}
    for t in targets:
        with open(os.path.join(reply, t["jsonFile"])) as f:
            files[t["name"]] = json.load(f).get("nameOnDisk")
    return files


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        source = os.path.abspath(os.path.dirname(__file__))
        package_dir = os.path.abspath(os.path.dirname(self.get_ext_fullpath(ext.name)))
        build_dir = os.path.abspath(os.path.join(self.build_temp, "cmake"))
        os.makedirs(build_dir, exist_ok=True)
        # Ask CMake's file API for the target list (read by configured_targets).
        query = os.path.join(build_dir, ".cmake", "api", "v1", "query", "codemodel-v2")
        os.makedirs(os.path.dirname(query), exist_ok=True)
        open(query, "w").close()
        subprocess.check_call([
            "cmake", "-S", source, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
            "-DGIPDYN_BUILD_TESTS=OFF", "-DGIPDYN_BUILD_BENCHMARKS=OFF", "-DGIPDYN_BUILD_EXAMPLES=OFF",
            f"-DPython3_EXECUTABLE={sys.executable}", f"-DGIPDYN_PYTHON_PACKAGE_DIR={package_dir}",
        ])
        prebuilt = os.environ.get("GIPDYN_PREBUILT_CORE")
        if prebuilt:
            targets = configured_targets(build_dir)
            if "_core" not in targets:
                sys.exit("setup.py: the CMake configuration has no _core target; build it in python/CMakeLists.txt")
            os.makedirs(package_dir, exist_ok=True)
            shutil.copy2(prebuilt, self.get_ext_fullpath(ext.name))
            # The nn estimator's libtorch plugin, which the build put beside _core.
            if targets.get("gipdyn_torch"):
                plugin = os.path.join(os.path.dirname(prebuilt), targets["gipdyn_torch"])
                if os.path.exists(plugin):
                    shutil.copy2(plugin, package_dir)
            return
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "_core", "-j", str(os.cpu_count() or 2)])


setup(
    options={"build": {"build_base": "build/setuptools"}},  # beside, not inside, the CMake build tree
    packages=["gipdyn"],
    package_dir={"": "python"},
    ext_modules=[CMakeExtension("gipdyn._core")],
    cmdclass={"build_ext": CMakeBuild},
)
