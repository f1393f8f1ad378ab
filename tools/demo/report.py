#!/usr/bin/env python3
"""The demo's report (tools/demo.sh): the controller's summary beside the loop bench's reference,
and what the run's LCM log holds. Exits 1 if a check of the run fails.

    tools/demo/report.py DEMO_DIR
"""
import csv, json, math, os, re, struct, sys
from collections import Counter

d = sys.argv[1]
s = json.load(open(os.path.join(d, "summary.json")))
ref = json.load(open(os.path.join(d, "loop_bench.json")))
model = json.load(open(os.path.join(d, "model.json")))

def f(x, digits=1):
    return "-" if x is None else f"{x:.{digits}f}"

def pct(p, unit="us"):
    return f"p50 {f(p['p50']):>7}  p99 {f(p['p99']):>7}  max {f(p['max']):>8} {unit}"

def ratio(a, b):
    return "-" if not b else f"{a / b:.2f}"

jit, sleep = s["jitter_us"], ref["sleep_jitter_us"]
lat, rtt = s["latency_us"], ref["lcm_round_trip_us"]
track = s["tracking_error"]
unit = "rad" if all(t != "prismatic" for t in model["joint_types"]) else "rad or m"
print()
print(f"{model['robot']}: {model['dof']} joints to {model['tip_link']}; controller {'SCHED_FIFO' if s.get('realtime') else 'SCHED_OTHER (real time refused)'}")
print(f"  ticks               {s['ticks']} in {f(s.get('seconds'), 2)} s ({f(s['rate_hz'], 1)} Hz), {s.get('tick', 'clock')}-driven")
print(f"  wake-up jitter      {pct(jit)}   ({'state arrival' if s.get('tick') == 'state' else 'schedule'} -> tick start)")
print(f"  overruns            {s['overruns']}")
print(f"  compute             {pct(s['compute_us'])}")
print(f"  latency             {pct(lat)}   (state arrival -> command sent)")
print(f"  tracking error      rms {track['rms']:.3g}  max {track['max']:.3g} {unit}")
print(f"  stale states        {s['stale_states']}")
print(f"  rejected messages   {s['rejected_messages']}")
print(f"  faults              {s['faults']}")
print(f"  contact             {s.get('contacts', 0)} contacts, {s.get('reflexes', 0)} reflexes; peak estimated tip force "
      f"{f(s.get('peak_tip_force_n'), 1)} N (the plant pushed 30 N)")
# What the controller said about refusals and faults, and the plant's own account.
notes = [line.rstrip() for line in open(os.path.join(d, "chasles_controller.err"))
         if any(w in line for w in ("warning", "refused", "FAULT", "rejected", "REFLEX"))]
for line in notes[:6]:
    print(f"  {line}")
if len(notes) > 6:
    print(f"  ... {len(notes) - 6} more in {os.path.join(d, 'chasles_controller.err')}")
late_pct = None
plant = [line.strip() for line in open(os.path.join(d, "chasles_plant.err")) if "stopped after" in line]
if plant:
    m = re.search(r"late cycles (\d+) of (\d+) commanded steps \(([0-9.]+) %\), late stops (\d+)", plant[-1])
    if m:
        print(f"  late cycles (plant) {m.group(1)} of {m.group(2)} commanded steps ({m.group(3)} %), {m.group(4)} late stops")
        late_pct = float(m.group(3))
    print(f"  {plant[-1]}")
print()
print(f"Reference on this machine (chasles_loop_bench, {ref['sched']}, {f(ref['seconds'], 0)} s each):")
print(f"  bare 1 kHz loop     {pct(sleep)}, {sleep['late_500us']} wake-ups > 500 us")
print(f"  LCM ping-pong       {pct(rtt)}  ({rtt['message_bytes']}-byte robot_state_t, {rtt['answered']}/{rtt['sent']} answered)")
if rtt.get("sent"):
    print(f"  ping-pongs slower than a period: {rtt['beyond_period']} of {rtt['sent']} ({100 * rtt['beyond_period'] / rtt['sent']:.3f} %), "
          "the late cycles a bare LCM exchange would have")
