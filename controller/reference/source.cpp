#include "controller/reference/source.hpp"

#include <algorithm>
#include <cmath>

#include "core/kinematics/kinematics.hpp"

namespace chasles::controller {
namespace {

// The generator needs finite limits; a joint without one (a URDF without a velocity limit, and so
// no default acceleration or jerk) is given these, far beyond what an arm does.
constexpr double kUnlimitedVelocity = 1e3, kUnlimitedAcceleration = 1e5, kUnlimitedJerk = 1e7;

Eigen::VectorXd finite_or(const Eigen::VectorXd& x, double fallback) {
  return x.unaryExpr([fallback](double v) { return std::isfinite(v) ? v : fallback; });
}

}  // namespace

ReferenceKinematics::ReferenceKinematics(const RobotModel& model)
    : data_(model), q_(Eigen::VectorXd::Constant(model.dof(), std::numeric_limits<double>::quiet_NaN())) {}

const Data& ReferenceKinematics::at(const RobotModel& model, const Eigen::VectorXd& q) {
  // Exact equality: the same reference, not a nearby one. NaN in q_ never equals.
  if (model_ != &model || !(q.array() == q_.array()).all()) {
    body_jacobian(model, data_, q);
    q_ = q;
    model_ = &model;
  }
  return data_;
}

GeneratorLimits::GeneratorLimits(const motion::MotionLimits& limits, const Eigen::VectorXd& effort,
                                 const Eigen::VectorXd& torque_rate, bool cap_acceleration, bool cap_jerk)
    : acceleration_(finite_or(limits.acceleration, kUnlimitedAcceleration)),
      jerk_(finite_or(limits.jerk, kUnlimitedJerk)),
      effort_(effort),
      torque_rate_(torque_rate),
      cap_acceleration_(cap_acceleration),
      cap_jerk_(cap_jerk) {
  limits_.velocity = finite_or(limits.velocity, kUnlimitedVelocity);
  limits_.acceleration = acceleration_;
  limits_.jerk = jerk_;
}

// At the pose where the generator takes a new goal (a setpoint, a jog command, a stop), and held
// until the next: the plan is then time-optimal for limits that stay put, as Ruckig's is for the
// limits it is given. Capped anew every tick instead, a rest-to-rest move replanned under a jerk
// that changed with M(q) took up to 1.17 times the time-optimal duration at its limits.
//
// One factor for every joint keeps the proportions of the accelerations (and the jerks), and so a
// twist's direction through a change; half of what is left leaves room for M(q) and g(q) to change
// along the way to the next goal.
void GeneratorLimits::fit_to_arm(const Data& data) {
  const Eigen::MatrixXd& M = data.M;
  // The largest factor s ≤ 1 with Σ_j |M_ij| s·limit_j ≤ budget(i) for every joint i.
  const auto factor_within = [&M](const Eigen::VectorXd& limit, auto budget) {
    double scale = 1.0;
    for (int i = 0; i < M.rows(); ++i) {
      const double asked = M.row(i).cwiseAbs().dot(limit);
      if (asked > 0.0) scale = std::min(scale, budget(i) / asked);
    }
    return scale;
  };
  if (cap_acceleration_) {
    // τ = M(q) q̈ + C(q, q̇) q̇ + g(q): what is left of a joint's effort once g(q) is held up is what
    // the reference's acceleration may ask through M(q). Where gravity takes nearly all of it (a
    // pose the arm barely holds), a fifth of the effort still counts as left: a reference that may not
    // accelerate at all could not even brake. A joint without an effort limit (∞) bounds nothing.
    limits_.acceleration = factor_within(acceleration_, [&](int i) {
                             return kEffortShare * std::max(effort_(i) - std::abs(data.g(i)), 0.2 * effort_(i));
                           }) *
                           acceleration_;
  }
  if (cap_jerk_) {
    // τ̇ ≈ M(q) q⃛ is what a reference's jerk asks of the torque rate.
    limits_.jerk = factor_within(jerk_, [&](int i) { return kTorqueRateShare * torque_rate_(i); }) * jerk_;
  }
}

bool StreamClock::take_if_newer(int64_t utime) {
  if (first_ || utime > utime_) return true;
  ++dropped_;
  return false;
}

double StreamClock::take(int64_t utime, int64_t now_ns, double timeout) {
  const int64_t offset_us = now_ns / 1000 - utime;
  offset_us_ = first_ ? offset_us : std::min(offset_us_ + (now_ns - arrival_ns_) / 10'000'000, offset_us);
  first_ = false;
  utime_ = utime;
  arrival_ns_ = now_ns;
  ++taken_;
  return std::clamp(1e-6 * static_cast<double>(offset_us - offset_us_), 0.0, timeout);
}

bool StreamClock::silent(int64_t now_ns, double timeout) const {
  return now_ns - arrival_ns_ > static_cast<int64_t>(timeout * 1e9);
}

double stream_step(int64_t last_ns, int64_t now_ns) {
  return std::clamp(1e-9 * static_cast<double>(now_ns - last_ns), 0.0, 0.1);
}

}  // namespace chasles::controller
