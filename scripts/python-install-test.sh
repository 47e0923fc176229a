#!/usr/bin/env bash
# `pip install .` checked as a user meets it (docs/python.md, "Install"), in fresh venvs made
# with Debian's /usr/bin/python3 -m venv --system-site-packages (numpy, scipy, pytest from
# Debian), offline (--no-build-isolation: nothing is downloaded):
# 1. pip install --no-build-isolation . into a venv; `kanedyn --help` there (the tool in the
#    package, by the console command);
# 2. the Python suite (python/tests) against that installed package: from a scratch folder, so
#    that the repository's python/ is not on sys.path, without PYTHONPATH, KANEDYN_TOOL the
#    venv's `kanedyn` (skipped with --no-suite);
# 3. pip wheel --no-build-isolation . makes a wheel that installs into a second venv, where
#    `import kanedyn; kanedyn.load('examples/eight_body.yaml')` and `kanedyn --help` work.
# KANEDYN_CMAKE_BUILD_DIR (e.g. build, configured and built by scripts/test.sh) makes both
# installs take the module and the tool from that tree (seconds); without it, the first install
# builds them in build-python/ (13 min on 2 cores shared with other builds) and the wheel
# reuses that build.
# Usage: scripts/python-install-test.sh [--no-suite]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
suite=1
for arg in "$@"; do
  case "$arg" in
    --no-suite) suite=0 ;;
    *) echo "python-install-test: unknown option $arg (expected --no-suite)" >&2; exit 2 ;;
  esac
done
python=/usr/bin/python3
scratch=$(mktemp -d "${TMPDIR:-/tmp}/kanedyn-pip.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
# The build tree the installs use: given, or setup.py's own (for the suite's cmake --install test).
build_tree() {
  if [[ -n "${KANEDYN_CMAKE_BUILD_DIR:-}" ]]; then
    (cd "$root" && cd "$KANEDYN_CMAKE_BUILD_DIR" && pwd)
  else
    ls -d "$root"/build-python/temp.*/cmake | head -n 1
  fi
}
seconds() { echo "$(($(date +%s%N) / 1000000))"; }
elapsed() { local ms=$(($(seconds) - $1)); printf '%d.%03d s' $((ms / 1000)) $((ms % 1000)); }

echo "python-install-test: pip install --no-build-isolation . (KANEDYN_CMAKE_BUILD_DIR=${KANEDYN_CMAKE_BUILD_DIR:-unset})"
"$python" -m venv --system-site-packages "$scratch/venv"
t=$(seconds)
"$scratch/venv/bin/pip" install -q --no-build-isolation --no-cache-dir "$root"
echo "python-install-test: installed in $(elapsed "$t")"
cd "$scratch"
"$scratch/venv/bin/kanedyn" --help >"$scratch/help.txt"
grep -q '^kanedyn: dynamics of multibody systems' "$scratch/help.txt"
t=$(seconds)
where=$(env -u PYTHONPATH "$scratch/venv/bin/python" -c 'import kanedyn; print(kanedyn.__file__)')
echo "python-install-test: import kanedyn in $(elapsed "$t") (the interpreter's start included): $where"
case "$where" in
  "$scratch/venv/"*) ;;
  *) echo "python-install-test: kanedyn was imported from $where, not from the venv" >&2; exit 1 ;;
esac

if ((suite)); then
  echo "python-install-test: python/tests against the installed package"
  # pytest's exit code 5 (no tests collected) fails like any other.
  env -u PYTHONPATH PYTHONDONTWRITEBYTECODE=1 KANEDYN_TOOL="$scratch/venv/bin/kanedyn" \
    KANEDYN_BUILD_DIR="$(build_tree)" \
    "$scratch/venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests"
fi

echo "python-install-test: pip wheel, installed into a second venv"
cd "$root"
"$scratch/venv/bin/pip" wheel -q --no-build-isolation --no-deps --no-cache-dir -w "$scratch/wheels" "$root"
wheel=$(ls "$scratch"/wheels/kanedyn-*.whl)
"$python" -m venv --system-site-packages "$scratch/venv2"
"$scratch/venv2/bin/pip" install -q --no-index --no-cache-dir "$wheel"
# From the repository (examples/ is relative), where no kanedyn/ folder could be imported instead.
env -u PYTHONPATH "$scratch/venv2/bin/python" -c "import kanedyn, sys
m = kanedyn.load('examples/eight_body.yaml')
assert kanedyn.__file__.startswith(sys.argv[1]), kanedyn.__file__
assert m.N == 8, m.N" "$scratch/venv2/"
"$scratch/venv2/bin/kanedyn" --help >"$scratch/help2.txt"
grep -q '^kanedyn: dynamics of multibody systems' "$scratch/help2.txt"
echo "python-install-test: $(basename "$wheel") works in a fresh venv"
