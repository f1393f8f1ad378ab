"""The values the client hands out and takes (chasles.client re-exports every name here): a
robot_state_t and a controller_status_t as frozen dataclasses, and the setpoints of a stream.

Apart from the client (chasles.client) because they are plain values built from a message or into
one, with no bus and no thread: a caller may build and read them without an arm.
"""
from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np

from chasles._command_checks import ArrayLike, rotation_from_quaternion
from chasles.lcmtypes import controller_status_t, robot_state_t

STATES = {
    controller_status_t.WAITING: "WAITING",
    controller_status_t.RUNNING: "RUNNING",
    controller_status_t.HOLDING: "HOLDING",
    controller_status_t.FAULT: "FAULT",
    controller_status_t.REFLEX: "REFLEX",
}


@dataclasses.dataclass(frozen=True)
class State:
    """One robot_state_t (PREFIX STATE, from the plant or the arm's driver)."""

    utime: int  #: when the state was sampled, µs since the Unix epoch, sender's clock
    seq: int  #: the sender's step counter
    position: np.ndarray  #: q, rad or m, root to tip
    velocity: np.ndarray  #: q̇, rad/s or m/s
    effort: np.ndarray  #: the torque applied over the step that ended at the sample, N·m or N

    @classmethod
    def from_message(cls, m: robot_state_t) -> "State":
        return cls(m.utime, m.seq, np.array(m.position), np.array(m.velocity), np.array(m.effort))


@dataclasses.dataclass(frozen=True)
class Status:
    """One controller_status_t (PREFIX STATUS, ~100 Hz); lcmtypes/chasles_controller_status_t.lcm
    documents every field. Joint arrays have num_joints entries, root to tip."""

    utime: int  #: µs since the Unix epoch, the controller's clock
    state: int  #: WAITING 0, RUNNING 1, HOLDING 2, FAULT 3, REFLEX 4 (STATES names them)
    message: str  #: why FAULT or REFLEX, or the last refusal; may be empty
    num_joints: int
    q: np.ndarray  #: measured joint positions, rad or m
    q_desired: np.ndarray  #: the reference at this tick, rad or m
    tracking_error: np.ndarray  #: q_desired - q, rad or m
    tip_position: np.ndarray  #: p_sb, m, the tip frame's origin in the base frame (FK of q)
    tip_quaternion: np.ndarray  #: R_sb as (w, x, y, z)
    torque: np.ndarray  #: last commanded joint torques, N·m or N
    ik_iterations: int
    ik_residual: float
    ik_converged: bool
    jitter_p50_us: float
    jitter_p99_us: float
    jitter_max_us: float
    compute_p50_us: float
    compute_p99_us: float
    compute_max_us: float
    latency_p50_us: float
    latency_p99_us: float
    latency_max_us: float
    ticks: int
    overruns: int
    stale_states: int
    rejected_messages: int  #: malformed or refused messages, since start
    faults: int
    tau_ext: np.ndarray  #: estimated external joint torque, N·m or N
    tip_wrench_ext: np.ndarray  #: (m, f) on the tip, N·m and N, base-aligned, about the tip origin
    contact: bool
    collision: bool
    contacts: int
    reflexes: int
    law: int  #: the control law in force (LAWS maps names to it)
    payload_mass: float  #: kg
    state_period: float  #: s
    trajectory_id: int
    trajectory_outcome: int  #: controller_status_t.TRAJECTORY_*
    trajectory_elapsed: float  #: s
    trajectory_duration: float  #: s
    trajectory_time_scale: float
    trajectory_waypoint: int
    trajectory_message: str
    streaming: bool
    setpoints: int
    setpoints_dropped: int
    jogging: bool
    jogs: int
    jogs_dropped: int
    jog_condition: float
    jog_scale: float
    jog_limited_by: int
    jog_joint: int
    #: the limits streams, jogs and stops are planned with now, per joint: velocity rad/s, acceleration
    #: rad/s², jerk rad/s³ (the configured jerk capped by the torque rate at the latest goal's pose)
    generator_velocity_limit: np.ndarray
    generator_acceleration_limit: np.ndarray
    generator_jerk_limit: np.ndarray
    #: the pair of collision objects closest at the latest state ("<link>/<k> and <other>"; "" without
    #: geometry), its signed distance in m (< 0: overlapping), the pair that slowed the reference in
    #: the last 0.1 s ("": none) and the share of the motion asked that was kept then
    clearance_pair: str
    clearance_distance: float
    #: the closest pair's witness points, base frame, m: row 0 on the arm's object, row 1 on the
    #: other (zeros without a pair)
    clearance_points: np.ndarray
    clearance_slowed_by: str
    clearance_kept: float
    #: where on the arm the locator last found a contact (contact_estimate_t on PREFIX CONTACT): the
    #: URDF link ("": none), whether its force reaches the contact threshold, the point (m) and the
    #: force on the arm there (N), both in the base frame
    contact_link: str
    contact_located_flag: bool
    contact_point: np.ndarray
    contact_force: np.ndarray

    @property
    def state_name(self) -> str:
        """WAITING, RUNNING, HOLDING, FAULT or REFLEX."""
        return STATES.get(self.state, str(self.state))

    @property
    def T_sb(self) -> np.ndarray:
        """The tip pose as a 4×4 homogeneous transform, base (space) frame."""
        T = np.eye(4)
        T[:3, :3] = rotation_from_quaternion(self.tip_quaternion)
        T[:3, 3] = self.tip_position
        return T

    @classmethod
    def from_message(cls, m: controller_status_t) -> "Status":
        values = {}
        for field in dataclasses.fields(cls):
            value = getattr(m, field.name)
            values[field.name] = np.array(value, dtype=float) if isinstance(value, (list, tuple)) else value
        return cls(**values)


@dataclasses.dataclass(frozen=True)
class JointSetpoint:
    """One setpoint of a joint stream (joint_setpoint_t): positions, rad or m, and how fast the
    setpoint moves on, rad/s or m/s (None: 0, a stream of positions alone)."""

    position: ArrayLike
    velocity: Optional[ArrayLike] = None


@dataclasses.dataclass(frozen=True)
class TipSetpoint:
    """One setpoint of a Cartesian stream (tip_setpoint_t): the tip pose in the base frame, p_sb in
    m and R_sb as a unit quaternion (w, x, y, z), and its twist (ω, v) in the base frame's axes,
    rad/s and m/s (None: 0)."""

    position: ArrayLike
    quaternion: ArrayLike
    twist: Optional[ArrayLike] = None
