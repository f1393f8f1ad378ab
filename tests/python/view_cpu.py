"""The view's CPU with a 1 kHz bus, measured over 10 s as docs/view.md gives it; not a test:

  tools/netns.sh build/venv/bin/python tests/python/view_cpu.py [--browser] [--plant]

with PYTHONPATH=build/python and CHASLES_TEST_DATA=tests/data. It runs python -m chasles.view on
the Panda, publishes robot_state_t at 1 kHz (--plant: also sim_truth_t at 1 kHz with a contact and
a controller_status_t at 100 Hz with the reference 0.2 rad away and a contact, as chasles_plant
--push and the controller send), optionally with headless Chromium showing the page, and prints
the view's CPU share of one core (from /proc, per thread) and the rates its panel gives.
"""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from chasles.lcmtypes import sim_truth_t  # noqa: E402
from test_view import DATA, LCM_URL, Q1, TIP, URDF, Bus, status, state  # noqa: E402
from view_browser import Browser  # noqa: E402


def cpu_of_threads(pid: int) -> dict:
    shares = {}
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        shares[task] = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return shares


def main() -> None:
    browser_wanted, plant = "--browser" in sys.argv, "--plant" in sys.argv
    view = subprocess.Popen([sys.executable, "-m", "chasles.view", "--urdf", URDF, "--tip", TIP, "--package-dir",
                             os.path.join(DATA, "packages"), "--url", LCM_URL, "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    url = re.search(r"http://\S+", view.stdout.readline()).group(0)
    browser = None
    if browser_wanted:
        browser = Browser(960, 720)
        browser.open(url)
        browser.wait_text(r"no status|state seq", timeout=30)
    bus, done = Bus(), threading.Event()
    truth = sim_truth_t()
    truth.num_joints, truth.tau_ext, truth.contact, truth.num_contacts = 7, [0.0] * 7, True, 0

    def send():
        start, k = time.monotonic(), 0
        while not done.is_set():
            wave = math.sin(2 * math.pi * 0.5 * k * 1e-3)
            q = Q1 + 0.3 * wave
            bus.publish("CHASLES_STATE", state(q, k))
            if plant:
                truth.seq, truth.tip_wrench_ext = k, [0.0, 0.0, 0.0, 0.0, 0.0, -20.0 - 10 * wave]
                bus.publish("CHASLES_TRUTH", truth)
                if k % 10 == 0:
                    bus.publish("CHASLES_STATUS", status(q, q + 0.2, k, force=(0.0, 0.0, -20.0 - 10 * wave)))
            k += 1
            delay = start + k * 1e-3 - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    sender = threading.Thread(target=send)
    sender.start()
    try:
        time.sleep(2.0)  # past the start: the measurement is of the steady stream
        before, t0 = cpu_of_threads(view.pid), time.monotonic()
        time.sleep(10.0)
        after, t1 = cpu_of_threads(view.pid), time.monotonic()
        shares = sorted((100 * (after[k] - before.get(k, 0.0)) / (t1 - t0) for k in after), reverse=True)
        print(f"{'states, truths and statuses' if plant else 'states'} at 1 kHz, "
              f"{'a browser' if browser else 'no browser'}: the view took {sum(shares):.1f} % of a core "
              f"over {t1 - t0:.1f} s (its threads: {', '.join(f'{s:.1f}' for s in shares if s > 0)} %)")
        if browser:
            print(re.search(r"state seq .*drawn", browser.text()).group(0))
    finally:
        done.set()
        sender.join()
        if browser:
            browser.close()
        view.terminate()
        view.wait()


if __name__ == "__main__":
    main()
