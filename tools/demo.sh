#!/usr/bin/env bash
# The main job: the controller driving the simulated arm at 1 kHz over LCM, and how its timing
# compares with what this machine can do at best. Installs missing Debian packages and builds
# first (into build/, as tools/test.sh does).
#
#   tools/demo.sh [--seconds N] [--robot ur5|panda|iiwa|FILE.urdf] [--tip LINK] [--summary FILE]
#                 [--tick state|clock] [--protocol chasles|drake-iiwa|drake-panda]
#                 [--engine chasles|mujoco] [--no-view] [--view-host HOST] [--view-port PORT]
#
#   --seconds N      length of the programme of targets (default 16, at least 10); the waypoint
#                    trajectory, a stream of setpoints and the jogs follow it (about 12 s; on the
#                    Panda the clearance segments, about 7 s more)
#   --robot R        ur5, panda or iiwa (tests/data/R.urdf, iiwa14.urdf), or a URDF file (default
#                    panda; iiwa with --protocol drake-iiwa)
#   --tip LINK       the chain's tip, for a URDF with several leaves (ur5: tool0, panda: panda_hand,
#                    iiwa: iiwa_link_ee)
#   --summary FILE   also copy the controller's summary JSON here
#   --tick T         the controller's ticks: 'state', as each state arrives (default), or 'clock',
#                    every period on its own clock (a state then waits up to a period)
#   --protocol P     the messages plant and controller speak (docs/protocols.md): chasles's own
#                    (default), or Drake's iiwa driver's (IIWA_STATUS/IIWA_COMMAND at 200 Hz, the
#                    torque sent less g(q)) or Panda driver's (PANDA_STATUS/PANDA_COMMAND, 1 kHz)
#   --engine E       who simulates the arm: chasles's own plant (default: RK4, the push and the
#                    table act on the tip) or MuJoCo (tools/mujoco.sh installs it: the table is a
#                    box under the hand, the push a ball pressing the elbow; docs/simulation.md)
#   --no-view        no 3D view; by default `python -m chasles.view` draws the run live (docs/view.md)
#                    and the demo prints its address first, `view: http://127.0.0.1:8080`
#   --view-host H    where a browser reaches the view (default 127.0.0.1: this machine only; 0.0.0.0
#                    lets other machines in, unauthenticated)
#   --view-port P    its port (default 8080; 0 picks a free one, and the address printed says which)
#
# In a private network namespace (tools/netns.sh) it starts lcm-logger, chasles_plant (real time,
# 1 kHz, damped, with a table under the arm) and chasles_controller --realtime, sends a programme
# of targets with `chasles target` (hold; a joint move; another; a Cartesian move; back home;
# hold; a push the stop reflex answers), then the compliant segment: the arm goes over the table,
# switches to Cartesian impedance (`chasles mode`) and presses on it with its target 1 cm below
# the surface, then holds and switches back. After N seconds, the planner's part: a waypoint
# trajectory (`chasles target --trajectory`) lifts the arm off the table and takes it through the
# second pose and the first one back home, timed by trapezoidal profiles at a fraction of the
# limits; once the controller says it SUCCEEDED, a stream of joint setpoints (`chasles stream`, 30 Hz
# for 4 s) swings every joint and back, and two jogs (`chasles jog`) bend every joint and send the
# tip down. On the Panda the controller has the arm's collision geometry (tests/data/packages, the
# SRDF) and a scene, tools/demo/panda_scene.json (a virtual wall at y = 0.52 m; the plant's table is
# not in it: every link but the wrist goes under its plane, and the press would take the wrist within
# 5 mm of it, a refusal), and two more segments (about 7 s) must stop short: a twist jog that would take the arm
# through the wall, and a stream that would swing the fingers into the forearm; the report checks
# from the log that the wall and a pair of the arm slowed them and that no pair came within its stop
# distance, and fails the demo otherwise. Then the demo stops every process, then runs
# chasles_loop_bench (a bare 1 kHz loop and an LCM ping-pong, 3 s each) for reference and prints
# the controller's figures beside it, the trajectory's outcome, time scale and tracking error, and the
# clearance (the plots add clearance.png, the closest pair's distance). Everything of the run (the LCM log,
# each process's output, the summaries) is kept in build/demo/<time>/. CHASLES_BUILD_DIR chooses
# another build tree.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
readonly lcm_url='udpm://239.255.76.67:7667?ttl=0'  # inside the namespace: multicast stays on lo
# The Panda's collision geometry (its meshes under tests/data/packages, the pairs its SRDF never
# checks) and the demo's scene, a virtual wall (tools/demo/panda_scene.json).
readonly scene=$root/tools/demo/panda_scene.json
readonly panda_srdf=$root/tests/data/packages/example-robot-data/robots/panda_description/srdf/panda.srdf
readonly self_stop_mm=5  # the controller's default

# ---------------------------------------------------------------------------------------------
# Inside the network namespace: the run itself. Settings come in the DEMO_* environment.
# ---------------------------------------------------------------------------------------------
names=()
pids=()

# start NAME CMD...: runs CMD in the background, its output in $DEMO_DIR/NAME.out and NAME.err.
start() {
  local name=$1
  shift
  "$@" >"$DEMO_DIR/$name.out" 2>"$DEMO_DIR/$name.err" &
  names+=("$name")
  pids+=("$!")
}

alive() { kill -0 "$1" 2>/dev/null; }

# index_of NAME: where the process started as NAME is in names and pids.
index_of() {
  local i
  for i in "${!names[@]}"; do [ "${names[$i]}" = "$1" ] && { echo "$i"; return; }; done
  echo "demo.sh: no process named $1" >&2
  return 1
}

# The last lines a process wrote to stderr, indented.
stderr_tail() { tail -n 15 "$DEMO_DIR/$1.err" | sed 's/^/    /' >&2; }

# stop_process I: SIGTERM, up to 5 s to exit, then SIGKILL. Returns the exit status.
stop_process() {
  local i=$1 name=${names[$1]} pid=${pids[$1]} status=0 tries
  [ "$pid" = 0 ] && return 0
  if alive "$pid"; then
    kill -TERM "$pid" 2>/dev/null || true
    for ((tries = 0; tries < 50; tries++)); do
      alive "$pid" || break
      sleep 0.1
    done
    if alive "$pid"; then
      echo "demo.sh: $name (pid $pid) did not stop within 5 s of SIGTERM; sending SIGKILL" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
  wait "$pid" 2>/dev/null || status=$?
  pids[$i]=0
  return "$status"
}

# Stops everything still running, newest first (the controller before the plant it commands).
stop_all() {
  local i
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do stop_process "$i" || true; done
}