print(f"  jitter  p99: controller / bare loop       = {ratio(jit['p99'], sleep['p99'])}")
print(f"  latency p50: controller / LCM round trip  = {ratio(lat['p50'], rtt['p50'])}")
print(f"  latency p99: controller / LCM round trip  = {ratio(lat['p99'], rtt['p99'])}")
ticks = json.load(open(os.path.join(d, "tick_bench.json")))
print("Controller::tick alone, in closed loop with no other work between ticks (chasles_tick_bench, 5 s per law):")
for law, t in ticks.items():
    print(f"  {law:<20} p50 {f(t['p50_us'], 2):>6}  p99 {f(t['p99_us'], 2):>6}  max {f(t['max_us'], 1):>7} us, "
          f"{t['allocations']} allocations")

# The LCM log's events, (utime, channel, data), in order (LCM's log format: a 28-byte header each,
# (sync 0xEDA1DA01, number, utime, channel length, data length), then the channel and the data).
def events(path):
    with open(path, "rb") as file:
        while True:
            head = file.read(28)
            if len(head) < 28:
                return
            sync, _, utime, channel_len, data_len = struct.unpack(">IqqII", head)
            if sync != 0xEDA1DA01:
                return
            channel = file.read(channel_len).decode(errors="replace")
            yield utime, channel, file.read(data_len)

log = os.path.join(d, "chasles.lcmlog")
counts = Counter(channel for _, channel, _ in events(log))

# The compliant segment: the plant's contact force (TRUTH) while the arm rests on the table, against
# the two springs in series.
press = json.load(open(os.path.join(d, "press.json")))
def doubles(data, offset, n):
    return list(struct.unpack_from(f">{n}d", data, offset)), offset + 8 * n
truth_f = []
for utime, channel, data in events(log):
    if not (press["from_utime"] <= utime <= press["to_utime"]):
        continue
    if channel.endswith("TRUTH"):  # hash, utime, seq, num_joints, tau_ext[n], tip_wrench_ext[6], contact
        n = struct.unpack_from(">i", data, 24)[0]
        wrench, _ = doubles(data, 28 + 8 * n, 6)
        truth_f.append(wrench[5])
k, K, depth = press["press_k"], press["table_k"], press["depth"]
expected = k * K / (k + K) * depth
# The controller's side of the same window: its estimate of the force, and whether it faulted.
window = [r for r in csv.DictReader(open(os.path.join(d, "status.csv")))
          if press["from_utime"] <= int(r["log_utime"]) <= press["to_utime"]]
mujoco = press.get("engine") == "mujoco"
if mujoco and window:
    # MuJoCo's table is no spring of a known stiffness: the commanded spring at the deflection the
    # tip shows (its height above the press's goal) is what the table must push back with.
    deflection = sum(float(r["tip_position[z]"]) for r in window) / len(window) - press["goal_z"]
    expected = k * deflection
estimate = [float(r["tip_wrench_ext[fz]"]) for r in window]
faulted = len({r["faults"] for r in window}) > 1 or any(r["state"] == "3" for r in window)
print()
if mujoco:
    print(f"Compliant segment: Cartesian impedance {k:g} N/m pressing the hand {100 * depth:g} cm into MuJoCo's table:")
else:
    print(f"Compliant segment: Cartesian impedance {k:g} N/m pressing {100 * depth:g} cm behind a {K:g} N/m table:")
if truth_f:
    mean = sum(truth_f) / len(truth_f)
    print(f"  contact force (plant's truth)   {mean:.3f} N, mean of {len(truth_f)} steps at rest on the table")
    if estimate:
        print(f"  contact force (controller's estimate) {sum(estimate) / len(estimate):.3f} N, mean of {len(estimate)} statuses")
    if mujoco:
        print(f"  k (z_tip - z_goal)              {expected:.3f} N  (truth / expected = {mean / expected:.4f})")
    else:
        print(f"  k K/(k + K) depth               {expected:.3f} N  (truth / expected = {mean / expected:.4f})")
else:
    print("  the plant reported no contact with the table while the arm pressed on it")
