"""The client's messages without processes: what each sending method puts on the wire (heard back
on LCM's in-process memq:// provider and decoded with the generated classes), the fingerprints of
the generated Python classes against the C++ ones, the receive side (latest values, the states
iterator's drop policy, waits that time out), every refusal, and the log reader on a file written
here."""
import dataclasses
import math
import os
import pathlib
import queue
import re
import struct

import lcm
import numpy as np
import pytest

import chasles
from chasles import lcmtypes
from chasles.client import (
    Arm,
    InvalidCommand,
    JointSetpoint,
    State,
    Status,
    TipSetpoint,
    now_us,
    quaternion_from_rotation,
    rotation_from_quaternion,
)
from chasles.lcmtypes import (
    arm_target_t,
    control_mode_t,
    controller_status_t,
    jog_command_t,
    joint_setpoint_t,
    joint_trajectory_t,
    payload_t,
    robot_state_t,
    tip_setpoint_t,
)
from chasles.logs import LogError, read_log

NQ = 7


@pytest.fixture
def heard():
    """Every message the arm's LCM carries on T_*, as (channel, bytes), in order."""
    return queue.Queue()


@pytest.fixture
def arm(heard):
    """A started client on LCM's in-process memq://, with `heard` subscribed before its receive
    thread starts and unsubscribed after it stops (LCM's Python subscribe and unsubscribe must
    not race the thread's handle)."""
    arm = Arm(url="memq://", prefix="T_", nq=NQ)
    subscription = arm._lcm.subscribe("T_.*", lambda channel, data: heard.put((channel, data)))
    with arm:
        yield arm
    arm._lcm.unsubscribe(subscription)


def lists(value):
    """The generated classes decode arrays as tuples (of tuples); as lists, for comparing with what was given."""
    return [lists(v) for v in value] if isinstance(value, (tuple, list)) else value


def one(heard, channel, kind):
    """The next message heard, which must be on `channel`, decoded as `kind` with its arrays as lists."""
    got_channel, data = heard.get(timeout=2.0)
    assert got_channel == channel
    message = kind.decode(data)
    for field in kind.__slots__:
        setattr(message, field, lists(getattr(message, field)))
    return message


# ---- fingerprints --------------------------------------------------------------------------------

# Drake's, from Drake's own generated classes (as tests/lcmtypes/drake_test.cpp pins them).
DRAKE_FINGERPRINTS = {
    "lcmt_iiwa_status": 0xF16FB804284ABCA3,
    "lcmt_iiwa_command": 0xDDC7C7738C815334,
    "lcmt_panda_status": 0x19571CDF4D82FAE6,
    "lcmt_panda_command": 0xE68DF777004D59D0,
}


def cpp_fingerprint(name):
    """The fingerprint lcm-gen's C++ header gives: its base hash rotated left by one bit, as the
    header's _computeHash does for a type with no struct members."""
    header = pathlib.Path(os.environ["CHASLES_BUILD"]) / "lcmtypes" / "include" / "chasles" / f"{name}.hpp"
    base = int(re.search(r"uint64_t hash = (0x[0-9a-f]+)LL;", header.read_text()).group(1), 16)
    return ((base << 1) & 0xFFFFFFFFFFFFFFFF) | (base >> 63)


def test_every_python_class_has_the_cpp_fingerprint():
    names = [n for n in lcmtypes.__all__ if n not in DRAKE_FINGERPRINTS]
    assert len(names) == 13  # chasles's eleven, scene_t and contact_estimate_t
    for name in names:
        assert struct.unpack(">Q", getattr(lcmtypes, name)._get_packed_fingerprint())[0] == cpp_fingerprint(name), name
    for name, fingerprint in DRAKE_FINGERPRINTS.items():
        assert struct.unpack(">Q", getattr(lcmtypes, name)._get_packed_fingerprint())[0] == fingerprint, name


# ---- what each method sends ----------------------------------------------------------------------


