"""The compiled part of the Python module smseg for pip: the CMake target _smseg (eval/python).

pyproject.toml holds the metadata; this file gives the version (the CMake project's) and a build_ext
that configures the whole CMake project once in build-pip/ (Release, no tests, no benchmarks, for the
interpreter that runs pip), builds only _smseg and copies it beside the .py files of the wheel.
setuptools' own folders go to build-pip/setuptools, away from the CMake build of build/.
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
# One folder below the source like build/, so that ccache (base folder: the source) finds the objects
# of a build/ made from the same sources, whatever path the clone has. Ignored by git (/build-*/).
CMAKE_BUILD = ROOT / "build-pip"


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(smseg\s+VERSION\s+([0-9][0-9.]*)", text)
    if not match:
        sys.exit(f"setup.py: no 'project(smseg VERSION x.y.z)' in {ROOT / 'CMakeLists.txt'}")
    return match.group(1)


class CMakeBuild(build_ext):
    """Builds each extension as the CMake target of its last name part (smseg._smseg -> _smseg)."""

    def build_extension(self, ext):
        cmake = shutil.which("cmake")
        if cmake is None:
            raise RuntimeError("setup.py: cmake is not on PATH (Debian: apt-get install cmake)")
        target = ext.name.split(".")[-1]
        configure = [cmake, "-S", str(ROOT), "-B", str(CMAKE_BUILD), "-DCMAKE_BUILD_TYPE=Release",
                     "-DSMSEG_BUILD_TESTS=OFF", "-DSMSEG_BUILD_BENCHMARKS=OFF", "-DSMSEG_BUILD_PYTHON=ON",
                     f"-DPython3_EXECUTABLE={sys.executable}"]
        env = dict(os.environ)
        if shutil.which("ccache"):
            # Paths inside the source are hashed relative to it: clones at other paths share the cache.
            configure.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
            env["CCACHE_BASEDIR"] = str(ROOT)
            env["CCACHE_NOHASHDIR"] = "1"
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        subprocess.run(configure, check=True, env=env)
        subprocess.run([cmake, "--build", str(CMAKE_BUILD), "--target", target, "-j", jobs], check=True, env=env)
        # eval/python/CMakeLists.txt puts the module in build-pip/python/smseg, named for this interpreter.
        built = CMAKE_BUILD / "python" / "smseg" / (target + sysconfig.get_config_var("EXT_SUFFIX"))
        if not built.is_file():
            raise RuntimeError(f"setup.py: the CMake build did not make {built}")
        dest = Path(self.get_ext_fullpath(ext.name))
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, dest)


CMAKE_BUILD.mkdir(exist_ok=True)  # egg_info wants its egg_base to exist
setup(
    version=project_version(),
    ext_modules=[Extension("smseg._smseg", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": str(CMAKE_BUILD / "setuptools")},
             "egg_info": {"egg_base": str(CMAKE_BUILD)}},
)