if faulted:
    print("  a FAULT came during the press (a stall of the machine past --stale-ms, see the controller's stderr): the")
    print("  controller then held where the arm was, which released the press; the figure above is not the press's")
# The push, where the controller's locator put it (contact.csv, PREFIX CONTACT) against where the
# plant says it was (truth.csv: its largest contact, MuJoCo's), state by state over the push.
push_path, contact_path, truth_path = (os.path.join(d, n) for n in ("push.json", "contact.csv", "truth.csv"))
push = json.load(open(push_path)) if os.path.exists(push_path) else {"link": ""}
# Only MuJoCo's plant names the link it pushes (chasles's pushes the tip's origin with a wrench).
if push["link"] and os.path.exists(contact_path) and os.path.exists(truth_path):
    inside = lambda r: push["from_utime"] <= int(r["utime"]) <= push["to_utime"]
    truth = {r["utime"]: r for r in csv.DictReader(open(truth_path)) if inside(r) and r.get("largest_contact_link")}
    found = [r for r in csv.DictReader(open(contact_path)) if inside(r) and r["state"] == "1"]
    pairs = [(r, truth[r["utime"]]) for r in found if r["utime"] in truth]
    print()
    if pairs:
        xyz = lambda r, key: [float(r[f"{key}[{a}]"]) for a in "xyz"]
        off = sorted(math.dist(xyz(r, "point"), xyz(t, "largest_contact_point")) for r, t in pairs)
        links = Counter(r["link"] for r, _ in pairs)
        right = sum(r["link"] == t["largest_contact_link"] for r, t in pairs)
        compute = sorted(float(r["compute_us"]) for r in found)
        print(f"Contact anywhere on the arm: the push on {push['link']}, located from the external torque alone "
              f"({len(found)} estimates at up to 100 Hz):")
        print(f"  link                {right} of {len(pairs)} on the truth's ({', '.join(f'{l} {n}' for l, n in links.most_common(3))})")
        print(f"  point               {1e3 * off[len(off) // 2]:.1f} mm from the truth's, median; "
              f"{1e3 * off[int(0.9 * (len(off) - 1))]:.1f} mm p90")
        print(f"  search              {compute[len(compute) // 2]:.0f} us median, {compute[-1]:.0f} us max (its own thread)")
    else:
        print(f"Contact anywhere on the arm: no located contact during the push on {push['link']} "
              f"({len(found)} estimates, {len(truth)} true contacts)")
# The waypoint trajectory, the stream and the jog, from the controller's statuses (status.csv).
statuses = list(csv.DictReader(open(os.path.join(d, "status.csv"))))
errors_of = lambda r: [float(v) for k, v in r.items() if k.startswith("tracking_error[")]
plan = json.load(open(os.path.join(d, "trajectory_plan.json")))
active, last = [], None
for r in statuses:
    if r["trajectory_id"] != str(plan["id"]):
        continue
    st = {"e": errors_of(r), "outcome": int(r["trajectory_outcome"]), "elapsed": float(r["trajectory_elapsed"]),
          "duration": float(r["trajectory_duration"]), "scale": float(r["trajectory_time_scale"]),
          "waypoint": int(r["trajectory_waypoint"]), "message": r["trajectory_message"]}
    last = st
    if st["outcome"] == 1:
        active.append(st)
outcomes = ["NONE", "ACTIVE", "SUCCEEDED", "ABORTED", "PREEMPTED", "REJECTED"]
duration_planned = plan["points"][-1]["time_from_start"]
print()
print(f"Waypoint trajectory {plan['id']}: {len(plan['points'])} waypoints off the table to the second pose, the first and "
      f"home, {duration_planned:.3f} s as planned ({plan['planner']}):")
if last is None:
    print("  the controller's statuses never named it")
