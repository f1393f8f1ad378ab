"""The simulated arm as processes for the client's end-to-end tests: chasles_plant (lockstep, so
every run is the same) and chasles_controller (on its clock) on the Panda of tests/data, and
lcm-logger, all on the URL tools/netns.sh documents (ctest runs these tests inside it). Readiness
is waited for, never slept for: the controller's first status that is not WAITING, a log file
that exists and grows."""
from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import tempfile
import time
from typing import Iterator

from chasles.client import Arm

LCM_URL = "udpm://239.255.76.67:7667?ttl=0"
URDF = os.path.join(os.environ.get("CHASLES_TEST_DATA", "tests/data"), "panda.urdf")
TIP = "panda_hand_tcp"
#: Where the plant starts: the Panda bent, as the C++ daemon tests start it (tests/support/arm.cpp).
BENT = [0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0]


class Process:
    """A child process whose stderr is kept for failure messages; stopped by `stop`."""

    def __init__(self, argv: list[str]):
        self.argv = argv
        self._stderr = tempfile.TemporaryFile()
        self.process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=self._stderr)

    def stderr(self) -> str:
        self._stderr.seek(0)
        return self._stderr.read().decode(errors="replace")

    def stop(self, sig: int = signal.SIGTERM, timeout: float = 5.0) -> int:
        if self.process.poll() is None:
            self.process.send_signal(sig)
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode


@contextlib.contextmanager
def simulated_arm(timeout: float = 10.0) -> Iterator[Arm]:
    """The plant and the controller running, and a started client on their bus whose controller
    is HOLDING the arm at BENT."""
    q0 = ",".join(repr(x) for x in BENT)
    model = ["--robot", URDF, "--tip", TIP, "--lcm-url", LCM_URL]
    plant = Process([os.environ["CHASLES_PLANT"], *model, "--lockstep", "--q0", q0])
    # --stale-ms 500: what these tests judge is the client and the motion, and a machine running
    # other builds on its two cores stalls the lockstep pair now and then for over 100 ms (measured
    # 106 and 216 ms in 1 run of 7), which the C++ daemon tests' 100 would turn into a FAULT.
    controller = Process([os.environ["CHASLES_CONTROLLER"], *model, "--tick", "clock", "--stale-ms", "500"])
    try:
        with Arm(url=LCM_URL) as arm:
            try:
                arm.wait_ready(timeout)
            except TimeoutError as e:
                raise TimeoutError(f"{e}\ncontroller: {controller.stderr()}\nplant: {plant.stderr()}") from None
            yield arm
    finally:
        controller.stop()
        plant.stop()


@contextlib.contextmanager
def lcm_logger(path: str, timeout: float = 5.0) -> Iterator[Process]:
    """lcm-logger writing every channel to `path`, from when its file exists and has grown (it
    flushes every 100 ms) until the block ends; then stopped by SIGINT, which closes the file."""
    logger = Process([os.environ["LCM_LOGGER"], "--quiet", "--force", f"--lcm-url={LCM_URL}", path])
    try:
        deadline = time.monotonic() + timeout
        first = None
        while True:
            size = os.path.getsize(path) if os.path.exists(path) else None
            if size is not None and first is not None and size > first:
                break
            first = size if first is None else first
            if time.monotonic() > deadline or logger.process.poll() is not None:
                raise TimeoutError(f"lcm-logger did not start writing {path} within {timeout} s: {logger.stderr()}")
            time.sleep(0.02)
        yield logger
    finally:
        logger.stop(signal.SIGINT)
