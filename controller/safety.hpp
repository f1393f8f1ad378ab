// The last stage of every tick (docs/controller.md, "Safety"): the law's torque becomes a command
// through one pipeline, whatever the law or the reference —
//
//   a switch's offset, fading → non-finite refused → effort limits → torque-rate limit → command
//
// A new law takes over without a torque jump: at its first tick the difference between the torque
// last commanded and the new law's is kept as an offset that fades linearly to zero over the
// torque-ramp time, the time the rate limit allows to cross the effort range, so a switch between
// laws whose torques differ by less than that range never meets the rate limit. The commands sent
// are kept, for the contact observer to know the torque across states that were lost.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/model/model.hpp"

namespace chasles::controller {

/// The commands of the last kSize ticks and when they were sent.
class CommandHistory {
 public:
  static constexpr int kSize = 16;
  explicit CommandHistory(int dof);
  void record(const Eigen::VectorXd& tau, int64_t sent_ns);
  /// The latest command sent at or before at_ns, among those kept; −1 when there is none.
  int in_force(int64_t at_ns) const;
  /// Command j (from in_force).
  Eigen::MatrixXd::ConstColXpr command(int j) const { return torque_.col(j); }

 private:
  Eigen::MatrixXd torque_;
  std::vector<int64_t> sent_ns_;
  int next_ = 0;
};

class TorqueGuard {
 public:
  /// The effort limits from the model (∞ where the URDF gives none), the rate limit
  /// effort / torque_ramp per joint, `period` the tick's.
  TorqueGuard(const RobotModel& model, double torque_ramp, double period);
  /// The command starts again from `tau` (within the effort limits), with no offset: entering HOLD
  /// from WAITING or FAULT, from g(q), what a plant applies while it brakes or waits, so the first
  /// commands do not jump.
  void restart(const Eigen::VectorXd& tau);
  /// A new law: its offset is taken at the next apply().
  void begin_switch() { switch_pending_ = true; }
  /// The law's torque `tau` at now_ns made the command, in place. False, tau left unusable, when it
  /// is not finite. Allocates nothing.
  bool apply(Eigen::VectorXd& tau, int64_t now_ns);
  /// Each joint's effort limit, N·m (∞ where the URDF gives none).
  const Eigen::VectorXd& effort_limit() const { return effort_limit_; }
  /// Each joint's torque-rate limit, N·m/s.
  const Eigen::VectorXd& torque_rate() const { return torque_rate_; }

 private:
  void limit_rate(Eigen::VectorXd& tau) const;

  double torque_ramp_;
  Eigen::VectorXd effort_limit_, rate_limit_per_tick_, torque_rate_;  // N·m, N·m per tick, N·m/s
  Eigen::VectorXd previous_;       // the last command
  Eigen::VectorXd switch_offset_;  // what the command last sent differed from the new law's
  bool switch_pending_ = false;
  int64_t switch_start_ns_ = 0;
};

}  // namespace chasles::controller