# Fails the demo if a process has ended before its time, with the end of its stderr.
check_alive() {
  local i status
  for i in "${!pids[@]}"; do
    [ "${pids[$i]}" = 0 ] && continue
    alive "${pids[$i]}" && continue
    status=0
    wait "${pids[$i]}" 2>/dev/null || status=$?
    pids[$i]=0
    echo "demo.sh: ${names[$i]} exited early (status $status). The end of its stderr ($DEMO_DIR/${names[$i]}.err):" >&2
    stderr_tail "${names[$i]}"
    stop_all
    exit 1
  done
}

now() { printf '%s\n' "$EPOCHREALTIME"; }

# Sleeps until `start + offset` seconds, checking every 0.2 s that everything still runs.
wait_until() {
  local deadline left
  deadline=$(awk -v s="$run_start" -v o="$1" 'BEGIN { printf "%.6f", s + o }')
  while true; do
    check_alive
    left=$(awk -v d="$deadline" -v n="$(now)" 'BEGIN { x = d - n; printf "%.3f", (x > 0.2 ? 0.2 : x) }')
    awk -v x="$left" 'BEGIN { exit !(x <= 0) }' && return 0
    sleep "$left"
  done
}

# send WHAT ARGS...: one `chasles target`; what it sent goes to targets.jsonl.
send() {
  local what=$1 err
  shift
  printf '  %6.2f s  %s\n' "$(awk -v s="$run_start" -v n="$(now)" 'BEGIN { print n - s }')" "$what"
  if ! "$DEMO_BUILD/tools/chasles" target --lcm-url "$lcm_url" "$@" >>"$DEMO_DIR/targets.jsonl" 2>"$DEMO_DIR/target.err"; then
    err=$(cat "$DEMO_DIR/target.err")
    echo "demo.sh: chasles target refused or failed: $err" >&2
    stop_all
    exit 1
  fi
}

# wait_trajectory ID REFUSALS TIMEOUT: waits for the controller's stderr to say what became of
# trajectory ID ("chasles_controller: trajectory ID SUCCEEDED", or ABORTED or PREEMPTED with the
# reason; a refusal is said as "target refused: ..." beyond the REFUSALS there were before it was
# sent), checking every 0.05 s that everything still runs. Fails the demo unless it SUCCEEDED
# within TIMEOUT seconds of the run's start.
wait_trajectory() {
  local id=$1 refusals=$2 deadline line err=$DEMO_DIR/chasles_controller.err
  deadline=$(awk -v s="$run_start" -v o="$3" 'BEGIN { printf "%.6f", s + o }')
  while true; do
    check_alive
    line=$(grep -E "^chasles_controller: trajectory $id (SUCCEEDED|ABORTED|PREEMPTED)" "$err" | tail -n 1 || true)
    if [ -n "$line" ]; then
      printf '  %6.2f s  %s\n' "$(awk -v s="$run_start" -v n="$(now)" 'BEGIN { print n - s }')" "$line"
      case "$line" in
        *" SUCCEEDED"*) return 0 ;;
        *) echo "demo.sh: the waypoint trajectory did not succeed: $line" >&2; stop_all; exit 1 ;;
      esac
    fi
    if [ "$(grep -c 'target refused' "$err" || true)" -gt "$refusals" ]; then
      echo "demo.sh: the controller refused the waypoint trajectory: $(grep 'target refused' "$err" | tail -n 1)" >&2
      stop_all
      exit 1
    fi
    if awk -v d="$deadline" -v n="$(now)" 'BEGIN { exit !(n > d) }'; then
      echo "demo.sh: no outcome for the waypoint trajectory by $3 s; the end of the controller's stderr:" >&2
      stderr_tail chasles_controller
      stop_all
      exit 1
    fi
    sleep 0.05
  done
}

# wait_holding HOLDS TIMEOUT: waits for the controller's stderr to say HOLDING once more than the
# HOLDS times it had said it before a move was sent (the move done), checking every 0.05 s that
# everything still runs; fails the demo after TIMEOUT seconds.
wait_holding() {
  local holds=$1 deadline err=$DEMO_DIR/chasles_controller.err
  deadline=$(awk -v n="$(now)" -v t="$2" 'BEGIN { printf "%.6f", n + t }')
  while [ "$(grep -c '^chasles_controller: HOLDING' "$err" || true)" -le "$holds" ]; do
    check_alive
    if awk -v d="$deadline" -v n="$(now)" 'BEGIN { exit !(n > d) }'; then
      echo "demo.sh: the controller did not settle after the move within $2 s; the end of its stderr:" >&2
      stderr_tail chasles_controller
      stop_all
      exit 1
    fi
    sleep 0.05
  done
}

# play WHAT SUBCOMMAND ARGS...: one `chasles stream` or `chasles jog`, which returns once all of it
# is sent; what it sent goes to streams.jsonl.
play() {
  local what=$1 err
  shift
  printf '  %6.2f s  %s\n' "$(awk -v s="$run_start" -v n="$(now)" 'BEGIN { print n - s }')" "$what"
  if ! "$DEMO_BUILD/tools/chasles" "$@" --lcm-url "$lcm_url" >>"$DEMO_DIR/streams.jsonl" 2>"$DEMO_DIR/stream.err"; then
    err=$(cat "$DEMO_DIR/stream.err")
    echo "demo.sh: chasles $1 failed: $err" >&2
    stop_all
    exit 1
  fi
}

# mode WHAT LAW ARGS...: one `chasles mode`.
mode() {
  local what=$1 err
  shift
  printf '  %6.2f s  law: %s\n' "$(awk -v s="$run_start" -v n="$(now)" 'BEGIN { print n - s }')" "$what"
  if ! "$DEMO_BUILD/tools/chasles" mode "$@" "${model[@]}" --lcm-url "$lcm_url" >>"$DEMO_DIR/modes.jsonl" \
    2>"$DEMO_DIR/mode.err"; then
    err=$(cat "$DEMO_DIR/mode.err")
    echo "demo.sh: chasles mode refused or failed: $err" >&2
    stop_all
    exit 1
  fi
}

