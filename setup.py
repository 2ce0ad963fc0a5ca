"""Builds the gonio Python module with the project's CMake build (docs/python.md, "pip install").

pip calls this with `pip install --no-build-isolation .`: CMake configures the checkout (once;
later installs reuse the build folder and rebuild only what changed) and builds the target
gonio_python, whose extension module is then installed like any other.

Environment:
  GONIO_CMAKE_BUILD_DIR  an existing or new CMake build folder to use (default: a folder under
                         build/python-pip/ of the checkout)
  GONIO_PIP_BUILD_BASE   setuptools' own build folder (default: build/python-pip)
  GONIO_BUILD_JOBS       parallel compile jobs (default: the CPU count)
"""
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

SOURCE = Path(__file__).resolve().parent
BUILD_BASE = Path(os.environ.get("GONIO_PIP_BUILD_BASE", SOURCE / "build" / "python-pip"))


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = Path(os.environ.get("GONIO_CMAKE_BUILD_DIR", BUILD_BASE / "cmake")).resolve()
        if not (build_dir / "CMakeCache.txt").exists():
            generator = ["-G", "Ninja"] if shutil.which("ninja") else []
            subprocess.run(
                ["cmake", "-S", str(SOURCE), "-B", str(build_dir), *generator,
                 "-DCMAKE_BUILD_TYPE=Release", "-DGONIO_BUILD_TESTS=OFF",
                 "-DGONIO_BUILD_BENCH=OFF", f"-DPython_EXECUTABLE={sys.executable}"],
                check=True)
        jobs = os.environ.get("GONIO_BUILD_JOBS", str(os.cpu_count() or 1))
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "gonio_python",
                        "-j", jobs], check=True)
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        built = build_dir / "python" / f"gonio{suffix}"
        if not built.exists():
            found = sorted(p.name for p in (build_dir / "python").glob("gonio*.so"))
            raise RuntimeError(
                f"{built}: not built for this Python ({suffix}); {build_dir} holds {found}: "
                "its CMake build is for another interpreter (configure it with "
                f"-DPython_EXECUTABLE={sys.executable}, or leave GONIO_CMAKE_BUILD_DIR unset)")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, target)


BUILD_BASE.mkdir(parents=True, exist_ok=True)
setup(
    ext_modules=[CMakeExtension("gonio")],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": str(BUILD_BASE)}, "egg_info": {"egg_base": str(BUILD_BASE)}},
)
