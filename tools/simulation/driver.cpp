#include "tools/simulation/driver.hpp"

#include <algorithm>
#include <drake/lcmt_panda_status.hpp>

#include "core/dynamics/dynamics.hpp"

namespace chasles::plant {

Driver::Driver(const RobotModel& model, controller::TorqueSemantics semantics)
    : model_(model),
      semantics_(semantics),
      data_(model),
      torque_(Eigen::VectorXd::Zero(model.dof())),
      desired_(Eigen::VectorXd::Zero(model.dof())),
      position_commanded_(Eigen::VectorXd::Zero(model.dof())),
      zero_(Eigen::VectorXd::Zero(model.dof())) {}

const Eigen::VectorXd& Driver::gravity(const Eigen::VectorXd& q) { return gravity_torques(model_, data_, q); }

void Driver::judge_step(bool fresh) {
  fresh_steps_[static_cast<size_t>(judged_steps_ % kSuccessWindow)] = fresh;
  ++judged_steps_;
}

const Eigen::VectorXd& Driver::command(const Command& command, bool fresh, const Eigen::VectorXd& q) {
  desired_ = command.torque;
  torque_ = command.torque;
  if (semantics_ == controller::TorqueSemantics::kOverlay) torque_ += gravity(q);
  has_position_ = command.has_position;
  if (has_position_) position_commanded_ = command.position;
  commanding_ = commanded_ever_ = true;
  judge_step(fresh);
  return torque_;
}

const Eigen::VectorXd& Driver::brake(const Eigen::VectorXd& brake, const Eigen::VectorXd& q) {
  torque_ = brake;
  desired_ = torque_;
  if (semantics_ == controller::TorqueSemantics::kOverlay) desired_ -= gravity(q);
  has_position_ = false;
  commanding_ = false;
  if (commanded_ever_) judge_step(false);
  return torque_;
}

DriverReport Driver::report(const Physics& plant, const Eigen::VectorXd* tau_ext, int64_t robot_utime) const {
  const double success_rate =
      judged_steps_ > 0 ? static_cast<double>(fresh_steps_.count()) /
                              static_cast<double>(std::min(judged_steps_, kSuccessWindow))
                        : 0.0;
  const int8_t robot_mode = !commanded_ever_ ? drake::lcmt_panda_status::kIdle
                            : commanding_    ? drake::lcmt_panda_status::kMove
                                             : drake::lcmt_panda_status::kReflex;
  const int8_t control_mode =
      commanded_ever_ ? controller::conventions(controller::Protocol::kDrakePanda).command_control_mode : int8_t{0};
  return {plant.qd(),
          plant.effort(),
          torque_,
          desired_,
          has_position_ ? position_commanded_ : plant.q(),
          tau_ext != nullptr ? *tau_ext : zero_,
          commanding_,
          success_rate,
          robot_mode,
          control_mode,
          robot_utime};
}

}  // namespace chasles::plant
