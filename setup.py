"""Builds the Python package kanedyn with the repository's CMake project.

    /usr/bin/python3 -m venv --system-site-packages ~/kanedyn-venv
    ~/kanedyn-venv/bin/pip install --no-build-isolation .

build_ext configures the CMake project in Release with only what the package needs (no tests,
benchmarks or examples), builds the module (target kanedyn_python, BUILD/python/kanedyn/) and
the tool (target kanedyn_cli, BUILD/kanedyn), and puts both in the package: the module beside
python/kanedyn/*.py, the tool as kanedyn/bin/kanedyn (run by the console command `kanedyn`).

Environment:
  KANEDYN_CMAKE_BUILD_DIR  a build tree already configured (with the module and the tool) to
                           take them from, after `cmake --build DIR --target kanedyn_python
                           kanedyn_cli` (nothing to do when it is up to date); relative to the
                           repository. Without it, the build tree is BUILD_TEMP/cmake
                           (build-python/temp.*/cmake), kept between installs.
  KANEDYN_VIEWER           ON, OFF or AUTO: the viewer page of Result.view and `kanedyn view`
                           (node and npm bundle it). Unset: on when node and npm are found and
                           viewer/node_modules is there or `npm ci` can fill it, else off.
  CMAKE_ARGS               more arguments for the configure step (split on spaces).
  CMAKE_BUILD_PARALLEL_LEVEL  build jobs (default: the number of CPUs).
"""

from __future__ import annotations

import os
import pathlib
import re
import shutil
import subprocess
import sys
import sysconfig
from typing import Dict, List

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def project_version() -> str:
    text = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    found = re.search(r"project\(kanedyn VERSION ([0-9][0-9.]*)", text)
    if not found:
        raise RuntimeError("setup.py: no `project(kanedyn VERSION ...)` in CMakeLists.txt")
    return found.group(1)


def say(message: str) -> None:
    # pip shows a build's output with -v, or when it fails.
    print(f"kanedyn setup.py: {message}", file=sys.stderr, flush=True)


def run(args: List[str], cwd: pathlib.Path | None = None) -> None:
    say("$ " + " ".join(map(str, args)))
    subprocess.run([str(a) for a in args], cwd=cwd, check=True)


def read_cache(build_dir: pathlib.Path) -> Dict[str, str]:
    cache: Dict[str, str] = {}
    for line in (build_dir / "CMakeCache.txt").read_text(encoding="utf-8", errors="replace").splitlines():
        found = re.match(r"([A-Za-z_][A-Za-z0-9_.-]*):[A-Z]+=(.*)", line)
        if found:
            cache[found.group(1)] = found.group(2)
    return cache


def is_on(value: str) -> bool:
    return value.upper() in ("1", "ON", "YES", "TRUE", "Y")


def viewer_setting() -> str:
    """KANEDYN_VIEWER for the configure step: the page needs node, npm and viewer/node_modules."""
    asked = os.environ.get("KANEDYN_VIEWER", "").strip().upper()
    if asked in ("ON", "OFF", "AUTO"):
        return asked
    if asked:
        raise RuntimeError(f"setup.py: KANEDYN_VIEWER is {asked!r}: ON, OFF or AUTO")
    viewer = ROOT / "viewer"
    if not (shutil.which("node") and shutil.which("npm")):
        say("node or npm not found: built without the viewer (Result.view and `kanedyn view` say so)")
        return "OFF"
    stamp = viewer / "node_modules" / ".package-lock.json"
    inputs = [viewer / "package.json", viewer / "package-lock.json"]
    if stamp.exists() and stamp.stat().st_mtime >= max(p.stat().st_mtime for p in inputs):
        return "ON"
    # The build runs the same command; here a failure (offline, no npm cache) leaves the viewer
    # out instead of failing the install.
    try:
        run(["npm", "ci", "--no-audit", "--no-fund", "--prefer-offline", "--loglevel=error"], cwd=viewer)
        return "ON"
    except (subprocess.CalledProcessError, OSError) as e:
        say(f"npm ci in viewer/ failed ({e}): built without the viewer "
            "(Result.view and `kanedyn view` say so)")
        return "OFF"


