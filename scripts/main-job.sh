#!/usr/bin/env bash
# The README's first command: install what is missing, build, and run the main job on the
# notes' eight-body example: its equations, its 10 s trajectory and a web page of it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" --target kanedyn_cli
model=examples/eight_body.yaml
echo "== build/kanedyn info $model"
build/kanedyn info "$model"
echo
echo "== build/kanedyn eom $model --json > eight_body_eom.json"
build/kanedyn eom "$model" --json > eight_body_eom.json.partial
mv eight_body_eom.json.partial eight_body_eom.json
echo "A, f, ydot and xdot at the initial state went to eight_body_eom.json"
echo "(readable tables: build/kanedyn eom $model)"
echo
echo "== build/kanedyn simulate $model"
build/kanedyn simulate "$model"
echo
echo "== build/kanedyn view $model eight_body.csv"
build/kanedyn view "$model" eight_body.csv
echo "open eight_body.html in a browser: the run animated, with plots (docs/viewer.md)"
