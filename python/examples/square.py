"""Drives the arm's tip around a square with the chasles client, logs the run with lcm-logger,
reads the log back and plots the tip's path.

    python square.py --lcm-url 'udpm://239.255.76.67:7667?ttl=0' --log square.lcmlog --png square.png

With chasles_controller running (and chasles_plant under it, or a real arm), from where the tip
is: four Cartesian moves of --side m, toward the base along its x axis, then along y, then back,
holding the tip's orientation, each in --seconds s and waited for until the arm is at rest. Then the log's
statuses give the tip's path (controller_status_t.tip_position, the forward kinematics of the
measured q, base frame), drawn from above with the corners, and how near the path came to each
corner. Prints one JSON line: {"corners", "closest", "log", "png"} (m).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chasles.client import Arm  # noqa: E402
from chasles.logs import read_log  # noqa: E402


def square_corners(p0: np.ndarray, side: float) -> np.ndarray:
    """The square's corners in the order visited, starting and ending at p0: along the base frame's
    x toward the base, then along y, then back, in the horizontal plane through p0 (m)."""
    steps = np.array([[0, 0, 0], [-side, 0, 0], [-side, side, 0], [0, side, 0], [0, 0, 0]], dtype=float)
    return p0 + steps


def start_logger(url: str | None, path: str, timeout: float = 5.0) -> subprocess.Popen:
    """lcm-logger on `url` writing `path`, returned once the file exists and has grown."""
    logger_program = shutil.which(os.environ.get("LCM_LOGGER", "lcm-logger"))
    if logger_program is None:
        sys.exit("square.py: lcm-logger not found (Debian: liblcm-bin)")
    logger = subprocess.Popen([logger_program, "--quiet", "--force", *([f"--lcm-url={url}"] if url else []), path])
    deadline = time.monotonic() + timeout
    first = None
    while True:
        size = os.path.getsize(path) if os.path.exists(path) else None
        if first is not None and size is not None and size > first:
            return logger
        first = size if first is None else first
        if time.monotonic() > deadline or logger.poll() is not None:
            logger.kill()
            sys.exit(f"square.py: lcm-logger did not start writing {path} within {timeout} s")
        time.sleep(0.02)


def drive(arm: Arm, corners: np.ndarray, quaternion: np.ndarray, seconds: float) -> None:
    for corner in corners[1:]:
        arm.move_cartesian((corner, quaternion), seconds)
        arm.wait_until_settled(timeout=seconds + 10.0)


def plot(path_xy: np.ndarray, corners: np.ndarray, png: str) -> None:
    """The tip's path from above (base frame x, y in mm) with the corners, written atomically."""
    figure, axes = plt.subplots(figsize=(5, 5))
    axes.plot(1e3 * path_xy[:, 0], 1e3 * path_xy[:, 1], lw=1.5, label="tip (controller status)")
    axes.plot(1e3 * corners[:, 0], 1e3 * corners[:, 1], "o", mfc="none", ms=10, label="corners")
    axes.set_xlabel("x, base frame (mm)")
    axes.set_ylabel("y, base frame (mm)")
    axes.set_aspect("equal")
    axes.grid(True, alpha=0.3)
    axes.legend(loc="best")
    axes.set_title("chasles: the tip driven around a square")
    directory = os.path.dirname(os.path.abspath(png))
    with tempfile.NamedTemporaryFile(dir=directory, suffix=".png", delete=False) as scratch:
        figure.savefig(scratch, format="png", dpi=100)
    plt.close(figure)
    os.replace(scratch.name, png)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--lcm-url", default=None, help="LCM URL (default: $LCM_DEFAULT_URL, else LCM's)")
    parser.add_argument("--prefix", default="CHASLES_", help="the controller's channel prefix")
    parser.add_argument("--side", type=float, default=0.08, help="the square's side, m")
    parser.add_argument("--seconds", type=float, default=1.0, help="time for each side, s")
    parser.add_argument("--log", default="square.lcmlog", help="the LCM log to write")
    parser.add_argument("--png", default="square.png", help="the plot to write")
    args = parser.parse_args()

    with Arm(url=args.lcm_url, prefix=args.prefix) as arm:
        status = arm.wait_ready(timeout=10.0)
        corners = square_corners(status.tip_position, args.side)
        logger = start_logger(args.lcm_url or os.environ.get("LCM_DEFAULT_URL"), args.log)
        try:
            drive(arm, corners, status.tip_quaternion, args.seconds)
            # One status more, so the log holds the arm at rest at the last corner.
            settled = arm.state().utime
            arm.wait_status(lambda s: s.utime > settled, 2.0, "a status after the last corner")
        finally:
            logger.send_signal(signal.SIGINT)
            logger.wait(timeout=5.0)

    statuses = read_log(args.log, channels=[args.prefix + "STATUS"])[args.prefix + "STATUS"]
    path = statuses["tip_position"]
    closest = [float(np.linalg.norm(path - corner, axis=1).min()) for corner in corners]
    plot(path[:, :2], corners, args.png)
    print(json.dumps({"corners": corners.tolist(), "closest": closest, "log": args.log, "png": args.png}))


if __name__ == "__main__":
    main()
