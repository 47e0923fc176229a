#!/usr/bin/env bash
# Installs, with apt-get, the Debian 12 packages kanedyn needs to build and test.
# Does nothing when everything is already present.
# Usage: scripts/install-deps.sh [--peers] [--clang] [--fuzz]
#   --peers  also the peer engines for bench/peers (Simbody, MuJoCo, DART and its URDF loader);
#            never needed for tests.
#   --clang  also clang 14 and clang-format 14 (CI's clang build and format check).
#   --fuzz   also clang 14 and libFuzzer, for the fuzz target (scripts/fuzz.sh).
set -euo pipefail
pkgs=(build-essential cmake g++ pkg-config libeigen3-dev libyaml-dev liburdfdom-dev libcli11-dev
      nlohmann-json3-dev liblapack-dev libopenblas-dev libgtest-dev libgmock-dev libbenchmark-dev
      python3 python3-dev pybind11-dev python3-numpy python3-pytest python3-matplotlib
      python3-scipy python3-venv python3-pip python3-setuptools python3-wheel)
for arg in "$@"; do
  case "$arg" in
    --peers) pkgs+=(libsimbody-dev libmujoco-dev libdart-dev libdart-utils-urdf-dev) ;;
    --clang) pkgs+=(clang-14 clang-format-14 libclang-rt-14-dev) ;;
    --fuzz) pkgs+=(clang-14 libfuzzer-14-dev libclang-rt-14-dev) ;;
    *) echo "install-deps: unknown option $arg (expected --peers, --clang or --fuzz)" >&2; exit 2 ;;
  esac
done
# The viewer (kanedyn view): node and npm bundle it with esbuild; its tests drive Debian's
# chromium headless. A node that is already there (nodesource's, say, whose nodejs package
# brings its own npm and conflicts with Debian's) is used as it is: node 18 or later works.
pkgs+=(chromium)
# Studies on a dask.distributed cluster (docs/studies.md) and their tests.
pkgs+=(python3-distributed)
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then pkgs+=(nodejs npm); fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  exit 0
fi
echo "install-deps: installing ${missing[*]}" >&2
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
