"""Builds the gipdyn Python package with the project's CMake build.

`pip install --no-build-isolation .` (Debian's setuptools, no network) runs
CMake for the `_core` extension and packages python/gipdyn with it.

GIPDYN_PREBUILT_CORE=PATH packages the `_core` extension at PATH, built by the
project's own CMake build, instead of compiling the library a second time (five
minutes on two cores); the CMake configuration is still run and must offer the
`_core` target. The packaging test (tests/python_wheel_test.sh) uses it.
"""
import os
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        source = os.path.abspath(os.path.dirname(__file__))
        package_dir = os.path.abspath(os.path.dirname(self.get_ext_fullpath(ext.name)))
        build_dir = os.path.abspath(os.path.join(self.build_temp, "cmake"))
        os.makedirs(build_dir, exist_ok=True)
        subprocess.check_call([
            "cmake", "-S", source, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
            "-DGIPDYN_BUILD_TESTS=OFF", "-DGIPDYN_BUILD_BENCHMARKS=OFF", "-DGIPDYN_BUILD_EXAMPLES=OFF",
            f"-DPython3_EXECUTABLE={sys.executable}", f"-DGIPDYN_PYTHON_PACKAGE_DIR={package_dir}",
        ])
        prebuilt = os.environ.get("GIPDYN_PREBUILT_CORE")
        if prebuilt:
            # A dry run (make and ninja both take -n) fails if the target is gone.
            subprocess.check_call(["cmake", "--build", build_dir, "--target", "_core", "--", "-n"],
                                  stdout=subprocess.DEVNULL)
            os.makedirs(package_dir, exist_ok=True)
            shutil.copy2(prebuilt, self.get_ext_fullpath(ext.name))
            return
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "_core", "-j", str(os.cpu_count() or 2)])


setup(
    options={"build": {"build_base": "build/setuptools"}},  # beside, not inside, the CMake build tree
    packages=["gipdyn"],
    package_dir={"": "python"},
    ext_modules=[CMakeExtension("gipdyn._core")],
    cmdclass={"build_ext": CMakeBuild},
)
