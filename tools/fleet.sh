#!/usr/bin/env bash
# Many arms on one host: N simulated Pandas and N controllers at 1 kHz, each pair on its own
# channel prefix (ARM<i>_), and by default its own multicast group and port. Installs missing
# Debian packages and builds first (into build/, as tools/demo.sh does).
#
#   tools/fleet.sh N [--seconds S] [--shared-bus] [--no-realtime] [--cpus LIST]
#
#   N                number of arms (1 to 64)
#   --seconds S      length of the run (default 60)
#   --shared-bus     every pair on udpm://239.255.76.67:7667 (default: arm i on
#                    239.255.76.(67+i), port 7667+i)
#   --no-realtime    run every process under SCHED_OTHER (default: --realtime for all)
#   --cpus LIST      CPUs the controllers' loops are pinned to, round robin (default: every CPU)
#
# In a private network namespace (tools/netns.sh) it starts the plants (real time, damping 0.5),
# then the controllers (state-driven, --realtime), sends each arm a JOINT move after 2 s and one
# back at half time, and stops everything after S seconds. It prints each arm's figures — the
# controller's ticks, FAULTs, overruns, latency, the plant's late cycles and late stops, the CPU
# each process used — and the totals, beside a bare 1 kHz loop run alongside (the machine's own
# stalls, which every arm shares). Exit status 0 when every arm held (0 FAULTs, 0 late stops,
# late cycles ≤ 0.1 %), 3 when one did not, 1 when a process failed. Everything of the run is kept
# in build/fleet/<time>/. CHASLES_BUILD_DIR chooses another build tree.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
readonly home_pose='0,0,0,-0.0698,0,0,0'
readonly move_pose='0.3,0.3,0.3,-0.67,0.3,0.6,0.3'

# ---------------------------------------------------------------------------------------------
# Inside the network namespace: the run itself. Settings come in the FLEET_* environment.
# ---------------------------------------------------------------------------------------------
pids=()
stop_all() {
  local pid
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  pids=()
}

url_of() {
  if [ "$FLEET_SHARED" = 1 ]; then
    echo 'udpm://239.255.76.67:7667?ttl=0'
  else
    echo "udpm://239.255.76.$((67 + $1)):$((7667 + $1))?ttl=0"
  fi
}

# CPU time of a process so far, in clock ticks (utime + stime).
cpu_ticks() { awk '{ print $14 + $15 }' "/proc/$1/stat" 2>/dev/null || echo 0; }

