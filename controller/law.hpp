// The control laws a Controller can run, each a free function of the model, the state and the
// reference, writing joint torques into a preallocated vector (the safety pipeline after them is
// the Controller's, the same for every law):
//
//   computed torque      τ = M(q)(q̈_d + K_d ė + K_p e) + c + g                       (MR eq. 11.35)
//   joint impedance      τ = K e + D ė + M(q) q̈_d + c + g,  D = 2ζ√(K_i M_ii(q)) by default
//   Cartesian impedance  τ = J_cᵀ (K_c ξ + D_c ξ̇) + c + g + N(q) τ_null,  about the stiffness frame c
//                        fixed on the tip; ξ = log(T_sc⁻¹ T_sd) ∈ se(3), exact to θ = π; D_c by
//                        double diagonalisation of K_c with the Cartesian inertia Λ(q), so every
//                        mode of the tip is damped by ζ wherever the arm is; N the dynamically
//                        consistent nullspace projector I − J_cᵀ Λ J_c M⁻¹
//   free drive           τ = c + g − D q̇: the arm floats, damped, and stays where it is left
//
// with e = q_d − q. The Cartesian law's desired pose and twist are those of frame c at the joint
// reference (T_sd = T_sb(q_d) T_bc, V_d = J_c(q_d) q̇_d), so every target the controller follows —
// a quintic joint motion, a Cartesian path planned by IK, a hold — works under every law.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "core/motion/quintic.hpp"
#include "core/model/model.hpp"

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

/// Whether `settings` can drive `model`: nullptr, or why not written into `why` (naming the field
/// and the joint), without allocating: sizes, finiteness, K positive and within LawBounds, K_c
/// symmetric and each diagonal block positive definite within bounds (the whole positive
/// definite), ζ in its range, a rotation that is one, a posture within the joint limits.
const char* law_problem(const RobotModel& model, const LawSettings& settings, char (&why)[192]);

/// The damping that makes Λ ẍ + D ẋ + K x = 0 damped by ζ in every mode: with Λ = L Lᵀ and
/// L⁻¹ K L⁻ᵀ = U Σ Uᵀ, Q = L U gives Λ = Q Qᵀ and K = Q Σ Qᵀ, and D = Q (2ζ√Σ) Qᵀ (double
/// diagonalisation, Albu-Schäffer et al. 2003). Λ and K symmetric positive definite.
Matrix6d modal_damping(const Matrix6d& Lambda, const Matrix6d& K, double zeta);

/// Everything a law needs beside the model's Data, sized once.
struct LawWorkspace {
  Matrix6Xd J_c;              ///< Jacobian of frame c, in frame c
  Eigen::MatrixXd Minv_JcT;   ///< M⁻¹ J_cᵀ, n × 6
  Eigen::VectorXd null_torque;
  Eigen::VectorXd damping;  ///< the joint impedance's D at the last call
  Eigen::VectorXd apparent_inertia;  ///< 1 / (M⁻¹)_ii: joint i's inertia with the others free
  Eigen::VectorXd inverse_column;    ///< column i of M⁻¹, on the way to apparent_inertia(i)
  /// The loop's period, s: the joint impedance's damping from a ratio is bounded by what a loop of
  /// this period renders (0: unbounded).
  double period = 0.0;
  /// An impedance's own pull at the last call, τ less what compensates the arm's dynamics: K e + D ė
  /// (joint), J_cᵀ F + N τ_null (Cartesian). The force the arm is meant to apply when it presses.
  Eigen::VectorXd spring;
  Matrix6d Lambda = Matrix6d::Zero();  ///< the Cartesian inertia at frame c, bounded
  Vector6d xi = Vector6d::Zero(), xi_dot = Vector6d::Zero(), wrench = Vector6d::Zero();
  explicit LawWorkspace(int n = 0);
};

/// The largest eigenvalue the Cartesian inertia is allowed, kg (or kg·m²): near a singularity Λ
/// grows without bound along the lost direction; clamped there, the damping and the nullspace
/// projector stay finite and the law keeps commanding bounded torques.
inline constexpr double kMaxCartesianInertia = 100.0;

// Each law reads the terms of the tick from `data`, computed at the state (q, q̇) by
// compute_tick_terms (M, c + g, the tip pose and J_b), and owns no Data; the impedances factor M
// into data.M_llt, the one factor of M a tick keeps.

/// Computed torque into tau: M (q̈_d + K_d ė + K_p e) + c + g.
void computed_torque(const RobotModel& model, const Data& data, const Eigen::VectorXd& kp, const Eigen::VectorXd& kd,
                     const motion::Reference& ref, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                     Eigen::VectorXd& qdd_scratch, Eigen::VectorXd& tau);

/// Joint impedance into tau.
void joint_impedance(const RobotModel& model, Data& data, LawWorkspace& work, const LawSettings& settings,
                     const motion::Reference& ref, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, Eigen::VectorXd& tau);

/// Cartesian impedance with nullspace into tau; work.xi, xi_dot, wrench and Lambda hold its parts.
/// `data_ref` holds the tip pose and J_b at the reference q_d (body_jacobian at ref.q).
void cartesian_impedance(const RobotModel& model, Data& data, const Data& data_ref, LawWorkspace& work,
                         const LawSettings& settings, const motion::Reference& ref, const Eigen::VectorXd& q,
                         const Eigen::VectorXd& qd, Eigen::VectorXd& tau);

/// Free drive into tau.
void free_drive(const RobotModel& model, const Data& data, const LawSettings& settings, const Eigen::VectorXd& qd,
                Eigen::VectorXd& tau);

/// The compliant reflex into tau: gravity and velocity terms compensated and every joint damped as
/// q̈ = −rate q̇, τ = M (−rate q̇) + c + g; nothing holds the arm, so it yields to a push and stops
/// where it is left.
void damped_float(const RobotModel& model, const Data& data, double rate, const Eigen::VectorXd& qd,
                  Eigen::VectorXd& qdd_scratch, Eigen::VectorXd& tau);

}  // namespace chasles::controller
