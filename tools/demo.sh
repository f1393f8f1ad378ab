#!/usr/bin/env bash
# The main job on the bundled UR5: what chasles knows of the arm, then its tip pose, Jacobians
# and joint torques at a few configurations. Installs missing Debian packages and builds first.
#
#   tools/demo.sh [--robot ur5|panda]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}"

robot=ur5
while [ $# -gt 0 ]; do
  case "$1" in
    --robot) robot="$2"; shift 2 ;;
    -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
    *) echo "demo.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
done
case "$robot" in
  ur5) tip=tool0 ;;
  panda) tip=panda_hand ;;
  *) echo "demo.sh: --robot must be ur5 or panda" >&2; exit 2 ;;
esac
urdf="$root/tests/data/$robot.urdf"

cmake -S "$root" -B "$root/build" -G Ninja >/dev/null
cmake --build "$root/build" -j 2 --target chasles >/dev/null
chasles="$root/build/tools/chasles"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$chasles" inspect --urdf "$urdf" --tip "$tip" >"$work/inspect.json"
python3 - "$work/inspect.json" "$work/cases.json" <<'PY'
import json, math, sys
m = json.load(open(sys.argv[1]))
print(f"{m['robot']}: {m['dof']} joints, {m['base_link']} -> {m['tip_link']}")
for name, kind, lo, hi, eff in zip(m["joint_names"], m["joint_types"], m["limits"]["lower"],
                                   m["limits"]["upper"], m["limits"]["effort"]):
    print(f"  {name:22s} {kind:10s} [{lo:+.3f}, {hi:+.3f}] rad, effort {eff} N·m")
lo, hi = m["limits"]["lower"], m["limits"]["upper"]
mid = [0.5 * (a + b) for a, b in zip(lo, hi)]
cases = [[0.0 if a <= 0.0 <= b else c for a, b, c in zip(lo, hi, mid)],
         [c + 0.06 * (b - a) * math.sin(k + 1) for k, (a, b, c) in enumerate(zip(lo, hi, mid))],
         [c - 0.06 * (b - a) * math.cos(2 * k) for k, (a, b, c) in enumerate(zip(lo, hi, mid))]]
n = m["dof"]
json.dump({"cases": [{"q": q, "qd": [0.1] * n, "qdd": [0.0] * n} for q in cases]}, open(sys.argv[2], "w"))
PY
"$chasles" eval --urdf "$urdf" --tip "$tip" --cases "$work/cases.json" >"$work/eval.json"
python3 - "$work/cases.json" "$work/eval.json" <<'PY'
import json, sys
cases = json.load(open(sys.argv[1]))["cases"]
out = json.load(open(sys.argv[2]))["cases"]
fmt = lambda v: "[" + ", ".join(f"{x:+.4f}" for x in v) + "]"
for k, (c, r) in enumerate(zip(cases, out)):
    T = r["T"]
    print(f"\npose {k + 1}: q = {fmt(c['q'])} rad")
    print(f"  tip position  {fmt([T[0][3], T[1][3], T[2][3]])} m")
    for i in range(3):
        print(f"  R[{i}]          {fmt(T[i][:3])}")
    print("  space Jacobian J_s (rows ω, v; one column per joint):")
    for row in r["J_s"]:
        print("    " + fmt(row))
    if "tau" in r:
        print(f"  gravity torque g(q)          {fmt(r['g'])} N·m")
        print(f"  torque at q̇ = 0.1, q̈ = 0   {fmt(r['tau'])} N·m")
PY
