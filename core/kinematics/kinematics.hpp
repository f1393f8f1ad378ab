// Forward kinematics and Jacobians of a serial chain in product-of-exponentials form
// (Modern Robotics ch. 4 and 5). Every function allocates nothing; results land in Data.
#pragma once

#include "core/model/model.hpp"

namespace chasles {

using JointVector = Eigen::Ref<const Eigen::VectorXd>;

/// Throws ArgumentError unless v has one entry per joint; `name` names it ("q", "qd").
void check_joint_vector(const RobotModel& model, const JointVector& v, const char* name);

/// The joint transforms T_{i−1,i}(q_i) = M_{i−1,i} · exp([A_i] q_i) into data.T_local, with
/// sin q_i and cos q_i into data.sin_q and data.cos_q; the first step of the dynamics algorithms
/// (those of an all-aligned arm need only the sines and cosines).
void local_transforms(const RobotModel& model, Data& data, const JointVector& q);

/// Tip pose T_sb and every body pose T_0i, by the local PoE recursion
/// T_0i = T_0,i−1 · M_{i−1,i} · exp([A_i] q_i). The fast path the Jacobians and dynamics use. It
/// leaves data.T_local as it was (local_transforms computes those).
const Transform& forward_kinematics(const RobotModel& model, Data& data, const JointVector& q);

/// Every chain link's pose (data.T_link, in RobotModel::links order); runs forward_kinematics.
const std::vector<Transform>& link_poses(const RobotModel& model, Data& data, const JointVector& q);

/// Space form T = e^[S_1 q_1] ⋯ e^[S_n q_n] M (MR eq. 4.14).
Transform forward_kinematics_space(const RobotModel& model, const JointVector& q);

/// Body form T = M e^[B_1 q_1] ⋯ e^[B_n q_n] (MR eq. 4.16).
Transform forward_kinematics_body(const RobotModel& model, const JointVector& q);

/// Space Jacobian J_s(q): column i is the screw axis of joint i in the base frame at q,
/// [Ad_{T_0i}] A_i = [Ad_{e^[S_1 q_1]⋯e^[S_{i−1} q_{i−1}]}] S_i (MR eq. 5.11). Also runs
/// forward_kinematics.
const Matrix6Xd& space_jacobian(const RobotModel& model, Data& data, const JointVector& q);

/// Body Jacobian J_b(q) at the tip: [Ad_{T_sb⁻¹}] J_s (MR eq. 5.18). Also runs
/// forward_kinematics.
const Matrix6Xd& body_jacobian(const RobotModel& model, Data& data, const JointVector& q);

/// The same from the poses already in data (data.T_body and data.T_sb, as forward_kinematics or
/// compute_tick_terms leave them), without computing them again.
const Matrix6Xd& body_jacobian_from_poses(const RobotModel& model, Data& data);

/// dJ_b: how the body Jacobian changes for a change dq of the joints, to first order, from J_b
/// alone (no pass over the chain): column i is [ad_{J_bi}] Σ_{j>i} J_bj dq_j, since a joint turns
/// the axes between it and the base, seen from the tip, and leaves the ones beyond it. What lets a
/// jog look ahead along its motion at the reference's Jacobian instead of computing another.
/// Allocates nothing (dJ sized as J_b).
void body_jacobian_change(const Matrix6Xd& J_b, const JointVector& dq, Matrix6Xd& dJ);

}  // namespace chasles
