#!/usr/bin/env bash
# Installs MuJoCo's C library, at exactly the version below, for chasles's MuJoCo plant
# (tools/mujoco), and prints its prefix on stdout: PREFIX/include/mujoco/mujoco.h and
# PREFIX/lib/libmujoco.so.VERSION. tools/test.sh and tools/demo.sh configure with it
# (-DCHASLES_MUJOCO_PREFIX=...).
#
#   tools/mujoco.sh                 the prefix on stdout; pip's noise on stderr
#
# Why the PyPI wheel and not Debian's libmujoco-dev: Debian 12 has MuJoCo 2.2.2 (2022), before
# mjSpec (3.2, the model-editing API the plant builds its scene with). The wheel carries the same shared library DeepMind builds
# and its public headers; nothing of its Python part is used. 3.3.4 is the last 3.x release with a
# binary wheel here (PyPI's 4.0.x are pure-Python wheels without the library).
#
# The wheel is fetched with pip (from a throwaway venv of Debian's python3-venv), checked against
# the hash below, and unpacked into build-deps/mujoco-VERSION. An existing, complete prefix is
# reused as it is. Nothing is installed outside the repository. Needs PyPI; without it, fails with
# a message.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# Change these together, and retake the figures in docs/simulation.md.
version=3.3.4
wheel=mujoco-$version-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl
sha256=4439485e2e62fc0c7d872fcedfb2c91463b8cbe1955f9b49fff996d3e4084dea

prefix="$root/build-deps/mujoco-$version"
complete() {
  [ -f "$prefix/include/mujoco/mujoco.h" ] && [ -f "$prefix/lib/libmujoco.so.$version" ] &&
    [ -L "$prefix/lib/libmujoco.so" ]
}

if ! complete; then
  echo "mujoco: installing MuJoCo $version into $prefix" >&2
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  /usr/bin/python3 -m venv "$work/venv" >&2
  if ! "$work/venv/bin/pip" download --disable-pip-version-check --no-input --no-deps \
    --only-binary=:all: --python-version 3.11 --platform manylinux2014_x86_64 \
    -d "$work" "mujoco==$version" >&2; then
    echo "mujoco: could not download mujoco==$version from PyPI (no network?)" >&2
    exit 1
  fi
  if [ "$(sha256sum "$work/$wheel" | cut -d' ' -f1)" != "$sha256" ]; then
    echo "mujoco: $wheel does not have the pinned sha256 $sha256" >&2
    exit 1
  fi
  "$work/venv/bin/python" -m zipfile -e "$work/$wheel" "$work/wheel"
  # Built beside the prefix and renamed into place: a half-unpacked prefix is never taken.
  rm -rf "$prefix.partial"
  mkdir -p "$prefix.partial/lib"
  cp -r "$work/wheel/mujoco/include" "$prefix.partial/include"
  cp "$work/wheel/mujoco/libmujoco.so.$version" "$prefix.partial/lib/"
  ln -s "libmujoco.so.$version" "$prefix.partial/lib/libmujoco.so"
  cp -r "$work/wheel/mujoco-$version.dist-info/licenses" "$prefix.partial/licenses"
  rm -rf "$prefix"
  mv "$prefix.partial" "$prefix"
  complete || { echo "mujoco: $prefix is incomplete after unpacking" >&2; exit 1; }
fi
echo "$prefix"