inside() {
  local n=$FLEET_N seconds=$FLEET_SECONDS dir=$FLEET_DIR i realtime=() model=()
  model=(--robot "$root/tests/data/panda.urdf" --tip panda_hand)
  [ "$FLEET_REALTIME" = 1 ] && realtime=(--realtime)
  read -r -a cpus <<<"$FLEET_CPUS"
  trap 'stop_all' EXIT
  trap 'echo "fleet.sh: interrupted" >&2; exit 130' INT TERM

  local plant_pids=() controller_pids=()
  for ((i = 0; i < n; i++)); do
    "$FLEET_BUILD/tools/chasles_plant" "${model[@]}" "${realtime[@]}" --rate 1000 --damping 0.5 --q0 "$home_pose" \
      --channel-prefix "ARM${i}_" --lcm-url "$(url_of "$i")" >"$dir/plant$i.out" 2>"$dir/plant$i.err" &
    plant_pids+=("$!")
    pids+=("$!")
  done
  for ((i = 0; i < n; i++)); do
    local cpu=()
    [ "$FLEET_REALTIME" = 1 ] && cpu=(--cpu "${cpus[$((i % ${#cpus[@]}))]}")
    "$FLEET_BUILD/controller/chasles_controller" "${model[@]}" "${realtime[@]}" "${cpu[@]}" --damping 0.5 \
      --channel-prefix "ARM${i}_" --lcm-url "$(url_of "$i")" --seconds "$seconds" --summary "$dir/arm$i.json" \
      >"$dir/controller$i.out" 2>"$dir/controller$i.err" &
    controller_pids+=("$!")
    pids+=("$!")
  done

  # The anchor, in the same minute: a bare 1 kHz loop beside the fleet, whose stalls every arm
  # shares (a wake-up more than 10 ms late is one no controller's default --stale-ms rides out).
  "$FLEET_BUILD/tools/chasles_loop_bench" --mode sleep \
    --seconds "$(awk -v s="$seconds" 'BEGIN { printf "%.1f", (s > 3 ? s - 2 : 1) }')" "${realtime[@]}" \
    >"$dir/loop_bench.json" 2>"$dir/loop_bench.err" &
  local bench_pid=$!
  pids+=("$bench_pid")

  local start=$SECONDS
  # After the controllers have started (loaded the URDF, listened, begun to hold), the CPU count
  # starts; the moves go out, one per arm.
  sleep 2
  local before=()
  for pid in "${plant_pids[@]}" "${controller_pids[@]}"; do before+=("$(cpu_ticks "$pid")"); done
  local t0=$EPOCHREALTIME
  for ((i = 0; i < n; i++)); do
    "$FLEET_BUILD/tools/chasles" target "${model[@]}" --channel-prefix "ARM${i}_" --lcm-url "$(url_of "$i")" \
      --joint "$move_pose" --duration 2 >>"$dir/targets.jsonl" 2>>"$dir/target.err"
  done
  sleep "$(awk -v s="$seconds" 'BEGIN { printf "%.1f", s / 2 - 2 }')"
  for ((i = 0; i < n; i++)); do
    "$FLEET_BUILD/tools/chasles" target "${model[@]}" --channel-prefix "ARM${i}_" --lcm-url "$(url_of "$i")" \
      --joint "$home_pose" --duration 2 >>"$dir/targets.jsonl" 2>>"$dir/target.err"
  done
  # The CPU window ends a second before the controllers do.
  sleep "$(awk -v s="$seconds" -v e="$((SECONDS - start))" 'BEGIN { x = s - e - 1; printf "%.1f", (x > 0 ? x : 0) }')"
  local after=() k=0
  for pid in "${plant_pids[@]}" "${controller_pids[@]}"; do after+=("$(cpu_ticks "$pid")"); done
  local window
  window=$(awk -v a="$t0" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.3f", b - a }')
  : >"$dir/cpu.txt"
  for pid in "${plant_pids[@]}" "${controller_pids[@]}"; do
    echo "$pid ${before[$k]} ${after[$k]} $window $(getconf CLK_TCK)" >>"$dir/cpu.txt"
    k=$((k + 1))
  done

  local failed=0
  for ((i = 0; i < n; i++)); do
    wait "${controller_pids[$i]}" || { echo "fleet.sh: controller $i failed: $(tail -n 3 "$dir/controller$i.err")" >&2; failed=1; }
  done
  for ((i = 0; i < n; i++)); do kill -INT "${plant_pids[$i]}" 2>/dev/null || true; done
  for ((i = 0; i < n; i++)); do
    wait "${plant_pids[$i]}" || { echo "fleet.sh: plant $i failed: $(tail -n 3 "$dir/plant$i.err")" >&2; failed=1; }
  done
  wait "$bench_pid" || { echo "fleet.sh: the bare-loop anchor failed: $(tail -n 3 "$dir/loop_bench.err")" >&2; failed=1; }
  pids=()
  echo "${plant_pids[*]}" >"$dir/plant_pids.txt"
  echo "${controller_pids[*]}" >"$dir/controller_pids.txt"
  return "$failed"
}

if [ "${FLEET_INSIDE:-}" = 1 ]; then
  inside
  exit $?
fi

# ---------------------------------------------------------------------------------------------
# Outside: arguments, packages, build, the run in a fresh namespace, the report.
# ---------------------------------------------------------------------------------------------
usage() { sed -n '6,14s/^# \{0,1\}//p' "$0"; }
n=
seconds=60
shared=0
realtime=1
cpus=$(seq -s ' ' 0 $(($(nproc) - 1)))
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds | --cpus)
      [ $# -ge 2 ] || { echo "fleet.sh: $1 needs a value (try --help)" >&2; exit 2; }
      case "$1" in
        --seconds) seconds=$2 ;;
        --cpus) cpus=${2//,/ } ;;
      esac
      shift 2
      ;;
    --shared-bus) shared=1; shift ;;
    --no-realtime) realtime=0; shift ;;
    -h | --help) usage; exit 0 ;;
    -*) echo "fleet.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
    *) [ -z "$n" ] || { echo "fleet.sh: one N only (got '$n' and '$1')" >&2; exit 2; }; n=$1; shift ;;
  esac
done
if ! [[ "$n" =~ ^[0-9]+$ ]] || [ "$n" -lt 1 ] || [ "$n" -gt 64 ]; then
  echo "fleet.sh: N must be a number of arms from 1 to 64 (got '${n}'; try --help)" >&2
  exit 2
fi
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 8 ]; then
  echo "fleet.sh: --seconds must be a whole number of seconds, at least 8 (got '$seconds')" >&2
  exit 2
fi
for c in $cpus; do
  [[ "$c" =~ ^[0-9]+$ ]] && [ "$c" -lt "$(nproc)" ] ||
    { echo "fleet.sh: --cpus: '$c' is not a CPU of this machine (0 to $(($(nproc) - 1)))" >&2; exit 2; }
done

source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}"

