#include "controller/law.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "core/lie/se3.hpp"

namespace chasles::controller {
namespace {

// A rotation matrix off orthonormal by more than this did not come from a unit quaternion.
constexpr double kRotationTolerance = 1e-6;
// K_c's off-diagonal blocks must match their transposes to this relative precision.
constexpr double kSymmetryTolerance = 1e-9;

const char* say(char (&why)[192], const char* format, ...) __attribute__((format(printf, 2, 3)));
const char* say(char (&why)[192], const char* format, ...) {
  va_list args;
  va_start(args, format);
  std::vsnprintf(why, sizeof(why), format, args);
  va_end(args);
  return why;
}

// The eigenvalues of a symmetric 3×3 block, ascending.
Vector3d block_eigenvalues(const Matrix3d& block) {
  return Eigen::SelfAdjointEigenSolver<Matrix3d>(block, Eigen::EigenvaluesOnly).eigenvalues();
}

// M(q) x + c + g into tau, from the tick's terms: the inverse dynamics at q̈ = x.
void inverse_dynamics_at(const Data& data, const Eigen::VectorXd& x, Eigen::VectorXd& tau) {
  tau.noalias() = data.M * x;
  tau += data.bias;
}

}  // namespace

LawWorkspace::LawWorkspace(int n)
    : J_c(Matrix6Xd::Zero(6, n)),
      Minv_JcT(Eigen::MatrixXd::Zero(n, 6)),
      null_torque(Eigen::VectorXd::Zero(n)),
      damping(Eigen::VectorXd::Zero(n)),
      apparent_inertia(Eigen::VectorXd::Zero(n)),
      inverse_column(Eigen::VectorXd::Zero(n)),
      spring(Eigen::VectorXd::Zero(n)) {}

constexpr double kMaxDampingPerPeriod = 1.0;  // D T / m, see joint_impedance

const char* law_problem(const RobotModel& model, const LawSettings& s, char (&why)[192]) {
  const int n = model.dof();
  if (s.joint_stiffness.size() != n || s.joint_damping.size() != n || s.nullspace_posture.size() != n) {
    return say(why, "settings sized for another arm (the arm has %d joints)", n);
  }
  if (!(s.damping_ratio >= LawBounds::kMinDampingRatio && s.damping_ratio <= LawBounds::kMaxDampingRatio)) {
    return say(why, "damping ratio %g is outside [%g, %g]", s.damping_ratio, LawBounds::kMinDampingRatio,
               LawBounds::kMaxDampingRatio);
  }
  switch (s.law) {
    case Law::kComputedTorque:
      return nullptr;
    case Law::kJointImpedance:
      for (int i = 0; i < n; ++i) {
        const double k = s.joint_stiffness(i), d = s.joint_damping(i);
        if (!(k > 0.0 && k <= LawBounds::kMaxJointStiffness)) {
          return say(why, "joint %s: stiffness %g is not in (0, %g]", model.joint(i).name.c_str(), k,
                     LawBounds::kMaxJointStiffness);
        }
        if (!s.damping_from_ratio && !(d >= 0.0 && std::isfinite(d))) {
          return say(why, "joint %s: damping %g is not finite and non-negative", model.joint(i).name.c_str(), d);
        }
      }
      return nullptr;
    case Law::kFreeDrive:
      for (int i = 0; i < n && !s.damping_from_ratio; ++i) {
        const double d = s.joint_damping(i);
        if (!(d > 0.0 && std::isfinite(d))) {
          return say(why, "joint %s: free-drive damping %g must be positive and finite (0 would let the arm drift)",
                     model.joint(i).name.c_str(), d);
        }
      }
      return nullptr;
    case Law::kCartesianImpedance:
      break;
    default:
      return say(why, "unknown law %d", static_cast<int>(s.law));
  }
  const Matrix6d& K = s.cartesian_stiffness;
  if (!K.allFinite()) return say(why, "the Cartesian stiffness is not finite");
  if (!((K - K.transpose()).cwiseAbs().maxCoeff() <= kSymmetryTolerance * K.cwiseAbs().maxCoeff())) {
    return say(why, "the Cartesian stiffness is not symmetric");
  }
  const Vector3d rotational = block_eigenvalues(K.topLeftCorner<3, 3>());
  const Vector3d translational = block_eigenvalues(K.bottomRightCorner<3, 3>());
  if (!(rotational(0) > 0.0) || !(translational(0) > 0.0) || Eigen::LLT<Matrix6d>(K).info() != Eigen::Success) {
    return say(why, "the Cartesian stiffness is not positive definite (eigenvalues of its rotational block from %g, "
               "of its translational block from %g)", rotational(0), translational(0));
  }
  if (rotational(2) > LawBounds::kMaxRotationalStiffness) {
    return say(why, "the Cartesian rotational stiffness reaches %g N*m/rad, over %g", rotational(2),
               LawBounds::kMaxRotationalStiffness);
  }
  if (translational(2) > LawBounds::kMaxTranslationalStiffness) {
    return say(why, "the Cartesian translational stiffness reaches %g N/m, over %g", translational(2),
               LawBounds::kMaxTranslationalStiffness);
  }
  const Matrix3d& R = s.T_tip_frame.linear();
  if (!R.allFinite() || !s.T_tip_frame.translation().allFinite() ||
      (R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() > kRotationTolerance ||
      std::abs(R.determinant() - 1.0) > kRotationTolerance) {
    return say(why, "the stiffness frame is not a rigid transform");
  }
  if (!(s.T_tip_frame.translation().norm() <= LawBounds::kMaxFrameOffset)) {
    return say(why, "the stiffness frame is %g m from the tip, over %g", s.T_tip_frame.translation().norm(),
               LawBounds::kMaxFrameOffset);
  }
  if (!(s.nullspace_stiffness >= 0.0 && s.nullspace_stiffness <= LawBounds::kMaxNullspaceStiffness)) {
    return say(why, "nullspace stiffness %g is not in [0, %g]", s.nullspace_stiffness,
               LawBounds::kMaxNullspaceStiffness);
  }
  for (int i = 0; i < n && s.fixed_posture; ++i) {
    const Joint& joint = model.joint(i);
    const double x = s.nullspace_posture(i);
    if (!std::isfinite(x) ||
        (joint.type != JointType::Continuous && (x < joint.limits.lower || x > joint.limits.upper))) {
      return say(why, "joint %s: nullspace posture %g is outside its limits [%g, %g]", joint.name.c_str(), x,
                 joint.limits.lower, joint.limits.upper);
    }
  }
  return nullptr;
}

Matrix6d modal_damping(const Matrix6d& Lambda, const Matrix6d& K, double zeta) {
  const Eigen::LLT<Matrix6d> llt(Lambda);
  const Matrix6d L = llt.matrixL();
  // A = L⁻¹ K L⁻ᵀ by two triangular solves.
  Matrix6d A = llt.matrixL().solve(K);
  A = llt.matrixL().solve(A.transpose()).eval();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (A + A.transpose()));
  const Matrix6d Q = L * eigen.eigenvectors();
  const Vector6d modal = 2.0 * zeta * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return Q * modal.asDiagonal() * Q.transpose();
}

void computed_torque(const RobotModel& /*model*/, const Data& data, const Eigen::VectorXd& kp,
                     const Eigen::VectorXd& kd, const motion::Reference& ref, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& qd, Eigen::VectorXd& qdd_scratch, Eigen::VectorXd& tau) {
  qdd_scratch = ref.qdd + kd.cwiseProduct(ref.qd - qd) + kp.cwiseProduct(ref.q - q);
  inverse_dynamics_at(data, qdd_scratch, tau);
}

void joint_impedance(const RobotModel& /*model*/, Data& data, LawWorkspace& work, const LawSettings& s,
                     const motion::Reference& ref, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, Eigen::VectorXd& tau) {
  const Eigen::VectorXd& K = s.joint_stiffness;
  if (s.damping_from_ratio) {
    work.damping = 2.0 * s.damping_ratio * (K.cwiseProduct(data.M.diagonal())).cwiseSqrt();
    if (work.period > 0.0) {
      data.M_llt.factorize(data.M);
      for (int i = 0; i < K.size(); ++i) {
        work.inverse_column.setZero();
        work.inverse_column(i) = 1.0;
        data.M_llt.solveInPlace(work.inverse_column);
        work.apparent_inertia(i) = 1.0 / work.inverse_column(i);
      }
      // Alone, a joint of inertia m damped by D under a torque held for T has its speed scaled by
      // 1 − D T / m each period: D T / m ≤ 1 keeps that in [0, 1), no sign flip. With the others
      // free the inertia it feels is 1 / (M⁻¹)_ii, far below M_ii where joints couple: on the Panda
      // at 200 Hz, 2ζ√(K M_ii) at franka_ros's stiffness gives joints 1 and 3 D T / m of 2.6–5 and
      // drove joint 3 past its velocity limit. At 1 kHz the bound leaves that damping as it is.
      work.damping = work.damping.cwiseMin(kMaxDampingPerPeriod / work.period * work.apparent_inertia);
    }
  } else {
    work.damping = s.joint_damping;
  }
  work.spring = K.cwiseProduct(ref.q - q) + work.damping.cwiseProduct(ref.qd - qd);
  inverse_dynamics_at(data, ref.qdd, tau);  // M q̈_d + c + g
  tau += work.spring;
}

void cartesian_impedance(const RobotModel& model, Data& data, const Data& data_ref, LawWorkspace& work,
                         const LawSettings& s, const motion::Reference& ref, const Eigen::VectorXd& q,
                         const Eigen::VectorXd& qd, Eigen::VectorXd& tau) {
  const Transform& T_bc = s.T_tip_frame;
  // Frame c at the reference: its pose and its body twist.
  const Transform T_sd = data_ref.T_sb * T_bc;
  const Vector6d V_d = adjoint_inverse_times(T_bc, data_ref.J_b * ref.qd);
  // Frame c where the arm is.
  const Transform T_sc = data.T_sb * T_bc;
  for (int i = 0; i < model.dof(); ++i) work.J_c.col(i) = adjoint_inverse_times(T_bc, data.J_b.col(i));
  const Vector6d V_c = work.J_c * qd;
  // The error as the twist that carries c to d in unit time, in frame c (MR eq. 11.16), and its
  // rate with the desired twist moved into frame c (MR eq. 11.18).
  const Transform T_cd = inverse(T_sc) * T_sd;
  work.xi = log6(T_cd);
  work.xi_dot = adjoint_times(T_cd, V_d) - V_c;

  data.M_llt.factorize(data.M);
  // Λ⁻¹ = J_c M⁻¹ J_cᵀ, inverted on its eigenvectors with each eigenvalue of Λ bounded.
  work.Minv_JcT = work.J_c.transpose();
  data.M_llt.solveInPlace(work.Minv_JcT);
  const Matrix6d Lambda_inv = work.J_c * work.Minv_JcT;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (Lambda_inv + Lambda_inv.transpose()));
  const Vector6d inertia = eigen.eigenvalues().cwiseMax(1.0 / kMaxCartesianInertia).cwiseInverse();
  work.Lambda = eigen.eigenvectors() * inertia.asDiagonal() * eigen.eigenvectors().transpose();

