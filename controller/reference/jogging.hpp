// Jog commands and a stream of tip poses, turned into the reference by the Jogger (jog.hpp): held
// until the next message, within every limit, short of a singularity, braked to rest when the
// messages stop.
#pragma once

#include <cstdint>

#include "controller/jog.hpp"
#include "controller/reference/source.hpp"
#include "controller/signals.hpp"

namespace chasles::controller {

/// What a jog and a tip stream share: the Jogger that moves the reference, the timing of their
/// messages, the limits. No command for `timeout` s: the reference halts, and once at rest the
/// motion is over.
class JoggedMotion : public ReferenceSource {
 public:
  /// The messages (re)start at now_ns: the next is taken whatever its stamp.
  void start(int64_t now_ns);
  const StreamClock& clock() const { return clock_; }
  const JogConfig& config() const { return jogger_.config(); }

 protected:
  JoggedMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits, GeneratorLimits& generator,
               double timeout, JogProgress& progress);
  /// The time the reference moves by at this tick, s; `halt`: whether the messages stopped.
  double step(int64_t now_ns, bool& halt);

  const motion::MotionLimits& limits_;
  GeneratorLimits& generator_;
  double timeout_;
  JogProgress& progress_;
  Jogger jogger_;
  StreamClock clock_;
  int64_t tick_ns_ = 0;
};

class JogMotion final : public JoggedMotion {
 public:
  JogMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits, GeneratorLimits& generator,
            double timeout, JogProgress& progress);
  /// Takes a command newer than the last (false, counted as dropped, if it is not), its
  /// acceleration and jerk fitted to the arm at the state whose terms are `data`. Allocates nothing.
  bool take(const Jog& jog, const Data& data, int64_t now_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;

 private:
  Jog jog_;  // the latest command taken
};

class TipStreamMotion final : public JoggedMotion {
 public:
  TipStreamMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits, GeneratorLimits& generator,
                  double timeout, JogProgress& progress);
  /// Takes a setpoint newer than the last (false, counted as dropped, if it is not): the pose,
  /// moved on with its twist by how late it came, its acceleration and jerk fitted to the arm at the
  /// state whose terms are `data`. Its quaternion is taken as unit (checked by the caller). Allocates nothing.
  bool take(const TipSetpoint& setpoint, const Data& data, int64_t now_ns);
  Progress advance(const Tick& tick, motion::Reference& ref) override;

 private:
  Transform target_;  // the pose, moved on with twist_ every tick
  Vector6d twist_ = Vector6d::Zero();
};

}  // namespace chasles::controller
