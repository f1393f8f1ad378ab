#include "core/kinematics/kinematics.hpp"

#include <cassert>
#include <cmath>
#include <string>

#include "core/lie/se3.hpp"
#include "core/lie/sincos.hpp"
#include "core/model/joint_axis.hpp"

namespace chasles {
// Out of line: the cold throwing path stays out of the flattened algorithms that call this.
__attribute__((noinline)) void check_joint_vector(const RobotModel& model, const JointVector& v, const char* name) {
  if (v.size() != model.dof()) {
    throw ArgumentError(std::string(name) + " has " + std::to_string(v.size()) + " entries, the model has " +
                                std::to_string(model.dof()) + " joints");
  }
}

namespace {

// T_{i−1,i}(q_i) = M_{i−1,i} exp([A_i] q_i). For a revolute joint about ±x, ±y or ±z the rotation
// only mixes two columns of M's (12 flops, against 45 for Rodrigues followed by a 3×3 product),
// with s = sin q and c = cos q from joint_sin_cos.
CHASLES_ALWAYS_INLINE void local_transform(const RobotModel& model, int i, double q, double s, double c,
                                           Transform& T) {
  const Joint& joint = model.joint(i);
  const Matrix3d& R_parent_joint = joint.T_parent_joint.linear();
  visit_axis(model, i, [&](auto axis) {
    if constexpr (is_general_axis<decltype(axis)>) {
      if (joint.type == JointType::Prismatic) {
        T.linear() = R_parent_joint;
        T.translation().noalias() = R_parent_joint * (joint.axis * q);
        T.translation() += joint.T_parent_joint.translation();
        return;
      }
      T.linear().noalias() = R_parent_joint * exp3_unit(joint.axis, q);
    } else {
      axis.rotate(R_parent_joint, c, s, T.linear());
    }
    T.translation() = joint.T_parent_joint.translation();
  });
}

// T_0i = T_0,i−1 M_{i−1,i} exp([A_i] q_i) from T_0,i−1 directly, without forming T_{i−1,i}:
// p_0i = p_0,i−1 + R_0,i−1 t and R_0i = R_0,i−1 R_M exp([a] q), the placement's rotation R_M and
// then the joint's applied to R_0,i−1 by their shapes: for a URDF origin with one rpy angle (or
// none) and an axis-aligned joint, two turns of two columns, 24 multiplications (12 without the
// angle) where R_M exp([a] q) and then a 3×3 product took 39. s = sin q and c = cos q.
CHASLES_ALWAYS_INLINE void compose_joint(const RobotModel& model, int i, double q, double s, double c,
                                         const Transform& T_prev, Transform& T) {
  const Joint& joint = model.joint(i);
  T.translation().noalias() = T_prev.linear() * joint.T_parent_joint.translation();
  T.translation() += T_prev.translation();
  visit_placement(model, i, [&](auto placement) {
    Matrix3d placed;
    const Matrix3d& R = placement.after(T_prev.linear(), placed);  // R_0,i−1 R_M
    visit_axis(model, i, [&](auto axis) {
      if constexpr (is_general_axis<decltype(axis)>) {
        if (joint.type == JointType::Prismatic) {
          T.linear() = R;
          T.translation().noalias() += R * (joint.axis * q);
          return;
        }
        T.linear().noalias() = R * exp3_unit(joint.axis, q);
      } else {
        axis.rotate(R, c, s, T.linear());
      }
    });
  });
}

// sin q_i and cos q_i of every joint into data, before any transform: two at a time, and off the
// chain of dependent products that follows (lie/sincos.hpp).
CHASLES_ALWAYS_INLINE void joint_sin_cos(const RobotModel& model, Data& data, const JointVector& q) {
  sin_cos(q.data(), model.dof(), data.sin_q.data(), data.cos_q.data());
}

}  // namespace

CHASLES_FLATTEN void local_transforms(const RobotModel& model, Data& data, const JointVector& q) {
  check_joint_vector(model, q, "q");
  assert(model.check(data) && "a Data sized for another model");
  ++data.passes.joint_transforms;
  joint_sin_cos(model, data, q);
  for (int i = 0; i < model.dof(); ++i) {
    local_transform(model, i, q(i), data.sin_q(i), data.cos_q(i), data.T_local[static_cast<size_t>(i) + 1]);
  }
}

CHASLES_FLATTEN const Transform& forward_kinematics(const RobotModel& model, Data& data, const JointVector& q) {
  check_joint_vector(model, q, "q");
  assert(model.check(data) && "a Data sized for another model");
  ++data.passes.joint_transforms;
  joint_sin_cos(model, data, q);
  for (int i = 0; i < model.dof(); ++i) {
    const size_t b = static_cast<size_t>(i) + 1;
    compose_joint(model, i, q(i), data.sin_q(i), data.cos_q(i), data.T_body[b - 1], data.T_body[b]);
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

CHASLES_FLATTEN const Matrix6Xd& space_jacobian(const RobotModel& model, Data& data, const JointVector& q) {
  forward_kinematics(model, data, q);
  for (int i = 0; i < model.dof(); ++i) {
    const Transform& T = data.T_body[static_cast<size_t>(i) + 1];
    data.J_s.col(i) = visit_axis(model, i, [&](auto axis) { return axis.adjoint(T.linear(), T.translation()); });
  }
  return data.J_s;
}

const Matrix6Xd& body_jacobian(const RobotModel& model, Data& data, const JointVector& q) {
  forward_kinematics(model, data, q);
  return body_jacobian_from_poses(model, data);
}

CHASLES_FLATTEN const Matrix6Xd& body_jacobian_from_poses(const RobotModel& model, Data& data) {
  ++data.passes.body_jacobians;
  // Copies: a store into J_b might otherwise be a store into T_sb, for all the compiler knows, and
  // each column would load R_sb and p_sb again (J_b 2 % faster).
  const Matrix3d R_sb = data.T_sb.linear();
  const Vector3d p_sb = data.T_sb.translation();
  for (int i = 0; i < model.dof(); ++i) {
    // Joint i's axis seen from the tip, [Ad_{T_sb⁻¹ T_0i}] A_i (MR eq. 5.18 column by column): its
    // space form [Ad_T0i] A_i taken about the tip's origin (translation p_0i − p_sb), then turned
    // by R_sbᵀ. For a revolute joint about ±e_K, R_0i a is column K of R_0i.
    const Transform& T = data.T_body[static_cast<size_t>(i) + 1];
    const Vector3d d = T.translation() - p_sb;
    const Vector6d A_s = visit_axis(model, i, [&](auto axis) { return axis.adjoint(T.linear(), d); });
    // R_sbᵀ ω and R_sbᵀ v side by side, entry k of each in one SSE2 register (lie/sincos.hpp's
    // vector extensions): one pass of 2-wide products and sums turns both halves, where Eigen's
    // 3-vector products run one lane at a time (J_b of the Panda 5 % faster).
    using detail::Double2;
    const Double2 A[3] = {{A_s(0), A_s(3)}, {A_s(1), A_s(4)}, {A_s(2), A_s(5)}};
    for (int k = 0; k < 3; ++k) {
      const Double2 row = R_sb(0, k) * A[0] + R_sb(1, k) * A[1] + R_sb(2, k) * A[2];
      data.J_b(k, i) = row[0];
      data.J_b(3 + k, i) = row[1];
    }
  }
  return data.J_b;
}

void body_jacobian_change(const Matrix6Xd& J_b, const JointVector& dq, Matrix6Xd& dJ) {
  // From the tip inward, carrying the twist of the joints beyond column i.
  Vector6d beyond = Vector6d::Zero();
  for (Eigen::Index i = J_b.cols() - 1; i >= 0; --i) {
    dJ.col(i) = ad_times(J_b.col(i), beyond);
    beyond += J_b.col(i) * dq(i);
  }
}

}  // namespace chasles
