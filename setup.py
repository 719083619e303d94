"""Build the C++ core (pfmpm._core) with CMake inside a setuptools build."""

import os
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        import pybind11

        target_dir = Path(self.get_ext_fullpath(ext.name)).resolve().parent
        # One CMake tree for the module and, with -DPFMPM_TESTS=ON, the unit
        # tests (tools/test.sh): the library is compiled once for both.
        build_dir = ROOT / "build" / "cmake"
        build_dir.mkdir(parents=True, exist_ok=True)
        subprocess.check_call(
            [
                "cmake",
                str(ROOT),
                f"-DCMAKE_LIBRARY_OUTPUT_DIRECTORY={target_dir}",
                f"-DPython3_EXECUTABLE={sys.executable}",
                f"-Dpybind11_DIR={pybind11.get_cmake_dir()}",
                "-DCMAKE_BUILD_TYPE=Release",
                # Extra CMake options, e.g. CMAKE_ARGS=-DPFMPM_NATIVE=OFF for a portable build.
                *os.environ.get("CMAKE_ARGS", "").split(),
            ],
            cwd=build_dir,
        )
        jobs = str(os.cpu_count() or 2)
        subprocess.check_call(["cmake", "--build", ".", "--target", "_core", "-j", jobs], cwd=build_dir)


setup(ext_modules=[CMakeExtension("pfmpm._core")], cmdclass={"build_ext": CMakeBuild})