else:
    outcome = outcomes[last["outcome"]] if 0 <= last["outcome"] < len(outcomes) else str(last["outcome"])
    print(f"  outcome             {outcome} at {last['elapsed']:.3f} s of {last['duration']:.3f} s, waypoint "
          f"{last['waypoint']} of {len(plan['points'])}" + (f"; {last['message']}" if last["message"] else ""))
    print(f"  time scale          {last['scale']:.3f}" + (" (as planned: within every limit)" if last["scale"] == 1.0
                                                         else " (the controller slowed it to fit its limits)"))
    if active:
        errors = [abs(x) for st in active for x in st["e"]]
        rms = math.sqrt(sum(x * x for x in errors) / len(errors))
        worst = max(active, key=lambda st: max(abs(x) for x in st["e"]))
        milli = "mrad" if unit == "rad" else "mrad or mm"
        print(f"  tracking error      rms {1e3 * rms:.4f}  max {1e3 * max(errors):.4f} {milli} ({worst['elapsed']:.3f} s into "
              f"it) over {len(active)} statuses while it ran; {1e3 * max(abs(x) for x in active[0]['e']):.4f} at its start")
# The stream and the jogs: the statuses of each by the controller's running counts of setpoints and jog
# commands taken, against what each `chasles stream` and `chasles jog` sent (streams.jsonl, in order).
sent = [json.loads(line) for line in open(os.path.join(d, "streams.jsonl"))]
stream_counts = [x["sent"] for x in sent if x["channel"].endswith("SETPOINT")]
jog_counts = [x["sent"] for x in sent if x["channel"].endswith("JOG")]
def nth(rows, counts, field, k):
    """The rows taken while the k-th stream or jog (from 0) ran: its count range of `field`."""
    lo, hi = sum(counts[:k]), sum(counts[:k + 1])
    return [r for r in rows if lo < int(r[field]) <= hi]
streaming = nth([r for r in statuses if r["streaming"] == "1"], stream_counts, "setpoints", 0)
jogging = [r for r in statuses if r["jogging"] == "1"]
print()
print("Stream of joint setpoints (30 Hz, 4 s, every joint swinging toward the middle of its range and back):")
if streaming:
    errors = [abs(x) for r in streaming for x in errors_of(r)]
    milli = "mrad" if unit == "rad" else "mrad or mm"
    print(f"  setpoints           {streaming[-1]['setpoints']} taken, {streaming[-1]['setpoints_dropped']} dropped "
          f"(late or repeated) by its last status")
    print(f"  tracking error      rms {1e3 * math.sqrt(sum(x * x for x in errors) / len(errors)):.4f}  "
          f"max {1e3 * max(errors):.4f} {milli} over {len(streaming)} statuses while it ran")
else:
    print("  no status showed it streaming")
limits = ["nothing", "a joint's velocity limit", "a joint's position limit", "a singularity ahead"]
for title, rows in (("Joint jog (every joint toward the middle of its range at 0.25 rad/s for 1 s):",
                     nth(jogging, jog_counts, "jogs", 0)),
                    ("Twist jog (the tip down at 3 cm/s for 1.5 s, in the base frame):",
                     nth(jogging, jog_counts, "jogs", 1))):
    print(title)
    if not rows:
        print("  no status showed it jogging")
        continue
    cut = Counter(int(r["jog_limited_by"]) for r in rows)
    kappa = [float(r["jog_condition"]) for r in rows]
    print(f"  commands            {rows[-1]['jogs']} taken in all, {rows[-1]['jogs_dropped']} dropped")
    print(f"  J_b condition       {kappa[0]:.1f} -> {kappa[-1]:.1f} (a twist toward a singularity slows from 17, stops before 30)")
    print(f"  speed               {100 * min(float(r['jog_scale']) for r in rows):.0f} % of the asked at the least; cut by " +
          ", ".join(f"{limits[k] if 0 <= k < 4 else k} in {n}" for k, n in sorted(cut.items())) + f" of {len(rows)} statuses")
    p0 = [float(rows[0][f"tip_position[{a}]"]) for a in "xyz"]
    p1 = [float(rows[-1][f"tip_position[{a}]"]) for a in "xyz"]
    print(f"  tip moved           ({1e3 * (p1[0] - p0[0]):+.1f}, {1e3 * (p1[1] - p0[1]):+.1f}, {1e3 * (p1[2] - p0[2]):+.1f}) mm "
          "over the statuses while it ran")
