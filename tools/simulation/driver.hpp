// The arm's driver between the controller's commands and the joints, as the simulated plant plays
// it: what it adds to a command — under overlay, the gravity of its own model (the nominal one, the
// bare arm) at the present state, every step, as drake-iiwa-driver's KUKA controller, Drake's
// simulated iiwa driver and libfranka do — and what Drake's statuses report of it: the torque it
// handed the joints, the command without its gravity, the commanded positions, and the Panda's
// success rate and robot mode.
#pragma once

#include <Eigen/Core>
#include <bitset>
#include <cstdint>

#include "controller/transport/conventions.hpp"
#include "core/model/model.hpp"
#include "core/simulation/physics.hpp"
#include "tools/simulation/messaging.hpp"

namespace chasles::plant {

class Driver {
 public:
  /// Keeps a reference to `model`, the nominal one whose gravity the driver compensates.
  Driver(const RobotModel& model, controller::TorqueSemantics semantics);

  /// The torque for the joints under `command` at the state q; `fresh`: the command arrived since
  /// the last step (the Panda's success rate counts it). Allocates nothing.
  const Eigen::VectorXd& command(const Command& command, bool fresh, const Eigen::VectorXd& q);
  /// The torque for the joints under the watchdog's brake, `brake` (whole joint torques) at q.
  const Eigen::VectorXd& brake(const Eigen::VectorXd& brake, const Eigen::VectorXd& q);
  /// What a Drake status says of the driver at the last step, with the plant's state and the
  /// external joint torque `tau_ext` (nullptr: none).
  DriverReport report(const Physics& plant, const Eigen::VectorXd* tau_ext, int64_t robot_utime) const;

  /// The number of steps whose freshness the Panda's control_command_success_rate counts
  /// (libfranka's "last 100 control commands").
  static constexpr int64_t kSuccessWindow = 100;

  controller::TorqueSemantics semantics() const { return semantics_; }

 private:
  const Eigen::VectorXd& gravity(const Eigen::VectorXd& q);
  void judge_step(bool fresh);

  const RobotModel& model_;
  const controller::TorqueSemantics semantics_;
  Data data_;  // the nominal model's, for the driver's gravity
  Eigen::VectorXd torque_;              // handed to the joints, before the effort limits
  Eigen::VectorXd desired_;             // the command without the driver's gravity
  Eigen::VectorXd position_commanded_;  // the command's positions, when it has them
  Eigen::VectorXd zero_;
  bool has_position_ = false, commanding_ = false, commanded_ever_ = false;
  std::bitset<kSuccessWindow> fresh_steps_;  // since the first command, step % kSuccessWindow
  int64_t judged_steps_ = 0;
};

}  // namespace chasles::plant
