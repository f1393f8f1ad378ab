#include "chasles/core/kinematics/kinematics.hpp"

#include <cassert>
#include <cmath>
#include <string>

#include "chasles/core/lie/se3.hpp"

namespace chasles {
void check_joint_vector(const RobotModel& model, const JointVector& v, const char* name) {
  if (v.size() != model.dof()) {
    throw ArgumentError(std::string(name) + " has " + std::to_string(v.size()) + " entries, the model has " +
                                std::to_string(model.dof()) + " joints");
  }
}

namespace {

// R exp([â]θ) for a unit axis â. URDF axes are nearly always ±x, ±y or ±z, and then the product
// only mixes two columns of R (12 flops, against 45 for Rodrigues followed by a 3×3 product).
CHASLES_ALWAYS_INLINE void rotate_about_axis(const Matrix3d& R, const Vector3d& axis, double theta, Matrix3d& out) {
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    if (axis(i) == 0.0 && axis(j) == 0.0) {
      const double s = axis(k) * std::sin(theta), c = std::cos(theta);  // axis(k) = ±1
      out.col(i) = c * R.col(i) + s * R.col(j);
      out.col(j) = c * R.col(j) - s * R.col(i);
      out.col(k) = R.col(k);
      return;
    }
  }
  out.noalias() = R * exp3_unit(axis, theta);
}

}  // namespace

void local_transforms(const RobotModel& model, Data& data, const JointVector& q) {
  check_joint_vector(model, q, "q");
  assert(model.check(data) && "a Data sized for another model");
  ++data.passes.joint_transforms;
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    Transform& T = data.T_local[static_cast<size_t>(i) + 1];
    const Matrix3d& R_parent_joint = joint.T_parent_joint.linear();
    if (joint.type == JointType::Prismatic) {
      T.linear() = R_parent_joint;
      T.translation().noalias() = R_parent_joint * (joint.axis * q(i));
      T.translation() += joint.T_parent_joint.translation();
    } else {
      rotate_about_axis(R_parent_joint, joint.axis, q(i), T.linear());
      T.translation() = joint.T_parent_joint.translation();
    }
  }
}

const Transform& forward_kinematics(const RobotModel& model, Data& data, const JointVector& q) {
  local_transforms(model, data, q);
  for (size_t i = 1; i < data.T_body.size(); ++i) data.T_body[i] = data.T_body[i - 1] * data.T_local[i];
  data.T_sb = data.T_body.back() * model.T_last_tip();
  return data.T_sb;
}

const std::vector<Transform>& link_poses(const RobotModel& model, Data& data, const JointVector& q) {
  forward_kinematics(model, data, q);
  const auto& links = model.links();
  for (size_t k = 0; k < links.size(); ++k) {
    data.T_link[k] = data.T_body[static_cast<size_t>(links[k].body)] * links[k].T_body_link;
  }
  return data.T_link;
}

Transform forward_kinematics_space(const RobotModel& model, const JointVector& q) {
  check_joint_vector(model, q, "q");
  Transform T = Transform::Identity();
  for (int i = 0; i < model.dof(); ++i) T = T * exp6(model.space_axes().col(i) * q(i));
  return T * model.home_tip();
}

Transform forward_kinematics_body(const RobotModel& model, const JointVector& q) {
  check_joint_vector(model, q, "q");
  Transform T = model.home_tip();
  for (int i = 0; i < model.dof(); ++i) T = T * exp6(model.body_axes().col(i) * q(i));
  return T;
}

const Matrix6Xd& space_jacobian(const RobotModel& model, Data& data, const JointVector& q) {
  forward_kinematics(model, data, q);
  for (int i = 0; i < model.dof(); ++i) {
    data.J_s.col(i) = adjoint_times(data.T_body[static_cast<size_t>(i) + 1], model.local_axis(i));
  }
  return data.J_s;
}

const Matrix6Xd& body_jacobian(const RobotModel& model, Data& data, const JointVector& q) {
  forward_kinematics(model, data, q);
  return body_jacobian_from_poses(model, data);
}

const Matrix6Xd& body_jacobian_from_poses(const RobotModel& model, Data& data) {
  ++data.passes.body_jacobians;
  for (int i = 0; i < model.dof(); ++i) {
    // Joint i's axis seen from the tip: [Ad_{T_sb⁻¹ T_0i}] A_i.
    const Vector6d A_s = adjoint_times(data.T_body[static_cast<size_t>(i) + 1], model.local_axis(i));
    data.J_b.col(i) = adjoint_inverse_times(data.T_sb, A_s);
  }
  return data.J_b;
}

}  // namespace chasles
