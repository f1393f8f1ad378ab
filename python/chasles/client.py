"""A client of the running arm: chasles_controller (and the plant or driver under it) over LCM.

    from chasles.client import Arm
    with Arm(url="udpm://239.255.76.67:7667?ttl=0") as arm:
        arm.wait_ready()
        arm.move_joints([0, -0.3, 0, -2, 0, 1.7, 0.8], duration=2.0)
        arm.wait_until_settled()
        print(arm.status().tip_position)

Every message is filled as the `chasles` command-line tool fills it (tools/chasles/*.cpp), and
refused before sending, with an InvalidCommand (a ValueError) saying what is wrong, on the same
grounds: a wrong shape, a number that is not finite, a quaternion whose norm is more than 1e-3
from 1 (within it, normalised), a setting outside the bounds lcmtypes/chasles_control_mode_t.lcm
gives. What only the arm's model can judge (joint limits, reach) the controller judges: a refusal
comes back in its status (`rejected_messages`, `message`), which wait_until_settled raises as
TargetRefused.

Conventions (Modern Robotics): joint quantities root to tip in rad or m (prismatic) and per
second; the tip pose is T_sb, the tip frame in the base (space) frame, its rotation a unit
quaternion (w, x, y, z); twists are (ω, v), wrenches (m, f); SI units; times (utime) are
microseconds since the Unix epoch on the sender's clock (CLOCK_REALTIME), as every chasles tool
stamps them.

Threading: one LCM instance; a receive thread, started by start() or `with`, runs the callbacks
and keeps the latest state and status; close() (or leaving `with`) stops it within 50 ms. Sending
is safe from any thread.

The checks of what is sent live in chasles._command_checks and the received values in
chasles._messages; every name of theirs is importable from here, where callers import it.
"""
from __future__ import annotations

import collections
import re
import struct
import threading
import time
from typing import Callable, Iterator, Optional, Sequence, Union

import lcm
import numpy as np

from chasles._command_checks import (
    _LAW_OPTIONS,
    DAMPING_RATIO_RANGE,
    LAWS,
    MAX_WAYPOINTS,
    ArrayLike,
    InvalidCommand,
    _cartesian_stiffness,
    _duration,
    _number,
    _vector,
    pose_parts,
    quaternion_from_rotation,
    rotation_from_quaternion,
    unit_quaternion,
)
from chasles._core import ArgumentError, Error
# The bounds and defaults of the C++ that judges the same commands (the controller, the CLI), read
# from it: a quaternion's norm tolerance (core/lie/so3.hpp), a law's bounds and defaults
# (controller/law_settings.hpp LawBounds, LawDefaults: control_mode_t documents them), the payload's bounds
# (core/model/payload.hpp). The payload's principal moments are judged with core/model/inertia.cpp's
# tolerance: 2e-3 × the largest + m·(1 µm)².
from chasles._core import (
    DEFAULT_DAMPING_RATIO,
    DEFAULT_NULLSPACE_STIFFNESS,
    DEFAULT_ROTATIONAL_STIFFNESS,
    DEFAULT_TRANSLATIONAL_STIFFNESS,
    MAX_DAMPING_RATIO,
    MAX_FRAME_OFFSET,
    MAX_JOINT_STIFFNESS,
    MAX_NULLSPACE_STIFFNESS,
    MAX_PAYLOAD_INERTIA,
    MAX_PAYLOAD_MASS,
    MAX_PAYLOAD_REACH,
    MAX_ROTATIONAL_STIFFNESS,
    MAX_TRANSLATIONAL_STIFFNESS,
    MIN_DAMPING_RATIO,
    QUATERNION_NORM_TOLERANCE,
)
from chasles._messages import STATES, JointSetpoint, State, Status, TipSetpoint
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


# The classes defined apart carry this module's name, where callers import them from: tracebacks
# say chasles.client.InvalidCommand, and pickles name the module that will go on holding them.
for _moved in (InvalidCommand, State, Status, JointSetpoint, TipSetpoint):
    _moved.__module__ = __name__
del _moved


class ArmError(Error):
    """The arm did not do what was awaited: base of TargetRefused and ArmFault."""


class TargetRefused(ArmError):
    """The controller refused the last target, mode or trajectory; the message is its reason."""


class ArmFault(ArmError):
    """The controller went to FAULT or REFLEX while a motion was awaited; the message is its reason."""


