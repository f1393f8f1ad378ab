#include "chasles/controller/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace chasles::controller {

void QuinticTrajectory::start(const Reference& from, const Eigen::VectorXd& goal, double duration) {
  const double T = duration, T2 = T * T, T3 = T2 * T;
  duration_ = duration;
  for (Eigen::Index i = 0; i < a_.rows(); ++i) {
    const double d = goal(i) - from.q(i), v = from.qd(i), acc = from.qdd(i);
    a_(i, 0) = from.q(i);
    a_(i, 1) = v;
    a_(i, 2) = 0.5 * acc;
    a_(i, 3) = (20.0 * d - 12.0 * v * T - 3.0 * acc * T2) / (2.0 * T3);
    a_(i, 4) = (-30.0 * d + 16.0 * v * T + 3.0 * acc * T2) / (2.0 * T3 * T);
    a_(i, 5) = (12.0 * d - 6.0 * v * T - acc * T2) / (2.0 * T3 * T2);
  }
}

void QuinticTrajectory::sample(double t, Reference& out) const {
  t = std::clamp(t, 0.0, duration_);
  for (Eigen::Index i = 0; i < a_.rows(); ++i) {
    const auto a = a_.row(i);
    // Horner's rule for q and its two derivatives.
    out.q(i) = a(0) + t * (a(1) + t * (a(2) + t * (a(3) + t * (a(4) + t * a(5)))));
    out.qd(i) = a(1) + t * (2.0 * a(2) + t * (3.0 * a(3) + t * (4.0 * a(4) + t * 5.0 * a(5))));
    out.qdd(i) = 2.0 * a(2) + t * (6.0 * a(3) + t * (12.0 * a(4) + t * 20.0 * a(5)));
  }
}

LimitExcess QuinticTrajectory::excess(const MotionLimits& limits) const {
  for (Eigen::Index i = 0; i < a_.rows(); ++i) {
    const auto a = a_.row(i);
    const int joint = static_cast<int>(i);
    if (std::isfinite(limits.lower(i)) || std::isfinite(limits.upper(i))) {
      double low = 0.0, high = 0.0;
      polynomial_range(a.data(), 5, duration_, low, high);
      if (high > limits.upper(i)) return {LimitExcess::kPosition, joint, high, limits.upper(i)};
      if (low < limits.lower(i)) return {LimitExcess::kPosition, joint, low, limits.lower(i)};
    }
    const double v[5] = {a(1), 2 * a(2), 3 * a(3), 4 * a(4), 5 * a(5)};
    const double acc[4] = {2 * a(2), 6 * a(3), 12 * a(4), 20 * a(5)};
    const double jerk[3] = {6 * a(3), 24 * a(4), 60 * a(5)};
    if (const double peak = max_abs_polynomial(v, 4, duration_); peak > limits.velocity(i)) {
      return {LimitExcess::kVelocity, joint, peak, limits.velocity(i)};
    }
    if (const double peak = max_abs_polynomial(acc, 3, duration_); peak > limits.acceleration(i)) {
      return {LimitExcess::kAcceleration, joint, peak, limits.acceleration(i)};
    }
    if (const double peak = max_abs_polynomial(jerk, 2, duration_); peak > limits.jerk(i)) {
      return {LimitExcess::kJerk, joint, peak, limits.jerk(i)};
    }
  }
  return {};
}

}  // namespace chasles::controller
