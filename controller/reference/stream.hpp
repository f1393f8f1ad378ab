// A stream of joint setpoints, and the brake to rest that ends a stream, a jog or a trajectory
// cut short: both through the online generator (core/motion/online_generator.hpp), replanned from
// the reference every tick toward a target that may move, so the reference stays C² and within
// every limit whatever the stream does.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "controller/reference/source.hpp"
#include "controller/signals.hpp"

namespace chasles::controller {

class StreamMotion final : public ReferenceSource {
 public:
  /// No setpoint for `timeout` s: the stream is over and the reference brakes to rest.
  StreamMotion(int dof, const motion::MotionLimits& limits, GeneratorLimits& generator, double timeout);
  /// The stream (re)starts at now_ns: its next setpoint is taken whatever its stamp.
  void start(int64_t now_ns);
  /// Takes a setpoint newer than the last (false, counted as dropped, if it is not): the target
  /// moves toward it, aged by how late it came, clamped into the limits less the margin, its
  /// velocity toward a limit cut to what can stop before it. Any goal but the same one at rest
  /// again is planned under the acceleration and jerk fitted to the arm at the state whose terms
  /// are `data` (GeneratorLimits::fit_to_arm). Allocates nothing.
  bool take(const Setpoint& setpoint, const Data& data, int64_t now_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  const char* failure() const override { return failure_; }
  /// When the reference last moved, ns: where a brake taking over starts from.
  int64_t last_tick_ns() const { return tick_ns_; }
  const StreamClock& clock() const { return clock_; }

 private:
  const motion::MotionLimits& limits_;
  GeneratorLimits& generator_;
  double timeout_;
  StreamClock clock_;
  int64_t tick_ns_ = 0;
  motion::OnlineGenerator otg_;
  motion::KinematicState from_, target_, out_;
  char failure_[160] = {};
};

class StopMotion final : public ReferenceSource {
 public:
  StopMotion(int dof, const motion::MotionLimits& limits, GeneratorLimits& generator);
  /// Brakes `ref` to rest along the fastest stop the generator's limits allow, its end clamped
  /// into the position limits, moving on from from_ns (the last tick the reference moved); the
  /// acceleration and jerk fitted to the arm at the state whose terms are `data`. Allocates nothing.
  void start(const motion::Reference& ref, const Data& data, int64_t from_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  const char* failure() const override { return failure_; }

 private:
  const motion::MotionLimits& limits_;
  GeneratorLimits& generator_;
  int64_t tick_ns_ = 0;
  motion::OnlineGenerator otg_;
  motion::KinematicState from_, target_, out_;
  char failure_[160] = {};
};

}  // namespace chasles::controller