# Clearance: the controller kept the arm clear of itself and the scene (the Panda; clearance.json says
# when the two segments aimed at a collision ran); `chasles log plot` read clearance_distance and
# clearance_slowed_by off the log (plots.json).
failures = []
plots = json.load(open(os.path.join(d, "plots.json"))) if os.path.exists(os.path.join(d, "plots.json")) else {}
if os.path.exists(os.path.join(d, "clearance.json")):
    seg = json.load(open(os.path.join(d, "clearance.json")))
    cl = plots.get("clearance")
    geometry = [line.strip().split(": ", 1)[1] for line in open(os.path.join(d, "chasles_controller.err"))
                if line.startswith("chasles_controller: collision geometry:")]
    print()
    print(f"Clearance ({geometry[0] if geometry else 'collision geometry'}; the scene {os.path.relpath(seg['scene'], os.path.dirname(os.path.dirname(os.path.dirname(seg['scene']))))}: "
          f"a wall at y = 0.52 m, every link kept {100 * seg['wall']['stop']:g} cm behind it):")
    if cl is None:
        failures.append("the controller's statuses named no closest pair: it ran without collision geometry")
    else:
        print(f"  closest of the run  {1e3 * cl['least_distance']:.1f} mm ({cl['least_pair']}) at {cl['least_t']:.2f} s of the log")
        is_arm = lambda name: "/" in name  # an arm object is <link>/<k>; a scene object or plane has its own name
        for key, title, wanted in (
                ("wall", "Twist jog toward the wall (15 cm/s along +y for 2.5 s, 37 cm):",
                 lambda pair: seg["wall"]["name"] in pair.split(" and ")),
                ("fold", "Stream swinging the fingers into the forearm (joint 7 from 0.785 to -0.785 rad in 2 s, the wrist bent back):",
                 lambda pair: all(is_arm(x) for x in pair.split(" and ")))):
            w = seg[key]
            runs = [r for r in cl["slowed"] if r["to_utime"] >= w["from_utime"] and r["from_utime"] <= w["to_utime"]]
            hits = [r for r in runs if wanted(r["pair"])]
            print(title)
            if not hits:
                print(f"  not stopped short: no status in it named a {'wall' if key == 'wall' else 'self'} pair as "
                      "slowing the reference" + (f" (slowed by {', '.join(sorted({r['pair'] for r in runs}))})" if runs else ""))
                failures.append(f"the {'jog toward the wall' if key == 'wall' else 'folding stream'} was not stopped short by "
                                f"{'the wall' if key == 'wall' else 'a pair of the arm'}")
                continue
            least = min(hits, key=lambda r: r["least_distance"] if r["least_distance"] is not None else math.inf)
            pair, dist = least["pair"], least["least_distance"]
            ok = dist is not None and dist >= w["stop"]
            print(f"  stopped short       slowed by {pair} for {sum(r['to'] - r['from'] for r in hits):.2f} s "
                  f"({sum(r['statuses'] for r in hits)} statuses)")
            print(f"  least distance      {'-' if dist is None else f'{1e3 * dist:.1f}'} mm ({least['least_pair']}); "
                  f"its stop distance {1e3 * w['stop']:g} mm" + ("" if ok else "  <- INSIDE IT"))
            if not ok:
                failures.append(f"{pair} came within its stop distance {1e3 * w['stop']:g} mm "
                                f"({'-' if dist is None else f'{1e3 * dist:.1f}'} mm)")
print()
print(f"Log: {log} ({os.path.getsize(log) / 1e6:.1f} MB; " +
      ", ".join(f"{c} {n}" for c, n in sorted(counts.items())) + ")")
print(f"Run directory: {d} (each process's output, summary.json, loop_bench.json, targets.jsonl, trajectory_plan.json, "
      "stream_plan.json, streams.jsonl, status.csv" + (", fold_plan.json, clearance.json" if failures or plots.get("clearance") else "") + ")")
if failures:
    for failure in failures:
        print(f"demo.sh: clearance: {failure}", file=sys.stderr)
    sys.exit(1)
