#!/usr/bin/env bash
# The state-driven tick across two hosts: chasles_plant in namespace A and chasles_controller in
# namespace B, joined by a veth pair (tools/netns2.sh), both --realtime, for S seconds; then the
# LCM ping-pong across the same pair (chasles_loop_bench --echo-netns) as the anchor, and the
# controller's latency beside it as ratios. Builds first (into build/, as tools/demo.sh does).
#
#   tools/twohost_bench.sh [--seconds S] [--receive direct|lcm]
#
#   --seconds S      length of the controlled run (default 10); the ping-pong takes 5 s
#   --receive R      how both processes read the wire (default direct; lcm: LCM's receive thread)
#
# Prints one line: the controller's latency p50/p99 (state arrival at B → command sent), the
# ping-pong's, their ratios, and the controller's FAULTs. Nothing leaves the machine.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
readonly url='udpm://239.255.76.67:7667?ttl=1'  # one hop: across the veth

if [ "${TWOHOST_INSIDE:-}" = 1 ]; then
  dir=$TWOHOST_DIR
  build=$TWOHOST_BUILD
  model=(--robot "$root/tests/data/panda.urdf" --tip panda_hand)
  "$build/tools/chasles_plant" "${model[@]}" --realtime --damping 0.5 --lcm-url "$url" --receive "$TWOHOST_RECEIVE" \
    --seconds "$(awk -v s="$TWOHOST_SECONDS" 'BEGIN { print s + 3 }')" >"$dir/plant.out" 2>"$dir/plant.err" &
  plant=$!
  nsenter --net="$CHASLES_NETNS_B" -- "$build/controller/chasles_controller" "${model[@]}" --realtime --damping 0.5 \
    --lcm-url "$url" --receive "$TWOHOST_RECEIVE" --seconds "$TWOHOST_SECONDS" --summary "$dir/summary.json" \
    >"$dir/controller.out" 2>"$dir/controller.err"
  wait "$plant"
  "$build/tools/chasles_loop_bench" --mode pingpong --seconds 5 --realtime --lcm-url "$url" \
    --echo-netns "$CHASLES_NETNS_B" >"$dir/loop_bench.json" 2>"$dir/loop_bench.err"
  exit 0
fi

seconds=10
receive=direct
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=${2:?--seconds needs a value}; shift 2 ;;
    --receive) receive=${2:?--receive needs a value}; shift 2 ;;
    -h | --help) sed -n '7,10s/^# \{0,1\}//p' "$0"; exit 0 ;;
    *) echo "twohost_bench.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
done
case "$receive" in direct | lcm) ;; *) echo "twohost_bench.sh: --receive must be direct or lcm" >&2; exit 2 ;; esac
awk -v n="$seconds" 'BEGIN { exit !(n >= 1) }' 2>/dev/null || { echo "twohost_bench.sh: --seconds must be at least 1" >&2; exit 2; }

source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}"
build=${CHASLES_BUILD_DIR:-$root/build}
chasles_build twohost "$build" chasles_plant chasles_controller_daemon chasles_loop_bench || exit 1
dir="$build/twohost/$(date +%Y%m%d-%H%M%S)"
mkdir -p "$dir"
TWOHOST_INSIDE=1 TWOHOST_DIR="$dir" TWOHOST_BUILD="$build" TWOHOST_SECONDS="$seconds" TWOHOST_RECEIVE="$receive" \
  "$root/tools/netns2.sh" bash "$root/tools/twohost_bench.sh"
python3 - "$dir" "$receive" <<'PY'
import json, os, sys
d, receive = sys.argv[1], sys.argv[2]
s = json.load(open(os.path.join(d, "summary.json")))
b = json.load(open(os.path.join(d, "loop_bench.json")))["lcm_round_trip_us"]
l = s["latency_us"]
print(f"two hosts, --receive {receive}: controller latency p50 {l['p50']:.0f} us, p99 {l['p99']:.0f} us "
      f"({s['ticks']} ticks, {s['faults']} FAULTs); veth LCM ping-pong p50 {b['p50']:.0f} us, p99 {b['p99']:.0f} us; "
      f"controller / ping-pong: p50 {l['p50'] / b['p50']:.2f}, p99 {l['p99'] / b['p99']:.2f}  ({d})")
PY
