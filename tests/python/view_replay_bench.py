"""The replay's speed, as docs/view.md gives it; not a test (it prints figures and asserts nothing
about speed). Issue [V]'s targets: a 15 MB demo log opens in at most 5 s, and a seek anywhere in
it takes at most 100 ms.

  build/venv/bin/python tests/python/view_replay_bench.py [--mb 15] [--log FILE] [--seeks 30]

with PYTHONPATH=build/python and CHASLES_TEST_DATA=tests/data; no bus is used (a replay hears
none), so it needs no network namespace. Without --log it writes a log as a demo's lcm-logger
would (lcm.EventLog, real lcm-gen-encoded messages at the demo's rates: robot_state_t,
joint_torque_command_t and sim_truth_t at 1 kHz, controller_status_t at 100 Hz, contact_estimate_t
at 100 Hz while the arm is pushed, a target every 2 s) until it holds --mb megabytes. Then:

1. `python -m chasles.view LOG` as a process: the time from its start to its line
   `chasles view: http://...`, and to the page in headless Chromium showing the first state
   drawn (the panel's `state seq`, then one animation frame);
2. a seek in the browser, as a person makes it: End or Home on the time slider, timed by the
   page's own clock from the key's event to the panel showing the new log time;
3. a seek in-process (the view built in this process on its own viser server): Replay.show(t) at
   random times, what a frame does after the slider's change, from the seek to the draw sent.
"""
from __future__ import annotations

import argparse
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import lcm  # noqa: E402
import numpy as np  # noqa: E402

from chasles.lcmtypes import arm_target_t, contact_estimate_t, joint_torque_command_t, sim_truth_t  # noqa: E402
from test_view import DATA, Q1, TIP, URDF, state, status  # noqa: E402
from view_browser import Browser  # noqa: E402

PACKAGES = os.path.join(DATA, "packages")


def write_demo_log(path: str, megabytes: float) -> float:
    """A log of a demo's channels at its rates, until it holds `megabytes` MB; returns its length, s."""
    log = lcm.EventLog(path, "w", overwrite=True)
    t0 = 1_800_000_000_000_000  # µs
    rng = np.random.default_rng(3)
    truth, command, contact = sim_truth_t(), joint_torque_command_t(), contact_estimate_t()
    truth.num_joints, command.num_joints = 7, 7
    k = 0
    while os.path.getsize(path) < megabytes * 1e6 or k % 1000:
        t = k * 1e-3
        pushed = t % 10 >= 8  # a push for 2 s of every 10
        q = Q1 + 0.4 * np.sin(2 * math.pi * 0.1 * t + np.arange(7))
        # The logger's receive times: each message's send time and a few tens of µs of transport.
        utime = t0 + k * 1000 + int(rng.integers(20, 80))
        m = state(q, k)
        m.utime, m.velocity, m.effort = t0 + k * 1000, list(0.1 * np.cos(t + np.arange(7))), list(np.sin(t + np.arange(7)))
        log.write_event(utime, "CHASLES_STATE", m.encode())
        truth.utime, truth.seq, truth.tau_ext = m.utime, k, list(0.01 * np.sin(t + np.arange(7)))
        truth.contact, force = pushed, (30.0 if pushed else 0.0)
        truth.tip_wrench_ext = [0.0, 0.0, 0.0, force, 0.0, 0.0]
        log.write_event(utime + 5, "CHASLES_TRUTH", truth.encode())
        command.utime, command.seq, command.state_seq = m.utime + 150, k, k
        command.torque = list(np.sin(t + np.arange(7)))
        log.write_event(utime + 200, "CHASLES_COMMAND", command.encode())
        if k % 10 == 0:
            s = status(q, q + 0.05 * math.sin(t), k, force=(force, 0.0, 0.0) if pushed else None)
            s.utime = m.utime + 300
            log.write_event(utime + 350, "CHASLES_STATUS", s.encode())
            if pushed:
                contact.utime, contact.seq, contact.state, contact.contact = s.utime, k, contact_estimate_t.LOCATED, True
                contact.link, contact.point, contact.normal = "panda_hand", list(s.tip_position), [-1.0, 0.0, 0.0]
                contact.force = [force, 0.0, 0.0]
                log.write_event(utime + 600, "CHASLES_CONTACT", contact.encode())
        if k % 2000 == 0:
            target = arm_target_t()
            target.utime, target.mode, target.num_joints = m.utime, arm_target_t.JOINT, 7
            target.joint_position = list(Q1 + 0.2 * math.sin(t))
            target.duration = 1.5
            log.write_event(utime + 10, "CHASLES_TARGET", target.encode())
        k += 1
    log.close()
    return (k - 1) * 1e-3


def figures(values) -> str:
    v = sorted(values)
    return (f"median {1e3 * statistics.median(v):.1f} ms, p90 {1e3 * v[int(0.9 * (len(v) - 1))]:.1f} ms, "
            f"max {1e3 * v[-1]:.1f} ms over {len(v)}")


