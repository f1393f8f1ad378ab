#!/usr/bin/env bash
# Benchmarks chasles against Orocos KDL (tests/bench/dynamics_bench.cpp) on the UR5 and the Panda
# and prints, per robot and quantity, the median time of each and their ratio, next to the ratio
# Pinocchio reaches against KDL (the anchor the issue sets); then inverse kinematics, chasles's
# Ceres solver against KDL's NR_JL on the reference targets (tests/bench/ik_bench.cpp); then contact
# estimation, chasles's momentum observer and tip wrench against KDL's ChainExternalWrenchEstimator
# on the same recording, time per update and accuracy (tests/bench/contact_bench.cpp). Installs
# missing Debian packages, builds a separate Release tree in build-bench/ and only the benchmark
# targets there.
#
# Then chasles against Pinocchio (tests/bench/pinocchio_bench.cpp): Pinocchio's own C++ from the
# pip package `pin`, at the version tools/pinocchio.sh pins, which that script installs in the
# project's venv build-bench/venv; the binary compiles its headers with chasles's flags. One run of
# that binary gives, per robot and quantity (fk, J_b, RNEA, M, forward dynamics), chasles's and
# Pinocchio's time and their ratio against the issue's target of 0.50; for M and forward dynamics
# Pinocchio's time is the faster of crba's / aba's two conventions (LOCAL, WORLD), both timed.
# Without PyPI (no venv) it says so on stderr and the rest runs without that table.
#
# Then the distances a tick watches (tests/bench/proximity_bench.cpp, with the same venv): chasles's
# compute_distances, and every pair exact, against Pinocchio's computeDistances on coal (the wheel's
# libcoal), on the Panda's self pairs plus a 6-object scene, the same shapes and pairs, on a clear
# 1 kHz path and on uniform configurations: p50, p99 and max µs per call, the ratios, the issue's
# targets, agreement with coal and allocations. Without the venv it is left out with the Pinocchio
# table.
#
# Last, online trajectory generation: chasles's OnlineGenerator (core/motion) against Ruckig's C++
# (tests/bench/otg_bench.cpp), from the sdist of the PyPI package ruckig at the version
# tools/ruckig.sh pins, compiled into chasles_ruckig_bench with chasles's flags: on the same 10^5
# random 7-axis problems, the ratio of the durations (max, mean), failures and sampled limit
# violations of each, and ns per plan of each with their ratio. Without PyPI it says so on stderr
# and the rest runs without that table.
#
#   tools/bench.sh                                  the tables (build and benchmark noise on stderr)
#   tools/bench.sh --json                           {"<robot>": {"<quantity>": {"chasles_ns": .., "kdl_ns": ..,
#                                                   "pinocchio": {"chasles_ns": .., "pinocchio_ns": ..}}}}
#                                                   on stdout, nothing else ("pinocchio" only where
#                                                   that binary ran: its own run's chasles time, and
#                                                   for M and FD "pinocchio_convention", the faster)
#   tools/bench.sh --benchmark_filter=ur5           other arguments go to chasles_bench and
#                                                   chasles_pinocchio_bench (and override the
#                                                   defaults below)
#
# Times are the median of 3 repetitions of at least 0.2 s each, CPU time per call (against
# Pinocchio: 5 repetitions, interleaved at random so that the load of a shared machine hits both);
# the whole run takes about a minute. Benchmark names are "<chasles|kdl|pinocchio>/<robot>/<quantity>".
# The IK and contact tables follow; --json leaves them out.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

json=0
args=()
for arg in "$@"; do
  case "$arg" in
    --json) json=1 ;;
    *) args+=("$arg") ;;
  esac
done

source "$root/tools/deps.sh"
chasles_install_missing "${chasles_packages_build[@]}" "${chasles_packages_bench[@]}" >&2

# Pinocchio's C++ comes from the project's venv (tools/pinocchio.sh makes it); without it, no
# chasles_pinocchio_bench, and the rest runs.
pinocchio_prefix=""
if ! pinocchio_prefix=$("$root/tools/pinocchio.sh"); then
  pinocchio_prefix=""
  echo "bench: no Pinocchio: tools/pinocchio.sh could not make build-bench/venv (see above); running without the comparison with Pinocchio" >&2
fi