def test_move_joints_sends_a_joint_target_exactly(arm, heard):
    q = [0.1, -0.3, 0.25, -0.07, -0.1, 1.7, -2.8973]
    before = now_us()
    utime = arm.move_joints(q, 2.5)
    t = one(heard, "T_TARGET", arm_target_t)
    assert (t.mode, t.num_joints, t.joint_position, t.duration) == (arm_target_t.JOINT, 7, q, 2.5)
    assert t.utime == utime and before <= utime <= now_us()


def test_move_cartesian_normalises_the_quaternion_and_takes_a_matrix(arm, heard):
    arm.move_cartesian(([0.4, -0.1, 0.5], [0.7071, 0, 0.7071, 0]), 3.0)
    t = one(heard, "T_TARGET", arm_target_t)
    assert (t.mode, t.num_joints, t.joint_position, t.duration) == (arm_target_t.CARTESIAN, 0, [], 3.0)
    assert t.tip_position == [0.4, -0.1, 0.5]
    assert t.tip_quaternion[0] == t.tip_quaternion[2] and t.tip_quaternion[1] == t.tip_quaternion[3] == 0.0
    assert t.tip_quaternion[0] == pytest.approx(math.sqrt(0.5), abs=1e-15)

    # A half turn about x: R = diag(1, -1, -1), quaternion (0, 1, 0, 0).
    T = np.diag([1.0, -1.0, -1.0, 1.0])
    T[:3, 3] = [0.3, 0.2, 0.1]
    arm.move_cartesian(T, 1.5)
    t = one(heard, "T_TARGET", arm_target_t)
    assert t.tip_position == [0.3, 0.2, 0.1] and t.tip_quaternion == [0.0, 1.0, 0.0, 0.0]


def test_hold_sends_a_hold_target(arm, heard):
    arm.hold()
    t = one(heard, "T_TARGET", arm_target_t)
    assert (t.mode, t.num_joints, t.duration) == (arm_target_t.HOLD, 0, 0.0)


def test_set_mode_fills_each_law_as_chasles_mode(arm, heard):
    arm.set_mode("computed-torque")
    m = one(heard, "T_MODE", control_mode_t)
    assert (m.law, m.num_joints, m.damping_ratio, m.num_posture, m.nullspace_stiffness) == (0, 0, 1.0, 0, 0.0)
    assert m.stiffness_frame_quaternion == [1.0, 0.0, 0.0, 0.0]

    arm.set_mode("joint-impedance", stiffness=[600, 600, 600, 600, 250, 150, 50])
    m = one(heard, "T_MODE", control_mode_t)
    assert (m.law, m.num_joints) == (control_mode_t.JOINT_IMPEDANCE, 7)
    assert m.joint_stiffness == [600, 600, 600, 600, 250, 150, 50] and m.joint_damping == [0.0] * 7

    arm.set_mode("free-drive", damping=2)
    m = one(heard, "T_MODE", control_mode_t)
    assert (m.law, m.num_joints, m.joint_stiffness, m.joint_damping) == (3, 7, [0.0] * 7, [2.0] * 7)

    arm.set_mode("cartesian-impedance", translational=800, rotational=40, frame=[0, 0, 0.1],
                 posture=[0, -0.3, 0, -2, 0, 1.7, 0.8])
    m = one(heard, "T_MODE", control_mode_t)
    assert m.law == control_mode_t.CARTESIAN_IMPEDANCE and m.num_joints == 0
    assert np.array_equal(m.cartesian_stiffness, np.diag([40, 40, 40, 800, 800, 800]))
    assert m.stiffness_frame_position == [0, 0, 0.1] and m.stiffness_frame_quaternion == [1, 0, 0, 0]
    assert (m.num_posture, m.nullspace_posture, m.nullspace_stiffness) == (7, [0, -0.3, 0, -2, 0, 1.7, 0.8], 10.0)

    arm.set_mode(control_mode_t.CARTESIAN_IMPEDANCE, cartesian_stiffness=[10, 20, 30, 100, 200, 300],
                 frame=[0, 0, 0, 0.7071, 0.7071, 0, 0], damping_ratio=0.7)
    m = one(heard, "T_MODE", control_mode_t)
    assert np.array_equal(m.cartesian_stiffness, np.diag([10, 20, 30, 100, 200, 300])) and m.damping_ratio == 0.7
    assert m.stiffness_frame_quaternion[0] == m.stiffness_frame_quaternion[1] == pytest.approx(math.sqrt(0.5), 1e-15)


