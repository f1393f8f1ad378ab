#include "core/identification/regressor.hpp"

#include <cassert>
#include <string>

#include "core/lie/se3.hpp"
#include "core/lie/so3.hpp"

namespace chasles {
namespace {

size_t body(int joint_index) { return static_cast<size_t>(joint_index) + 1; }

// L(w) with L(w) (I_xx, I_xy, I_xz, I_yy, I_yz, I_zz) = I w for a symmetric I.
Eigen::Matrix<double, 3, 6> inertia_times_regressor(const Vector3d& w) {
  Eigen::Matrix<double, 3, 6> L;
  L << w(0), w(1), w(2), 0.0, 0.0, 0.0,  //
      0.0, w(0), 0.0, w(1), w(2), 0.0,   //
      0.0, 0.0, w(0), 0.0, w(1), w(2);
  return L;
}

}  // namespace

const char* const kInertialParameterNames[10] = {"m", "hx", "hy", "hz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"};

Vector10d body_parameters(const SpatialInertia& G) {
  Vector10d pi;
  pi << G.mass, G.h, G.I(0, 0), G.I(0, 1), G.I(0, 2), G.I(1, 1), G.I(1, 2), G.I(2, 2);
  return pi;
}

SpatialInertia spatial_inertia(const Vector10d& pi) {
  SpatialInertia G;
  G.mass = pi(0);
  G.h = pi.segment<3>(1);
  G.I << pi(4), pi(5), pi(6),  //
      pi(5), pi(7), pi(8),      //
      pi(6), pi(8), pi(9);
  return G;
}

Eigen::MatrixXd inertial_parameters(const RobotModel& model) {
  Eigen::MatrixXd parameters(model.dof(), 10);
  for (int i = 0; i < model.dof(); ++i) parameters.row(i) = body_parameters(model.body_inertia(i)).transpose();
  return parameters;
}

Eigen::VectorXd model_parameters(const RobotModel& model) {
  const ParameterLayout layout = parameter_layout(model);
  Eigen::VectorXd pi = Eigen::VectorXd::Zero(layout.size());
  for (int i = 0; i < model.dof(); ++i) {
    pi.segment<10>(layout.inertial(i)) = body_parameters(model.body_inertia(i));
    pi(layout.armature(i)) = model.armature()[i];
  }
  return pi;
}

RobotModel with_inertial_parameters(const RobotModel& model, const Eigen::MatrixXd& parameters) {
  ChainDescription description = model.description();
  if (parameters.rows() != model.dof() || parameters.cols() != 10) {
    throw ModelError(description.source + ": inertial parameters are " + std::to_string(parameters.rows()) + "×" +
                     std::to_string(parameters.cols()) + "; the chain needs " + std::to_string(model.dof()) +
                     "×10 (one row of m, h, I per body)");
  }
  for (int i = 0; i < model.dof(); ++i) {
    description.inertia[static_cast<size_t>(i)] = spatial_inertia(parameters.row(i).transpose()).matrix();
  }
  return RobotModel(std::move(description));
}

RegressorWorkspace::RegressorWorkspace(const RobotModel& model)
    : data(model),
      A(static_cast<size_t>(model.dof()), Matrix6x10d::Zero()),
      Y(Eigen::MatrixXd::Zero(model.dof(), parameter_layout(model).size())) {}

Matrix6x10d momentum_rate_regressor(const Vector6d& V, const Vector6d& Vd) {
  const Vector3d w = V.head<3>(), v = V.tail<3>(), alpha = Vd.head<3>();
  // The acceleration of the frame's origin as a particle there feels it (gravity included):
  // a + ω × v, what the mass and the first moment multiply.
  const Vector3d a = Vd.tail<3>() + w.cross(v);
  Matrix6x10d A;
  A.col(0) << Vector3d::Zero(), a;
  const Matrix3d W = hat3(w);
  A.block<3, 3>(0, 1) = -hat3(a);
  A.block<3, 3>(3, 1) = hat3(alpha) + W * W;
  A.block<3, 6>(0, 4) = inertia_times_regressor(alpha) + W * inertia_times_regressor(w);
  A.block<3, 6>(3, 4).setZero();
  return A;
}

const Eigen::MatrixXd& joint_torque_regressor(const RobotModel& model, RegressorWorkspace& workspace,
                                              const JointVector& q, const JointVector& qd, const JointVector& qdd) {
  check_joint_vector(model, qd, "qd");
  check_joint_vector(model, qdd, "qdd");
  Data& data = workspace.data;
  local_transforms(model, data, q);  // asserts that data was sized for a chain of this shape
  const int n = model.dof();
  const ParameterLayout layout = parameter_layout(model);
  assert(workspace.A.size() == static_cast<size_t>(n) && workspace.Y.rows() == n &&
         workspace.Y.cols() == layout.size() && "a RegressorWorkspace sized for another model");
  // Forward (MR eq. 8.50–8.51): twists and their rates, gravity as the base's acceleration.
  data.V[0].setZero();
  data.Vd[0] << Vector3d::Zero(), -model.gravity();
  for (int i = 0; i < n; ++i) {
    const Transform& T = data.T_local[body(i)];
    const Vector6d& axis = model.local_axis(i);
    Vector6d& V = data.V[body(i)];
    V = adjoint_inverse_times(T, data.V[body(i) - 1]) + axis * qd(i);
    data.Vd[body(i)] = adjoint_inverse_times(T, data.Vd[body(i) - 1]) + ad_times(V, axis) * qd(i) + axis * qdd(i);
    workspace.A[static_cast<size_t>(i)] = momentum_rate_regressor(V, data.Vd[body(i)]);
  }
  // Backward: body j's wrench reaches joint i ≤ j carried through the frames between them
  // (MR eq. 8.52–8.53, one body at a time); each of its ten columns is a wrench.
  Eigen::MatrixXd& Y = workspace.Y;
  Y.setZero();
  for (int j = n - 1; j >= 0; --j) {
    Matrix6x10d F = workspace.A[static_cast<size_t>(j)];
    for (int i = j; i >= 0; --i) {
      Y.block<1, 10>(i, layout.inertial(j)).noalias() = model.local_axis(i).transpose() * F;
      if (i > 0) {
        for (int k = 0; k < 10; ++k) F.col(k) = adjoint_inverse_transpose_times(data.T_local[body(i)], F.col(k));
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    Y(i, layout.viscous(i)) = qd(i);
    Y(i, layout.coulomb(i)) = static_cast<double>((qd(i) > 0.0) - (qd(i) < 0.0));
    Y(i, layout.armature(i)) = qdd(i);
  }
  return Y;
}

}  // namespace chasles
