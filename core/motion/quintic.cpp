#include "core/motion/quintic.hpp"

#include <algorithm>
#include <cmath>

namespace chasles::motion {

void QuinticTrajectory::start(const Reference& from, const Eigen::VectorXd& goal, double duration) {
  duration_ = duration;
  for (int i = 0; i < dof(); ++i) {
    quintic_hermite(from.q(i), from.qd(i), from.qdd(i), goal(i), 0.0, 0.0, duration, a_.row(i).data());
  }
}

void QuinticTrajectory::sample(double t, Reference& out) const {
  t = std::clamp(t, 0.0, duration_);
  for (int i = 0; i < dof(); ++i) sample_quintic(a_.row(i).data(), t, out.q(i), out.qd(i), out.qdd(i));
}

// A limit met exactly (a waypoint on the position limit, a velocity given at the limit) must not
// read as exceeded by the last bits of Horner's rule: the allowance of the checks, rad or relative.
constexpr double kRounding = 1e-9;

LimitExcess quintic_excess(const double* a, double T, const MotionLimits& limits, int joint) {
  const int i = joint;
  if (std::isfinite(limits.lower(i)) || std::isfinite(limits.upper(i))) {
    double low = 0.0, high = 0.0;
    polynomial_range(a, 5, T, low, high);
    if (high > limits.upper(i) + kRounding) return {LimitExcess::kPosition, joint, high, limits.upper(i)};
    if (low < limits.lower(i) - kRounding) return {LimitExcess::kPosition, joint, low, limits.lower(i)};
  }
  const double v[5] = {a[1], 2 * a[2], 3 * a[3], 4 * a[4], 5 * a[5]};
  const double acc[4] = {2 * a[2], 6 * a[3], 12 * a[4], 20 * a[5]};
  const double jerk[3] = {6 * a[3], 24 * a[4], 60 * a[5]};
  if (const double peak = max_abs_polynomial(v, 4, T); peak > limits.velocity(i) * (1.0 + kRounding)) {
    return {LimitExcess::kVelocity, joint, peak, limits.velocity(i)};
  }
  if (const double peak = max_abs_polynomial(acc, 3, T); peak > limits.acceleration(i) * (1.0 + kRounding)) {
    return {LimitExcess::kAcceleration, joint, peak, limits.acceleration(i)};
  }
  if (const double peak = max_abs_polynomial(jerk, 2, T); peak > limits.jerk(i) * (1.0 + kRounding)) {
    return {LimitExcess::kJerk, joint, peak, limits.jerk(i)};
  }
  return {};
}

bool worse_excess(const LimitExcess& a, const LimitExcess& b) {
  if (!a || !b) return a && !b;
  const bool a_position = a.quantity == LimitExcess::kPosition, b_position = b.quantity == LimitExcess::kPosition;
  if (a_position != b_position) return a_position;
  if (a_position) return std::abs(a.value - a.limit) > std::abs(b.value - b.limit);
  return a.value / a.limit > b.value / b.limit;
}

LimitExcess quintic_worst_excess(const double* a, double T, const MotionLimits& limits, int joint) {
  const int i = joint;
  LimitExcess worst;
  if (std::isfinite(limits.lower(i)) || std::isfinite(limits.upper(i))) {
    double low = 0.0, high = 0.0;
    polynomial_range(a, 5, T, low, high);
    const double above = high - limits.upper(i), below = limits.lower(i) - low;
    if (above > kRounding && above >= below) return {LimitExcess::kPosition, joint, high, limits.upper(i)};
    if (below > kRounding) return {LimitExcess::kPosition, joint, low, limits.lower(i)};
  }
  const double v[5] = {a[1], 2 * a[2], 3 * a[3], 4 * a[4], 5 * a[5]};
  const double acc[4] = {2 * a[2], 6 * a[3], 12 * a[4], 20 * a[5]};
  const double jerk[3] = {6 * a[3], 24 * a[4], 60 * a[5]};
  const LimitExcess rates[3] = {
      {LimitExcess::kVelocity, joint, max_abs_polynomial(v, 4, T), limits.velocity(i)},
      {LimitExcess::kAcceleration, joint, max_abs_polynomial(acc, 3, T), limits.acceleration(i)},
      {LimitExcess::kJerk, joint, max_abs_polynomial(jerk, 2, T), limits.jerk(i)}};
  for (const LimitExcess& e : rates) {
    if (e.value > e.limit * (1.0 + kRounding) && worse_excess(e, worst)) worst = e;
  }
  return worst;
}

void quintic_hermite(double p0, double v0, double a0, double p1, double v1, double a1, double h, double* c) {
  const double d = p1 - p0, h2 = h * h, h3 = h2 * h;
  c[0] = p0;
  c[1] = v0;
  c[2] = 0.5 * a0;
  c[3] = (20.0 * d - (8.0 * v1 + 12.0 * v0) * h - (3.0 * a0 - a1) * h2) / (2.0 * h3);
  c[4] = (-30.0 * d + (14.0 * v1 + 16.0 * v0) * h + (3.0 * a0 - 2.0 * a1) * h2) / (2.0 * h3 * h);
  c[5] = (12.0 * d - 6.0 * (v1 + v0) * h - (a0 - a1) * h2) / (2.0 * h3 * h2);
}

void sample_quintic(const double* c, double t, double& q, double& qd, double& qdd) {
  // Horner's rule for q and its two derivatives.
  q = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))));
  qd = c[1] + t * (2.0 * c[2] + t * (3.0 * c[3] + t * (4.0 * c[4] + t * 5.0 * c[5])));
  qdd = 2.0 * c[2] + t * (6.0 * c[3] + t * (12.0 * c[4] + t * 20.0 * c[5]));
}

LimitExcess QuinticTrajectory::excess(const MotionLimits& limits) const {
  for (int i = 0; i < dof(); ++i) {
    if (const LimitExcess e = quintic_excess(a_.row(i).data(), duration_, limits, i)) return e;
  }
  return {};
}

}  // namespace chasles::motion
