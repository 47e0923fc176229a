#!/usr/bin/env bash
# The README's second command: install what is missing, build everything, run the tests.
# Extra arguments go to cmake's configure step (e.g. -DKANEDYN_SANITIZE=ON); BUILD_DIR picks
# the build folder (default build).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
build_dir=${BUILD_DIR:-build}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DKANEDYN_WERROR=ON "$@" >/dev/null
cmake --build "$build_dir" -j"$(nproc)"
ctest --test-dir "$build_dir" --output-on-failure -j"$(nproc)"
