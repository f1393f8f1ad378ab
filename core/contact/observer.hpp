// What the environment does to the arm, estimated from what the arm does: the generalized-momentum
// observer of De Luca and Haddadin for the external joint torque, and the tip wrench that explains
// it.
//
// The momentum balance of the model is ṗ = τ − D q̇ + Cᵀ(q, q̇) q̇ − g(q) + τ_ext (p = M q̇, D the
// known viscous damping). The observer's residual
//     r = K_O [p − p(0) − ∫ (τ − D q̇ + Cᵀq̇ − g + r) dt]
// obeys ṙ = K_O (τ_ext − r): each joint's r is τ_ext through a first-order lag of time constant
// 1/K_O, with no acceleration measured and no inversion of M.
//
// Discrete form, for states sampled every T with τ held over each step (what robot_state_t.effort
// reports): over a step the momentum balance gives the mean external torque exactly but for the
// smooth terms, integrated by the trapezoid rule (error O(T³) per step),
//     τ̄_ext,k = (p_k − p_{k−1}) / T − τ_k − ½ (γ_{k−1} + γ_k),   γ = Cᵀq̇ − g − D q̇,
// and the lag is advanced exactly for a constant input over T,
//     r_k = a r_{k−1} + (1 − a) τ̄_ext,k,   a = exp(−K_O T),
// so for a constant τ_ext the residual is (1 − exp(−K_O t)) τ_ext at every sample, whatever T.
#pragma once

#include <Eigen/Core>

#include "core/kinematics/kinematics.hpp"

namespace chasles {

/// Thrown for gains, periods or damping that cannot make an observer (sizes, signs, non-finite).
class ObserverError : public Error {
 public:
  using Error::Error;
};

/// The momentum observer of one arm: allocates nothing after construction. It owns no Data: each
/// sample's p = M q̇, Cᵀq̇ and g come from the caller's, computed at that sample by
/// compute_tick_terms (a controller's tick) or momentum_terms.
/// The velocity, rad/s (m/s), below which known Coulomb friction f_c is taken as f_c tanh(q̇ / v_c)
/// rather than f_c sign(q̇): the observer's and the law's, so that the joint at rest (where static
/// friction is anything in ±f_c) and a reference through zero velocity see no step.
constexpr double kCoulombVelocity = 0.05;

/// f_c ∘ tanh(q̇ / kCoulombVelocity) added to `tau` (nothing for an empty f_c). Allocates nothing.
void add_coulomb_friction(const Eigen::VectorXd& coulomb, const Eigen::VectorXd& qd, Eigen::VectorXd& tau);

class MomentumObserver {
 public:
  /// `gain` is K_O, 1/s, one per joint of `model` (the bandwidth of the estimate); `damping` the
  /// model's known viscous joint damping D, N·m·s/rad or N·s/m, and `coulomb` its known Coulomb
  /// friction f_c, N·m or N (each empty: none; identified by chasles_calibrate dynamics). Throws
  /// ObserverError.
  MomentumObserver(const RobotModel& model, const Eigen::VectorXd& gain, const Eigen::VectorXd& damping = {},
                   const Eigen::VectorXd& coulomb = {});

  /// Starts (again) from the sample in `data` (p, Cᵀq̇ and g at (q, q̇)) with r = 0: the first
  /// update() integrates from here.
  void reset(const Data& data, const JointVector& qd);
  bool started() const { return started_; }

  /// Takes the sample in `data` (p, Cᵀq̇ and g at (q, q̇)) reached `dt` seconds after the previous
  /// one, with τ the joint torque applied over that interval; returns τ̂_ext = r. Before reset(),
  /// only starts. Throws ArgumentError for a dt that is not positive and finite, whatever the state:
  /// no step of that length can be integrated (reset() starts again).
  const Eigen::VectorXd& update(const Data& data, const JointVector& qd, const JointVector& tau, double dt);

  /// τ̂_ext: N·m or N per joint, the torque the environment applies, positive along the joint axis.
  const Eigen::VectorXd& external_torque() const { return r_; }
  const Eigen::VectorXd& gain() const { return gain_; }

 private:
  // γ = Cᵀq̇ − g − D q̇ − f_c tanh(q̇ / v_c) at the sample in data.
  void momentum_balance(const Data& data, const JointVector& qd, Eigen::VectorXd& gamma) const;

  Eigen::VectorXd gain_, damping_, coulomb_;
  Eigen::VectorXd r_, p_prev_, gamma_, gamma_prev_, mean_;
  bool started_ = false;
};

/// Damping of the wrench estimate near a singularity: a singular value σ of J_b below `threshold`
/// gets λ² = λ_max² (1 − (σ/threshold)²) (no damping above it, the exact least-squares answer).
struct WrenchDamping {
  double threshold = 0.02;  ///< m (J_b's linear rows are in m)
  double lambda_max = 0.02;
};

/// F̂ = (J_bᵀ)⁺ τ: the wrench on the tip, in the tip frame, (m, f), whose joint torques J_bᵀ F best
/// match τ, by damped least squares over the singular directions of J_b, so it stays bounded at a
/// singularity (|F̂| ≤ |τ| / 2λ_max there) and is exact where J_b has full row rank. A direction the
/// joints cannot feel (a chain of fewer than six joints, or at a singularity) gets no wrench.
/// Allocates nothing.
Vector6d tip_wrench_from_torque(const Matrix6Xd& J_b, const Eigen::VectorXd& tau, const WrenchDamping& damping = {});

/// A tip-frame wrench (m, f) with the base frame's orientation, still about the tip's origin
/// (libfranka's O_F_ext_hat_K, in (m, f) order): (R_sb m, R_sb f).
Vector6d base_aligned_wrench(const Transform& T_sb, const Vector6d& F_tip);

}  // namespace chasles