  const Matrix6d D = modal_damping(work.Lambda, s.cartesian_stiffness, s.damping_ratio);
  work.wrench = s.cartesian_stiffness * work.xi + D * work.xi_dot;
  tau.noalias() = work.J_c.transpose() * work.wrench;

  // The posture torque, each joint damped critically against its own inertia, minus what of it
  // would move frame c: N = I − J_cᵀ Λ J_c M⁻¹ (J_c M⁻¹ = (M⁻¹ J_cᵀ)ᵀ).
  const Eigen::VectorXd& posture = s.fixed_posture ? s.nullspace_posture : ref.q;
  const double k_n = s.nullspace_stiffness;
  work.null_torque = k_n * (posture - q) -
                     (2.0 * s.damping_ratio * (k_n * data.M.diagonal()).cwiseSqrt()).cwiseProduct(qd);
  const Vector6d Jc_Minv_tau = work.Minv_JcT.transpose() * work.null_torque;  // fixed size: no heap
  const Vector6d moving_c = work.Lambda * Jc_Minv_tau;
  work.null_torque.noalias() -= work.J_c.transpose() * moving_c;
  tau += work.null_torque;
  work.spring = tau;
  tau += data.bias;
}

void free_drive(const RobotModel& /*model*/, const Data& data, const LawSettings& s, const Eigen::VectorXd& qd,
                Eigen::VectorXd& tau) {
  if (s.damping_from_ratio) {
    // D = rate · M: M q̈ = τ_ext − rate · M q̇, so unpushed the velocity decays as exp(−rate t) in
    // every direction whatever the joints' coupling, and the loop renders it while rate · T ≪ 2.
    // Damping each joint by rate · M_ii alone decays the coupled directions at up to rate times the
    // largest eigenvalue of M⁻¹ diag(M): on the Panda that left the arm drifting at 1–12 mm/s at
    // 200 Hz instead of resting.
    tau = data.bias - LawDefaults::kFreeDriveRate * data.p;
  } else {
    tau = data.bias - s.joint_damping.cwiseProduct(qd);
  }
}

void damped_float(const RobotModel& /*model*/, const Data& data, double rate, const Eigen::VectorXd& qd,
                  Eigen::VectorXd& qdd_scratch, Eigen::VectorXd& tau) {
  qdd_scratch = -rate * qd;
  inverse_dynamics_at(data, qdd_scratch, tau);
}

}  // namespace chasles::controller
