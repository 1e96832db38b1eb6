"""Builds the extension sspc._sspc with the project's CMake for `pip install .` (pyproject.toml).

The library and the module are compiled by CMake exactly as `cmake --build` does (the
SSPC_BUILD_PYTHON target _sspc), for the interpreter running pip; setuptools only places the
result beside python/sspc/'s pure-Python modules.
"""

import os
import pathlib
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

SOURCE_DIR = pathlib.Path(__file__).resolve().parent


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = pathlib.Path(self.build_temp).resolve() / "cmake"
        generator = ["-G", "Ninja"] if shutil.which("ninja") else []
        subprocess.run(
            ["cmake", "-S", str(SOURCE_DIR), "-B", str(build_dir), *generator, "-DCMAKE_BUILD_TYPE=Release",
             "-DSSPC_BUILD_TESTS=OFF", "-DSSPC_BUILD_BENCH=OFF", "-DSSPC_BUILD_APPS=OFF", "-DSSPC_BUILD_PYTHON=ON",
             f"-DPython3_EXECUTABLE={sys.executable}"],
            check=True)
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "_sspc", "-j", str(os.cpu_count() or 1)],
                       check=True)
        built = next((build_dir / "python" / "sspc").glob("_sspc*.so"))
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, target)


setup(
    package_dir={"": "python"},
    packages=["sspc"],
    ext_modules=[Extension("sspc._sspc", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
)