# The clearance segments (the Panda, with its collision geometry and the scene): a twist jog that
# would take the arm through the wall, and a stream that would swing the fingers into the forearm;
# each must stop short. Their windows, as utimes, go to clearance.json for the report, which checks
# them against the log.
clearance_segments() {
  local wall_from fold_from holds
  # The fold: the wrist bent back to its stop (joint 6 at 0: the hand folded back toward the forearm,
  # link 5), joint 7 turns the hand from 0.785 to -0.785 rad in a straight line, swinging the right
  # finger past the forearm: from 23 mm it would pass 6.8 mm from it, within the 5 mm the arm's parts
  # keep apart plus the 2 mm margin the reference keeps besides, so it must stop short. The Panda cannot fold further into itself here: every other
  # pair its SRDF checks is against the base (links 0-2), which the hand reaches only under the
  # plant's table, and its joint limits keep the forearm off the shoulder.
  local fold_start=0,-0.3,0,-1.8,0,0.0,0.785 fold_end=0,-0.3,0,-1.8,0,0.0,-0.785
  python3 - "$fold_start" "$fold_end" "$dir/fold_plan.json" <<'PY'
import json, sys
a, b = ([float(x) for x in text.split(",")] for text in sys.argv[1:3])
rate, seconds = 30.0, 2.0
points = []
for k in range(int(rate * seconds) + 1):
    s = k / (rate * seconds)
    last = k == int(rate * seconds)
    points.append({"t": round(k / rate, 6), "position": [x + s * (y - x) for x, y in zip(a, b)],
                   "velocity": [0.0 if last else (y - x) / seconds for x, y in zip(a, b)]})
json.dump({"kind": "joint", "points": points}, open(sys.argv[3], "w"))
PY
  holds=$(grep -c '^chasles_controller: HOLDING' "$dir/chasles_controller.err" || true)
  wall_from=$(now)
  play "a twist jog toward the wall (y = 0.52 m, every link kept 2 cm behind it): the tip along +y at 15 cm/s for 2.5 s, 37 cm, through where the wall is" \
    jog --twist 0,0,0,0,0.15,0 --seconds 2.5 --rate 50
  wait_holding "$holds" 5
  holds=$(grep -c '^chasles_controller: HOLDING' "$dir/chasles_controller.err" || true)
  send "JOINT move to where the fold starts, [$fold_start]" "${model[@]}" --joint "$fold_start" --duration "$move"
  wait_holding "$holds" "$(awk -v m="$move" 'BEGIN { print m + 5 }')"
  fold_from=$(now)
  play "a stream of joint setpoints that swings the fingers into the forearm, 30 Hz for 2 s: joint 7 from 0.785 to -0.785 rad, the wrist bent back, [$fold_end]" \
    stream "$dir/fold_plan.json"
  sleep 0.5  # the stream's end: the arm at rest where it stopped
  python3 - "$dir/clearance.json" "$scene" "$wall_from" "$fold_from" "$(now)" "$fold_end" "$self_stop_mm" <<'PY'
import json, sys
path, scene, wall_from, fold_from, fold_to, fold_end = sys.argv[1:7]
wall = next(p for p in json.load(open(scene))["planes"] if p["name"] == "wall")
us = lambda x: round(float(x) * 1e6)
json.dump({"scene": scene,
           "wall": {"name": "wall", "stop": wall["clearance"]["stop"], "from_utime": us(wall_from), "to_utime": us(fold_from)},
           # the controller's --self-stop-mm
           "fold": {"stop": float(sys.argv[7]) / 1e3, "from_utime": us(fold_from), "to_utime": us(fold_to), "end": fold_end}},
          open(path, "w"), indent=1)
PY
}

# start_view [SCENE]: the 3D view on the demo's bus, served on this namespace's loopback, and the
# relay that hands it the connections the outside relay takes on the host's port (through the Unix
# socket $DEMO_DIR/view.sock, a file both sides see: a network namespace's loopback is its own, and
# the bus's multicast must stay in it). Prints the view's address once it serves.
start_view() {
  local deadline
  start chasles_view env PYTHONPATH="$DEMO_BUILD/python" "$DEMO_BUILD/venv/bin/python" -m chasles.view \
    --urdf "$DEMO_URDF" ${DEMO_TIP:+--tip "$DEMO_TIP"} --protocol "$DEMO_PROTOCOL" \
    --package-dir "$root/tests/data/packages" --url "$lcm_url" --host 127.0.0.1 --port 0 ${1:+--scene "$1"}
  deadline=$(awk -v n="$(now)" 'BEGIN { printf "%.6f", n + 60 }')
  until grep -qs '^chasles view: http://' "$DEMO_DIR/chasles_view.out"; do
    check_alive
    if awk -v d="$deadline" -v n="$(now)" 'BEGIN { exit !(n > d) }'; then
      echo "demo.sh: the view did not serve within 60 s; the end of its stderr:" >&2
      stderr_tail chasles_view
      exit 1
    fi
    sleep 0.05
  done
  start view_relay python3 "$root/tools/demo/relay.py" "unix:$DEMO_DIR/view.sock" \
    "tcp:$(sed -n 's|^chasles view: http://||p' "$DEMO_DIR/chasles_view.out")"
  until grep -qs '^relay: listening' "$DEMO_DIR/view_relay.out"; do
    check_alive
    sleep 0.05
  done
  echo "view: $DEMO_VIEW  (the arm live in a browser; docs/view.md)"
}

