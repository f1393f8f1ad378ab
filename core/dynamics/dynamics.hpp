// Rigid-body dynamics of the chain in the PoE form of Modern Robotics ch. 8: inverse dynamics by
// recursive Newton-Euler, the mass matrix by composite rigid bodies, forward dynamics by a
// Cholesky solve. Every function allocates nothing and writes its result into Data.
//
// The equations of motion are τ = M(q) q̈ + c(q, q̇) + g(q) + J_bᵀ(q) F_tip, where F_tip is the
// wrench the tip applies to the environment, in the tip frame, (m, f) order (MR eq. 8.1, 8.54).
//
// M(q) = M_rigid(q) + diag(model.armature()): each joint's reflected rotor inertia (MR §8.9.2) is on
// the diagonal of every M these functions compute, and τ = ID(q, q̇, q̈) includes armature ∘ q̈, as
// Pinocchio's crba and rnea with model.armature. A constant diagonal leaves c, g and Cᵀq̇ alone.
#pragma once

#include <string>

#include "core/kinematics/kinematics.hpp"

namespace chasles {

/// τ = ID(q, q̇, q̈, F_tip) by RNEA with the model's gravity (MR §8.3.2).
const Eigen::VectorXd& inverse_dynamics(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd, const JointVector& qdd,
                                        const Vector6d& F_tip = Vector6d::Zero());

/// g(q): the torques that hold the arm still against gravity.
const Eigen::VectorXd& gravity_torques(const RobotModel& model, Data& data, const JointVector& q);

/// c(q, q̇) = C(q, q̇) q̇: Coriolis and centripetal torques (no gravity).
const Eigen::VectorXd& velocity_product(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd);

/// The terms of the generalized-momentum balance ṗ = τ + Cᵀ(q, q̇) q̇ − g(q) + τ_ext, in one O(n)
/// pass: p = M(q) q̇ into data.p, Cᵀ(q, q̇) q̇ into data.ct_qd (with the Christoffel C, so that
/// Ṁ = C + Cᵀ) and g(q) into data.g. Joint j's entries are A_jᵀ H_j, A_jᵀ [ad_{V_j}]ᵀ H_j and A_jᵀ W_j,
/// H_j and W_j being the momentum of bodies j…n and the wrench that holds them against gravity, in
/// body j's frame: since p = Σ J_iᵀ G_i V_i with each body's own inertia constant, ṗ − Σ J_iᵀ Ḣ_i =
/// Σ J̇_iᵀ G_i V_i, and joint j's column moves as [Ad_T0j] ad_{V_j} A_j. Returns data.p.
const Eigen::VectorXd& momentum_terms(const RobotModel& model, Data& data, const JointVector& q, const JointVector& qd);

/// Everything a control tick needs at (q, q̇), with the joint transforms computed once (as
/// Pinocchio's computeAllTerms): the body poses data.T_body, the tip pose data.T_sb, the body
/// Jacobian data.J_b, the body twists data.V, the mass matrix data.M (full, symmetric), the bias
/// data.bias = c + g with data.c and data.g apart, and the momentum-balance terms data.p = M q̇ and
/// data.ct_qd = Cᵀ q̇ (see momentum_terms). One forward pass, one backward pass and the mass
/// matrix's O(n²) columns; allocates nothing. Returns data.
const Data& compute_tick_terms(const RobotModel& model, Data& data, const JointVector& q, const JointVector& qd);

/// M(q) by the composite-rigid-body algorithm; the full symmetric matrix.
const Eigen::MatrixXd& mass_matrix(const RobotModel& model, Data& data, const JointVector& q);

/// q̈ = FD(q, q̇, τ, F_tip) = M⁻¹(τ − c − g − J_bᵀ F_tip), by a Cholesky factorisation of M kept in
/// data.M_llt (so a second solve at the same q is cheap). Throws DynamicsError, naming the joint
/// (see mass_matrix_defect), when M(q) is singular.
const Eigen::VectorXd& forward_dynamics(const RobotModel& model, Data& data, const JointVector& q,
                                        const JointVector& qd, const JointVector& tau,
                                        const Vector6d& F_tip = Vector6d::Zero());

/// Why M(q) is singular, naming the first joint whose column adds no inertia, or "" when M(q) is
/// positive definite. Allocates: for start-up checks and error messages, not for a tick.
std::string mass_matrix_defect(const RobotModel& model, Data& data, const JointVector& q);

/// The same at the middle of every joint's range: the check a controller or simulator makes before
/// it starts (a chain whose last bodies are massless is singular everywhere).
std::string mass_matrix_defect(const RobotModel& model);

/// ½ q̇ᵀ M(q) q̇, summed body by body as ½ Σ V_iᵀ G_i V_i, plus the rotors' ½ Σ armature_i q̇_i².
double kinetic_energy(const RobotModel& model, Data& data, const JointVector& q, const JointVector& qd);

/// −Σ m_i gᵀ c_i: the potential energy of gravity, zero when every centre of mass is at the base
/// origin's height along g.
double potential_energy(const RobotModel& model, Data& data, const JointVector& q);

}  // namespace chasles
