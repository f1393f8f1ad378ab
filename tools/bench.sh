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
#   tools/bench.sh                                  the table (build and benchmark noise on stderr)
#   tools/bench.sh --json                           {"<robot>": {"<quantity>": {"chasles_ns": .., "kdl_ns": ..}}}
#                                                   on stdout, nothing else
#   tools/bench.sh --benchmark_filter=ur5           other arguments go to chasles_bench (and
#                                                   override the defaults below)
#
# Times are the median of 3 repetitions of at least 0.2 s each, CPU time per call; the whole run
# takes about half a minute. Benchmark names are "<chasles|kdl>/<robot>/<quantity>". The IK and
# contact tables follow; --json leaves them out.
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

# Tests and tools are not needed here; leaving them out keeps this build independent of them.
build="$root/build-bench"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCHASLES_BUILD_BENCHMARKS=ON \
  -DCHASLES_BUILD_TESTS=OFF -DCHASLES_BUILD_TOOLS=OFF -DCHASLES_WERROR=OFF >&2
cmake --build "$build" --target chasles_bench chasles_ik_bench chasles_contact_bench -j 2 >&2

report=$(mktemp)
trap 'rm -f "$report"' EXIT
echo "bench: running chasles_bench (about half a minute)" >&2
start=$SECONDS
"$build/tests/bench/chasles_bench" --benchmark_format=json --benchmark_min_time=0.2 \
  --benchmark_repetitions=3 --benchmark_report_aggregates_only=true ${args[@]+"${args[@]}"} >"$report"
echo "bench: chasles_bench took $((SECONDS - start)) s" >&2

python3 - "$report" "$json" <<'EOF'
import json
import sys

report_path, as_json = sys.argv[1], sys.argv[2] == "1"
with open(report_path) as f:
    text = f.read()
if not text.strip():
    sys.exit("bench: chasles_bench ran no benchmark (did --benchmark_filter match nothing?)")
report = json.loads(text)

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