inside() {
  local dir=$DEMO_DIR seconds=$DEMO_SECONDS model=() i
  model=(--robot "$DEMO_URDF")
  [ -n "$DEMO_TIP" ] && model+=(--tip "$DEMO_TIP")
  trap 'stop_all' EXIT
  trap 'echo "demo.sh: interrupted" >&2; exit 130' INT TERM

  # Home is where the plant starts (zero, moved into the limits where zero is outside them); the two
  # poses move every joint from there towards the middle of its range.
  "$DEMO_BUILD/tools/chasles" inspect --urdf "$DEMO_URDF" ${DEMO_TIP:+--tip "$DEMO_TIP"} >"$dir/model.json"
  local poses home pose_a pose_b
  poses=$(python3 - "$dir/model.json" <<'PY'
import json, math, sys
m = json.load(open(sys.argv[1]))
home, a, b = [], [], []
for k, (kind, lo, hi) in enumerate(zip(m["joint_types"], m["limits"]["lower"], m["limits"]["upper"])):
    if kind == "continuous":
        lo, hi = -math.pi, math.pi
    q0 = min(max(0.0, lo + 0.02), hi - 0.02)  # inside the controller's 0.01 rad position margin
    mid = 0.5 * (lo + hi)
    towards = 1.0 if mid >= q0 else -1.0
    step = min(0.6, 0.25 * (hi - lo))  # rad or m; never past the middle of the range by more
    home.append(q0)
    a.append(q0 + towards * step * (1.0 if k % 2 == 0 else 0.5))
    b.append(q0 + towards * step * (0.3 if k % 2 == 0 else 1.0))
print(",".join(repr(x) for x in home))
print(",".join(repr(x) for x in a))
print(",".join(repr(x) for x in b))
PY
  )
  { read -r home; read -r pose_a; read -r pose_b; } <<<"$poses"
  # Poses by the CLI's FK: the Cartesian goal is the tip pose at pose_a, reached again in a straight
  # line; the table lies 5 mm under the tip at pose_b, the lowest point of the programme, facing up,
  # and the press aims 1 cm below its surface with the tip's orientation there.
  local tip_pose table press_pose
  echo "{\"cases\":[{\"q\":[$pose_a]},{\"q\":[$pose_b]}]}" >"$dir/pose_cases.json"
  "$DEMO_BUILD/tools/chasles" eval --urdf "$DEMO_URDF" ${DEMO_TIP:+--tip "$DEMO_TIP"} \
    --cases "$dir/pose_cases.json" >"$dir/poses.json"
  { read -r tip_pose; read -r table; read -r press_pose; } < <(python3 - "$dir/poses.json" <<'PY'
import json, math, sys
def pose(T, z_offset=0.0):
    """T's position (z moved by z_offset) and its rotation as a unit quaternion (w, x, y, z),
    branching on the largest diagonal term."""
    R = [row[:3] for row in T[:3]]
    t = R[0][0] + R[1][1] + R[2][2]
    if t > 0:
        s = 2 * math.sqrt(1 + t); w, x, y, z = s / 4, (R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s
    elif R[0][0] > R[1][1] and R[0][0] > R[2][2]:
        s = 2 * math.sqrt(1 + R[0][0] - R[1][1] - R[2][2]); w, x, y, z = (R[2][1] - R[1][2]) / s, s / 4, (R[0][1] + R[1][0]) / s, (R[0][2] + R[2][0]) / s
    elif R[1][1] > R[2][2]:
        s = 2 * math.sqrt(1 + R[1][1] - R[0][0] - R[2][2]); w, x, y, z = (R[0][2] - R[2][0]) / s, (R[0][1] + R[1][0]) / s, s / 4, (R[1][2] + R[2][1]) / s
    else:
        s = 2 * math.sqrt(1 + R[2][2] - R[0][0] - R[1][1]); w, x, y, z = (R[1][0] - R[0][1]) / s, (R[0][2] + R[2][0]) / s, (R[1][2] + R[2][1]) / s, s / 4
    return ",".join(repr(v) for v in (T[0][3], T[1][3], T[2][3] + z_offset, w, x, y, z))
a, b = (case["T"] for case in json.load(open(sys.argv[1]))["cases"])
surface = b[2][3] - 0.005
print(pose(a))
print(f"{b[0][3]!r},{b[1][3]!r},{surface!r},0,0,1")
print(pose(b, -0.015))
PY
  )
  # On MuJoCo the table is a thing the hand's own shapes meet: a box (the plant's --scene) just wide
  # enough for the hand, its top 5 mm under the lowest point of the collision geometry on the tip's
  # body at pose_b (chasles eval --collision), so that the same press takes that point 1 cm into it.
  local mujoco_scene=$dir/mujoco_table.json
  if [ "$DEMO_ENGINE" = mujoco ]; then
    echo "{\"cases\":[{\"q\":[$pose_b]}]}" >"$dir/pose_b_case.json"
    "$DEMO_BUILD/tools/chasles" eval --urdf "$DEMO_URDF" ${DEMO_TIP:+--tip "$DEMO_TIP"} --cases "$dir/pose_b_case.json" \
      --collision --package-dir "$root/tests/data/packages" >"$dir/pose_b_collision.json"
    python3 - "$dir/pose_b_collision.json" "$dir/model.json" "$mujoco_scene" <<'PY'
import json, sys
case = json.load(open(sys.argv[1]))["cases"][0]
n = len(json.load(open(sys.argv[2]))["joint_types"])
hand = [b for b in case["collision_boxes"] if b["body"] == n]
if not hand:
    sys.exit("demo.sh: the tip's body has no collision geometry for MuJoCo's table to meet")
lo = [min(b["min"][k] for b in hand) for k in range(3)]
hi = [max(b["max"][k] for b in hand) for k in range(3)]
top = lo[2] - 0.005
size = [hi[0] - lo[0] + 0.1, hi[1] - lo[1] + 0.1, 0.05]  # 5 cm to spare on every side
below = [b["object"] for b in case["collision_boxes"] if b["body"] < n and b["min"][2] < top
         and b["max"][0] > lo[0] - 0.05 and b["min"][0] < hi[0] + 0.05 and b["max"][1] > lo[1] - 0.05 and b["min"][1] < hi[1] + 0.05]
if below:
    sys.exit("demo.sh: " + ", ".join(below) + " would be inside MuJoCo's table at the press pose")
json.dump({"version": 1, "objects": [{"name": "table", "shape": {"box": {"size": size}},
           "pose": {"xyz": [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, top - 0.025]}}]}, open(sys.argv[3], "w"), indent=1)
PY
  fi

  # The planner's trajectory: from the arm at rest on the table, up to pose_b in 0.5 s, then pose_b ->
  # pose_a -> home, each leg a straight line in joint space timed by one trapezoidal profile for all
  # joints (at 40 % of each joint's velocity limit and 15 % of its acceleration limit, the slowest
  # joint setting the leg's time) and sampled at 7 equal steps: 15 waypoints, positions only (the
  # controller chooses the velocities), stopping at pose_a. The controller may slow it down to fit
  # its limits (time_scaling); the report gives the scale it used.
  local accel_limits=''
  [ "$(basename "$DEMO_URDF")" = panda.urdf ] && accel_limits=15,7.5,10,12.5,15,20,20
  local trajectory_id=1 trajectory_points trajectory_s
  read -r trajectory_points trajectory_s < <(python3 - "$dir/model.json" "$pose_b" "$pose_a" "$home" \
    "$accel_limits" "$trajectory_id" "$dir/trajectory_plan.json" <<'PY'
import json, math, sys
m = json.load(open(sys.argv[1]))
legs = [[float(x) for x in text.split(",")] for text in sys.argv[2:5]]  # pose_b, pose_a, home
v_max = [v if v > 0 else 1.0 for v in m["limits"]["velocity"]]  # a URDF without one: 1 rad/s (m/s)
# The controller's: the Panda's as the demo passes them, else its default, the velocity limit / 0.4 s.
a_max = [float(a) for a in sys.argv[5].split(",")] if sys.argv[5] else [v / 0.4 for v in v_max]
V, A = 0.40, 0.15
points, t = [{"time_from_start": 0.5, "positions": legs[0]}], 0.5
for q0, q1 in zip(legs, legs[1:]):
    d = [b - a for a, b in zip(q0, q1)]
    # s in [0, 1] along the line: its speed and acceleration limits are the tightest joint's.
    vs = min(V * v / abs(x) for v, x in zip(v_max, d) if abs(x) > 1e-12)
    as_ = min(A * a / abs(x) for a, x in zip(a_max, d) if abs(x) > 1e-12)
    if vs * vs / as_ >= 1.0:  # no cruise: a triangle
        vs = math.sqrt(as_)
    T = 1.0 / vs + vs / as_
    ta = vs / as_
    def s(tau):
        if tau < ta:
            return 0.5 * as_ * tau * tau
        if tau > T - ta:
            return 1.0 - 0.5 * as_ * (T - tau) ** 2
        return 0.5 * as_ * ta * ta + vs * (tau - ta)
    for k in range(1, 8):
        tau = T * k / 7
        points.append({"time_from_start": round(t + tau, 6), "positions": [a + s(tau) * x for a, x in zip(q0, d)]})
    t += T
plan = {"id": int(sys.argv[6]), "points": points, "path_tolerance": 0.05, "goal_tolerance": 0.005,
        "goal_time_tolerance": 1.0, "time_scaling": True,
        "planner": f"trapezoids at {V:.0%} of the velocity and {A:.0%} of the acceleration limits"}
json.dump(plan, open(sys.argv[7], "w"), indent=1)
print(len(points), f"{t:.3f}")
PY
  )

  # The streamed segment, as a teleoperation device sends it: 30 joint setpoints a second for 4 s,
  # each joint swinging from home toward the middle of its range and back twice (by up to 0.2 rad
  # or 4 cm), with its velocity; then a joint jog bending every joint toward the middle of its
# range for a second, and a twist jog sending the tip down at 3 cm/s for a second and a half.
  python3 - "$dir/model.json" "$home" "$dir/stream_plan.json" <<'PY'
import json, math, sys
m = json.load(open(sys.argv[1]))
home = [float(x) for x in sys.argv[2].split(",")]
rate, seconds, w = 30.0, 4.0, 2 * math.pi / 2.0  # two swings
amplitude = []
for kind, lo, hi, q0 in zip(m["joint_types"], m["limits"]["lower"], m["limits"]["upper"], home):
    if kind == "continuous":
        lo, hi = -math.pi, math.pi
    size = 0.04 if kind == "prismatic" else 0.2
    amplitude.append(math.copysign(min(size, 0.25 * (hi - lo)), 0.5 * (lo + hi) - q0))
points = []
for k in range(int(rate * seconds) + 1):
    t = k / rate
    points.append({"t": round(t, 6),
                   "position": [q0 + a * 0.5 * (1 - math.cos(w * t)) for q0, a in zip(home, amplitude)],
                   "velocity": [a * 0.5 * w * math.sin(w * t) for a in amplitude]})
json.dump({"kind": "joint", "points": points}, open(sys.argv[3], "w"))
# The first jog's joint velocities: every joint toward the middle of its range at 0.25 rad/s (m/s).
print(",".join(repr(math.copysign(0.25, a)) for a in amplitude), file=open(sys.argv[3] + ".jog", "w"))
PY
  local jog_velocity
  jog_velocity=$(cat "$dir/stream_plan.json.jog")

  # Where the twist jog starts: the joint jog leaves the arm near the edge of its ranges (on the
  # Panda J_b's condition was 110 there, and the jog stops before 30), so first a JOINT move to a
  # pose from which the tip can go down: of 64 poses spread over the middle half of every joint's
  # range, the one whose J_b is best conditioned, its tip at least 10 cm above the table and the
  # straight joint path to it from where the joint jog ends at least 5 cm above it.
  local jog_pose jog_condition
  python3 - "$dir/model.json" "$home" "$jog_velocity" >"$dir/jog_cases.json" <<'PY'
import json, math, sys
m = json.load(open(sys.argv[1]))
home = [float(x) for x in sys.argv[2].split(",")]
speed = [float(x) for x in sys.argv[3].split(",")]
ranges = []
for kind, lo, hi in zip(m["joint_types"], m["limits"]["lower"], m["limits"]["upper"]):
    ranges.append((-math.pi, math.pi) if kind == "continuous" else (lo, hi))
jog_end = [q + v * 1.0 for q, v in zip(home, speed)]  # the joint jog: 1 s at these speeds
# Kronecker points: joint i at the fractional part of k times the i-th prime's square root.
roots = [math.sqrt(p) for p in (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37)]
cases = []
for k in range(1, 65):
    q = [lo + (hi - lo) * (0.25 + 0.5 * ((k * roots[i % len(roots)]) % 1.0)) for i, (lo, hi) in enumerate(ranges)]
    cases.append({"q": q})
    for s in range(1, 9):  # the path there
        cases.append({"q": [a + s / 9 * (b - a) for a, b in zip(jog_end, q)]})
json.dump({"cases": cases}, sys.stdout)
PY
  "$DEMO_BUILD/tools/chasles" eval --urdf "$DEMO_URDF" ${DEMO_TIP:+--tip "$DEMO_TIP"} \
    --cases "$dir/jog_cases.json" >"$dir/jog_poses.json"
  read -r jog_pose jog_condition < <(python3 - "$dir/jog_cases.json" "$dir/jog_poses.json" "$table" <<'PY'
import json, math, sys
cases = json.load(open(sys.argv[1]))["cases"]
evals = json.load(open(sys.argv[2]))["cases"]
surface = float(sys.argv[3].split(",")[2])

def eigenvalues(A):
    """A symmetric matrix's eigenvalues by Jacobi rotations (no numpy on a fresh machine)."""
    n = len(A)
    A = [row[:] for row in A]
    for _ in range(100):
        off = max((abs(A[i][j]), i, j) for i in range(n) for j in range(i + 1, n))
        if off[0] < 1e-15:
            break
        _, p, q = off
        theta = 0.5 * math.atan2(2 * A[p][q], A[q][q] - A[p][p])
        c, s = math.cos(theta), math.sin(theta)
        for k in range(n):
            akp, akq = A[k][p], A[k][q]
            A[k][p], A[k][q] = c * akp - s * akq, s * akp + c * akq
        for k in range(n):
            apk, aqk = A[p][k], A[q][k]
            A[p][k], A[q][k] = c * apk - s * aqk, s * apk + c * aqk
    return [A[i][i] for i in range(n)]

best = None
for k in range(0, len(cases), 9):
    tip_z = evals[k]["T"][2][3]
    path_z = min(e["T"][2][3] for e in evals[k + 1:k + 9])
    if tip_z < surface + 0.10 or path_z < surface + 0.05:
        continue
    J = evals[k]["J_b"]
    rows = len(J)
    JJt = [[sum(J[i][c] * J[j][c] for c in range(len(J[0]))) for j in range(rows)] for i in range(rows)]
    lam = eigenvalues(JJt)
    condition = math.sqrt(max(lam) / min(lam)) if min(lam) > 0 else math.inf
    if best is None or condition < best[0]:
        best = (condition, cases[k]["q"])
if best is None:
    sys.exit("demo.sh: no pose found to start the twist jog from")
print(",".join(repr(x) for x in best[1]), f"{best[0]:.1f}")
PY
  )

  # The programme, as fractions of the run: for 16 s, moves of 1.76 s starting at 0.8, 2.7, 4.6
  # and 6.6 s, the push at 8.6 s, the compliant segment from 9.6 s.
  local move t_hold t_a t_b t_cart t_home t_hold2 t_push push_s t_release push
  local t_over t_mode t_press t_measure t_lift t_back press_s
  move=$(awk -v n="$seconds" 'BEGIN { d = 0.11 * n; printf "%g", (d > 2 ? 2 : d) }')
  read -r t_hold t_a t_b t_cart t_home t_hold2 t_push push_s t_release < <(awk -v n="$seconds" \
    'BEGIN { printf "%g %g %g %g %g %g %g %g %g\n", 0.03 * n, 0.05 * n, 0.17 * n, 0.29 * n, 0.41 * n, 0.53 * n,
             0.54 * n, 0.02 * n, 0.58 * n }')
  read -r t_over t_mode t_press press_s t_measure t_lift t_back < <(awk -v n="$seconds" \
    'BEGIN { printf "%g %g %g %g %g %g %g\n", 0.60 * n, 0.73 * n, 0.74 * n, 0.03 * n, 0.86 * n, 0.89 * n, 0.91 * n }')
  # The plant pushes the resting arm's tip with 30 N along the base's x axis, ramped in and out over
  # 10 ms (from the plant's start, which comes first): the controller's estimate crosses the
  # collision threshold and the stop reflex holds the arm until the next target.
  push="$t_push,$push_s,0.01,0,0,0,30,0,0"
  # The table has the plant's default stiffness, 10^4 N/m; with a Cartesian stiffness of 1000 N/m
  # the two springs in series press with 9.09 N.
  local press_k=1000 table_k=10000

  start lcm-logger lcm-logger --lcm-url="$lcm_url" --force "$dir/chasles.lcmlog"
  # On MuJoCo: the box under the hand, and instead of the tip's push a ball pressing the elbow with
  # the same 30 N along x, over the same window.
  local environment=(--push "$push" --wall "$table,$table_k,100") press_link=
  if [ "$DEMO_ENGINE" = mujoco ]; then
    # Aimed at the link's origin, but on the Panda 8 cm up its forearm: at home the line through
    # the elbow's origin meets link 3 first (the plant would skip the press, and say so).
    local press_aim=0,0,0
    case "$(basename "$DEMO_URDF")" in
      panda.urdf) press_link=panda_link4 press_aim=-0.04,0.08,0 ;;
      iiwa14.urdf) press_link=iiwa_link_4 ;;
      ur5.urdf) press_link=forearm_link ;;
      *) press_link=$DEMO_TIP ;;
    esac
    push="$press_link,$t_push,$push_s,0.01,$press_aim,1,0,0,30"
    environment=(--engine mujoco --package-dir "$root/tests/data/packages" --scene "$mujoco_scene" --press "$push")
  fi
  if [ -n "$DEMO_VIEW" ]; then
    # Before the plant: the view takes seconds to serve, and MuJoCo's press is timed from the
    # plant's start, the programme from just after the controller's. The scene drawn is the one
    # the controller keeps the arm out of (the Panda's).
    if [ "$(basename "$DEMO_URDF")" = panda.urdf ]; then start_view "$scene"; else start_view; fi
  fi
  start chasles_plant "$DEMO_BUILD/tools/chasles_plant" "${model[@]}" --realtime --protocol "$DEMO_PROTOCOL" \
    --damping 0.5 --q0 "$home" "${environment[@]}" --lcm-url "$lcm_url"
  # The controller knows the plant's joint damping and feeds it forward (--damping). On the Panda
  # it takes the arm's own acceleration and jerk limits, libfranka's; elsewhere the defaults.
  local limits=() clearance=()
  if [ "$(basename "$DEMO_URDF")" = panda.urdf ]; then
    limits=(--acceleration-limit 15,7.5,10,12.5,15,20,20 --jerk-limit 7500,3750,5000,6250,7500,10000,10000)
    # Home folds the wrist back to its stop (joint 6 at 0.0025 rad): the right finger is 9 mm from the
    # forearm there, 2 mm from the 5 mm the arm's parts keep apart plus the 2 mm margin, where the
    # default 50 ms time constant lets the pair close at only 4 cm/s: the trajectory's last steps home
    # were cut (ABORTED "stopped short: panda_link5/0 and panda_rightfinger/0") in one run of three.
    # 20 ms lets them close at 6 cm/s (the 1 m/s^2 deceleration bound is then the tighter). The
    # reference keeps 3 mm beyond each stop distance, not 2: the jog meets the wall at 15 cm/s, and
    # the arm lagged its reference there by up to 1.9 mm in real time.
    clearance=(--collision on --package-dir "$root/tests/data/packages" --srdf "$panda_srdf" --scene "$scene"
               --self-stop-mm "$self_stop_mm" --clearance-time-constant-ms 20 --clearance-margin-mm 3)
  fi
  start chasles_controller "$DEMO_BUILD/controller/chasles_controller" "${model[@]}" --realtime --damping 0.5 \
    --protocol "$DEMO_PROTOCOL" \
    "${limits[@]}" "${clearance[@]}" --lcm-url "$lcm_url" \
    --tick "$DEMO_TICK" --summary "$dir/summary.json"
  run_start=$(now)
  # Where the report reads the press: the window in which the arm rests on the table, as utimes.
  # On MuJoCo the table is no spring of a known stiffness: the report holds the force against the
  # commanded spring at the deflection it measures (the press's goal height against the tip's).
  awk -v s="$run_start" -v a="$t_measure" -v b="$t_lift" -v k="$press_k" -v K="$table_k" -v e="$DEMO_ENGINE" \
    -v goal="$(cut -d, -f3 <<<"$press_pose")" \
    'BEGIN { printf "{\"press_k\": %s, \"table_k\": %s, \"depth\": 0.01, \"from_utime\": %.0f, \"to_utime\": %.0f, \"engine\": \"%s\", \"goal_z\": %s}\n",
             k, K, (s + a) * 1e6, (s + b) * 1e6, e, goal }' >"$dir/press.json"
  # Where the report looks for the push the controller located (on MuJoCo: the press on the elbow).
  awk -v s="$run_start" -v a="$t_push" -v d="$push_s" -v l="$press_link" \
    'BEGIN { printf "{\"link\": \"%s\", \"from_utime\": %.0f, \"to_utime\": %.0f}\n", l, (s + a) * 1e6, (s + a + d) * 1e6 }' \
    >"$dir/push.json"
  sleep 0.3
  check_alive

  echo "Programme (${seconds} s; moves of ${move} s):"
  wait_until "$t_hold"
  send "hold" --hold
  wait_until "$t_a"
  send "JOINT move to [$pose_a]" "${model[@]}" --joint "$pose_a" --duration "$move"
  wait_until "$t_b"
  send "JOINT move to [$pose_b]" "${model[@]}" --joint "$pose_b" --duration "$move"
  wait_until "$t_cart"
  send "CARTESIAN move, a straight line to the tip pose at the first pose [$tip_pose]" --pose "$tip_pose" \
    --duration "$move"
  wait_until "$t_home"
  send "JOINT move home to [$home]" "${model[@]}" --joint "$home" --duration "$move"
  wait_until "$t_hold2"
  send "hold" --hold
  if [ "$DEMO_ENGINE" = mujoco ]; then
    echo "  MuJoCo's ball presses the elbow ($press_link): 30 N along x from ${t_push} s for ${push_s} s (chasles_plant --press $push)"
  else
    echo "  the plant pushes the tip: 30 N along x from ${t_push} s for ${push_s} s (chasles_plant --push $push)"
  fi
  wait_until "$t_release"
  send "hold (a new target ends the reflex)" --hold
  wait_until "$t_over"
  send "JOINT move over the table, to [$pose_b]" "${model[@]}" --joint "$pose_b" --duration "$move"
  wait_until "$t_mode"
  mode "Cartesian impedance, $press_k N/m and 50 N*m/rad about the tip" cartesian-impedance \
    --translational "$press_k" --rotational 50
  wait_until "$t_press"
  send "CARTESIAN press, the target 1 cm below the table's surface [$press_pose]" --pose "$press_pose" \
    --duration "$press_s"
  wait_until "$t_lift"
  send "hold (where the arm rests on the table)" --hold
  wait_until "$t_back"
  mode "computed torque" computed-torque
  wait_until "$seconds"
  local refusals
  refusals=$(grep -c 'target refused' "$dir/chasles_controller.err" || true)
  send "waypoint trajectory $trajectory_id: $trajectory_points waypoints, off the table to pose_b, to pose_a, home, planned in ${trajectory_s} s" \
    "${model[@]}" --trajectory "$dir/trajectory_plan.json"
  # Its end: the planned time, slowed by up to 3x, its goal time and 2 s for a loaded machine.
  wait_trajectory "$trajectory_id" "$refusals" \
    "$(awk -v n="$seconds" -v t="$trajectory_s" 'BEGIN { printf "%.3f", n + 3 * t + 1 + 2 }')"
  play "a stream of joint setpoints, 30 Hz for 4 s: every joint swings toward the middle of its range and back, twice" \
    stream "$dir/stream_plan.json"
  local holds
  holds=$(grep -c '^chasles_controller: HOLDING' "$dir/chasles_controller.err" || true)
  play "a joint jog: every joint toward the middle of its range at 0.25 rad/s for 1 s (50 commands a second)" \
    jog --joint-velocity "$jog_velocity" --seconds 1 --rate 50
  wait_holding "$holds" 5  # the jog's stop: a JOINT move must start from rest
  holds=$(grep -c '^chasles_controller: HOLDING' "$dir/chasles_controller.err" || true)
  send "JOINT move to where the tip can go down (J_b condition $jog_condition), [$jog_pose]" "${model[@]}" \
    --joint "$jog_pose" --duration "$move"
  wait_holding "$holds" "$(awk -v m="$move" 'BEGIN { print m + 5 }')"
  play "a twist jog: the tip down at 3 cm/s for 1.5 s (in the base frame, 50 commands a second)" \
    jog --twist 0,0,0,0,0,-0.03 --seconds 1.5 --rate 50
  sleep 0.3  # the jog's stop: a brake of a few tens of milliseconds, well inside this
  if [ ${#clearance[@]} -gt 0 ]; then
    clearance_segments
  fi

  # The controller first: its summary covers a run in which the plant never stopped answering.
  # (The view, if any, is stopped with the rest when the run exits.)
  local name
  for name in chasles_controller chasles_plant lcm-logger; do
    i=$(index_of "$name")
    if ! stop_process "$i"; then
      echo "demo.sh: ${names[$i]} did not exit cleanly. The end of its stderr ($dir/${names[$i]}.err):" >&2
      stderr_tail "${names[$i]}"
      exit 1
    fi
  done
  [ -s "$dir/summary.json" ] || { echo "demo.sh: the controller wrote no summary ($dir/summary.json)" >&2; exit 1; }

  echo "Reference: chasles_loop_bench (bare 1 kHz loop, then LCM ping-pong; 3 s each) ..."
  if ! "$DEMO_BUILD/tools/chasles_loop_bench" --mode both --seconds 3 --realtime --lcm-url "$lcm_url" \
    >"$dir/loop_bench.json" 2>"$dir/loop_bench.err"; then
    echo "demo.sh: chasles_loop_bench failed:" >&2
    stderr_tail loop_bench
    exit 1
  fi
  echo "Reference: chasles_tick_bench (Controller::tick alone under each law, 5 s each) ..."
  if ! "$DEMO_BUILD/tools/chasles_tick_bench" --robot "$DEMO_URDF" ${DEMO_TIP:+--tip "$DEMO_TIP"} --seconds 5 --json \
    >"$dir/tick_bench.json" 2>"$dir/tick_bench.err"; then
    echo "demo.sh: chasles_tick_bench failed:" >&2
    stderr_tail tick_bench
    exit 1
  fi
}

# The report: the controller's summary beside the reference, and what the log holds.
report() {
  "$DEMO_BUILD/tools/chasles" log export "$DEMO_DIR/chasles.lcmlog" --channel CHASLES_STATUS \
    --out "$DEMO_DIR/status.csv" >/dev/null
  # The located contacts and the plant's truth beside them (the controller locates with the arm's
  # collision geometry; MuJoCo's truth names the contacts).
  local channel
  for channel in CONTACT TRUTH; do
    "$DEMO_BUILD/tools/chasles" log export "$DEMO_DIR/chasles.lcmlog" --channel "CHASLES_$channel" \
      --out "$DEMO_DIR/$(tr 'A-Z' 'a-z' <<<"$channel").csv" >/dev/null 2>&1 || true
  done
  python3 "$root/tools/demo/report.py" "$DEMO_DIR"
}

if [ "${DEMO_INSIDE:-}" = 1 ]; then
  inside
  exit 0
fi

# ---------------------------------------------------------------------------------------------
# Outside: arguments, packages, build, then the run in a fresh network namespace.
# ---------------------------------------------------------------------------------------------
usage() { sed -n '6,30s/^# \{0,1\}//p' "$0"; }
seconds=16
robot=
tip=
summary=
tick=state
protocol=chasles
engine=chasles
view=1
view_host=127.0.0.1
view_port=8080
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds | --robot | --tip | --summary | --tick | --protocol | --engine | --view-host | --view-port)
      [ $# -ge 2 ] || { echo "demo.sh: $1 needs a value (try --help)" >&2; exit 2; }
      case "$1" in
        --seconds) seconds=$2 ;;
        --robot) robot=$2 ;;
        --tip) tip=$2 ;;
        --summary) summary=$2 ;;
        --tick) tick=$2 ;;
        --protocol) protocol=$2 ;;
        --engine) engine=$2 ;;
        --view-host) view_host=$2 ;;
        --view-port) view_port=$2 ;;
      esac
      shift 2
      ;;
    --no-view) view=0; shift ;;
    -h | --help) usage; exit 0 ;;
    *) echo "demo.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