def as_a_process(path: str, seeks: int, rng) -> None:
    started = time.monotonic()
    view = subprocess.Popen([sys.executable, "-m", "chasles.view", path, "--urdf", URDF, "--tip", TIP,
                             "--package-dir", PACKAGES, "--port", "0", "--paused"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    browser = None
    try:
        line = view.stdout.readline()
        served = time.monotonic() - started
        match = re.fullmatch(r"chasles view: (http://\S+)\s*", line)
        if not match:
            raise SystemExit(f"the view printed {line!r}; stderr:\n{view.stderr.read()}")
        print(f"open: `python -m chasles.view LOG` printed its address after {served:.2f} s")
        browser = Browser(960, 720)
        browser_up = time.monotonic() - started
        browser.open(match.group(1))
        text = browser.wait_text(r"state seq \d+", timeout=60)
        browser.frames(1)
        drawn = time.monotonic() - started
        print(f"open: the page showed the first state drawn {drawn:.2f} s after the start "
              f"(Chromium itself started by {browser_up:.2f} s; {drawn - browser_up:.2f} s from its page's load)")
        duration = float(re.search(r"log \d+\.\d+ s of (\d+\.\d+) s", text).group(1))
        # From the keyboard on the slider's thumb, as the test does: End and Home in turn, each a
        # seek across the whole log. (Chromium's synthetic clicks on Mantine's track are not taken.)
        # The page's own clock times it: from the key's event to the panel's text changing to the
        # new time (a MutationObserver), not counting this script's polls.
        slider = "document.querySelector('[role=slider]')"
        browser.evaluate("""(() => {
            window.seeks = [];
            document.addEventListener('keydown', () => window.seeks.push(['key', performance.now()]), true);
            new MutationObserver(() => {
                const m = document.body.innerText.match(/log (\\d+\\.\\d+) s of/);
                if (m && m[1] !== window.shown) { window.shown = m[1]; window.seeks.push([m[1], performance.now()]); }
            }).observe(document.body, {subtree: true, childList: true, characterData: true});
        })()""")
        browser.evaluate(f"{slider}.focus()")
        times = []
        for k in range(seeks):
            key, code, want = ("End", 35, f"{duration:.3f}") if k % 2 == 0 else ("Home", 36, "0.000")
            for kind in ("keyDown", "keyUp"):
                browser.call("Input.dispatchKeyEvent", type=kind, key=key, code=key, windowsVirtualKeyCode=code)
            browser.wait_text(rf"log {re.escape(want)} s of", timeout=30)
            marks = dict(browser.evaluate("window.seeks.splice(0)"))
            times.append((marks[want] - marks["key"]) / 1e3)
        print(f"seek in the browser (End or Home on the slider, until the panel shows the new time; "
              f"log of {duration:.1f} s): {figures(times)}")
    finally:
        if browser is not None:
            browser.close()
        view.terminate()
        view.wait(timeout=10)


def in_process(path: str, seeks: int, rng) -> None:
    """The view built here as python -m chasles.view builds it, Replay.show(t) timed."""
    import contextlib
    import io

    import viser

    import chasles
    from chasles.view.app import View, default_camera, setup_scene
    from chasles.view.replay import Replay
    from chasles.view.shapes import load_parts

    model = chasles.Model.from_urdf(URDF, tip=TIP)
    parts, notes = load_parts(URDF, model.link_names, [PACKAGES])
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        setup_scene(server, default_camera([T[:3, 3] for T in model.link_poses(np.zeros(model.nq))]))
        view = View(server, model, parts, notes, say=lambda text: None)
        started = time.perf_counter()
        replay = Replay(view, path, playing=False)
        print(f"open, in-process: Replay() took {time.perf_counter() - started:.2f} s")
        times = []
        for _ in range(seeks):
            t = rng.uniform(0, replay.duration)
            started = time.perf_counter()
            replay.show(t)
            times.append(time.perf_counter() - started)
        print(f"seek in-process (Replay.show at a random time: the messages found and handed over, the draw "
              f"and the plots sent; a slider's change waits besides for the next frame, at most "
              f"{1e3 * view.period:.0f} ms): {figures(times)}")
    finally:
        with contextlib.redirect_stdout(io.StringIO()):
            server.stop()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mb", type=float, default=15.0, help="the written log's size, MB (default 15)")
    p.add_argument("--log", help="a log to measure instead (a demo's, build/demo/<time>/chasles.lcmlog)")
    p.add_argument("--seeks", type=int, default=30, help="seeks timed in each way (default 30)")
    args = p.parse_args()
    rng = np.random.default_rng(11)
    with tempfile.TemporaryDirectory(prefix="chasles-replay-bench-") as folder:
        path = args.log
        if path is None:
            path = os.path.join(folder, "demo.lcmlog")
            started = time.monotonic()
            seconds = write_demo_log(path, args.mb)
            print(f"wrote {path}: {os.path.getsize(path) / 1e6:.1f} MB, {seconds:.1f} s of a demo "
                  f"(in {time.monotonic() - started:.1f} s)")
        else:
            print(f"log {path}: {os.path.getsize(path) / 1e6:.1f} MB")
        print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        as_a_process(path, args.seeks, rng)
        in_process(path, args.seeks, rng)


if __name__ == "__main__":
    main()
