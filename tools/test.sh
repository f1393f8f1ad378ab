#!/usr/bin/env bash
# Builds chasles and runs every test with ctest. Installs missing Debian packages first.
#
#   tools/test.sh                 Release build in build/, warnings are errors, with the Python
#                                 package (its venv build/venv from tools/python.sh, its pytest
#                                 suites in ctest as python.*)
#   tools/test.sh --sanitize      ASan + UBSan build of the in-process suites in build-sanitize/: the
#                                 libraries, the controller's logic, the messages, the fuzz replays,
#                                 the installed package; the tools and the tests that run them as
#                                 processes are the Release stage's (the fuzz stage sanitizes their
#                                 readers of untrusted input)
#   tools/test.sh -R lie          extra arguments go to ctest
#   tools/test.sh --long          the long runs alone, built and run in build/ (ctest label long:
#                                 the push campaign, ten minutes without a false alarm), then the
#                                 fuzz stage: every libFuzzer target (tests/fuzz) for 60 s, built
#                                 with clang, ASan and UBSan in build-fuzz/ (tools/fuzz.sh --ctest);
#                                 every other run leaves them out
#
# Every build also replays the fuzz seed corpus and the crashers kept in it (fuzz_replay.*).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/tools/deps.sh"
start=$SECONDS
chasles_install_missing "${chasles_packages_build[@]}" "${chasles_packages_monitor[@]}" "${chasles_packages_python[@]}" \
  "${chasles_packages_view[@]}"
echo "test.sh: packages took $((SECONDS - start)) s" >&2

build="$root/build"
options=(-DCHASLES_WERROR=ON)
fuzz=0
if [ "${1:-}" = "--sanitize" ]; then
  shift
  build="$root/build-sanitize"
  # Warnings are enforced by the normal build; GCC 12 reports false maybe-uninitialized warnings
  # inside libstdc++ (std::regex) under -fsanitize, so they are not errors here.
  # -Og -g1 (line tables, enough for ASan's reports): -O1 compiled in 40 % of the time -O2 -g
  # takes, and -Og in 74 % of -O1's (405 against 548 s on the 2-core VM) while the suite ran as
  # fast (126 against 120 s).
  options=(-DCHASLES_WERROR=OFF -DCHASLES_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo
           "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-Og -g1 -DNDEBUG" -DCHASLES_BUILD_TOOLS=OFF)
fi
long=OFF
if [ "${1:-}" = "--long" ]; then
  shift
  long=ON
  fuzz=1
  set -- -L long "$@"
fi
options+=("-DCHASLES_LONG_TESTS=$long")
# The MuJoCo plant and its tests, in both stages: MuJoCo's library at the version tools/mujoco.sh pins.
options+=("-DCHASLES_MUJOCO_PREFIX=$("$root/tools/mujoco.sh")")
# The Python package and its tests, in the Release stage only (an extension module under ASan needs
# the runtime preloaded into the interpreter; the C++ it binds is sanitized by the other suites).
if [ "$build" = "$root/build" ]; then
  python=$("$root/tools/python.sh" "$build/venv")
  options+=(-DCHASLES_PYTHON=ON "-DPython_EXECUTABLE=$python")
fi

# Each stage says how long it took, so CI's time can be read stage by stage.
stage() {
  local name=$1 start=$SECONDS
  shift
  "$@"
  echo "test.sh: $name took $((SECONDS - start)) s" >&2
}
stage "configure ($build)" cmake -S "$root" -B "$build" -G Ninja "${options[@]}" >/dev/null
stage "build ($build)" cmake --build "$build" -j 2
# The long runs only when asked for (--long): CI keeps to its 20 minutes. The 3D view's browser
# tests (label view: ctest -L view runs them alone) are in.
[ $# -gt 0 ] || set -- -LE long
stage "ctest ($build)" ctest --test-dir "$build" --output-on-failure -j 2 "$@"
# Fuzzing proper is a long run: CI's two builds replay the seed corpus and every crasher kept in it
# (fuzz_replay.*), while 6 s of new inputs a target cost CI 142 s (the libraries built again with
# clang) of its 20 minutes; a minute a target, when asked for, finds more.
if [ $fuzz -eq 1 ]; then
  stage "fuzz stage" "$root/tools/fuzz.sh" --ctest 60
fi