done
if ! [[ "$seconds" =~ ^[0-9]+([.][0-9]*)?$ ]] || ! awk -v n="$seconds" 'BEGIN { exit !(n >= 10) }'; then
  echo "demo.sh: --seconds must be a number of seconds, at least 10 (got '$seconds')" >&2
  exit 2
fi
case "$tick" in
  state | clock) ;;
  *) echo "demo.sh: --tick must be state or clock (got '$tick')" >&2; exit 2 ;;
esac
case "$engine" in
  chasles | mujoco) ;;
  *) echo "demo.sh: --engine must be chasles or mujoco (got '$engine')" >&2; exit 2 ;;
esac
case "$protocol" in
  chasles | drake-panda) : "${robot:=panda}" ;;
  drake-iiwa) : "${robot:=iiwa}" ;;
  *) echo "demo.sh: --protocol must be chasles, drake-iiwa or drake-panda (got '$protocol')" >&2; exit 2 ;;
esac
command_channel=$(case "$protocol" in chasles) echo CHASLES_COMMAND ;; drake-iiwa) echo IIWA_COMMAND ;;
                  drake-panda) echo PANDA_COMMAND ;; esac)
case "$robot" in
  ur5 | panda)
    urdf="$root/tests/data/$robot.urdf"
    [ -n "$tip" ] || { [ "$robot" = ur5 ] && tip=tool0 || tip=panda_hand; }
    ;;
  iiwa)
    urdf="$root/tests/data/iiwa14.urdf"
    [ -n "$tip" ] || tip=iiwa_link_ee
    ;;
  *.urdf)
    [ -f "$robot" ] || { echo "demo.sh: --robot $robot: no such file" >&2; exit 2; }
    urdf=$(cd "$(dirname "$robot")" && pwd)/$(basename "$robot")
    ;;
  *) echo "demo.sh: --robot must be ur5, panda, iiwa or a .urdf file (got '$robot')" >&2; exit 2 ;;
