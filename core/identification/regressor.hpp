// The dynamics of a serial chain are linear in its inertial and joint parameters (Atkeson, An and
// Hollerbach 1986; Khalil and Dombre ch. 12): τ = Y(q, q̇, q̈) π. The regressor Y is what
// identification from an arm's own logs fits π with; this header fixes π's layout and computes Y
// by a recursion over the bodies, as Pinocchio's computeJointTorqueRegressor does.
//
// Layout of π for an n-joint chain (13 n entries):
//   [ 10 n inertial | n viscous | n Coulomb | n armature ]
// Body i's ten inertial parameters (index 10 i … 10 i + 9), in body i's own frame, with the
// rotational inertia about the frame's origin (not the centre of mass) — the model's
// SpatialInertia, so that each enters the Newton-Euler equations linearly:
//   π_i = (m, h_x, h_y, h_z, I_xx, I_xy, I_xz, I_yy, I_yz, I_zz),  h = m c.
// Joint i's friction and rotor: viscous f_v (N·m·s/rad) with τ = f_v q̇, Coulomb f_c (N·m) with
// τ = f_c sign(q̇) (sign 0 = 0), armature a (kg·m²) with τ = a q̈ (model.armature()); for a
// prismatic joint read N, N·s/m and kg.
#pragma once

#include <vector>

#include "core/kinematics/kinematics.hpp"

namespace chasles {

using Vector10d = Eigen::Matrix<double, 10, 1>;
using Matrix6x10d = Eigen::Matrix<double, 6, 10>;

/// Where each parameter of π sits, for an n-joint chain.
struct ParameterLayout {
  int n = 0;
  static constexpr int kInertial = 10;  ///< inertial parameters per body
  /// Index of body i's first inertial parameter (its mass); k-th of the ten at inertial(i) + k.
  int inertial(int i) const { return kInertial * i; }
  int viscous(int i) const { return kInertial * n + i; }
  int coulomb(int i) const { return 11 * n + i; }
  int armature(int i) const { return 12 * n + i; }
  /// 13 n.
  int size() const { return 13 * n; }
};

/// π's layout for this model.
inline ParameterLayout parameter_layout(const RobotModel& model) { return ParameterLayout{model.dof()}; }

/// Names of the ten inertial parameters in their order, as used in reports: "m", "hx", … "Izz".
extern const char* const kInertialParameterNames[10];

/// The ten parameters of a spatial inertia, in the order above.
Vector10d body_parameters(const SpatialInertia& G);

/// The spatial inertia with these ten parameters (I symmetric by construction).
SpatialInertia spatial_inertia(const Vector10d& pi);

/// The model's inertial parameters, n × 10: row i is body i's π_i.
Eigen::MatrixXd inertial_parameters(const RobotModel& model);

/// The model's full π (13 n): its inertial parameters and armature, with zero friction (a model
/// carries none).
Eigen::VectorXd model_parameters(const RobotModel& model);

/// The model with each body's inertia replaced by row i of `parameters` (n × 10), as with_payload
/// and with_armature build new models. Throws ModelError for the wrong shape or for a body the
/// model refuses (a negative mass, an inertia that is not physical: see model/inertia.hpp).
/// Allocates: built once, off any real-time loop.
RobotModel with_inertial_parameters(const RobotModel& model, const Eigen::MatrixXd& parameters);

/// Scratch and result of joint_torque_regressor for one model, sized once.
struct RegressorWorkspace {
  explicit RegressorWorkspace(const RobotModel& model);
  Data data;                        ///< kinematics, body twists V_i and accelerations V̇_i
  std::vector<Matrix6x10d> A;       ///< each body's momentum-rate regressor, F_i = A_i π_i
  Eigen::MatrixXd Y;                ///< n × 13 n, the regressor
};

/// Body i's wrench F = G V̇ − [ad_V]ᵀ G V (MR eq. 8.52 without the children's) as a linear map of
/// its ten parameters: F = A(V, V̇) π_i. With ω, v = V and α, a = V̇ (gravity in a):
///   moment = I α + ω × I ω − (a + ω × v) × h,   force = m (a + ω × v) + (α × + ω × ω ×) h.
Matrix6x10d momentum_rate_regressor(const Vector6d& V, const Vector6d& Vd);

/// Y(q, q̇, q̈) with Y π = ID(q, q̇, q̈) + f_v ∘ q̇ + f_c ∘ sign(q̇) + a ∘ q̈ for every π laid out as
/// above (MR §8.3.2's RNEA with the model's gravity; its kinematics and joint axes, not its
/// inertias). Forward pass: V_i, V̇_i with gravity as the base acceleration (0, −g); backward: row i,
/// block j ≥ i is A_iᵀ [Ad_{T_ij}]ᵀ A_j (joint i's share of body j's wrench). Allocates nothing;
/// returns workspace.Y.
const Eigen::MatrixXd& joint_torque_regressor(const RobotModel& model, RegressorWorkspace& workspace,
                                              const JointVector& q, const JointVector& qd, const JointVector& qdd);

}  // namespace chasles