def now_us() -> int:
    """Microseconds since the Unix epoch (CLOCK_REALTIME), as every chasles tool stamps utime."""
    return time.time_ns() // 1000


class StateStream:
    """The states as they arrive, for `for s in arm.states(timeout=...)`.

    Its queue holds at most `size` states; when the consumer falls behind, the OLDEST state is
    dropped so that what it reads next is as recent as the queue allows, and `dropped` counts the
    states lost. Iteration raises TimeoutError when no state comes within `timeout` s; break out
    of the loop (or call close()) to stop listening."""

    def __init__(self, arm: "Arm", timeout: float, size: int):
        self._arm, self._timeout = arm, timeout
        self._queue: collections.deque[State] = collections.deque(maxlen=size)
        self._ready = threading.Condition()
        self.dropped = 0

    def _put(self, state: State) -> None:
        with self._ready:
            if len(self._queue) == self._queue.maxlen:
                self.dropped += 1
            self._queue.append(state)
            self._ready.notify()

    def __iter__(self) -> "StateStream":
        return self

    def __next__(self) -> State:
        with self._ready:
            if not self._ready.wait_for(lambda: self._queue, self._timeout):
                raise TimeoutError(f"no robot state on {self._arm.channel('STATE')} within {self._timeout} s")
            return self._queue.popleft()

    def close(self) -> None:
        with self._arm._lock:
            self._arm._streams.discard(self)

    def __del__(self) -> None:
        self.close()


# ---- the client -----------------------------------------------------------------------------------


