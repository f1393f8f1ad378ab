// An arm's controller (the Panda's unless said) ticked once a millisecond in a test, the state set
// by the test: its own reference (perfect tracking) or the model integrated under the command.
// Shared by the tests of the limits, waypoint trajectories, streams and jogs.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "controller/controller.hpp"
#include "core/dynamics/dynamics.hpp"
#include "support/arm.hpp"
#include "support/contact_off.hpp"

namespace chasles::controller::testing {

inline constexpr int64_t kMs = 1'000'000;

// libfranka's limits for the Panda (franka/rate_limiting.h).
inline Eigen::VectorXd franka_acceleration() {
  return (Eigen::VectorXd(7) << 15, 7.5, 10, 12.5, 15, 20, 20).finished();
}
inline Eigen::VectorXd franka_jerk() {
  return (Eigen::VectorXd(7) << 7500, 3750, 5000, 6250, 7500, 10000, 10000).finished();
}
inline Eigen::VectorXd bent_pose() { return (Eigen::VectorXd(7) << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3).finished(); }

class Following : public ::testing::Test {
 protected:
  explicit Following(double omega = 20.0) : Following(chasles::testing::panda(), bent_pose(), omega) {
    config_.limits.acceleration = franka_acceleration();
    config_.limits.jerk = franka_jerk();
  }
  /// Another arm from `start`, with the default acceleration and jerk limits.
  Following(const RobotModel& model, const Eigen::VectorXd& start, double omega = 20.0)
      : model_(model), state_(model.dof()) {
    config_ = Config::critically_damped(model.dof(), omega);
    // The tests judge the generated reference against the configured limits themselves; the caps of
    // the acceleration by the effort and the jerk by the torque rate are judged on their own (stream_test).
    config_.limits.jerk_within_torque_rate = false;
    config_.limits.acceleration_within_effort = false;
    // The state may be the reference itself, not an arm's answer to the torque: the contact
    // monitor, which would read the difference as a push, is off; the limits' guard stays on.
    chasles::testing::never_trip(config_.contact, model.dof());
    // Nor is its effort the torque applied, which the torque-semantics check would take for a
    // driver's gravity missing (semantics_check_test and the World's protocols judge that).
    config_.check_torque_semantics = false;
    state_.q = start;
  }
  /// One tick a millisecond after the last, with the state as it is now.
  bool tick(Controller& controller) {
    now_ += kMs;
    ++state_.seq;
    state_.arrival_ns = now_;
    return controller.tick(now_, &state_);
  }
  bool send(Controller& controller, const Eigen::VectorXd& goal, double duration) {
    Target target(model_.dof());
    target.mode = Target::kJoint;
    target.num_joints = model_.dof();
    target.q = goal;
    target.duration = duration;
    return controller.set_target(target, now_);
  }
  /// Every tick's reference within every limit; its jerk by differences of its acceleration.
  void expect_within_limits(const Controller& c, const motion::Reference& before) {
    const motion::MotionLimits& l = c.limits();
    const motion::Reference& r = c.reference();
    for (int i = 0; i < model_.dof(); ++i) {
      ASSERT_GE(r.q(i), l.lower(i) - 1e-9) << now_ << " joint " << i;
      ASSERT_LE(r.q(i), l.upper(i) + 1e-9) << now_ << " joint " << i;
      ASSERT_LE(std::abs(r.qd(i)), l.velocity(i) * (1 + 1e-9)) << now_ << " joint " << i;
      ASSERT_LE(std::abs(r.qdd(i)), l.acceleration(i) * (1 + 1e-9)) << now_ << " joint " << i;
      ASSERT_LE(std::abs(r.qdd(i) - before.qdd(i)) / 1e-3, l.jerk(i) * (1 + 1e-6)) << now_ << " joint " << i;
    }
  }
  /// The arm: the model itself under the command, 10 substeps of semi-implicit Euler per tick.
  void integrate(const Controller& controller, Data& data) {
    for (int s = 0; s < 10; ++s) {
      state_.qd += 1e-4 * forward_dynamics(model_, data, state_.q, state_.qd, controller.torque());
      state_.q += 1e-4 * state_.qd;
    }
    state_.effort = controller.torque();
  }
  RobotModel model_;
  Config config_;
  JointState state_;
  int64_t now_ = 0;
};

}  // namespace chasles::controller::testing
