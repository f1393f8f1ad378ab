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

#include "controller/law_settings.hpp"
#include "core/motion/quintic.hpp"
#include "core/model/model.hpp"

namespace chasles::controller {

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