def test_set_payload_fills_the_symmetric_inertia(arm, heard):
    arm.set_payload(2.0, com=[0, 0, 0.1], inertia=[0.01, 0.01, 0.005, 0.001, 0, 0])
    p = one(heard, "T_PAYLOAD", payload_t)
    assert (p.mass, p.centre_of_mass) == (2.0, [0, 0, 0.1])
    assert p.inertia == [[0.01, 0.001, 0.0], [0.001, 0.01, 0.0], [0.0, 0.0, 0.005]]
    arm.set_payload(-0.0)
    p = one(heard, "T_PAYLOAD", payload_t)
    assert math.copysign(1.0, p.mass) == 1.0 and p.inertia == [[0.0] * 3] * 3


def test_send_trajectory_fills_every_field(arm, heard):
    names = [f"panda_joint{i}" for i in range(1, 8)]
    positions = [[0.1, -0.3, 0.25, -0.5, -0.1, 1.7, 0.0], [0.2, -0.3, 0.25, -0.6, -0.1, 1.7, 0.1]]
    velocities = [[0, 0, 0.1, 0, 0, 0, 0], [0] * 7]
    first = arm.send_trajectory([0.5, 1.25], positions, velocities, joint_names=names, path_tolerance=0.05,
                                goal_tolerance=[0.001] * 6 + [0.002], goal_time_tolerance=0.5, time_scaling=True)
    t = one(heard, "T_TRAJECTORY", joint_trajectory_t)
    assert (t.id, t.num_joints, t.num_points, t.num_velocities, t.num_accelerations) == (first, 7, 2, 2, 0)
    assert t.joint_names == names and t.time_from_start == [0.5, 1.25]
    assert t.positions == positions and t.velocities == velocities and t.accelerations == []
    assert t.path_tolerance == [0.05] * 7 and t.goal_tolerance == [0.001] * 6 + [0.002]
    assert (t.goal_time_tolerance, t.time_scaling) == (0.5, True)
    assert arm.send_trajectory([1.0], [positions[0]], joint_names=names) == first + 1
    assert arm.send_trajectory([1.0], [positions[0]], joint_names=names, id=42) == 42


def test_stream_and_jog_are_stamped_strictly_increasing(arm, heard):
    stamps = [arm.stream(JointSetpoint([0.1] * 7, [0.2] * 7)) for _ in range(3)]
    for utime in stamps:
        s = one(heard, "T_SETPOINT", joint_setpoint_t)
        assert (s.utime, s.num_joints, s.position, s.velocity) == (utime, 7, [0.1] * 7, [0.2] * 7)
    assert stamps[0] < stamps[1] < stamps[2]

    arm.stream(TipSetpoint([0.4, 0, 0.5], [0, 1, 0, 0], [0, 0, 0, 0, 0.05, 0]))
    s = one(heard, "T_TIP_SETPOINT", tip_setpoint_t)
    assert (s.position, s.quaternion, s.twist) == ([0.4, 0, 0.5], [0, 1, 0, 0], [0, 0, 0, 0, 0.05, 0])

    a = arm.jog(twist=[0, 0, 0.3, 0, 0, 0], frame="tool")
    b = arm.jog(joint_velocity=[0.2, 0, 0, 0, 0, 0, 0])
    j = one(heard, "T_JOG", jog_command_t)
    assert (j.kind, j.frame, j.num_joints) == (jog_command_t.TWIST, jog_command_t.TOOL, 0)
    assert j.twist == [0, 0, 0.3, 0, 0, 0]
    j = one(heard, "T_JOG", jog_command_t)
    assert (j.kind, j.num_joints, j.joint_velocity, j.utime) == (jog_command_t.JOINT_VELOCITY, 7, [0.2] + [0.0] * 6, b)
    assert b > a


