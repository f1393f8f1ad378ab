#!/usr/bin/env bash
# Soak test: the controller driving the simulated arm for MINUTES, moving all the time, and what
# changed from start to end: overruns, wake-up jitter, latency, compute time and the resident
# memory (VmRSS) of both processes, sampled every minute. The goal is 0 overruns and flat memory.
# Not part of CI; the figure goes in the notes. Installs missing packages and builds into build/
# (CHASLES_BUILD_DIR chooses another tree).
#
#   tools/soak.sh MINUTES [--robot ur5|panda]
#
# Runs in a private network namespace (tools/netns.sh): chasles_plant --realtime at 1 kHz and
# chasles_controller --realtime (state-driven ticks), with a JOINT move between two poses every 2 s.
# Everything is kept in build/soak/<time>/: each process's output, summary.json, rss.csv.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
readonly lcm_url='udpm://239.255.76.67:7667?ttl=0'

rss_kb() { awk '/^VmRSS:/ { print $2 }' "/proc/$1/status" 2>/dev/null || echo 0; }

inside() {
  local dir=$SOAK_DIR build=$SOAK_BUILD model=(--robot "$SOAK_URDF" --tip "$SOAK_TIP") plant controller
  "$build/tools/chasles" inspect "${model[@]/--robot/--urdf}" >"$dir/model.json"
  local poses home a b
  poses=$(python3 - "$dir/model.json" <<'PY'
import json, math, sys
m = json.load(open(sys.argv[1]))
mids, a, b = [], [], []
for kind, lo, hi in zip(m["joint_types"], m["limits"]["lower"], m["limits"]["upper"]):
    if kind == "continuous":
        lo, hi = -math.pi, math.pi
    mid, step = 0.5 * (lo + hi), min(0.4, 0.2 * (hi - lo))
    mids.append(mid); a.append(mid + step); b.append(mid - step)
for pose in (mids, a, b):
    print(",".join(repr(x) for x in pose))
PY
  )
  { read -r home; read -r a; read -r b; } <<<"$poses"
  "$build/tools/chasles_plant" "${model[@]}" --realtime --rate 1000 --damping 0.5 --q0 "$home" \
    --lcm-url "$lcm_url" >"$dir/chasles_plant.out" 2>"$dir/chasles_plant.err" &
  plant=$!
  "$build/controller/chasles_controller" "${model[@]}" --realtime --damping 0.5 --lcm-url "$lcm_url" \
    --summary "$dir/summary.json" >"$dir/chasles_controller.out" 2>"$dir/chasles_controller.err" &
  controller=$!
  trap 'kill -TERM $controller $plant 2>/dev/null || true; wait' EXIT
  sleep 1
  "$build/tools/chasles" target --lcm-url "$lcm_url" --hold >/dev/null
  echo "minute,controller_rss_kb,plant_rss_kb" >"$dir/rss.csv"
  local end=$((SECONDS + 60 * SOAK_MINUTES)) next_sample=$SECONDS minute=0 pose=$a
  while [ $SECONDS -lt $end ]; do
    kill -0 $controller 2>/dev/null || { echo "soak.sh: the controller died:" >&2; tail "$dir/chasles_controller.err" >&2; exit 1; }
    kill -0 $plant 2>/dev/null || { echo "soak.sh: the plant died:" >&2; tail "$dir/chasles_plant.err" >&2; exit 1; }
    if [ $SECONDS -ge $next_sample ]; then
      echo "$minute,$(rss_kb $controller),$(rss_kb $plant)" | tee -a "$dir/rss.csv" >&2
      minute=$((minute + 1))
      next_sample=$((next_sample + 60))
    fi
    "$build/tools/chasles" target --lcm-url "$lcm_url" "${model[@]}" --joint "$pose" --duration 1.5 >/dev/null
    [ "$pose" = "$a" ] && pose=$b || pose=$a
    sleep 2
  done
  echo "$minute,$(rss_kb $controller),$(rss_kb $plant)" | tee -a "$dir/rss.csv" >&2
  kill -TERM $controller
  wait $controller
  kill -TERM $plant
  wait $plant || true
  trap - EXIT
}

if [ "${SOAK_INSIDE:-}" = 1 ]; then
  inside
  exit 0
fi

[ $# -ge 1 ] && [[ "$1" =~ ^[0-9]+$ ]] && [ "$1" -ge 1 ] || { sed -n '2,12s/^# \{0,1\}//p' "$0" >&2; exit 2; }
minutes=$1
robot=panda
[ "${2:-}" = --robot ] && robot=${3:?--robot needs ur5 or panda}
case "$robot" in
  ur5) tip=tool0 ;;
  panda) tip=panda_hand ;;
  *) echo "soak.sh: --robot must be ur5 or panda" >&2; exit 2 ;;
esac

source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}"
build=${CHASLES_BUILD_DIR:-$root/build}
cmake -S "$root" -B "$build" -G Ninja -DCHASLES_WERROR=ON >/dev/null
cmake --build "$build" -j 2 --target chasles chasles_plant chasles_controller_daemon >/dev/null
dir="$build/soak/$(date +%Y%m%d-%H%M%S)"
mkdir -p "$dir"
echo "soak.sh: $minutes min of $robot; RSS every minute (kB); output in $dir" >&2
SOAK_INSIDE=1 SOAK_DIR="$dir" SOAK_BUILD="$build" SOAK_MINUTES="$minutes" SOAK_URDF="$root/tests/data/$robot.urdf" \
  SOAK_TIP="$tip" "$root/tools/netns.sh" bash "$root/tools/soak.sh"

python3 - "$dir" <<'PY'
import csv, json, os, sys
d = sys.argv[1]
s = json.load(open(os.path.join(d, "summary.json")))
rows = list(csv.DictReader(open(os.path.join(d, "rss.csv"))))
def p(x): return f"p50 {x['p50']:.1f}  p99 {x['p99']:.1f}  max {x['max']:.1f} us"
print(f"soak: {s['ticks']} ticks in {s.get('seconds', 0):.0f} s ({s['rate_hz']:.1f} Hz), realtime {s.get('realtime')}")
print(f"  overruns        {s['overruns']}")
print(f"  wake-up jitter  {p(s['jitter_us'])}")
print(f"  compute         {p(s['compute_us'])}")
print(f"  latency         {p(s['latency_us'])}")
print(f"  faults {s['faults']}, stale states {s['stale_states']}, rejected messages {s['rejected_messages']}")
first, last = rows[1] if len(rows) > 1 else rows[0], rows[-1]  # minute 1: after start-up allocation
for who in ("controller", "plant"):
    a, b = int(first[f"{who}_rss_kb"]), int(last[f"{who}_rss_kb"])
    print(f"  {who:<10} RSS  {a} kB at minute {first['minute']} -> {b} kB at the end ({b - a:+d} kB)")
PY