esac
if [ -n "$summary" ]; then
  touch "$summary" 2>/dev/null || { echo "demo.sh: --summary $summary: cannot write there" >&2; exit 2; }
fi

[[ "$view_port" =~ ^[0-9]+$ ]] || { echo "demo.sh: --view-port must be a port number (got '$view_port')" >&2; exit 2; }

source "$root/tools/deps.sh"
packages=("${chasles_packages_build[@]}" "${chasles_packages_plots[@]}")
[ $view = 0 ] || packages+=("${chasles_packages_python[@]}")  # the venv's interpreter and headers
chasles_install_missing "${packages[@]}"

build=${CHASLES_BUILD_DIR:-$root/build}
echo "Building chasles, chasles_plant, chasles_controller, chasles_loop_bench and chasles_tick_bench in $build ..."
# MuJoCo's library at the version tools/mujoco.sh pins, for chasles_plant --engine mujoco.
[ "$engine" = mujoco ] && chasles_cmake_options=("-DCHASLES_MUJOCO_PREFIX=$("$root/tools/mujoco.sh")")
view_targets=()
if [ $view = 1 ]; then
  # The view: the Python package (CHASLES_PYTHON=ON) in the project's venv, which pins viser.
  chasles_cmake_options+=(-DCHASLES_PYTHON=ON "-DPython_EXECUTABLE=$("$root/tools/python.sh" "$build/venv")")
  view_targets=(_core chasles_python_sources)
