#!/usr/bin/env bash
# Builds chasles and runs every test with ctest. Installs missing Debian packages first.
#
#   tools/test.sh                 Release build in build/, warnings are errors
#   tools/test.sh --sanitize      ASan + UBSan build in build-sanitize/
#   tools/test.sh -R lie          extra arguments go to ctest
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}" "${chasles_packages_monitor[@]}"

build="$root/build"
options=(-DCHASLES_WERROR=ON)
if [ "${1:-}" = "--sanitize" ]; then
  shift
  build="$root/build-sanitize"
  # Warnings are enforced by the normal build; GCC 12 reports false maybe-uninitialized warnings
  # inside libstdc++ (std::regex) under -fsanitize, so they are not errors here.
  options=(-DCHASLES_WERROR=OFF -DCHASLES_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo)
fi

cmake -S "$root" -B "$build" -G Ninja "${options[@]}" >/dev/null
cmake --build "$build" -j 2
ctest --test-dir "$build" --output-on-failure -j 2 "$@"