# Ruckig's C++ comes from its sdist on PyPI (tools/ruckig.sh fetches and unpacks it); without it, no
# chasles_ruckig_bench, and the rest runs.
ruckig_source=""
if ! ruckig_source=$("$root/tools/ruckig.sh"); then
  ruckig_source=""
  echo "bench: no Ruckig: tools/ruckig.sh could not fetch its sources (see above); running without the comparison with Ruckig" >&2
fi

# MuJoCo's C library for chasles_mujoco_bench (tools/mujoco.sh); without it, that bench is left out.
mujoco_prefix=""
if ! mujoco_prefix=$("$root/tools/mujoco.sh"); then
  mujoco_prefix=""
  echo "bench: no MuJoCo: tools/mujoco.sh could not install it (see above); running without chasles_mujoco_bench" >&2
fi

# Tests and tools are not needed here; leaving them out keeps this build independent of them.
build="$root/build-bench"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCHASLES_BUILD_BENCHMARKS=ON \
  -DCHASLES_BUILD_TESTS=OFF -DCHASLES_BUILD_TOOLS=OFF -DCHASLES_WERROR=OFF \
  -DCHASLES_PINOCCHIO_PREFIX="$pinocchio_prefix" -DCHASLES_RUCKIG_SOURCE="$ruckig_source" \
  -DCHASLES_MUJOCO_PREFIX="$mujoco_prefix" >&2
targets=(chasles_bench chasles_ik_bench chasles_contact_bench)
[ -n "$pinocchio_prefix" ] && targets+=(chasles_pinocchio_bench chasles_coal_bench)
[ -n "$ruckig_source" ] && targets+=(chasles_ruckig_bench)
[ -n "$mujoco_prefix" ] && targets+=(chasles_mujoco_bench)
cmake --build "$build" --target "${targets[@]}" -j 2 >&2

report=$(mktemp)
pinocchio_report=$(mktemp)
ruckig_report=$(mktemp)
trap 'rm -f "$report" "$pinocchio_report" "$ruckig_report"' EXIT
echo "bench: running chasles_bench (about half a minute)" >&2
start=$SECONDS
"$build/tests/bench/chasles_bench" --benchmark_format=json --benchmark_min_time=0.2 \
  --benchmark_repetitions=3 --benchmark_report_aggregates_only=true ${args[@]+"${args[@]}"} >"$report"
echo "bench: chasles_bench took $((SECONDS - start)) s" >&2

if [ -n "$pinocchio_prefix" ]; then
  echo "bench: running chasles_pinocchio_bench (about half a minute)" >&2
  start=$SECONDS
  "$build/tests/bench/chasles_pinocchio_bench" --benchmark_format=json --benchmark_min_time=0.2 \
    --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true \
    --benchmark_report_aggregates_only=true ${args[@]+"${args[@]}"} >"$pinocchio_report"
  echo "bench: chasles_pinocchio_bench took $((SECONDS - start)) s" >&2
fi

python3 - "$report" "$json" "$pinocchio_report" <<'EOF'
import json
import sys

report_path, as_json, pinocchio_path = sys.argv[1], sys.argv[2] == "1", sys.argv[3]
with open(report_path) as f:
    text = f.read()
if not text.strip():
    sys.exit("bench: chasles_bench ran no benchmark (did --benchmark_filter match nothing?)")
report = json.loads(text)
with open(pinocchio_path) as f:
    text = f.read()
# Empty when there was no Pinocchio (or its binary matched nothing): no table for it then.
pinocchio_report = json.loads(text) if text.strip() else {}

robots = ["ur5", "panda"]
quantities = ["fk", "jacobian_space", "jacobian_body", "rnea", "gravity", "mass_matrix", "forward_dynamics"]
# Pinocchio's time as a fraction of KDL's, from the issue.
target = {
    "fk": {"ur5": 0.54, "panda": 0.48},
    "jacobian_body": {"ur5": 0.30, "panda": 0.24},
    "rnea": {"ur5": 0.63, "panda": 0.57},
    "mass_matrix": {"ur5": 0.26, "panda": 0.23},
    "forward_dynamics": {"ur5": 0.53, "panda": 0.48},
}
to_ns = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}

