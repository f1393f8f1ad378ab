#include "controller/reference/stream.hpp"

#include <algorithm>
#include <cstdio>

namespace chasles::controller {
namespace {

void size_states(int dof, std::initializer_list<motion::KinematicState*> states) {
  for (motion::KinematicState* state : states) state->p = state->v = state->a = Eigen::VectorXd::Zero(dof);
}

// The reference one step of dt along the generator's plan from it toward `target`, each joint on
// its own: a stream's target moves every period, so arriving together buys nothing, and the
// fixed-duration search it needs costs far more per tick. False (the reference as it was, `why`
// said) when no plan is found — never seen in the tests and benchmarks.
bool follow(motion::OnlineGenerator& otg, motion::KinematicState& from, const motion::KinematicState& target,
            const motion::Limits& limits, double dt, motion::KinematicState& out, motion::Reference& ref,
            char (&why)[160]) {
  from.p = ref.q;
  from.v = ref.qd;
  from.a = ref.qdd;
  if (!otg.plan(from, target, limits, 0.0, motion::Synchronization::kNone)) {
    std::snprintf(why, sizeof(why), "the trajectory generator found no motion (%.110s)", otg.reason());
    return false;
  }
  otg.at_time(dt, out);
  ref.q = out.p;
  ref.qd = out.v;
  ref.qdd = out.a;
  return true;
}

}  // namespace

StreamMotion::StreamMotion(int dof, const motion::MotionLimits& limits, GeneratorLimits& generator, double timeout)
    : limits_(limits), generator_(generator), timeout_(timeout), otg_(dof) {
  size_states(dof, {&from_, &target_, &out_});
}

void StreamMotion::start(int64_t now_ns) {
  clock_.restart();
  tick_ns_ = now_ns;
}

bool StreamMotion::take(const Setpoint& setpoint, const Data& data, int64_t now_ns) {
  if (!clock_.take_if_newer(setpoint.utime)) return false;
  const bool first = clock_.first();
  const double age = clock_.take(setpoint.utime, now_ns, timeout_);
  // The same goal at rest again (a stream holding its last point) keeps the limits it is planned
  // with; any other goal is planned under the jerk capped at the pose it starts from.
  bool held = !first && target_.v.isZero(0.0) && setpoint.qd.isZero(0.0);
  for (int i = 0; i < setpoint.q.size(); ++i) {
    const double p = std::clamp(setpoint.q(i) + setpoint.qd(i) * age, limits_.lower(i), limits_.upper(i));
    held = held && p == target_.p(i);
    target_.p(i) = p;
  }
  if (!held) generator_.fit_to_arm(data);
  const motion::Limits& g = generator_.limits();
  for (int i = 0; i < setpoint.q.size(); ++i) {
    target_.v(i) = motion::velocity_that_stops_in_range(setpoint.qd(i), target_.p(i), limits_.lower(i), limits_.upper(i),
                                                        g.velocity(i), g.acceleration(i), g.jerk(i));
    target_.a(i) = 0.0;
  }
  return true;
}

ReferenceSource::Progress StreamMotion::advance(const Tick& tick, motion::Reference& ref) {
  if (clock_.silent(tick.now_ns, timeout_)) return Progress::kStopping;
  const double dt = stream_step(tick_ns_, tick.now_ns);
  tick_ns_ = tick.now_ns;
  // The setpoint moves on at its velocity; at a limit it stops there.
  const motion::Limits& g = generator_.limits();
  for (int i = 0; i < ref.q.size(); ++i) {
    target_.p(i) = std::clamp(target_.p(i) + target_.v(i) * dt, limits_.lower(i), limits_.upper(i));
    target_.v(i) = motion::velocity_that_stops_in_range(target_.v(i), target_.p(i), limits_.lower(i), limits_.upper(i),
                                                        g.velocity(i), g.acceleration(i), g.jerk(i));
  }
  return follow(otg_, from_, target_, g, dt, out_, ref, failure_) ? Progress::kMoving : Progress::kFailed;
}

StopMotion::StopMotion(int dof, const motion::MotionLimits& limits, GeneratorLimits& generator)
    : limits_(limits), generator_(generator), otg_(dof) {
  size_states(dof, {&from_, &target_, &out_});
}

void StopMotion::start(const motion::Reference& ref, const Data& data, int64_t from_ns) {
  generator_.fit_to_arm(data);
  const motion::Limits& g = generator_.limits();
  for (int i = 0; i < ref.q.size(); ++i) {
    target_.p(i) = std::clamp(motion::stop_position(ref.q(i), ref.qd(i), ref.qdd(i), g.velocity(i), g.acceleration(i),
                                                    g.jerk(i)),
                              limits_.lower(i), limits_.upper(i));
  }
  target_.v.setZero();
  target_.a.setZero();
  tick_ns_ = from_ns;
}

ReferenceSource::Progress StopMotion::advance(const Tick& tick, motion::Reference& ref) {
  const double dt = stream_step(tick_ns_, tick.now_ns);
  tick_ns_ = tick.now_ns;
  if (!follow(otg_, from_, target_, generator_.limits(), dt, out_, ref, failure_)) return Progress::kFailed;
  if (otg_.duration() > dt) return Progress::kMoving;
  ref.hold(target_.p);
  return Progress::kArrived;
}

}  // namespace chasles::controller
