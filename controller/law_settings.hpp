// The control laws' settings as plain values: which law, its parameters, the bounds they must keep
// and the defaults a sender may leave out. What the wire (control_mode_t, read in
// controller/transport/lcm_io.hpp), `chasles mode` and the Python bindings share with the laws
// themselves (law.hpp), apart from their algorithms, so that the transport decodes a law without
// linking the control logic. No logic here but the names and the sizes.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "core/lie/types.hpp"

namespace chasles::controller {

enum class Law : int8_t { kComputedTorque = 0, kJointImpedance = 1, kCartesianImpedance = 2, kFreeDrive = 3 };
/// "computed-torque", "joint-impedance", "cartesian-impedance" or "free-drive".
const char* to_string(Law law);
/// The inverse of to_string; false for anything else.
bool parse_law(const std::string& text, Law& law);

/// Bounds a law's settings must keep (control_mode_t documents them for senders).
struct LawBounds {
  static constexpr double kMaxJointStiffness = 5000.0;       ///< N·m/rad or N/m
  static constexpr double kMaxRotationalStiffness = 500.0;   ///< N·m/rad, eigenvalues of K_c's ω block
  static constexpr double kMaxTranslationalStiffness = 5000.0;  ///< N/m, eigenvalues of K_c's v block
  static constexpr double kMaxNullspaceStiffness = 500.0;    ///< N·m/rad
  static constexpr double kMinDampingRatio = 0.1, kMaxDampingRatio = 2.0;
  static constexpr double kMaxFrameOffset = 1.0;  ///< m from the tip link's origin
};

/// What a law's settings are when a sender leaves them out: LawSettings starts from them, the wire
/// (control_mode_t) and `chasles mode` fall back to them, and `chasles mode --help` quotes them.
struct LawDefaults {
  static constexpr double kDampingRatio = 1.0;              ///< ζ, critical
  static constexpr double kRotationalStiffness = 50.0;      ///< N·m/rad about each axis of frame c
  static constexpr double kTranslationalStiffness = 1000.0;  ///< N/m along each axis of frame c
  static constexpr double kNullspaceStiffness = 10.0;       ///< N·m/rad per joint
  /// The decay rate of free drive's default damping D = rate · M(q), 1/s: unpushed, the arm's
  /// velocity decays in about 1/rate (50 ms) in every direction; a 10 N push on a Panda's hand
  /// moves it at about 0.15 m/s.
  static constexpr double kFreeDriveRate = 20.0;
};

/// A law and its parameters. Every vector is sized for the arm when built, so settings are copied
/// between threads and into the controller without allocating.
struct LawSettings {
  Law law = Law::kComputedTorque;
  /// Joint impedance: K per joint, N·m/rad or N/m.
  Eigen::VectorXd joint_stiffness;
  /// Joint impedance (when !damping_from_ratio) and free drive: D per joint, N·m·s/rad or N·s/m.
  Eigen::VectorXd joint_damping;
  /// Joint impedance: D_i = 2ζ√(K_i M_ii(q)), at most m_i / T (m_i = 1 / (M⁻¹(q))_ii, T the loop's
  /// period: what the loop renders), instead of joint_damping. Free drive: D =
  /// LawDefaults::kFreeDriveRate · M(q), the whole matrix, instead of joint_damping.
  bool damping_from_ratio = true;
  double damping_ratio = LawDefaults::kDampingRatio;  ///< ζ
  /// Cartesian impedance: K_c, (ω, v) order, about and in the axes of frame c.
  Matrix6d cartesian_stiffness = Matrix6d::Zero();
  /// Cartesian impedance: frame c in the tip frame, T_bc.
  Transform T_tip_frame = Transform::Identity();
  /// Cartesian impedance: the nullspace pulls toward nullspace_posture if fixed_posture, else
  /// toward the reference q_d, with nullspace_stiffness N·m/rad per joint.
  bool fixed_posture = false;
  Eigen::VectorXd nullspace_posture;
  double nullspace_stiffness = LawDefaults::kNullspaceStiffness;

  /// Computed torque, with LawDefaults for the other laws' parameters (a diagonal Cartesian
  /// stiffness); joint stiffness 0: a joint impedance must be given its K.
  explicit LawSettings(int n = 0);
};

}  // namespace chasles::controller
