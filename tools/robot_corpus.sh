#!/usr/bin/env bash
# Fetches the robot descriptions people use — the 69 URDFs of example-robot-data 6.0.0 (BSD-3-Clause,
# from PyPI, the package Pinocchio's examples load) — into DIR, for the corpus test
# (tests/core/corpus_test.cpp). The wheel is checked against its pinned SHA-256 and kept in
# ~/.cache/chasles, so a second run fetches nothing.
#
#   tools/robot_corpus.sh DIR
set -euo pipefail
[ $# -eq 1 ] || { echo "usage: $0 DIR" >&2; exit 2; }
out=$1
version=6.0.0
wheel=example_robot_data-$version-0-py3-none-any.whl
sha256=424092a8093411ac2cd4ccc0572382bfc6b5eb4833aa984ef5e671dd67cd0a6e
cache=${XDG_CACHE_HOME:-$HOME/.cache}/chasles
marker=$out/.example-robot-data-$version

[ -f "$marker" ] && exit 0
mkdir -p "$cache"
if ! echo "$sha256  $cache/$wheel" | sha256sum --check --status 2>/dev/null; then
  rm -f "$cache/$wheel"
  python3 -m pip download --quiet --no-deps --only-binary=:all: --dest "$cache" "example-robot-data==$version" ||
    { echo "robot_corpus: cannot download example-robot-data $version from PyPI (pip)" >&2; exit 1; }
  echo "$sha256  $cache/$wheel" | sha256sum --check --status ||
    { echo "robot_corpus: $cache/$wheel does not have the pinned SHA-256" >&2; exit 1; }
fi

# Only the URDFs, flattened to <package>/<file>.urdf; meshes are not needed to load a chain.
staging=$(mktemp -d "${out%/}.XXXXXX")
trap 'rm -rf "$staging"' EXIT
python3 - "$cache/$wheel" "$staging" <<'EOF'
import sys, zipfile, pathlib
wheel, staging = sys.argv[1], pathlib.Path(sys.argv[2])
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        parts = pathlib.PurePosixPath(name).parts
        if name.endswith(".urdf") and "robots" in parts:
            package = parts[parts.index("robots") + 1]
            target = staging / package / parts[-1]
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(z.read(name))
EOF
touch "$staging/.example-robot-data-$version"
rm -rf "$out"
mv "$staging" "$out"
trap - EXIT
echo "robot_corpus: $(find "$out" -name '*.urdf' | wc -l) URDFs of example-robot-data $version in $out"