class Arm:
    """A seat on the running arm's LCM bus: sends targets, modes, payloads, trajectories, streams
    and jogs to chasles_controller, and hears its STATE and STATUS channels.

    url: LCM provider URL; None for the environment's LCM_DEFAULT_URL, else LCM's default (as the
      C++ tools). Inside tools/netns.sh: "udpm://239.255.76.67:7667?ttl=0".
    prefix: the channels' prefix (the controller's --channel-prefix).
    nq: the arm's joint count; None to learn it from the first state or status heard.
    """

    def __init__(self, url: Optional[str] = None, prefix: str = "CHASLES_", nq: Optional[int] = None):
        if not re.fullmatch(r"[A-Za-z0-9_/-]*", prefix):
            raise InvalidCommand(
                f"prefix {prefix!r}: letters, digits, '_', '-' and '/' only (the controller subscribes by name)"
            )
        if nq is not None and (int(nq) != nq or nq < 1):
            raise InvalidCommand(f"nq = {nq}: the arm's joint count is a positive integer")
        self.url, self.prefix = url, prefix
        try:
            self._lcm = lcm.LCM(url) if url else lcm.LCM()
        except (RuntimeError, OSError) as e:
            multicast = not url or url.startswith("udpm://")
            hint = (
                ": is there a multicast route? (inside tools/netns.sh use 'udpm://239.255.76.67:7667?ttl=0')"
                if multicast
                else ""
            )
            raise ConnectionError(f"cannot start LCM{' on ' + url if url else ''} ({e}){hint}") from None
        self._nq = int(nq) if nq is not None else None
        self._lock = threading.Condition()
        self._state: Optional[State] = None
        self._status: Optional[Status] = None
        self._state_callbacks: list[Callable[[State], None]] = []
        self._status_callbacks: list[Callable[[Status], None]] = []
        self._streams: set[StateStream] = set()
        self._callback_error: Optional[BaseException] = None
        self._last_utime: dict[str, int] = {}
        self._target: Optional[tuple[int, float, int]] = None  # (utime, duration, rejections before)
        self._trajectory_id = 0
        self._subscriptions = [
            self._lcm.subscribe(self.channel("STATE"), self._on_state_bytes),
            self._lcm.subscribe(self.channel("STATUS"), self._on_status_bytes),
        ]
        self._thread: Optional[threading.Thread] = None
        self._stop = threading.Event()

    # -- lifetime --

    def start(self) -> "Arm":
        """Starts the receive thread (once)."""
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._receive, name="chasles.client", daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        """Stops the receive thread (within one 50 ms wait) and releases LCM; re-raises the first
        exception a callback raised, if any."""
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None
        for subscription in self._subscriptions:
            self._lcm.unsubscribe(subscription)
        self._subscriptions = []
        if self._callback_error is not None:
            error, self._callback_error = self._callback_error, None
            raise error

    def __enter__(self) -> "Arm":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def channel(self, name: str) -> str:
        """PREFIX name, e.g. channel("TARGET") = "CHASLES_TARGET"."""
        return self.prefix + name

    @property
    def nq(self) -> int:
        """The arm's joint count: given, or learned from the first state or status."""
        if self._nq is None:
            raise InvalidCommand(
                "the arm's joint count is not known yet: pass Arm(nq=...) or wait for a state (arm.wait_ready())"
            )
        return self._nq

    # -- receiving --

    def _receive(self) -> None:
        while not self._stop.is_set():
            self._lcm.handle_timeout(50)

    def _learn_nq(self, n: int) -> None:
        if self._nq is None and n > 0:
            self._nq = n

    def _on_state_bytes(self, channel: str, data: bytes) -> None:
        try:
            state = State.from_message(robot_state_t.decode(data))
        except (ValueError, struct.error):
            return  # another type on the channel: not this client's to judge
        with self._lock:
            self._learn_nq(len(state.position))
            self._state = state
            self._lock.notify_all()
            streams = list(self._streams)
        for stream in streams:
            stream._put(state)
        self._call(self._state_callbacks, state)

    def _on_status_bytes(self, channel: str, data: bytes) -> None:
        try:
            status = Status.from_message(controller_status_t.decode(data))
        except (ValueError, struct.error, UnicodeDecodeError):
            return
        with self._lock:
            self._learn_nq(status.num_joints)
            self._status = status
            self._lock.notify_all()
        self._call(self._status_callbacks, status)

    def _call(self, callbacks: list, message) -> None:
        for fn in list(callbacks):
            try:
                fn(message)
            except BaseException as e:  # kept for close(): the receive thread must go on
                if self._callback_error is None:
                    self._callback_error = e

    def state(self) -> Optional[State]:
        """The latest robot state heard, or None."""
        with self._lock:
            return self._state

    def status(self) -> Optional[Status]:
        """The latest controller status heard, or None."""
        with self._lock:
            return self._status

    def on_state(self, fn: Callable[[State], None]) -> Callable[[], None]:
        """Calls fn(state) on the receive thread for each state; returns a function that stops it.
        Keep fn short: the thread hears nothing while it runs. An exception it raises is re-raised
        by close()."""
        self._state_callbacks.append(fn)
        return lambda: self._state_callbacks.remove(fn)

    def on_status(self, fn: Callable[[Status], None]) -> Callable[[], None]:
        """As on_state, for each controller status."""
        self._status_callbacks.append(fn)
        return lambda: self._status_callbacks.remove(fn)

    def states(self, timeout: float = 1.0, size: int = 1000) -> StateStream:
        """An iterator over the states from now on (StateStream: bounded, drops the oldest)."""
        stream = StateStream(self, timeout, size)
        with self._lock:
            self._streams.add(stream)
        return stream

    def _wait(self, latest: Callable[[], object], predicate, timeout: float, what: str):
        deadline = time.monotonic() + timeout
        with self._lock:
            while True:
                message = latest()
                if message is not None and predicate(message):
                    return message
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"waited {timeout} s for {what}; {self._last_heard()}")
                self._lock.wait(left)

    def _last_heard(self) -> str:
        s = self._status
        if s is None:
            return f"no status heard on {self.channel('STATUS')} (is chasles_controller running on this bus?)"
        return f"last status {s.state_name}" + (f": {s.message}" if s.message else "")

    def wait_status(self, predicate: Callable[[Status], bool], timeout: float = 5.0, what: str = "") -> Status:
        """The first status (the latest at the call included) for which predicate holds; TimeoutError
        naming `what` (default: the predicate's name) when none does within timeout s."""
        return self._wait(lambda: self._status, predicate, timeout, what or getattr(predicate, "__name__", "a status"))

    def wait_state(self, predicate: Callable[[State], bool], timeout: float = 5.0, what: str = "") -> State:
        """As wait_status, for the robot states."""
        return self._wait(lambda: self._state, predicate, timeout, what or getattr(predicate, "__name__", "a state"))

    def wait_ready(self, timeout: float = 5.0) -> Status:
        """Waits until the controller reports a state other than WAITING: it hears the arm and
        commands it (HOLDING at start)."""
        return self.wait_status(lambda s: s.state != controller_status_t.WAITING, timeout,
                                f"chasles_controller on {self.channel('STATUS')} to hear the arm")

    def wait_until_settled(self, timeout: float = 10.0, speed: float = 1e-3) -> State:
        """Waits for the last target to end: the controller HOLDING in a status stamped after the
        target's utime plus its duration (a motion cannot end sooner; the controller's clock and
        this host's are taken to agree), and the arm at rest, every |q̇| < speed (rad/s or m/s).
        Returns the state that showed it at rest. Raises TargetRefused if the controller refused
        the target, ArmFault on FAULT or REFLEX, TimeoutError otherwise."""
        with self._lock:
            target = self._target
        if target is None:
            raise InvalidCommand("wait_until_settled: no target was sent by this client")
        utime, duration, rejections = target
        end_us = utime + int(duration * 1e6)

        def settled_or_failed(status: Status) -> bool:
            if status.utime < utime:
                return False
            if status.state in (controller_status_t.FAULT, controller_status_t.REFLEX):
                return True
            if status.rejected_messages > rejections and status.message.startswith("last target refused"):
                return True
            state = self._state
            return (status.state == controller_status_t.HOLDING and status.utime >= end_us and state is not None
                    and state.utime >= end_us and bool(np.all(np.abs(state.velocity) < speed)))

        status = self.wait_status(settled_or_failed, timeout, f"the target sent at {utime} to end at rest "
                                  f"(HOLDING, every |qd| < {speed})")
        if status.state in (controller_status_t.FAULT, controller_status_t.REFLEX):
            raise ArmFault(f"the controller is in {status.state_name}: {status.message}")
        if status.state != controller_status_t.HOLDING or status.utime < end_us:
            raise TargetRefused(status.message)
        return self.state()

    # -- sending --

    def _stamp(self, channel: str) -> int:
        """now_us(), strictly after the last stamp on `channel`: the controller drops a setpoint or
        jog not newer than the last it took."""
        utime = max(now_us(), self._last_utime.get(channel, 0) + 1)
        self._last_utime[channel] = utime
        return utime

    def _publish(self, name: str, message) -> int:
        channel = self.channel(name)
        message.utime = self._stamp(channel)
        self._lcm.publish(channel, message.encode())
        return message.utime

    def _send_target(self, target: arm_target_t) -> int:
        with self._lock:
            rejections = self._status.rejected_messages if self._status is not None else 0
        utime = self._publish("TARGET", target)
        with self._lock:
            self._target = (utime, target.duration, rejections)
        return utime

    def move_joints(self, q: ArrayLike, duration: float) -> int:
        """Sends a JOINT target (arm_target_t): reach joint positions q (rad or m, root to tip) in
        `duration` s. Returns the utime it was stamped with. Limits are the controller's to judge."""
        target = arm_target_t()
        target.mode = arm_target_t.JOINT
        goal = _vector(q, "q", self.nq)
        target.duration = _duration(duration)
        target.num_joints = goal.size
        target.joint_position = goal.tolist()
        return self._send_target(target)

    def move_cartesian(self, pose, duration: float) -> int:
        """Sends a CARTESIAN target: the tip pose T_sb (a 4×4 transform, or (p m, quaternion
        (w, x, y, z))) in the base frame, reached in `duration` s along a straight line. The
        quaternion is normalised (refused more than 1e-3 off unit norm). Returns its utime."""
        p, quaternion = pose_parts(pose)
        target = arm_target_t()
        target.mode = arm_target_t.CARTESIAN
        target.num_joints = 0
        target.tip_position = p.tolist()
        target.tip_quaternion = quaternion.tolist()
        target.duration = _duration(duration)
        return self._send_target(target)

    def hold(self) -> int:
        """Sends a HOLD target: stop and hold where the arm is. Returns its utime."""
        target = arm_target_t()
        target.mode = arm_target_t.HOLD
        target.num_joints = 0
        target.duration = 0.0
        return self._send_target(target)

    def set_mode(
        self,
        law: Union[str, int],
        *,
        stiffness: Optional[ArrayLike] = None,
        damping: Optional[ArrayLike] = None,
        damping_ratio: Optional[float] = None,
        translational: Optional[float] = None,
        rotational: Optional[float] = None,
        cartesian_stiffness: Optional[ArrayLike] = None,
        frame: Optional[ArrayLike] = None,
        posture: Optional[ArrayLike] = None,
        nullspace_stiffness: Optional[float] = None,
    ) -> int:
        """Sends a control_mode_t, as `chasles mode LAW --option ...` does (docs/tools.md gives
        each option's meaning and default; control_mode_t each law's equation).

        law: "computed-torque", "joint-impedance", "cartesian-impedance", "free-drive" or its
          control_mode_t constant. Joint values are one number for every joint or one per joint.
        stiffness: joint-impedance (required), N·m/rad, in (0, 5000].
        damping: joint-impedance (≥ 0; default from damping_ratio) or free-drive (> 0; default
          20/s · M(q)), N·m·s/rad; all 0 is refused (it means "none given").
        damping_ratio: joint- and cartesian-impedance, ζ in [0.1, 2] (default 1); not with damping.
        translational / rotational: cartesian-impedance, N/m (≤ 5000, default 1000) and N·m/rad
          (≤ 500, default 50) along and about each axis of the stiffness frame.
        cartesian_stiffness: instead of those, 6 numbers (the diagonal) or a 6×6 matrix, (ω, v).
        frame: the stiffness frame in the tip link's frame, (x, y, z) m or (x, y, z, qw, qx, qy, qz).
        posture: a fixed nullspace posture, one per joint; nullspace_stiffness in [0, 500] N·m/rad.
        Returns its utime; a refusal the model must judge (posture limits) comes back in the status.
        """
        names = {v: k for k, v in LAWS.items()}
        if isinstance(law, str):
            if law not in LAWS:
                raise InvalidCommand(f"unknown law {law!r} (laws: {', '.join(LAWS)})")
            wire = LAWS[law]
        elif law in names:
            wire = int(law)
        else:
            raise InvalidCommand(f"unknown law {law!r} (laws: {', '.join(f'{v} {k}' for k, v in LAWS.items())})")
        name = names[wire]
        given = {
            "stiffness": stiffness, "damping": damping, "damping_ratio": damping_ratio,
            "translational": translational, "rotational": rotational,
            "cartesian_stiffness": cartesian_stiffness, "frame": frame, "posture": posture,
            "nullspace_stiffness": nullspace_stiffness,
        }
        for option, value in given.items():
            if value is not None and option not in _LAW_OPTIONS[name]:
                takers = [law_name for law_name, options in _LAW_OPTIONS.items() if option in options]
                raise InvalidCommand(f"{option} does not apply to {name} (only to {' and '.join(takers)})")
        if damping is not None and damping_ratio is not None:
            raise InvalidCommand("damping replaces damping_ratio: give one of them")
        if cartesian_stiffness is not None and (translational is not None or rotational is not None):
            raise InvalidCommand("cartesian_stiffness replaces translational and rotational: give one or the other")

        m = control_mode_t()
        m.law = wire
        m.num_joints = 0
        m.damping_ratio = DEFAULT_DAMPING_RATIO if damping_ratio is None else _number(damping_ratio, "damping_ratio")
        lo, hi = DAMPING_RATIO_RANGE
        if not lo <= m.damping_ratio <= hi:
            raise InvalidCommand(f"damping ratio {m.damping_ratio} is outside [{lo}, {hi}]")
        m.stiffness_frame_quaternion = [1.0, 0.0, 0.0, 0.0]  # the tip frame itself, for every law
        m.num_posture = 0
        m.nullspace_stiffness = 0.0

        def per_joint(values: ArrayLike, option: str) -> np.ndarray:
            v = _vector(values, option)
            return np.full(self.nq, v[0]) if v.size == 1 else _vector(v, option, self.nq)

        def damping_values() -> np.ndarray:
            d = per_joint(damping, "damping")
            if not np.any(d):
                raise InvalidCommand("damping is 0 for every joint, which the controller reads as no damping "
                                     "given; omit damping for that")
            return d

        if name == "joint-impedance":
            if stiffness is None:
                raise InvalidCommand("joint-impedance needs stiffness (N*m/rad, one for every joint or one per joint)")
            k = per_joint(stiffness, "stiffness")
            bad = np.flatnonzero(~((k > 0) & (k <= MAX_JOINT_STIFFNESS)))
            if bad.size:
                raise InvalidCommand(f"joint {bad[0]}: stiffness {k[bad[0]]} is not in (0, {MAX_JOINT_STIFFNESS}]")
            d = np.zeros(self.nq) if damping is None else damping_values()
            if np.any(d < 0):
                raise InvalidCommand(f"joint {np.flatnonzero(d < 0)[0]}: damping is negative")
            m.num_joints, m.joint_stiffness, m.joint_damping = self.nq, k.tolist(), d.tolist()
        elif name == "free-drive" and damping is not None:
            d = damping_values()
            if np.any(d <= 0):
                raise InvalidCommand(f"joint {np.flatnonzero(d <= 0)[0]}: free-drive damping {d[d <= 0][0]} must be "
                                     "positive (0 would let the arm drift)")
            m.num_joints, m.joint_stiffness, m.joint_damping = self.nq, [0.0] * self.nq, d.tolist()
        elif name == "cartesian-impedance":
            m.cartesian_stiffness = _cartesian_stiffness(cartesian_stiffness, translational, rotational).tolist()
            if frame is not None:
                f = _vector(frame, "frame")
                if f.size not in (3, 7):
                    raise InvalidCommand(f"frame has {f.size} entries; give x, y, z (m) or x, y, z, qw, qx, qy, qz")
                if np.linalg.norm(f[:3]) > MAX_FRAME_OFFSET:
                    raise InvalidCommand(f"the stiffness frame is {np.linalg.norm(f[:3])} m from the tip, over "
                                         f"{MAX_FRAME_OFFSET}")
                m.stiffness_frame_position = f[:3].tolist()
                if f.size == 7:
                    m.stiffness_frame_quaternion = unit_quaternion(f[3:], "frame quaternion").tolist()
            if posture is not None:
                m.num_posture = self.nq
                m.nullspace_posture = _vector(posture, "posture", self.nq).tolist()
            m.nullspace_stiffness = (DEFAULT_NULLSPACE_STIFFNESS if nullspace_stiffness is None
                                     else _number(nullspace_stiffness, "nullspace_stiffness"))
            if not 0.0 <= m.nullspace_stiffness <= MAX_NULLSPACE_STIFFNESS:
                raise InvalidCommand(f"nullspace stiffness {m.nullspace_stiffness} is not in "
                                     f"[0, {MAX_NULLSPACE_STIFFNESS}]")
        return self._publish("MODE", m)

    def set_payload(self, mass: float, com: ArrayLike = (0.0, 0.0, 0.0), inertia: Optional[ArrayLike] = None) -> int:
        """Sends a payload_t, as `chasles payload` does: a load rigidly fixed to the tip, replacing
        the one in force; mass 0 removes it.

        mass: kg, ≥ 0. com: its centre of mass in the tip frame, m. inertia: about the centre of
        mass in the tip frame's axes, kg·m²: (Ixx, Iyy, Izz), (Ixx, Iyy, Izz, Ixy, Ixz, Iyz) or a
        symmetric 3×3; None: 0, a point mass. Refused as the controller refuses it: a number not
        finite, a negative mass, beyond any arm's load, an inertia not a body's. Returns its utime.
        """
        message = payload_t()
        message.mass = _number(mass, "mass") + 0.0  # + 0.0: -0 is sent as 0
        if message.mass == 0.0 and (inertia is not None or np.any(np.asarray(com, dtype=float) != 0)):
            raise InvalidCommand("mass 0 removes the payload; it takes no com or inertia")
        c = _vector(com, "com", 3)
        if inertia is None:
            I = np.zeros((3, 3))
        else:
            values = np.asarray(inertia, dtype=float)
            if values.shape == (3, 3):
                I = values
            elif values.shape in ((3,), (6,)):
                ixy, ixz, iyz = values[3:] if values.size == 6 else (0.0, 0.0, 0.0)
                I = np.array([[values[0], ixy, ixz], [ixy, values[1], iyz], [ixz, iyz, values[2]]])
            else:
                raise InvalidCommand(f"inertia has shape {values.shape}; give Ixx, Iyy, Izz, or Ixx, Iyy, Izz, Ixy, "
                                     "Ixz, Iyz (kg*m^2), or a 3x3 matrix")
        if not np.all(np.isfinite(I)):
            raise InvalidCommand("inertia: a number is not finite")
        if message.mass < 0:
            raise InvalidCommand(f"mass {message.mass} kg is negative")
        if (message.mass > MAX_PAYLOAD_MASS or np.linalg.norm(c) > MAX_PAYLOAD_REACH
                or np.abs(I).max() > MAX_PAYLOAD_INERTIA):
            raise InvalidCommand(
                f"mass {message.mass} kg, centre {np.linalg.norm(c)} m from the tip or an inertia entry of "
                f"{np.abs(I).max()} kg*m^2 is beyond any arm's load ({MAX_PAYLOAD_MASS} kg, {MAX_PAYLOAD_REACH} m, "
                f"{MAX_PAYLOAD_INERTIA} kg*m^2)")
        if np.linalg.norm(I - I.T) > max(1e-12 * np.linalg.norm(I), 1e-15):
            raise InvalidCommand("the inertia is not symmetric")
        if np.any(I):
            moments = np.linalg.eigvalsh(I)  # ascending
            tolerance = 2e-3 * np.abs(moments).max() + message.mass * 1e-12
            if moments[0] < -tolerance:
                raise InvalidCommand(f"principal moments {moments.tolist()} include a negative one")
            if moments[0] + moments[1] - moments[2] < -2 * tolerance:
                raise InvalidCommand(f"principal moments {moments.tolist()} break the triangle inequality")
        message.centre_of_mass = c.tolist()
        message.inertia = I.tolist()
        return self._publish("PAYLOAD", message)

    def send_trajectory(
        self,
        times: ArrayLike,
        positions: ArrayLike,
        velocities: Optional[ArrayLike] = None,
        accelerations: Optional[ArrayLike] = None,
        *,
        joint_names: Sequence[str],
        id: Optional[int] = None,
        path_tolerance: ArrayLike = 0.0,
        goal_tolerance: ArrayLike = 0.0,
        goal_time_tolerance: float = 0.0,
        time_scaling: bool = False,
    ) -> int:
        """Sends a waypoint trajectory (joint_trajectory_t), as `chasles target --trajectory`.

        times: (N,) s from when the controller takes it, increasing from > 0 (1 ≤ N ≤ 1000).
        positions, velocities, accelerations: (N, n) in joint_names' order, rad or m and per
          second; velocities and accelerations optional (accelerations only with velocities).
        joint_names: the URDF's names of every joint of the arm, in the columns' order.
        path_tolerance, goal_tolerance: one number or one per joint, rad or m, 0 for none.
        goal_time_tolerance: s ≥ 0. time_scaling: whether the controller may slow it to fit.
        id: echoed in the status's trajectory_id (default: this client's next, from 1).
        Returns the id; its outcome: wait_trajectory(id).
        """
        names = [str(name) for name in joint_names]
        n = len(names)
        if n != self.nq:
            raise InvalidCommand(f"joint_names names {n} joints; the arm has {self.nq}")
        t = _vector(times, "times")
        if not 1 <= t.size <= MAX_WAYPOINTS:
            raise InvalidCommand(f"{t.size} waypoints; a trajectory has 1 to {MAX_WAYPOINTS}")
        before = 0.0
        for k, time_k in enumerate(t):
            if not time_k > before:
                raise InvalidCommand(f"waypoint {k}: time {time_k} s is not after {before} s (times increase from > 0)")
            before = time_k

        def rows(values: ArrayLike, what: str) -> np.ndarray:
            a = np.asarray(values, dtype=float)
            if a.shape != (t.size, n):
                raise InvalidCommand(f"{what} has shape {a.shape}; expected ({t.size}, {n}): a row per waypoint")
            bad = np.argwhere(~np.isfinite(a))
            if bad.size:
                raise InvalidCommand(f"{what}: waypoint {bad[0][0]}, joint {names[bad[0][1]]} is not finite")
            return a

        def tolerance(values: ArrayLike, what: str) -> list:
            v = _vector(values, what)
            v = np.full(n, v[0]) if v.size == 1 else _vector(v, what, n)
            if np.any(v < 0):
                raise InvalidCommand(f"{what}: tolerances must be finite and non-negative")
            return v.tolist()

        if accelerations is not None and velocities is None:
            raise InvalidCommand("accelerations need velocities too")
        message = joint_trajectory_t()
        if id is None:
            self._trajectory_id += 1
            id = self._trajectory_id
        message.id = int(id)
        message.num_joints, message.num_points = n, t.size
        message.joint_names = names
        message.time_from_start = t.tolist()
        message.positions = rows(positions, "positions").tolist()
        message.num_velocities = 0 if velocities is None else t.size
        message.velocities = [] if velocities is None else rows(velocities, "velocities").tolist()
        message.num_accelerations = 0 if accelerations is None else t.size
        message.accelerations = [] if accelerations is None else rows(accelerations, "accelerations").tolist()
        message.path_tolerance = tolerance(path_tolerance, "path_tolerance")
        message.goal_tolerance = tolerance(goal_tolerance, "goal_tolerance")
        message.goal_time_tolerance = _number(goal_time_tolerance, "goal_time_tolerance")
        if message.goal_time_tolerance < 0:
            raise InvalidCommand("goal_time_tolerance must be finite and non-negative")
        message.time_scaling = bool(time_scaling)
        self._publish("TRAJECTORY", message)
        return message.id

    def wait_trajectory(self, id: int, timeout: float = 10.0) -> Status:
        """The status that ends trajectory `id` (SUCCEEDED, ABORTED, PREEMPTED or REJECTED: see
        its trajectory_outcome and trajectory_message); TimeoutError if it has not ended in time."""
        ended = (controller_status_t.TRAJECTORY_SUCCEEDED, controller_status_t.TRAJECTORY_ABORTED,
                 controller_status_t.TRAJECTORY_PREEMPTED, controller_status_t.TRAJECTORY_REJECTED)
        return self.wait_status(lambda s: s.trajectory_id == id and s.trajectory_outcome in ended, timeout,
                                f"trajectory {id} to end")

    def stream(self, setpoint: Union[JointSetpoint, TipSetpoint]) -> int:
        """Sends one setpoint of a stream, stamped now (strictly after the last): a JointSetpoint as
        joint_setpoint_t on PREFIX SETPOINT, a TipSetpoint as tip_setpoint_t on PREFIX TIP_SETPOINT.
        Send them at 10 to 1000 Hz; when they stop for the controller's --stream-timeout-ms the arm
        comes to rest. Returns the utime."""
        if isinstance(setpoint, JointSetpoint):
            message = joint_setpoint_t()
            position = _vector(setpoint.position, "setpoint position", self.nq)
            velocity = (np.zeros(self.nq) if setpoint.velocity is None
                        else _vector(setpoint.velocity, "setpoint velocity", self.nq))
            message.num_joints = self.nq
            message.position, message.velocity = position.tolist(), velocity.tolist()
            return self._publish("SETPOINT", message)
        if isinstance(setpoint, TipSetpoint):
            message = tip_setpoint_t()
            message.position = _vector(setpoint.position, "setpoint position", 3).tolist()
            quaternion = _vector(setpoint.quaternion, "setpoint quaternion", 4)
            if abs(np.linalg.norm(quaternion) - 1.0) > QUATERNION_NORM_TOLERANCE:
                raise InvalidCommand(f"setpoint quaternion has norm {np.linalg.norm(quaternion)}; it must be of unit "
                                     f"norm (within {QUATERNION_NORM_TOLERANCE})")
            message.quaternion = quaternion.tolist()  # as `chasles stream`: sent as given
            message.twist = (np.zeros(6) if setpoint.twist is None
                             else _vector(setpoint.twist, "setpoint twist", 6)).tolist()
            return self._publish("TIP_SETPOINT", message)
        raise InvalidCommand(f"stream: a JointSetpoint or a TipSetpoint is needed, got {type(setpoint).__name__}")

    def jog(self, joint_velocity: Optional[ArrayLike] = None, twist: Optional[ArrayLike] = None,
            frame: str = "base") -> int:
        """Sends one jog_command_t on PREFIX JOG, stamped now (strictly after the last): joint
        velocities (rad/s or m/s, one per joint) or a twist (ω rad/s, then v m/s) in the `frame`
        "base" (the tip's velocities in the base frame's axes) or "tool" (the body twist V_b).
        Exactly one of the two. The command holds until the next; send them at 30 Hz or more, and
        zeros to stop at once rather than at the controller's stream timeout. Returns the utime."""
        if (joint_velocity is None) == (twist is None):
            raise InvalidCommand("jog: give exactly one of joint_velocity and twist")
        message = jog_command_t()
        if joint_velocity is not None:
            v = _vector(joint_velocity, "joint_velocity", self.nq)
            message.kind = jog_command_t.JOINT_VELOCITY
            message.num_joints = v.size
            message.joint_velocity = v.tolist()
        else:
            if frame not in ("base", "tool"):
                raise InvalidCommand(f"jog frame {frame!r}: 'base' or 'tool'")
            message.kind = jog_command_t.TWIST
            message.frame = jog_command_t.TOOL if frame == "tool" else jog_command_t.BASE
            message.num_joints = 0
            message.twist = _vector(twist, "twist", 6).tolist()
        return self._publish("JOG", message)
