"""Regenerates docs/images/view-live.png and view-replay.png, the screenshots docs/view.md shows;
not a test:

  tools/netns.sh build/venv/bin/python tests/python/view_screenshots.py [OUT_DIR]

with PYTHONPATH=build/python and CHASLES_TEST_DATA=tests/data (default OUT_DIR: docs/images).
The live one: python -m chasles.view on the namespace's bus, the Panda mid-motion as a plant and a
controller would put it (the state moving, the controller's reference ahead of it as the ghost, a
30 N push on the hand felt as the magenta arrow and the plant's truth as the green one). The replay:
a log written as view_replay_bench.py writes a demo's, 9 s, seeked to its end (inside its push),
with the plots. Headless Chromium (view_browser) takes both; each is kept under 300 kB as a
256-colour PNG.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import threading

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from chasles.lcmtypes import sim_truth_t  # noqa: E402
from test_view import DATA, EYE, LCM_URL, Q1, TARGET, TIP, URDF, Bus, status, state  # noqa: E402
from view_browser import Browser  # noqa: E402
from view_replay_bench import write_demo_log  # noqa: E402

W, H = 1280, 720
CAMERA = ",".join(str(v) for v in EYE + TARGET)


def start_view(*extra) -> tuple:
    view = subprocess.Popen([sys.executable, "-m", "chasles.view", *extra, "--urdf", URDF, "--tip", TIP,
                             "--package-dir", os.path.join(DATA, "packages"), "--port", "0", "--camera", CAMERA],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    line = view.stdout.readline()
    match = re.fullmatch(r"chasles view: (http://\S+)\s*", line)
    if not match:
        view.kill()
        raise SystemExit(f"the view printed {line!r}")
    return view, match.group(1)


def save(browser: Browser, path: str) -> None:
    browser.frames(3)
    Image.fromarray(browser.screenshot()).quantize(256).save(path, optimize=True)
    print(f"{path}: {os.path.getsize(path) / 1e3:.0f} kB")


def live(path: str) -> None:
    view, url = start_view("--url", LCM_URL)
    bus, browser, done = Bus(), None, threading.Event()
    q = Q1 + 0.3 * np.sin(np.arange(7))  # mid-motion
    force = np.array([0.0, 0.0, -30.0])
    truth = sim_truth_t()
    truth.num_joints, truth.tau_ext, truth.contact, truth.num_contacts = 7, [0.0] * 7, True, 0
    truth.tip_wrench_ext = [0.0, 0.0, 0.0, *(force * 1.1)]

    def send():  # a plant's 1 kHz and a controller's 100 Hz, as the demo's
        k = 0
        while not done.wait(1e-3):
            bus.publish("CHASLES_STATE", state(q, k))
            truth.seq = k
            bus.publish("CHASLES_TRUTH", truth)
            if k % 10 == 0:
                bus.publish("CHASLES_STATUS", status(q, q + 0.25 * np.cos(np.arange(7)), 100 + k, force=force))
            k += 1

    sender = threading.Thread(target=send)
    sender.start()
    try:
        browser = Browser(W, H)
        browser.open(url)
        browser.wait_text(r"ticks \d+.*\n.*\n.*contact yes[\s\S]*truth seq", timeout=60)
        save(browser, path)
    finally:
        done.set()
        sender.join()
        if browser is not None:
            browser.close()
        view.terminate()
        view.wait(timeout=10)


def replay(path: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        log = os.path.join(folder, "demo.lcmlog")
        write_demo_log(log, 5.9)  # 9 s: its push from 8 s, shown at the end
        view, url = start_view(log, "--paused", "--speed", "1")
        browser = None
        try:
            browser = Browser(W, H)
            browser.open(url)
            browser.wait_text(r"log 0\.000 s of", timeout=60)
            # Seek with the keyboard to the end, where the plots hold the whole window.
            browser.evaluate("document.querySelector('[role=slider]').focus()")
            for kind in ("keyDown", "keyUp"):
                browser.call("Input.dispatchKeyEvent", type=kind, key="End", code="End", windowsVirtualKeyCode=35)
            browser.wait_text(r"log (\d+\.\d+) s of \1 s, paused", timeout=30)
            browser.wait_text(r"state seq [1-9]", timeout=30)
            save(browser, path)
        finally:
            if browser is not None:
                browser.close()
            view.terminate()
            view.wait(timeout=10)


def main() -> None:
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..", "docs", "images")
    os.makedirs(out, exist_ok=True)
    live(os.path.join(out, "view-live.png"))
    replay(os.path.join(out, "view-replay.png"))


if __name__ == "__main__":
    main()
