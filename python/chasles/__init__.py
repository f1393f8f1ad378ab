"""chasles from Python: the robot model, its kinematics and dynamics, the momentum observer, inverse
kinematics and calibration of chasles's C++ core (the extension ``chasles._core``), with numpy in
and out.

Conventions are Modern Robotics' (Lynch & Park): twists and Jacobian rows (ω, v), wrenches (m, f),
SI units. Every error is a :class:`chasles.Error` carrying the C++ library's message.

The client for the running arm and the log reader are the modules ``chasles.client`` and
``chasles.logs``.
"""

from ._core import (
    ArgumentError as ArgumentError,
    CalibrationError as CalibrationError,
    CalibrationOptions as CalibrationOptions,
    CalibrationResult as CalibrationResult,
    Dataset as Dataset,
    DynamicsError as DynamicsError,
    Error as Error,
    IkOptions as IkOptions,
    IkResult as IkResult,
    IkSolver as IkSolver,
    KinematicCorrections as KinematicCorrections,
    Loss as Loss,
    Model as Model,
    ModelError as ModelError,
    MomentumObserver as MomentumObserver,
    ObserverError as ObserverError,
    ResidualStats as ResidualStats,
    TipNotChosenError as TipNotChosenError,
    calibrate as calibrate,
    corrected_model as corrected_model,
    corrected_urdf as corrected_urdf,
    parameter_names as parameter_names,
    parse_dataset as parse_dataset,
    read_dataset as read_dataset,
    tip_wrench_from_torque as tip_wrench_from_torque,
)

__all__ = [
    "ArgumentError",
    "CalibrationError",
    "CalibrationOptions",
    "CalibrationResult",
    "Dataset",
    "DynamicsError",
    "Error",
    "IkOptions",
    "IkResult",
    "IkSolver",
    "KinematicCorrections",
    "Loss",
    "Model",
    "ModelError",
    "MomentumObserver",
    "ObserverError",
    "ResidualStats",
    "TipNotChosenError",
    "calibrate",
    "corrected_model",
    "corrected_urdf",
    "parameter_names",
    "parse_dataset",
    "read_dataset",
    "tip_wrench_from_torque",
]
