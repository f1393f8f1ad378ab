#!/usr/bin/env bash
# Makes the project's own Python environment for the bindings and their tests, and prints its
# interpreter's path on stdout:
#
#   tools/python.sh [VENV]          default VENV: build/venv
#
# The venv is made with Debian's CPython (/usr/bin/python3, python3-venv and python3-dev from
# tools/deps.sh) and holds exactly python/requirements.txt (binary wheels from PyPI). A venv
# made from the same requirements is reused as it is; one from other requirements (or a broken
# one) is made anew. Nothing is installed by hand, and nothing outside the venv.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=$(realpath -m "${1:-$root/build/venv}")
requirements=$root/python/requirements.txt
python=$venv/bin/python
stamp=$venv/chasles-requirements.sha256
want=$(sha256sum "$requirements" | cut -d' ' -f1)

if [ ! -x "$python" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ] || ! "$python" -c 'import nanobind, numpy' 2>/dev/null; then
  echo "python: making $venv from python/requirements.txt" >&2
  rm -rf "$venv"
  mkdir -p "$(dirname "$venv")"
  /usr/bin/python3 -m venv "$venv" >&2
  if ! "$venv/bin/pip" install --disable-pip-version-check --no-input --quiet --only-binary=:all: \
    -r "$requirements" >&2; then
    rm -rf "$venv"
    echo "python: could not install python/requirements.txt from PyPI (no network?)" >&2
    exit 1
  fi
  echo "$want" >"$stamp"
fi
echo "$python"