# ---- refusals: nothing is sent -------------------------------------------------------------------

NAMES = [f"j{i}" for i in range(7)]
REFUSED = [
    (lambda a: a.move_joints([0.0] * 6, 1.0), "q has 6 entries, expected 7"),
    (lambda a: a.move_joints([0, 0, 0, 0, math.nan, 0, 0], 1.0), "q: entry 4 is nan"),
    (lambda a: a.move_joints([0.0] * 7, 0.0), "duration: 0.0 s"),
    (lambda a: a.move_joints([0.0] * 7, math.inf), "duration is inf"),
    (lambda a: a.move_cartesian(([0.4, 0, 0.5], [1, 0, 0, 0.1]), 1.0), "has norm 1.00498"),
    (lambda a: a.move_cartesian(np.eye(3), 1.0), "got shape (3, 3)"),
    (lambda a: a.move_cartesian(np.diag([1.0, 1.0, 2.0, 1.0]), 1.0), "is not a rotation"),
    (lambda a: a.set_mode("stiff"), "unknown law 'stiff'"),
    (lambda a: a.set_mode("computed-torque", stiffness=100), "stiffness does not apply to computed-torque"),
    (lambda a: a.set_mode("joint-impedance"), "joint-impedance needs stiffness"),
    (lambda a: a.set_mode("joint-impedance", stiffness=6000), "stiffness 6000.0 is not in (0, 5000.0]"),
    (lambda a: a.set_mode("joint-impedance", stiffness=100, damping=0), "damping is 0 for every joint"),
    (lambda a: a.set_mode("joint-impedance", stiffness=100, damping=1, damping_ratio=1), "give one of them"),
    (lambda a: a.set_mode("joint-impedance", stiffness=[1, 2]), "stiffness has 2 entries, expected 7"),
    (lambda a: a.set_mode("free-drive", damping=[1, 1, 1, -1, 1, 1, 1]), "joint 3: free-drive damping -1.0"),
    (lambda a: a.set_mode("cartesian-impedance", damping_ratio=3), "damping ratio 3.0 is outside [0.1, 2.0]"),
    (lambda a: a.set_mode("cartesian-impedance", rotational=600), "rotational stiffness reaches 600.0"),
    (lambda a: a.set_mode("cartesian-impedance", cartesian_stiffness=np.triu(np.ones((6, 6)))), "not symmetric"),
    (lambda a: a.set_mode("cartesian-impedance", cartesian_stiffness=[1, 1, 1, 1, 1, -1]), "not positive definite"),
    (lambda a: a.set_mode("cartesian-impedance", frame=[0, 0, 1.5]), "1.5 m from the tip, over 1.0"),
    (lambda a: a.set_mode("cartesian-impedance", frame=[0, 0, 0, 1, 0, 0, 0.5]), "frame quaternion"),
    (lambda a: a.set_mode("cartesian-impedance", nullspace_stiffness=-1), "nullspace stiffness -1.0 is not in"),
    (lambda a: a.set_payload(-1.0), "mass -1.0 kg is negative"),
    (lambda a: a.set_payload(0.0, com=[0, 0, 0.1]), "mass 0 removes the payload"),
    (lambda a: a.set_payload(1.0, inertia=[1, 1, 3]), "break the triangle inequality"),
    (lambda a: a.set_payload(1.0, inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "not symmetric"),
    (lambda a: a.set_payload(2000.0), "beyond any arm's load"),
    (lambda a: a.send_trajectory([1.0, 1.0], [[0] * 7] * 2, joint_names=NAMES), "waypoint 1: time 1.0 s is not after"),
    (lambda a: a.send_trajectory([1.0], [[0] * 6], joint_names=NAMES), "positions has shape (1, 6)"),
    (lambda a: a.send_trajectory([1.0], [[0] * 7], joint_names=NAMES[:6]), "names 6 joints; the arm has 7"),
    (lambda a: a.send_trajectory([1.0], [[0] * 7], None, [[0] * 7], joint_names=NAMES), "need velocities"),
    (lambda a: a.send_trajectory([1.0], [[0] * 7], joint_names=NAMES, goal_tolerance=-1), "non-negative"),
    (lambda a: a.stream(TipSetpoint([0, 0, 0], [0, 0, 0, 0])), "must be of unit norm"),
    (lambda a: a.stream(JointSetpoint([0] * 7, [0, 0, math.inf, 0, 0, 0, 0])), "velocity: entry 2 is inf"),
    (lambda a: a.stream([0] * 7), "a JointSetpoint or a TipSetpoint is needed"),
    (lambda a: a.jog(), "exactly one of joint_velocity and twist"),
    (lambda a: a.jog(twist=[0] * 6, frame="world"), "jog frame 'world'"),
]


@pytest.mark.parametrize("send, words", REFUSED, ids=[w for _, w in REFUSED])
def test_bad_input_is_refused_and_nothing_sent(arm, heard, send, words):
    with pytest.raises(InvalidCommand) as refused:
        send(arm)
    assert words in str(refused.value)
    assert isinstance(refused.value, chasles.Error) and isinstance(refused.value, ValueError)
    # memq:// delivers in order: a marker published now is the first thing heard unless the refused
    # call sent something before it.
    arm._lcm.publish("T_MARKER", b"marker")
    assert heard.get(timeout=5.0) == ("T_MARKER", b"marker")


def test_an_unknown_joint_count_is_asked_for_and_learned_from_a_state():
    with Arm(url="memq://", prefix="T_") as arm:
        with pytest.raises(InvalidCommand, match=r"pass Arm\(nq=...\) or wait for a state"):
            arm.move_joints([0.0] * 7, 1.0)
        publish_state(arm, seq=0, n=6)
        arm.wait_state(lambda s: True, 2.0)
        assert arm.nq == 6
    with pytest.raises(InvalidCommand, match="letters, digits"):
        Arm(url="memq://", prefix="A B")


# ---- receiving -----------------------------------------------------------------------------------


def publish_state(arm, seq, n=NQ):
    m = robot_state_t()
    m.utime, m.seq, m.num_joints = 1000 + seq, seq, n
    m.position, m.velocity, m.effort = [0.01 * seq] * n, [0.0] * n, [float(seq)] * n
    arm._lcm.publish(arm.channel("STATE"), m.encode())


def test_latest_state_callbacks_and_the_iterator_drop_the_oldest(arm):
    seen = []
    arm.on_state(lambda s: seen.append(s.seq))
    stream = arm.states(timeout=0.5, size=3)
    for seq in range(5):
        publish_state(arm, seq)
    arm.wait_state(lambda s: s.seq == 4, 2.0)
    assert arm.state().seq == 4 and np.array_equal(arm.state().position, [0.04] * NQ)
    assert seen == [0, 1, 2, 3, 4]
    assert [next(stream).seq for _ in range(3)] == [2, 3, 4] and stream.dropped == 2
    with pytest.raises(TimeoutError, match="no robot state on T_STATE within 0.5 s"):
        next(stream)


def test_status_has_every_field_of_the_message_and_state_every_array():
    assert [f.name for f in dataclasses.fields(Status)] == list(controller_status_t.__slots__)
    assert [f.name for f in dataclasses.fields(State)] == [s for s in robot_state_t.__slots__ if s != "num_joints"]


def test_waits_time_out_naming_what_was_awaited(arm):
    with pytest.raises(TimeoutError, match="waited 0.1 s for the arm to fly; no status heard on T_STATUS"):
        arm.wait_status(lambda s: False, 0.1, "the arm to fly")
    status = controller_status_t()
    status.state, status.message, status.num_joints = controller_status_t.FAULT, "stale state", 0
    arm._lcm.publish("T_STATUS", status.encode())
    with pytest.raises(TimeoutError, match="waited 0.2 s for running; last status FAULT: stale state"):
        arm.wait_status(lambda s: s.state == controller_status_t.RUNNING, 0.2, "running")


def test_a_callback_error_is_raised_by_close():
    arm = Arm(url="memq://", prefix="T_", nq=NQ).start()
    arm.on_state(lambda s: 1 / 0)
    publish_state(arm, 0)
    arm.wait_state(lambda s: True, 2.0)
    with pytest.raises(ZeroDivisionError):
        arm.close()


def test_quaternion_and_rotation_are_inverse():
    # A quarter turn about z, by construction.
    assert np.allclose(quaternion_from_rotation(np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])),
                       [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-15)
    rng = np.random.default_rng(7)
    for _ in range(100):
        q = rng.normal(size=4)
        q = q / np.linalg.norm(q) * (1 if q[0] >= 0 else -1)
        R = rotation_from_quaternion(q)
        assert np.abs(R.T @ R - np.eye(3)).max() < 1e-14 and abs(np.linalg.det(R) - 1) < 1e-14
        assert np.abs(quaternion_from_rotation(R) - q).max() < 1e-14


