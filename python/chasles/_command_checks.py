"""What the client sends, judged before it goes (chasles.client re-exports every name here).

Each check raises InvalidCommand naming the input and why, on the grounds the `chasles` tool and the
controller use: a wrong shape, a number that is not finite, a quaternion off unit norm, a setting
outside the bounds the C++ gives (read from chasles._core, so that the two never disagree). Apart
from the client (chasles.client) because none of it touches the bus: it turns what a caller gives
into numbers a message may carry, or refuses it.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Union

import numpy as np

from chasles._core import ArgumentError
# The bounds and defaults these checks share with the C++ that judges the same commands: a
# quaternion's norm tolerance (core/lie/so3.hpp), a law's bounds and defaults (controller/law.hpp);
# the client reads the rest of them (chasles.client says which).
from chasles._core import (
    DEFAULT_ROTATIONAL_STIFFNESS,
    DEFAULT_TRANSLATIONAL_STIFFNESS,
    MAX_DAMPING_RATIO,
    MAX_ROTATIONAL_STIFFNESS,
    MAX_TRANSLATIONAL_STIFFNESS,
    MIN_DAMPING_RATIO,
    QUATERNION_NORM_TOLERANCE,
)
from chasles.lcmtypes import control_mode_t

ArrayLike = Union[Sequence[float], np.ndarray]

DAMPING_RATIO_RANGE = (MIN_DAMPING_RATIO, MAX_DAMPING_RATIO)
#: joint_trajectory_t holds 1 to this many waypoints.
MAX_WAYPOINTS = 1000

LAWS = {
    "computed-torque": control_mode_t.COMPUTED_TORQUE,
    "joint-impedance": control_mode_t.JOINT_IMPEDANCE,
    "cartesian-impedance": control_mode_t.CARTESIAN_IMPEDANCE,
    "free-drive": control_mode_t.FREE_DRIVE,
}
#: The options each law reads (`chasles mode` refuses the others as well).
_LAW_OPTIONS = {
    "computed-torque": set(),
    "joint-impedance": {"stiffness", "damping", "damping_ratio"},
    "cartesian-impedance": {"damping_ratio", "translational", "rotational", "cartesian_stiffness", "frame", "posture",
                            "nullspace_stiffness"},
    "free-drive": {"damping"},
}


class InvalidCommand(ArgumentError):
    """A command refused before anything was sent; the message says which input and why. A
    :class:`chasles.ArgumentError`, hence a :class:`chasles.Error` and a ``ValueError``."""


# ---- checks, each naming the input -------------------------------------------------------------


def _vector(values: ArrayLike, name: str, size: Optional[int] = None) -> np.ndarray:
    """`values` as a finite float vector of `size` entries (any size when None)."""
    try:
        v = np.array(values, dtype=float)
    except (TypeError, ValueError) as e:
        raise InvalidCommand(f"{name}: not a list of numbers ({e})") from None
    if v.ndim == 0:
        v = v.reshape(1)
    if v.ndim != 1:
        raise InvalidCommand(f"{name}: a vector is needed, got an array of shape {v.shape}")
    if size is not None and v.size != size:
        raise InvalidCommand(f"{name} has {v.size} entries, expected {size}")
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:
        raise InvalidCommand(f"{name}: entry {bad[0]} is {v[bad[0]]}, not a finite number")
    return v


def _number(value: float, name: str) -> float:
    x = float(value)
    if not math.isfinite(x):
        raise InvalidCommand(f"{name} is {x}, not a finite number")
    return x


def _duration(value: float) -> float:
    seconds = _number(value, "duration")
    if seconds <= 0.0:
        raise InvalidCommand(f"duration: {seconds} s; the time to reach the goal must be positive and finite")
    return seconds


def unit_quaternion(quaternion: ArrayLike, name: str = "quaternion") -> np.ndarray:
    """A quaternion (w, x, y, z) normalised; refused when its norm is more than 1e-3 from 1."""
    q = _vector(quaternion, name, 4)
    norm = float(np.linalg.norm(q))
    if not abs(norm - 1.0) <= QUATERNION_NORM_TOLERANCE:
        raise InvalidCommand(
            f"{name} (w, x, y, z) = ({', '.join(repr(float(x)) for x in q)}) has norm {norm!r}; give a unit "
            f"quaternion (norms within {QUATERNION_NORM_TOLERANCE} of 1 are normalised)"
        )
    return q / norm


def quaternion_from_rotation(R: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z), w ≥ 0, of a rotation matrix (Shepperd's method: the
    largest of the four squared components is taken first, so no branch divides by a small one)."""
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    squares = np.array([1.0 + trace, 1.0 + 2 * R[0, 0] - trace, 1.0 + 2 * R[1, 1] - trace, 1.0 + 2 * R[2, 2] - trace])
    k = int(np.argmax(squares))
    s = 2.0 * math.sqrt(squares[k])  # 4 × the k-th component
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    q = np.array(q)
    return -q if q[0] < 0 else q