fi
chasles_build demo "$build" chasles chasles_plant chasles_controller_daemon chasles_loop_bench chasles_tick_bench \
  "${view_targets[@]}" || exit 1

dir="$build/demo/$(date +%Y%m%d-%H%M%S)"
mkdir -p "$dir"
DEMO_VIEW=
relay=
if [ $view = 1 ]; then
  # The host's side of the view's relay (start_view says why); it listens before the run starts, so
  # that a port already taken is said now.
  python3 "$root/tools/demo/relay.py" "tcp:$view_host:$view_port" "unix:$dir/view.sock" >"$dir/host_relay.out" \
    2>"$dir/host_relay.err" &
  relay=$!
  trap '[ -n "$relay" ] && kill "$relay" 2>/dev/null; wait' EXIT
  until grep -qs '^relay: listening' "$dir/host_relay.out"; do
    kill -0 "$relay" 2>/dev/null || { echo "demo.sh: the view's relay: $(cat "$dir/host_relay.err")" >&2; exit 1; }
    sleep 0.05
  done
  DEMO_VIEW="http://$(sed -n 's/^relay: listening on //p' "$dir/host_relay.out")"
fi
export DEMO_INSIDE=1 DEMO_DIR="$dir" DEMO_BUILD="$build" DEMO_SECONDS="$seconds" DEMO_URDF="$urdf" \
  DEMO_TIP="$tip" DEMO_TICK="$tick" DEMO_PROTOCOL="$protocol" DEMO_ENGINE="$engine" DEMO_VIEW="$DEMO_VIEW"
"$root/tools/netns.sh" bash "$root/tools/demo.sh"

# The figures of the run, from its LCM log (before the report, which reads the clearance from them).
if ! "$build/tools/chasles" log plot "$dir/chasles.lcmlog" --out "$dir/plots" --urdf "$urdf" ${tip:+--tip "$tip"} \
  --command-channel "$command_channel" \
  >"$dir/plots.json" 2>"$dir/plots.err"; then
  echo "demo.sh: chasles log plot failed: $(cat "$dir/plots.err")" >&2
  exit 1
fi
report
echo "Plots: $dir/plots/ ($(python3 -c 'import json, os, sys; print(", ".join(os.path.basename(p) for p in json.load(open(sys.argv[1]))["plots"]))' "$dir/plots.json"))"
echo "  CSV of a channel: $build/tools/chasles log export $dir/chasles.lcmlog --channel CHASLES_STATUS --out status.csv"
if [ -n "$summary" ]; then
  cp "$dir/summary.json" "$summary"
  echo "Controller summary copied to $summary"
fi