# ---- the log reader ------------------------------------------------------------------------------


def logged_state(seq):
    m = robot_state_t()
    m.utime, m.seq, m.num_joints = 1000 + seq, seq, 2
    m.position, m.velocity, m.effort = [0.5 * seq, -1.0], [0.0, seq], [1.0, 2.0]
    return m.encode()


def write_log(path):
    log = lcm.EventLog(str(path), "w", overwrite=True)
    for seq in range(4):
        log.write_event(5000 + seq, "S", logged_state(seq))
        log.write_event(5000 + seq, "JUNK", b"not a message of any type")
    status = controller_status_t()
    status.message, status.num_joints = "hello", 0
    log.write_event(6000, "ST", status.encode())
    log.close()


def test_read_log_decodes_by_fingerprint_and_lists_what_it_skips(tmp_path):
    path = tmp_path / "run.lcmlog"
    write_log(path)
    log = read_log(str(path))
    assert log.types == {"S": "robot_state_t", "ST": "controller_status_t"} and log.skipped == {"JUNK": 4}
    s = log["S"]
    assert np.array_equal(s["event_utime"], [5000, 5001, 5002, 5003]) and np.array_equal(s["seq"], [0, 1, 2, 3])
    assert s["position"].shape == (4, 2) and np.array_equal(s["position"][:, 0], [0, 0.5, 1.0, 1.5])
    assert log["ST"]["message"].tolist() == ["hello"] and log["ST"]["tip_wrench_ext"].shape == (1, 6)
    assert list(read_log(str(path), channels=["ST"])) == ["ST"]


def test_a_cut_short_or_damaged_log_names_the_file_and_offset(tmp_path):
    path = tmp_path / "run.lcmlog"
    write_log(path)
    data = path.read_bytes()
    cut = tmp_path / "cut.lcmlog"
    cut.write_bytes(data[:-10])
    with pytest.raises(LogError, match=rf"{re.escape(str(cut))}: byte \d+: event #8 is cut short") as refused:
        read_log(str(cut))
    assert isinstance(refused.value, chasles.Error)
    damaged = tmp_path / "damaged.lcmlog"
    second = 28 + len("S") + len(logged_state(0))  # header, channel, message: where event #1 starts
    damaged.write_bytes(data[:second] + b"\0" + data[second + 1:])  # its sync word
    with pytest.raises(LogError, match=rf"{re.escape(str(damaged))}: byte {second}: event #1 does not start with"):
        read_log(str(damaged))