build=${CHASLES_BUILD_DIR:-$root/build}
echo "Building chasles, chasles_plant and chasles_controller in $build ..."
chasles_build fleet "$build" chasles chasles_plant chasles_controller_daemon chasles_loop_bench || exit 1

dir="$build/fleet/$(date +%Y%m%d-%H%M%S)"
mkdir -p "$dir"
echo "Fleet: $n arms, ${seconds} s, $([ "$shared" = 1 ] && echo "one shared bus" || echo "a group and port per arm"), $([ "$realtime" = 1 ] && echo "--realtime, loops on CPUs $cpus" || echo "SCHED_OTHER") ..."
status=0
FLEET_INSIDE=1 FLEET_DIR="$dir" FLEET_BUILD="$build" FLEET_N="$n" FLEET_SECONDS="$seconds" FLEET_SHARED="$shared" \
  FLEET_REALTIME="$realtime" FLEET_CPUS="$cpus" "$root/tools/netns.sh" bash "$root/tools/fleet.sh" || status=$?

python3 - "$dir" "$n" "$status" <<'PY'
import json, os, re, sys
d, n, status = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
cpu = {}
for line in open(os.path.join(d, "cpu.txt")):
    pid, before, after, window, hz = line.split()
    cpu[pid] = 100.0 * (int(after) - int(before)) / int(hz) / float(window)
plants = open(os.path.join(d, "plant_pids.txt")).read().split()
controllers = open(os.path.join(d, "controller_pids.txt")).read().split()
pattern = re.compile(r"late cycles (\d+) of (\d+) commanded steps \(([0-9.]+) %\), late stops (\d+)")
rows, held = [], 0
print(f"{'arm':>4} {'ticks':>7} {'faults':>6} {'overruns':>8} {'latency p50/p99 us':>19} {'late cycles':>16} "
      f"{'late stops':>10} {'cpu ctl %':>9} {'cpu plant %':>11}")
totals = dict(ticks=0, faults=0, overruns=0, steps=0, late=0, stops=0, cpu=0.0)
for i in range(n):
    try:
        s = json.load(open(os.path.join(d, f"arm{i}.json")))
    except (OSError, ValueError):
        print(f"{i:>4} no summary: see {os.path.join(d, f'controller{i}.err')}")
        continue
    m = None
    for line in open(os.path.join(d, f"plant{i}.err")):
        m = pattern.search(line) or m
    late, steps, late_pct, stops = (int(m.group(1)), int(m.group(2)), float(m.group(3)), int(m.group(4))) if m else (0, 0, 100.0, -1)
    c_ctl, c_plant = cpu[controllers[i]], cpu[plants[i]]
    ok = s["faults"] == 0 and stops == 0 and late_pct <= 0.1
    held += ok
    print(f"{i:>4} {s['ticks']:>7} {s['faults']:>6} {s['overruns']:>8} {s['latency_us']['p50']:>9.0f}/{s['latency_us']['p99']:<9.0f} "
          f"{late:>7} ({late_pct:6.3f} %) {stops:>10} {c_ctl:>9.1f} {c_plant:>11.1f}{'' if ok else '   <- did not hold'}")
    totals["ticks"] += s["ticks"]; totals["faults"] += s["faults"]; totals["overruns"] += s["overruns"]
    totals["steps"] += steps; totals["late"] += late; totals["stops"] += max(stops, 0)
    totals["cpu"] += c_ctl + c_plant
late_all = 100.0 * totals["late"] / totals["steps"] if totals["steps"] else 0.0
print(f"total: {totals['ticks']} ticks, {totals['faults']} FAULTs, {totals['overruns']} overruns; "
      f"{totals['late']} late cycles in {totals['steps']} steps ({late_all:.3f} %), {totals['stops']} late stops")
print(f"CPU: {totals['cpu']:.0f} % of one core in all, {totals['cpu'] / n:.1f} % per arm (controller and plant), "
      f"on {os.cpu_count()} cores")
try:
    bare = json.load(open(os.path.join(d, "loop_bench.json")))["sleep_jitter_us"]
    print(f"beside it, a bare 1 kHz loop ({bare['samples']} wake-ups): p99 {bare['p99']:.0f} us, max {bare['max'] / 1000:.1f} ms, "
          f"{bare['late_10ms']} wake-ups over 10 ms late, {bare['overruns']} over a period: the machine's own stalls, "
          "which every arm shares")
except (OSError, ValueError, KeyError):
    print("beside it, the bare 1 kHz loop gave no figures: see loop_bench.err")
print(f"{held} of {n} arms held (0 FAULTs, 0 late stops, late cycles <= 0.1 %)")
print(f"Run directory: {d}")
sys.exit(1 if status else (0 if held == n else 3))
PY
