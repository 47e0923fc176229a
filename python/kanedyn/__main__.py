"""The console command `kanedyn` (and `python -m kanedyn`): the kanedyn tool in this package.

`pip install .` puts the C++ tool at kanedyn/bin/kanedyn; the command runs it in its own
place (os.execv), with the same arguments, environment and exit code. A package built by CMake
(PYTHONPATH=build/python, or `cmake --install`) has no bin/: the tool is then build/kanedyn, or
PREFIX/bin/kanedyn once installed.
"""

from __future__ import annotations

import os
import sys


def tool_path() -> str:
    """Where the package keeps the tool (whether or not it is there)."""
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin", "kanedyn")


def main() -> None:
    path = tool_path()
    if not os.access(path, os.X_OK):
        sys.exit(
            f"kanedyn: this package has no tool at {path}: it was built by CMake, not by pip "
            "(the tool is then build/kanedyn, or PREFIX/bin/kanedyn after cmake --install)"
        )
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(path, [path, *sys.argv[1:]])


if __name__ == "__main__":
    main()
