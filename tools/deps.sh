#!/usr/bin/env bash
# Installs the Debian packages chasles needs, and only those that are missing.
# Sourced by demo.sh, test.sh and bench.sh; run alone it installs the full set (with the
# benchmarks' packages).
# As root it runs apt-get; otherwise it prints the exact command and fails.
set -euo pipefail

chasles_packages_build=(
  build-essential cmake ninja-build pkg-config libtinyxml2-dev
  libeigen3-dev liburdfdom-dev libceres-dev libgtest-dev
  libcli11-dev nlohmann-json3-dev libassimp-dev libqhull-dev
  liblcm-dev liblcm-bin libglib2.0-dev liblcm-java default-jdk-headless
  iproute2 util-linux python3
)

# The Python package (python/, built by tools/test.sh): Debian's CPython with its headers and
# venv; the pinned PyPI packages go into the venv tools/python.sh makes.
chasles_packages_python=(python3-dev python3-venv)

# `chasles log plot` (the demo's figures): gnuplot with its pngcairo terminal, and a font.
chasles_packages_plots=(gnuplot-nox fonts-dejavu-core)

# The 3D view's browser test (tests/python/test_view.py): headless Chromium loads the page and
# takes a screenshot (its software WebGL, SwiftShader, comes with the package).
chasles_packages_view=(chromium)

# Monitoring and its tests: the plots; tools/chasles-spy's chart library (liblcm-java does not pull
# it in) and a Java runtime with AWT; Xvfb, ImageMagick, tesseract and xdotool for the test that
# reads lcm-spy's window back from a virtual screen.
chasles_packages_monitor=(
  "${chasles_packages_plots[@]}" libjchart2d-java default-jre
  xvfb imagemagick tesseract-ocr tesseract-ocr-eng xdotool
)

# The benchmarks (tools/bench.sh): Google Benchmark, and Orocos KDL (1.5.1 in Debian 12, which has
# ChainExternalWrenchEstimator) with kdl_parser, the library chasles is timed against; and
# python3-venv, for the venv tools/pinocchio.sh makes to get Pinocchio's C++ from pip.
chasles_packages_bench=(libbenchmark-dev liborocos-kdl-dev libkdl-parser-dev python3-venv)

# The fuzz targets (tools/fuzz.sh, and the fuzz stage of tools/test.sh): clang with libFuzzer and
# the sanitizer runtimes.
chasles_packages_fuzz=(clang-14 libclang-rt-14-dev)

chasles_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# chasles_build NAME BUILD_DIR TARGET...: configures BUILD_DIR (warnings are errors, and the options
# in chasles_cmake_options) and builds the targets, the log in BUILD_DIR/NAME-build.log; when that
# fails, its tail and one line on stderr.
chasles_cmake_options=()
chasles_build() {
  local name=$1 build=$2
  shift 2
  mkdir -p "$build"
  if ! { cmake -S "$chasles_root" -B "$build" -G Ninja -DCHASLES_WERROR=ON "${chasles_cmake_options[@]}" &&
    cmake --build "$build" -j 2 --target "$@"; } >"$build/$name-build.log" 2>&1; then
    tail -n 40 "$build/$name-build.log" >&2
    echo "$name.sh: the build failed (full log: $build/$name-build.log)" >&2
    return 1
  fi
}

chasles_install_missing() {
  local missing=()
  local p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "chasles: missing Debian packages. Install them with:" >&2
    echo "  sudo apt-get install -y ${missing[*]}" >&2
    return 1
  fi
  echo "chasles: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get install -y --no-install-recommends "${missing[@]}" >/dev/null ||
    { apt-get update >/dev/null && apt-get install -y --no-install-recommends "${missing[@]}" >/dev/null; }
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  chasles_install_missing "${chasles_packages_build[@]}" "${chasles_packages_monitor[@]}" \
    "${chasles_packages_bench[@]}" "$@"
fi
