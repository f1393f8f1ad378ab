"""python/examples/square.py run against the simulated arm (arm_processes.py, in the test's
network namespace): it exits 0 having written its PNG, and the log it wrote holds a tip path that
passes within 1 mm (the C++ daemon tests' lockstep Cartesian tolerance) of each corner of the
square, the corners known by construction from where this test saw the tip before it started."""
import json
import os
import subprocess
import sys

import numpy as np

from arm_processes import LCM_URL, simulated_arm
from chasles.logs import read_log

SIDE = 0.08  # m
POSITION_TOLERANCE = 1e-3  # m


def test_square_example_drives_the_tip_through_every_corner_and_plots_it(tmp_path):
    log, png = str(tmp_path / "square.lcmlog"), str(tmp_path / "square.png")
    with simulated_arm() as arm:
        p0 = arm.status().tip_position
        run = subprocess.run(
            [sys.executable, os.path.join(os.environ["CHASLES_EXAMPLES"], "square.py"), "--lcm-url", LCM_URL,
             "--side", str(SIDE), "--seconds", "0.8", "--log", log, "--png", png],
            capture_output=True, text=True, timeout=50)
    assert run.returncode == 0, run.stderr
    with open(png, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    corners = p0 + SIDE * np.array([[0, 0, 0], [-1, 0, 0], [-1, 1, 0], [0, 1, 0]])
    path = read_log(log)["CHASLES_STATUS"]["tip_position"]
    closest = [np.linalg.norm(path - corner, axis=1).min() for corner in corners]
    assert max(closest) < POSITION_TOLERANCE, closest
    # The path is a square, not the four corners alone: halfway along each side it is on the side.
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        assert np.linalg.norm(path - (a + b) / 2, axis=1).min() < 5e-3
    printed = json.loads(run.stdout)
    assert printed["png"] == png and len(printed["closest"]) == 5