class CMakeExtension(Extension):
    """The module `kanedyn._kanedyn`, built by CMake (no sources for setuptools to compile)."""

    def __init__(self, name: str) -> None:
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext: Extension) -> None:
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        given = os.environ.get("KANEDYN_CMAKE_BUILD_DIR", "").strip()
        if given:
            build_dir = (ROOT / given).resolve()
            if not (build_dir / "CMakeCache.txt").is_file():
                raise RuntimeError(f"setup.py: KANEDYN_CMAKE_BUILD_DIR={given}: {build_dir} is not a "
                                   "configured CMake build tree (no CMakeCache.txt)")
            self.check_build_tree(build_dir, given)
        else:
            build_dir = pathlib.Path(self.build_temp).resolve() / "cmake"
            build_dir.mkdir(parents=True, exist_ok=True)
            configure = [
                "cmake", "-S", ROOT, "-B", build_dir,
                "-DCMAKE_BUILD_TYPE=Release",
                "-DKANEDYN_BUILD_TESTS=OFF", "-DKANEDYN_BUILD_BENCH=OFF", "-DKANEDYN_BUILD_EXAMPLES=OFF",
                "-DKANEDYN_BUILD_TOOL=ON", "-DKANEDYN_PYTHON=ON", "-DBUILD_SHARED_LIBS=OFF",
                f"-DKANEDYN_VIEWER={viewer_setting()}",
                f"-DPython_EXECUTABLE={sys.executable}",
            ]
            configure += os.environ.get("CMAKE_ARGS", "").split()
            run(configure)
        run(["cmake", "--build", build_dir, "--target", "kanedyn_python", "kanedyn_cli", "-j", jobs])

        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        module = build_dir / "python" / "kanedyn" / f"_kanedyn{suffix}"
        if not module.is_file():
            others = sorted(p.name for p in (build_dir / "python" / "kanedyn").glob("_kanedyn*"))
            raise RuntimeError(f"setup.py: no {module} (this interpreter's module); the build tree "
                               f"holds {others or 'none'}: it was configured for another Python "
                               f"(Python_EXECUTABLE={read_cache(build_dir).get('Python_EXECUTABLE')})")
        tool = build_dir / "kanedyn"
        if not (tool.is_file() and os.access(tool, os.X_OK)):
            raise RuntimeError(f"setup.py: the build made no tool at {tool}")

        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(module, target)
        os.chmod(target, 0o755)
        bin_dir = target.parent / "bin"
        bin_dir.mkdir(exist_ok=True)
        shutil.copyfile(tool, bin_dir / "kanedyn")
        os.chmod(bin_dir / "kanedyn", 0o755)

    @staticmethod
    def check_build_tree(build_dir: pathlib.Path, given: str) -> None:
        cache = read_cache(build_dir)
        problems = []
        if not is_on(cache.get("KANEDYN_PYTHON", "OFF")):
            problems.append("KANEDYN_PYTHON is OFF (pybind11 or numpy missing, or a sanitizer build)")
        if not is_on(cache.get("KANEDYN_BUILD_TOOL", "OFF")):
            problems.append("KANEDYN_BUILD_TOOL is OFF (the package ships the tool)")
        if is_on(cache.get("BUILD_SHARED_LIBS", "OFF")):
            problems.append("BUILD_SHARED_LIBS is ON (the module would load the libraries from the build tree)")
        if problems:
            raise RuntimeError(f"setup.py: KANEDYN_CMAKE_BUILD_DIR={given} cannot make the package: "
                               + "; ".join(problems))


# setuptools' build folders and its egg-info in build-python/ (ignored by git), not in the
# repository's root or in build/, the CMake build folder of the README.
BUILD_BASE = "build-python"
os.makedirs(ROOT / BUILD_BASE, exist_ok=True)

setup(
    version=project_version(),
    packages=["kanedyn"],
    package_dir={"kanedyn": "python/kanedyn"},
    ext_modules=[CMakeExtension("kanedyn._kanedyn")],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": BUILD_BASE}, "egg_info": {"egg_base": BUILD_BASE}},
    zip_safe=False,
)
