#include "support/arm.hpp"

#include <chrono>
#include <sstream>

#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles::testing {

const RobotModel& panda() {
  static const RobotModel model = load_urdf_file(data_path("panda.urdf"), UrdfOptions{"panda_hand_tcp"});
  return model;
}

const RobotModel& ur5() {
  static const RobotModel model = load_urdf_file(data_path("ur5.urdf"), UrdfOptions{"tool0"});
  return model;
}

Eigen::VectorXd gravity_of(const RobotModel& model, const Eigen::VectorXd& q) {
  Data data(model);
  return gravity_torques(model, data, q);
}

Eigen::VectorXd bent_pose() {
  Eigen::VectorXd q(7);
  q << 0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0;
  return q;
}

std::string list(const Eigen::VectorXd& v) {
  std::ostringstream text;
  text.precision(17);
  for (Eigen::Index i = 0; i < v.size(); ++i) text << (i > 0 ? "," : "") << v[i];
  return text.str();
}

Eigen::VectorXd vector_of(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

arm_target_t joint_target(const Eigen::VectorXd& q, double duration) {
  arm_target_t target{};
  target.utime =
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  target.mode = arm_target_t::JOINT;
  target.num_joints = static_cast<int32_t>(q.size());
  target.joint_position.assign(q.data(), q.data() + q.size());
  target.tip_quaternion[0] = 1.0;
  target.duration = duration;
  return target;
}

}  // namespace chasles::testing
