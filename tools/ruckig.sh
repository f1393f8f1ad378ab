#!/usr/bin/env bash
# Fetches Ruckig's C++ sources for the comparison of chasles's online trajectory generator
# (core/motion) with Ruckig: the source distribution of the PyPI package `ruckig` at exactly the
# version below, downloaded with pip into build-bench/ruckig and unpacked there, and prints its
# source root (the folder holding src/ruckig and include/ruckig) on stdout. tools/bench.sh
# configures the bench tree with it (-DCHASLES_RUCKIG_SOURCE=...) to build chasles_ruckig_bench
# (tests/bench/otg_bench.cpp), which compiles Ruckig's .cpp files with chasles's flags. Nothing of
# Ruckig's is committed to this repository.
#
#   tools/ruckig.sh                 the source root on stdout; pip's noise on stderr
#
# An already unpacked tree of this version is reused as it is. Needs PyPI; without it, fails with a
# message (bench.sh then runs without the Ruckig table).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# The version the figures in docs/benchmarks.md were taken with. Change it here only, and retake
# them.
ruckig_version=0.19.4

dir="$root/build-bench/ruckig"
source_root="$dir/ruckig-$ruckig_version"

unpacked() {
  [ -f "$source_root/include/ruckig/ruckig.hpp" ] && [ -f "$source_root/src/ruckig/position_third_step1.cpp" ]
}

if ! unpacked; then
  echo "ruckig: fetching the sdist of ruckig==$ruckig_version into $dir" >&2
  rm -rf "$dir"
  mkdir -p "$dir"
  # The sdist, not a wheel: the wheels hold the compiled Python module, the sdist the C++ sources.
  if ! python3 -m pip download --disable-pip-version-check --no-input --no-deps --no-binary :all: \
    "ruckig==$ruckig_version" -d "$dir" >&2; then
    rm -rf "$dir"
    echo "ruckig: could not download ruckig==$ruckig_version from PyPI (no network?)" >&2
    exit 1
  fi
  archive=$(find "$dir" -maxdepth 1 -name "ruckig-$ruckig_version.tar.gz" | head -n 1)
  [ -n "$archive" ] || { echo "ruckig: pip left no ruckig-$ruckig_version.tar.gz in $dir" >&2; exit 1; }
  tar -xzf "$archive" -C "$dir"
  unpacked || { echo "ruckig: ruckig-$ruckig_version.tar.gz has no C++ sources at $source_root" >&2; exit 1; }
fi
echo "$source_root"