# The median of the repetitions; a plain run (repetitions overridden to 1) has no aggregates.
def median_times(report):
    entries = report.get("benchmarks", [])
    medians = [b for b in entries if b.get("run_type") == "aggregate" and b.get("aggregate_name") == "median"]
    if not medians:
        medians = [b for b in entries if b.get("run_type") == "iteration"]
    times = {}
    for b in medians:
        name = b.get("run_name", b["name"])
        parts = name.split("/")
        if len(parts) != 3:
            continue
        library, robot, quantity = parts
        times[(library, robot, quantity)] = b["cpu_time"] * to_ns[b.get("time_unit", "ns")]
    return times

times = median_times(report)
# chasles's and Pinocchio's times from the one run of chasles_pinocchio_bench.
pinocchio_times = median_times(pinocchio_report)
pinocchio_quantities = ["fk", "jacobian_body", "rnea", "mass_matrix", "forward_dynamics"]
pinocchio_target = 0.50  # the issue's: chasles's time at most half of Pinocchio's

result = {}
for robot in robots:
    for quantity in quantities:
        c, k = times.get(("chasles", robot, quantity)), times.get(("kdl", robot, quantity))
        if c is None and k is None:
            continue
        result.setdefault(robot, {})[quantity] = {
            "chasles_ns": None if c is None else round(c, 1),
            "kdl_ns": None if k is None else round(k, 1),
        }
if not result:
    sys.exit("bench: no chasles/KDL results in the report (did --benchmark_filter match nothing?)")
pinocchio_rows = []
for robot in robots:
    for quantity in pinocchio_quantities:
        c = pinocchio_times.get(("chasles", robot, quantity))
        # Pinocchio at its faster convention where it has two ("<quantity>" LOCAL, ".world" WORLD).
        conventions = {"LOCAL": pinocchio_times.get(("pinocchio", robot, quantity)),
                       "WORLD": pinocchio_times.get(("pinocchio", robot, quantity + ".world"))}
        conventions = {k: v for k, v in conventions.items() if v is not None}
        convention = min(conventions, key=conventions.get) if conventions else None
        p = conventions.get(convention)
        if c is None and p is None:
            continue
        t = {"chasles_ns": None if c is None else round(c, 1), "pinocchio_ns": None if p is None else round(p, 1)}
        if len(conventions) > 1:
            t["pinocchio_convention"] = convention
        result.setdefault(robot, {}).setdefault(quantity, {})["pinocchio"] = t
        pinocchio_rows.append((robot, quantity, t["chasles_ns"], t["pinocchio_ns"], t.get("pinocchio_convention")))

if as_json:
    json.dump(result, sys.stdout, indent=2)
    print()
    sys.exit(0)

def fmt(x, spec):
    return "-" if x is None else format(x, spec)

header = ["robot", "quantity", "chasles ns", "KDL ns", "ratio", "pinocchio/KDL target"]
rows, behind = [], []
for robot, by_quantity in result.items():
    for quantity, t in by_quantity.items():
        if "kdl_ns" not in t:
            continue
        c, k = t["chasles_ns"], t["kdl_ns"]
        ratio = c / k if c is not None and k else None
        goal = target.get(quantity, {}).get(robot)
        rows.append([robot, quantity, fmt(c, ".1f"), fmt(k, ".1f"), fmt(ratio, ".2f"), fmt(goal, ".2f")])
        if ratio is not None and goal is not None and round(ratio, 2) > goal:
            behind.append(f"{robot} {quantity} ({ratio:.2f} > {goal:.2f})")
widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
line = lambda r: "  ".join(str(v).ljust(w) if i < 2 else str(v).rjust(w) for i, (v, w) in enumerate(zip(r, widths)))
print(line(header))
print("  ".join("-" * w for w in widths))
for r in rows:
    print(line(r))
print()
print("ratio = chasles time / KDL time (median CPU time per call); lower is better.")
if behind:
    print("Slower relative to KDL than Pinocchio: " + ", ".join(behind))
else:
    print("chasles is at or below Pinocchio's ratio wherever the issue gives one.")

if not pinocchio_rows:
    sys.exit(0)
context = pinocchio_report.get("context", {})
print()
print(f"Against Pinocchio {context.get('pinocchio_version', '?')} (its C++, compiled into chasles_pinocchio_bench with chasles's flags):")
print()
header = ["robot", "quantity", "chasles ns", "Pinocchio ns", "convention", "ratio", f"<= {pinocchio_target:.2f}"]
rows, behind = [], []
for robot, quantity, c, p, convention in pinocchio_rows:
    ratio = c / p if c is not None and p else None
    met = None if ratio is None else round(ratio, 2) <= pinocchio_target
    rows.append([robot, quantity, fmt(c, ".1f"), fmt(p, ".1f"), convention or "-", fmt(ratio, ".2f"),
                 "-" if met is None else ("yes" if met else "NO")])
    if met is False:
        behind.append(f"{robot} {quantity} ({ratio:.2f})")
widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
print(line(header))
print("  ".join("-" * w for w in widths))
for r in rows:
    print(line(r))
print()
print("ratio = chasles time / Pinocchio time (median CPU time per call, one run of one binary); the target is <= 0.50.")
print("convention: crba's and aba's, LOCAL or WORLD, whichever was faster in this run (both are timed).")
if behind:
    print("Above the target: " + ", ".join(behind))
else:
    print("chasles takes at most half of Pinocchio's time on every quantity.")
EOF

# Inverse kinematics, chasles (Ceres) against KDL (ChainIkSolverPos_NR_JL): success rates and
# times per solve on the reference targets, cold and warm. Table output only: --json keeps the
# dynamics format above.
if [ "$json" = 0 ]; then
  echo
  echo "bench: running chasles_ik_bench (200 targets per robot, cold and warm)" >&2
  "$build/tests/bench/chasles_ik_bench" 2> >(grep -v "KDL does not support a root link" >&2)
fi

# Contact estimation, chasles against KDL's ChainExternalWrenchEstimator: ns per update (median of 5
# repetitions, interleaved at random so that drift hits both) and the accuracy of each on the same
# recording. Table output only, as the IK bench's.
if [ "$json" = 0 ]; then
  echo
  echo "bench: running chasles_contact_bench (about 10 s)" >&2
  "$build/tests/bench/chasles_contact_bench" --benchmark_min_time=0.2 --benchmark_repetitions=5 \
    --benchmark_enable_random_interleaving=true --benchmark_display_aggregates_only=true
fi

# Distances every tick, chasles against Pinocchio + coal: per-call times over 2 × 20,000
# configurations, each library's calls interleaved. Table output only, as the IK bench's.
if [ "$json" = 0 ] && [ -n "$pinocchio_prefix" ]; then
  echo
  echo "bench: running chasles_coal_bench (2 x 20,000 configurations, about 15 s)" >&2
  echo "Distances every tick against Pinocchio + coal (Panda: self pairs + 17 objects x 6 obstacles):"
  echo
  "$build/tests/bench/chasles_coal_bench"
fi

# Online trajectory generation, chasles's OnlineGenerator against Ruckig's calculate() on the same
# 10^5 random 7-axis problems: the ratio of the durations, failures and sampled limit violations of
# each, then ns per plan (median of 5 repetitions, interleaved at random) and their ratio. Table
# output only, as the IK bench's.
if [ "$json" = 0 ] && [ -n "$ruckig_source" ]; then
  echo
  echo "bench: running chasles_ruckig_bench (10^5 problems, about a minute)" >&2
  echo "Online trajectory generation against Ruckig $(basename "$ruckig_source" | sed 's/^ruckig-//'):"
  echo
  "$build/tests/bench/chasles_ruckig_bench" --benchmark_min_time=0.2 --benchmark_repetitions=5 \
    --benchmark_enable_random_interleaving=true --benchmark_display_aggregates_only=true \
    --benchmark_out="$ruckig_report" --benchmark_out_format=json
  python3 - "$ruckig_report" <<'EOF'
import json
import sys

to_ns = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}
with open(sys.argv[1]) as f:
    report = json.load(f)
median = {b["run_name"]: b["cpu_time"] * to_ns[b.get("time_unit", "ns")]
          for b in report.get("benchmarks", [])
          if b.get("run_type") == "aggregate" and b.get("aggregate_name") == "median"}
c, r = median.get("chasles/plan"), median.get("ruckig/calculate")
if c is None or r is None:
    sys.exit("bench: chasles_ruckig_bench reported no median times")
print()
print(f"ns per plan (median CPU time): chasles {c:.0f}, Ruckig {r:.0f}, ratio {c / r:.2f} (the issue's target: <= 1.00)")
EOF
fi

if [ -n "$mujoco_prefix" ]; then
  echo "bench: running chasles_mujoco_bench (the MuJoCo plant's step beside chasles's, and one contact locate)" >&2
  echo
  "$build/tests/bench/chasles_mujoco_bench" --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
fi
