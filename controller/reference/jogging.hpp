// Jog commands and a stream of tip poses, turned into the reference by the Jogger (jog.hpp): held
// until the next message, within every limit, short of a singularity, braked to rest when the
// messages stop.
#pragma once

#include <cstdint>

#include "controller/jog.hpp"
#include "controller/reference/source.hpp"
#include "controller/signals.hpp"

namespace chasles::controller {

class JogMotion final : public ReferenceSource {
 public:
  /// No command for `timeout` s: the jog halts; the reference at rest, it is over.
  JogMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits, GeneratorLimits& generator,
            double timeout, JogProgress& progress);
  /// The jog (re)starts at now_ns: its next command is taken whatever its stamp.
  void start(int64_t now_ns);
  /// Takes a command newer than the last (false, counted as dropped, if it is not), its jerk
  /// capped at the pose of the state, whose mass matrix is M. Allocates nothing.
  bool take(const Jog& jog, const Eigen::MatrixXd& M, int64_t now_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  const JogConfig& config() const { return jogger_.config(); }
  const StreamClock& clock() const { return clock_; }

 private:
  const motion::MotionLimits& limits_;
  GeneratorLimits& generator_;
  double timeout_;
  JogProgress& progress_;
  Jogger jogger_;
  Jog jog_;  // the latest command taken
  StreamClock clock_;
  int64_t tick_ns_ = 0;
};

class TipStreamMotion final : public ReferenceSource {
 public:
  /// No setpoint for `timeout` s: the reference brakes to rest, and it is over.
  TipStreamMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits, GeneratorLimits& generator,
                  double timeout, JogProgress& progress);
  void start(int64_t now_ns);
  /// Takes a setpoint newer than the last (false, counted as dropped, if it is not): the pose,
  /// moved on with its twist by how late it came, its jerk capped at the pose of the state, whose
  /// mass matrix is M. Its quaternion is taken as unit (checked by the caller). Allocates nothing.
  bool take(const TipSetpoint& setpoint, const Eigen::MatrixXd& M, int64_t now_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  const StreamClock& clock() const { return clock_; }

 private:
  const motion::MotionLimits& limits_;
  GeneratorLimits& generator_;
  double timeout_;
  JogProgress& progress_;
  Jogger jogger_;
  Transform target_;  // the pose, moved on with twist_ every tick
  Vector6d twist_ = Vector6d::Zero();
  StreamClock clock_;
  int64_t tick_ns_ = 0;
};

}  // namespace chasles::controller
