"""Builds the Python module with CMake: the compiled qbond._core and the package python/qbond.

The version is the one CMakeLists.txt's project() declares. The CMake build goes to build-pip/,
or to $QBOND_PIP_BUILD_DIR (CMAKE_BUILD_PARALLEL_LEVEL jobs, 2 by default)."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
BUILD = Path(os.environ.get("QBOND_PIP_BUILD_DIR", ROOT / "build-pip"))


def project_version() -> str:
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(qbond VERSION (\d+\.\d+\.\d+)", text)
    if not match:
        raise RuntimeError("CMakeLists.txt: no project(qbond VERSION x.y.z)")
    return match.group(1)


class CMakeBuild(build_ext):
    """Configures and builds the qbond_python target, then copies the extension where setuptools wants it."""

    def build_extension(self, ext: Extension) -> None:
        build_dir = BUILD / "cmake"
        subprocess.run(
            ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
             "-DQBOND_BUILD_TESTS=OFF", "-DQBOND_BUILD_APPS=OFF", "-DQBOND_BUILD_PYTHON=ON",
             f"-DPython3_EXECUTABLE={sys.executable}"],
            check=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", "2")
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "qbond_python", "-j", jobs], check=True)
        built = sorted((build_dir / "python" / "qbond").glob("_core*.so"))
        if not built:
            raise RuntimeError(f"no qbond extension built in {build_dir / 'python' / 'qbond'}")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[-1], target)


setup(
    version=project_version(),
    packages=["qbond"],
    package_dir={"": "python"},
    package_data={"qbond": ["_core.pyi", "py.typed"]},
    ext_modules=[Extension("qbond._core", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": str(BUILD)}},
    zip_safe=False,
)
