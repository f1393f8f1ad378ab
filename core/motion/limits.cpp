#include "core/motion/limits.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.hpp"

namespace chasles::motion {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double horner(const double* c, int degree, double t) {
  double value = c[degree];
  for (int k = degree - 1; k >= 0; --k) value = value * t + c[k];
  return value;
}

// The roots of the polynomial in (0, T), ascending, into roots; returns their count (≤ degree).
// Between consecutive roots of the derivative the polynomial is monotone, so each sign change
// there brackets exactly one root, which bisection finds to the last bit.
int roots_in(const double* c, int degree, double T, double* roots) {
  while (degree > 0 && c[degree] == 0.0) --degree;
  if (degree == 0) return 0;
  if (degree == 1) {
    const double t = -c[0] / c[1];
    if (t > 0.0 && t < T) roots[0] = t;
    return t > 0.0 && t < T ? 1 : 0;
  }
  double derivative[5], critical[6];
  for (int k = 1; k <= degree; ++k) derivative[k - 1] = k * c[k];
  const int m = roots_in(derivative, degree - 1, T, critical + 1);
  critical[0] = 0.0;
  double ends[7];
  std::copy(critical, critical + m + 1, ends);
  ends[m + 1] = T;
  int count = 0;
  for (int i = 0; i <= m; ++i) {
    double lo = ends[i], hi = ends[i + 1];
    double f_lo = horner(c, degree, lo);
    const double f_hi = horner(c, degree, hi);
    if (f_lo == 0.0 || f_hi == 0.0 || (f_lo < 0.0) == (f_hi < 0.0)) continue;  // a zero at an end is an end
    for (int it = 0; it < 200 && hi - lo > 0.0; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      const double f_mid = horner(c, degree, mid);
      if ((f_mid < 0.0) == (f_lo < 0.0)) {
        lo = mid, f_lo = f_mid;
      } else {
        hi = mid;
      }
    }
    roots[count++] = 0.5 * (lo + hi);
  }
  return count;
}

}  // namespace

const char* to_string(LimitExcess::Quantity quantity) {
  switch (quantity) {
    case LimitExcess::kNone:
      return "none";
    case LimitExcess::kPosition:
      return "position";
    case LimitExcess::kVelocity:
      return "velocity";
    case LimitExcess::kAcceleration:
      return "acceleration";
    case LimitExcess::kJerk:
      return "jerk";
  }
  return "?";
}

const char* unit_of(LimitExcess::Quantity quantity) {
  switch (quantity) {
    case LimitExcess::kPosition:
      return "rad";
    case LimitExcess::kVelocity:
      return "rad/s";
    case LimitExcess::kAcceleration:
      return "rad/s²";
    case LimitExcess::kJerk:
      return "rad/s³";
    default:
      return "";
  }
}

void LimitConfig::validate(int dof) const {
  auto check = [dof](const Eigen::VectorXd& v, const char* name) {
    if (v.size() == 0) return;
    if (v.size() != dof) {
      throw ArgumentError(std::string(name) + " limits: " + std::to_string(v.size()) + " entries, the arm has " +
                          std::to_string(dof) + " joints");
    }
    if (!(v.array() > 0.0).all() || v.hasNaN()) throw ArgumentError(std::string(name) + " limits must be positive");
  };
  check(acceleration, "acceleration");
  check(jerk, "jerk");
  if (!(position_margin >= 0.0) || !std::isfinite(position_margin)) {
    throw ArgumentError("the position margin must be finite and non-negative");
  }
  if (!(velocity_tolerance >= 0.0) || !std::isfinite(velocity_tolerance)) {
    throw ArgumentError("the velocity tolerance must be finite and non-negative");
  }
}

MotionLimits::MotionLimits(const RobotModel& model, const LimitConfig& config)
    : hard_lower(model.dof()),
      hard_upper(model.dof()),
      lower(model.dof()),
      upper(model.dof()),
      velocity(model.dof()),
      acceleration(model.dof()),
      jerk(model.dof()),
      velocity_tolerance(config.velocity_tolerance) {
  config.validate(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    const bool bounded = joint.type != JointType::Continuous && joint.limits.lower < joint.limits.upper;
    hard_lower(i) = bounded ? joint.limits.lower : -kInf;
    hard_upper(i) = bounded ? joint.limits.upper : kInf;
    // A range narrower than two margins keeps its middle.
    const double margin = bounded ? std::min(config.position_margin, 0.5 * (hard_upper(i) - hard_lower(i))) : 0.0;
    lower(i) = hard_lower(i) + margin;
    upper(i) = hard_upper(i) - margin;
    velocity(i) = joint.limits.velocity > 0.0 ? joint.limits.velocity : kInf;
    acceleration(i) = config.acceleration.size()               ? config.acceleration(i)
                      : std::isfinite(joint.limits.acceleration) ? joint.limits.acceleration
                                                                 : velocity(i) / kAccelerationTime;
    jerk(i) = config.jerk.size() ? config.jerk(i) : acceleration(i) / kJerkTime;
  }
}

void polynomial_range(const double* c, int degree, double T, double& low, double& high) {
  double derivative[5], roots[5];
  for (int k = 1; k <= degree; ++k) derivative[k - 1] = k * c[k];
  low = high = horner(c, degree, 0.0);
  const int m = degree > 0 ? roots_in(derivative, degree - 1, T, roots) : 0;
  roots[m] = T;
  for (int i = 0; i <= m; ++i) {
    const double value = horner(c, degree, roots[i]);
    low = std::min(low, value), high = std::max(high, value);
  }
}

double max_abs_polynomial(const double* c, int degree, double T) {
  double low = 0.0, high = 0.0;
  polynomial_range(c, degree, T, low, high);
  return std::max(-low, high);
}

double speed_that_stops_within(double d, double A, double J) {
  if (!(d > 0.0)) return 0.0;
  const double b = A * A / J;
  return 0.5 * (-b + std::sqrt(b * b + 8.0 * A * d));
}

double velocity_that_stops_in_range(double v, double p, double lower, double upper, double fastest, double A,
                                    double J) {
  const double room = v > 0.0 ? upper - p : p - lower;
  return std::copysign(std::min({std::abs(v), fastest, speed_that_stops_within(room, A, J)}), v);
}

LimitExcess measured_excess(const MotionLimits& limits, const Eigen::VectorXd& q_before, const Eigen::VectorXd& q,
                            const Eigen::VectorXd& qd) {
  for (int i = 0; i < limits.dof(); ++i) {
    const double allowed = limits.velocity(i) * (1.0 + limits.velocity_tolerance);
    if (std::abs(qd(i)) > allowed) return {LimitExcess::kVelocity, i, qd(i), allowed};
    if (q(i) > limits.hard_upper(i) && q_before(i) <= limits.hard_upper(i)) {
      return {LimitExcess::kPosition, i, q(i), limits.hard_upper(i)};
    }
    if (q(i) < limits.hard_lower(i) && q_before(i) >= limits.hard_lower(i)) {
      return {LimitExcess::kPosition, i, q(i), limits.hard_lower(i)};
    }
  }
  return {};
}

}  // namespace chasles::motion
