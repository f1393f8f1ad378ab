#include "chasles/core/kinematics/kinematics.hpp"

#include <string>

#include "chasles/core/lie/se3.hpp"

namespace chasles {
namespace {

void check_size(const RobotModel& model, const JointVector& q) {
  if (q.size() != model.dof()) {
    throw std::invalid_argument("q has " + std::to_string(q.size()) + " entries, the model has " +
                                std::to_string(model.dof()) + " joints");
  }
}

// exp([A_i] q_i) for A_i = (axis, 0) or (0, axis): a pure rotation or a pure translation.
Transform joint_motion(const Joint& joint, double q) {
  Transform T = Transform::Identity();
  if (joint.type == JointType::Prismatic) {
    T.translation() = joint.axis * q;
  } else {
    T.linear() = exp3_unit(joint.axis, q);
  }
  return T;
}

}  // namespace

const Transform& forward_kinematics(const RobotModel& model, Data& data, const JointVector& q) {
  check_size(model, q);
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    data.T_body[static_cast<size_t>(i) + 1] =
        data.T_body[static_cast<size_t>(i)] * joint.T_parent_joint * joint_motion(joint, q(i));
  }
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
  check_size(model, q);
  Transform T = Transform::Identity();
  for (int i = 0; i < model.dof(); ++i) T = T * exp6(model.space_axes().col(i) * q(i));
  return T * model.home_tip();
}

Transform forward_kinematics_body(const RobotModel& model, const JointVector& q) {
  check_size(model, q);
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
  for (int i = 0; i < model.dof(); ++i) {
    // Joint i's axis seen from the tip: [Ad_{T_sb⁻¹ T_0i}] A_i.
    const Vector6d A_s = adjoint_times(data.T_body[static_cast<size_t>(i) + 1], model.local_axis(i));
    data.J_b.col(i) = adjoint_inverse_times(data.T_sb, A_s);
  }
  return data.J_b;
}

}  // namespace chasles
