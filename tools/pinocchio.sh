#!/usr/bin/env bash
# Makes the project's own Python environment for the comparison with Pinocchio: build-bench/venv,
# created with `python3 -m venv`, holding the pip package `pin` at exactly the version below (its
# manylinux x86_64 wheel, for Debian 12's Python 3.11), and prints the cmeel prefix in it, where
# the wheel keeps Pinocchio's C++ headers (include/pinocchio, and Boost's beside them), on stdout.
# tools/bench.sh configures the bench tree with it (-DCHASLES_PINOCCHIO_PREFIX=...) to build
# chasles_pinocchio_bench (tests/bench/pinocchio_bench.cpp).
#
#   tools/pinocchio.sh              the prefix on stdout; pip's noise on stderr
#
# Nothing is installed by hand: a venv that already holds this version is reused as it is; one
# with another version (or a broken one) is made anew. Needs PyPI; without it, fails with a message
# (bench.sh then runs without the Pinocchio table).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# The version the figures in docs/benchmarks.md were taken with. Change it here only, and retake
# them.
pin_version=4.1.0

venv="$root/build-bench/venv"
python="$venv/bin/python"

installed() {
  [ -x "$python" ] && [ "$("$python" -c 'import importlib.metadata as m; print(m.version("pin"))' 2>/dev/null)" = "$pin_version" ]
}

if ! installed; then
  echo "pinocchio: making $venv with pin==$pin_version" >&2
  rm -rf "$venv"
  mkdir -p "$root/build-bench"
  python3 -m venv "$venv" >&2
  if ! "$venv/bin/pip" install --disable-pip-version-check --no-input --only-binary=:all: \
    "pin==$pin_version" >&2; then
    rm -rf "$venv"
    echo "pinocchio: could not install pin==$pin_version from PyPI (no network?)" >&2
    exit 1
  fi
  installed || { echo "pinocchio: pin==$pin_version did not install" >&2; exit 1; }
fi

# cmeel keeps its prefix in site-packages/cmeel.prefix; ask the interpreter where that is.
prefix=$("$python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')/cmeel.prefix
if [ ! -f "$prefix/include/pinocchio/config.hpp" ]; then
  echo "pinocchio: pin==$pin_version has no C++ headers at $prefix/include/pinocchio" >&2
  exit 1
fi
echo "$prefix"
