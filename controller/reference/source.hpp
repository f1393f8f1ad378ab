// What moves the reference while the arm is RUNNING (docs/controller.md, "References"): one
// ReferenceSource per kind of motion — a quintic to a goal, a planned Cartesian path, a waypoint
// trajectory, a stream of joint or tip setpoints, a jog, the brake after one of them. Each owns
// its state; the Controller keeps which one is in force and switches between them in one place.
// They share what this header holds: the kinematics at the reference, computed once per tick; the
// limits the online generator plans with; the timing of a stream of stamped messages.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "core/model/model.hpp"
#include "core/motion/limits.hpp"
#include "core/motion/online_generator.hpp"
#include "core/motion/quintic.hpp"

namespace chasles::controller {

/// The tip pose and J_b at the reference, computed once for each reference position whoever asks
/// first: a jog reads them at the reference before it moves it on, the Cartesian law at the one it
/// moved to — the next tick's before — so a tick computes them at most once.
class ReferenceKinematics {
 public:
  explicit ReferenceKinematics(const RobotModel& model);
  /// Data's T_sb and J_b at q, computed unless they already are for this q and model.
  const Data& at(const RobotModel& model, const Eigen::VectorXd& q);
  /// What at() left last.
  const Data& data() const { return data_; }
  /// Whether `model` may use this Data (RobotModel::check).
  bool fits(const RobotModel& model) const { return model.check(data_); }

 private:
  Data data_;
  Eigen::VectorXd q_;
  const RobotModel* model_ = nullptr;  // the model data_ was last computed with
};

/// What a source reads at a tick besides its own state.
struct Tick {
  int64_t now_ns = 0;
  const RobotModel* model = nullptr;
  ReferenceKinematics* kinematics = nullptr;
};

/// The limits the online generator plans streams, jogs and stops with: MotionLimits' velocity (∞
/// as a large finite value), and its acceleration and jerk capped at the pose of the latest goal
/// taken by what the arm's effort and torque-rate limits let it follow there.
class GeneratorLimits {
 public:
  /// `effort`, `torque_rate`: each joint's limits, N·m and N·m/s (∞ where there is none);
  /// `cap_acceleration`, `cap_jerk`: whether the acceleration and the jerk are capped by them.
  GeneratorLimits(const motion::MotionLimits& limits, const Eigen::VectorXd& effort, const Eigen::VectorXd& torque_rate,
                  bool cap_acceleration, bool cap_jerk);
  const motion::Limits& limits() const { return limits_; }
  /// At the state whose terms are `data` (M(q), g(q)): the configured accelerations scaled down by
  /// one factor until M(q) times them asks at most kEffortShare of each joint's effort left over
  /// from holding up g(q), and the configured jerks by another until M(q) times them asks at most
  /// kTorqueRateShare of each joint's torque-rate limit. Allocates nothing.
  void fit_to_arm(const Data& data);
  /// The share of each joint's torque-rate limit a generated reference's jerk may take (through
  /// M): the rest is the feedback's, which must correct what the arm did not follow.
  static constexpr double kTorqueRateShare = 0.5;
  /// The share of each joint's effort beyond |g(q)| a generated reference's acceleration may take:
  /// the rest is the feedback's and the velocity terms' (C(q, q̇) q̇, which the pose alone does not
  /// give).
  static constexpr double kEffortShare = 0.5;

 private:
  motion::Limits limits_;
  Eigen::VectorXd acceleration_, jerk_;  // as configured, finite
  Eigen::VectorXd effort_, torque_rate_;
  bool cap_acceleration_, cap_jerk_;
};

/// The timing of a stream of messages stamped by their sender (setpoints, jog commands): which
/// move it on, how late each arrived, when it went silent. Counts what it takes and drops.
class StreamClock {
 public:
  /// The stream starts again: its next message is taken whatever its stamp.
  void restart() { first_ = true; }
  bool first() const { return first_; }
  /// Whether a message stamped `utime` (µs) moves the stream on; if not, it is counted as dropped
  /// (late or duplicated: the stream has moved past it).
  bool take_if_newer(int64_t utime);
  /// Takes a message stamped utime arriving at now_ns and returns its age, s, at most `timeout`:
  /// how much later than the stream's quickest it arrived (sender's utime against arrival). The
  /// least offset so far is let up by 100 ppm of the time since the last message: two clocks
  /// drift apart by less, so the estimate never falls behind.
  double take(int64_t utime, int64_t now_ns, double timeout);
  /// Whether no message came for `timeout` s before now_ns.
  bool silent(int64_t now_ns, double timeout) const;
  int64_t taken() const { return taken_; }
  int64_t dropped() const { return dropped_; }

 private:
  bool first_ = true;
  int64_t utime_ = 0, arrival_ns_ = 0, offset_us_ = 0;
  int64_t taken_ = 0, dropped_ = 0;
};

/// One kind of motion of the reference.
class ReferenceSource {
 public:
  enum class Progress : int8_t {
    kMoving,    ///< the reference moved on
    kArrived,   ///< the motion is over: the reference rests at its end, where the arm holds
    kStopping,  ///< the reference is left as it was, to brake to rest from (a stream gone silent)
    kFailed,    ///< the reference is left as it was; failure() says why
  };
  virtual ~ReferenceSource() = default;
  /// Moves `ref` on to tick.now_ns. Allocates nothing.
  virtual Progress advance(const Tick& tick, motion::Reference& ref) = 0;
  /// A motion laid out in time waits `ns` along its path: its clock is set back (the clearance
  /// slowed it). Nothing for a source that plans from the reference every tick.
  virtual void delay(int64_t ns) { (void)ns; }
  virtual const char* failure() const { return ""; }
};

/// A motion laid out in time from start_ns (a quintic, a path, a spline: anything with
/// sample(t, ref) and duration()) sampled at now_ns: past its end it holds its goal at rest.
template <typename Motion>
ReferenceSource::Progress sample_at(const Motion& motion, int64_t start_ns, int64_t now_ns, motion::Reference& ref) {
  const double t = 1e-9 * static_cast<double>(now_ns - start_ns);
  motion.sample(t, ref);
  return t >= motion.duration() ? ReferenceSource::Progress::kArrived : ReferenceSource::Progress::kMoving;
}

/// The time between two ticks a stream's reference moves by, s: from `last_ns` to now_ns, at most
/// 0.1 s (a loop that stalled longer does not jump the reference).
double stream_step(int64_t last_ns, int64_t now_ns);

}  // namespace chasles::controller
