#!/usr/bin/env bash
# libFuzzer on chasles's readers of untrusted input (tests/fuzz), built with clang, ASan and UBSan
# in build-fuzz/. Installs missing Debian packages first.
#
#   tools/fuzz.sh TARGET SECONDS [FLAGS...]   fuzz one target; FLAGS go to libFuzzer (-jobs=2, ...)
#   tools/fuzz.sh --ctest [SECONDS]           every target for SECONDS (default 10) each, as ctest
#                                             tests (tools/test.sh runs this)
#
# Targets: urdf, messages, calibration_csv, cases_json, lcm_log. Each starts from its seed corpus,
# tests/fuzz/corpus/TARGET, which is only read; new inputs go to build-fuzz/tests/fuzz/corpus/TARGET
# and crashers to build-fuzz/tests/fuzz/artifacts/TARGET-crash-*. After fixing a crash, copy its
# input into tests/fuzz/corpus/TARGET/ as a regression input: every build replays that folder.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
targets=(urdf messages calibration_csv cases_json lcm_log)

usage() {
  sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}
[ $# -ge 1 ] || usage
mode=$1
shift
seconds=10
if [ "$mode" = "--ctest" ]; then
  [ $# -le 1 ] || usage
  seconds=${1:-10}
else
  [ $# -ge 1 ] || usage
  seconds=$1
  shift
  found=0
  for t in "${targets[@]}"; do [ "$t" = "$mode" ] && found=1; done
  [ $found -eq 1 ] || { echo "fuzz: unknown target '$mode' (targets: ${targets[*]})" >&2; exit 2; }
fi
[[ "$seconds" =~ ^[0-9]+$ ]] && [ "$seconds" -gt 0 ] || { echo "fuzz: SECONDS must be a positive whole number, got '$seconds'" >&2; exit 2; }

source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}" "${chasles_packages_fuzz[@]}"

build="$root/build-fuzz"
CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$build" -G Ninja -DCHASLES_FUZZ=ON \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
  -DCHASLES_FUZZ_SECONDS="$seconds" >/dev/null

if [ "$mode" = "--ctest" ]; then
  cmake --build "$build" -j 2 --target "${targets[@]/#/fuzz_}"
  exec ctest --test-dir "$build" --output-on-failure -j 2 -L fuzz
fi

cmake --build "$build" -j 2 --target "fuzz_$mode"
work="$build/tests/fuzz/corpus/$mode"
mkdir -p "$work" "$build/tests/fuzz/artifacts"
echo "fuzz: $mode for $seconds s; new inputs in $work, crashers in $build/tests/fuzz/artifacts/" >&2
exec "$build/tests/fuzz/fuzz_$mode" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
  -artifact_prefix="$build/tests/fuzz/artifacts/$mode-" "$@" "$work" "$root/tests/fuzz/corpus/$mode"
