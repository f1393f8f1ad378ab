"""The package `pip install .` put into a fresh venv (test_pip_install.py leaves it in
$CHASLES_BUILD/pip-venv: the ctest fixture chasles_pip_venv) drives the simulated arm: run by the
venv's own interpreter, away from the source and build trees, chasles.client moves the plant
through the controller (arm_processes.py: lockstep, in the test's network namespace) to a joint
goal, within the C++ daemon tests' lockstep tolerance, and chasles.logs reads the target back from
the log lcm-logger wrote meanwhile."""
import json
import os
import subprocess
from pathlib import Path

import numpy as np

from arm_processes import BENT, LCM_URL, lcm_logger, simulated_arm

VENV = Path(os.environ["CHASLES_BUILD"]) / "pip-venv"
JOINT_TOLERANCE = 1e-3  # rad, tests/controller/daemon_test.cpp's lockstep JOINT move

DRIVE = """
import json, sys
import chasles.client
with chasles.client.Arm(url=sys.argv[1]) as arm:
    arm.wait_ready(10.0)
    utime = arm.move_joints(json.loads(sys.argv[2]), 0.6)
    state = arm.wait_until_settled(timeout=10.0)
print(json.dumps({"package": chasles.client.__file__, "position": state.position.tolist(), "utime": utime}))
"""
READ = """
import json, sys
import chasles.logs
targets = chasles.logs.read_log(sys.argv[1], channels=["CHASLES_TARGET"])["CHASLES_TARGET"]
print(json.dumps({"utime": targets["utime"].tolist(), "joint_position": targets["joint_position"].tolist()}))
"""


def test_the_installed_client_moves_the_arm_to_a_joint_goal(tmp_path: Path) -> None:
    python = VENV / "bin" / "python"
    assert python.is_file(), f"{python}: python.test_pip_install makes it (ctest fixture chasles_pip_venv)"
    goal = (np.array(BENT) + [0.15, -0.1, 0.0, 0.1, 0.0, 0.1, 0.0]).tolist()
    log = tmp_path / "run.lcmlog"

    def installed(script: str, *args: str) -> dict:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        run = subprocess.run([str(python), "-c", script, *args], capture_output=True, text=True, timeout=40,
                             cwd=tmp_path, env=env)
        assert run.returncode == 0, run.stderr
        return json.loads(run.stdout)

    with simulated_arm(), lcm_logger(str(log)):
        drive = installed(DRIVE, LCM_URL, json.dumps(goal))
    assert Path(drive["package"]).is_relative_to(VENV)
    assert np.abs(np.array(drive["position"]) - goal).max() < JOINT_TOLERANCE
    logged = installed(READ, str(log))
    assert logged == {"utime": [drive["utime"]], "joint_position": [goal]}  # exactly as sent
