// The arms the controller's tests drive — the Panda to its hand's TCP, the UR5 to tool0, loaded once
// — and what the tests that run the plant and the controller as processes say to them: the Panda
// pose they start from, joint vectors as command-line lists and back from messages, JOINT targets,
// and the gravity torques the laws are checked against.
#pragma once

#include <Eigen/Core>
#include <chasles/arm_target_t.hpp>
#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace chasles::testing {

/// tests/data/panda.urdf to panda_hand_tcp (the controller's tests' arm) and ur5.urdf to tool0,
/// each loaded on first use and kept.
const RobotModel& panda();
const RobotModel& ur5();

/// g(q), the joint torques that hold `model` up against gravity at q.
Eigen::VectorXd gravity_of(const RobotModel& model, const Eigen::VectorXd& q);

/// A bent Panda pose, within its limits, where gravity pulls hard on the shoulder and elbow.
Eigen::VectorXd bent_pose();
/// "v0,v1,..." at full precision, as --q0 and the like take it.
std::string list(const Eigen::VectorXd& v);
Eigen::VectorXd vector_of(const std::vector<double>& v);
/// A JOINT target to q over `duration` seconds, stamped now.
arm_target_t joint_target(const Eigen::VectorXd& q, double duration);

}  // namespace chasles::testing