def rotation_from_quaternion(quaternion: ArrayLike) -> np.ndarray:
    """R of a unit quaternion (w, x, y, z)."""
    w, x, y, z = quaternion
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def pose_parts(pose) -> tuple[np.ndarray, np.ndarray]:
    """(p, quaternion (w, x, y, z)) of a pose given as a 4×4 homogeneous T or as (p, quaternion);
    the rotation must be one (orthonormal within 1e-6, determinant +1), the quaternion unit."""
    if isinstance(pose, (tuple, list)) and len(pose) == 2:
        return _vector(pose[0], "pose position", 3), unit_quaternion(pose[1], "pose quaternion")
    T = np.asarray(pose, dtype=float)
    if T.shape != (4, 4):
        raise InvalidCommand(f"pose: a 4x4 transform or (position, quaternion) is needed, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise InvalidCommand("pose: the transform holds a number that is not finite")
    R = T[:3, :3]
    if not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
        raise InvalidCommand(f"pose: the last row is {T[3].tolist()}, not [0, 0, 0, 1]")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or abs(np.linalg.det(R) - 1.0) > 1e-6:
        raise InvalidCommand("pose: the upper-left 3x3 block is not a rotation (orthonormal, determinant +1)")
    return T[:3, 3].copy(), quaternion_from_rotation(R)


def _cartesian_stiffness(matrix: Optional[ArrayLike], translational: Optional[float],
                         rotational: Optional[float]) -> np.ndarray:
    """K_c, (ω, v) order, checked as law_problem checks it: symmetric, positive definite, each
    diagonal block's eigenvalues within their bounds."""
    if matrix is None:
        r = DEFAULT_ROTATIONAL_STIFFNESS if rotational is None else _number(rotational, "rotational")
        t = DEFAULT_TRANSLATIONAL_STIFFNESS if translational is None else _number(translational, "translational")
        K = np.diag([r, r, r, t, t, t])
    else:
        K = np.asarray(matrix, dtype=float)
        if K.shape == (6,):
            K = np.diag(K)
        elif K.shape != (6, 6):
            raise InvalidCommand(f"cartesian_stiffness has shape {K.shape}; give 6 numbers (the diagonal, rotational "
                                 "first) or a 6x6 matrix")
    if not np.all(np.isfinite(K)):
        raise InvalidCommand("the Cartesian stiffness is not finite")
    if not np.abs(K - K.T).max() <= 1e-9 * np.abs(K).max():
        raise InvalidCommand("the Cartesian stiffness is not symmetric")
    rotational_eigenvalues = np.linalg.eigvalsh(K[:3, :3])
    translational_eigenvalues = np.linalg.eigvalsh(K[3:, 3:])
    if not (rotational_eigenvalues[0] > 0 and translational_eigenvalues[0] > 0 and np.linalg.eigvalsh(K)[0] > 0):
        raise InvalidCommand(
            "the Cartesian stiffness is not positive definite (eigenvalues of its rotational block from "
            f"{rotational_eigenvalues[0]}, of its translational block from {translational_eigenvalues[0]})")
    if rotational_eigenvalues[-1] > MAX_ROTATIONAL_STIFFNESS:
        raise InvalidCommand(f"the Cartesian rotational stiffness reaches {rotational_eigenvalues[-1]} N*m/rad, over "
                             f"{MAX_ROTATIONAL_STIFFNESS}")
    if translational_eigenvalues[-1] > MAX_TRANSLATIONAL_STIFFNESS:
        raise InvalidCommand(f"the Cartesian translational stiffness reaches {translational_eigenvalues[-1]} N/m, over "
                             f"{MAX_TRANSLATIONAL_STIFFNESS}")
    return K
