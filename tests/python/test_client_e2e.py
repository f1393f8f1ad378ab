"""The client drives the real processes (arm_processes.py: plant and controller in lockstep, inside
the test's network namespace): a JOINT move and a CARTESIAN move end at their goals, judged from
what the client itself heard, with the C++ daemon tests' lockstep tolerances (1e-3 rad; 1 mm and
1 mrad); a target outside the Panda's joint limits is refused by the controller and counted. The run
is logged by lcm-logger and read back with read_log: the targets exactly as sent, the arm at each
goal in the logged states and statuses (not the refusal's count: the logger, another process, may
be stopped before it writes the status the client heard it in)."""
import math

import numpy as np
import pytest

from arm_processes import BENT, lcm_logger, simulated_arm
from chasles.client import TargetRefused
from chasles.lcmtypes import arm_target_t
from chasles.logs import read_log

JOINT_TOLERANCE = 1e-3  # rad, tests/controller/daemon_test.cpp's lockstep JOINT move
POSITION_TOLERANCE = 1e-3  # m, its lockstep CARTESIAN move
ROTATION_TOLERANCE = 1e-3  # rad


def rotation_angle(qa, qb):
    """The angle of the rotation between two unit quaternions (w, x, y, z), rad."""
    return 2.0 * math.acos(min(1.0, abs(float(np.dot(qa, qb)))))


def test_joint_and_cartesian_moves_reach_their_goals_and_a_bad_target_is_refused(tmp_path):
    log_path = str(tmp_path / "run.lcmlog")
    goal_q = np.array(BENT) + [0.4, -0.3, 0.0, 0.3, 0.0, 0.2, 0.0]
    bad_q = goal_q.copy()
    bad_q[3] = 0.5  # panda_joint4's limits are [-3.0718, -0.0698]
    with simulated_arm() as arm, lcm_logger(log_path):
        joint_utime = arm.move_joints(goal_q, 1.0)
        state = arm.wait_until_settled(timeout=10.0)
        assert np.abs(state.position - goal_q).max() < JOINT_TOLERANCE

        # 5 cm forward and 3 cm down from where the tip is, turned 0.2 rad about the base's z axis.
        start = arm.wait_status(lambda s: s.utime > state.utime, 2.0, "a status after the joint move")
        goal_p = start.tip_position + [0.05, 0.0, -0.03]
        turn = [math.cos(0.1), 0.0, 0.0, math.sin(0.1)]
        w1, v1 = turn[0], np.array(turn[1:])
        w2, v2 = start.tip_quaternion[0], start.tip_quaternion[1:]
        goal_quaternion = np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])
        cartesian_utime = arm.move_cartesian((goal_p, goal_quaternion), 1.0)
        state = arm.wait_until_settled(timeout=10.0)
        end = arm.wait_status(lambda s: s.utime > state.utime, 2.0, "a status after the Cartesian move")
        assert end.ik_converged
        assert np.linalg.norm(end.tip_position - goal_p) < POSITION_TOLERANCE
        assert rotation_angle(end.tip_quaternion, goal_quaternion) < ROTATION_TOLERANCE

        rejected = end.rejected_messages
        bad_utime = arm.move_joints(bad_q, 1.0)
        with pytest.raises(TargetRefused, match=r"last target refused: joint panda_joint4: target 0.5 is outside"):
            arm.wait_until_settled(timeout=5.0)
        assert arm.status().rejected_messages == rejected + 1
        assert arm.status().state_name == "HOLDING"

    log = read_log(log_path)
    targets = log["CHASLES_TARGET"]
    assert targets["utime"].tolist() == [joint_utime, cartesian_utime, bad_utime]
    assert targets["mode"].tolist() == [arm_target_t.JOINT, arm_target_t.CARTESIAN, arm_target_t.JOINT]
    assert np.array_equal(targets["joint_position"][0], goal_q)  # exactly as sent
    assert np.array_equal(targets["tip_position"][1], goal_p)
    states, statuses = log["CHASLES_STATE"], log["CHASLES_STATUS"]
    # The logged states reach the joint goal between the two moves; the statuses the tip goal after.
    between = (states["utime"] > joint_utime) & (states["utime"] < cartesian_utime)
    assert np.abs(states["position"][between] - goal_q).max(axis=1).min() < JOINT_TOLERANCE
    after = (statuses["utime"] > cartesian_utime) & (statuses["utime"] < bad_utime)
    assert np.linalg.norm(statuses["tip_position"][after] - goal_p, axis=1).min() < POSITION_TOLERANCE
