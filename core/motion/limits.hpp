// The arm's motion limits, per joint, and the checks every reference and every measured state
// pass (docs/controller.md, "Limits"). Position and velocity come from the URDF; acceleration from
// the configuration, else Drake's drake:acceleration where the URDF has it; jerk, which no URDF
// carries, from the configuration; conservative defaults for what is given nowhere.
#pragma once

#include <Eigen/Core>

#include "core/model/model.hpp"

namespace chasles::motion {

/// Defaults for an arm whose acceleration and jerk limits are not given: the velocity limit
/// reached from rest in kAccelerationTime, the acceleration limit from zero in kJerkTime. Both are
/// below libfranka's limits for the Panda on every joint (its v/a is 0.15–0.29 s, its a/j 2 ms):
/// an arm of unknown strength is driven gently rather than at a guess of its maximum.
constexpr double kAccelerationTime = 0.4;  // s
constexpr double kJerkTime = 0.02;         // s

struct LimitConfig {
  /// rad/s² (m/s² for a prismatic joint), one per joint; empty: the URDF's drake:acceleration,
  /// else velocity / kAccelerationTime.
  Eigen::VectorXd acceleration;
  /// rad/s³ (m/s³), one per joint; empty: acceleration / kJerkTime.
  Eigen::VectorXd jerk;
  /// rad (m): the reference keeps this far inside the URDF's position limits.
  double position_margin = 0.01;
  /// The measured velocity may exceed a joint's limit by this fraction before the guard trips.
  double velocity_tolerance = 0.1;
  /// Whether the online generator (streams, jogs, stops) keeps its jerk within what the
  /// torque-rate limit lets the arm follow at each state (GeneratorLimits::fit_to_arm):
  /// libfranka's Panda jerks ask up to ten times the torque rate. Off, it plans at `jerk` itself.
  bool jerk_within_torque_rate = true;
  /// Whether the online generator keeps its acceleration within what the effort limits leave
  /// beyond gravity at each state (GeneratorLimits::fit_to_arm): libfranka's Panda accelerations,
  /// asked at an outstretched pose, want more than a shoulder's 87 N·m. Off, it plans at
  /// `acceleration` itself.
  bool acceleration_within_effort = true;

  /// Throws ArgumentError naming what is wrong (sizes, signs, non-finite values).
  void validate(int dof) const;
};

/// Every joint's limits; ∞ where the arm has none (a continuous joint's position, a joint
/// without a URDF velocity limit and no configured acceleration).
struct MotionLimits {
  Eigen::VectorXd hard_lower, hard_upper;  ///< the URDF's position limits
  Eigen::VectorXd lower, upper;            ///< those, less the margin: where the reference may go
  Eigen::VectorXd velocity, acceleration, jerk;
  double velocity_tolerance = 0.1;

  MotionLimits() = default;
  MotionLimits(const RobotModel& model, const LimitConfig& config);
  int dof() const { return static_cast<int>(velocity.size()); }
};

/// Which limit a reference or a state broke, on which joint, by how much.
struct LimitExcess {
  enum Quantity : int8_t { kNone, kPosition, kVelocity, kAcceleration, kJerk };
  Quantity quantity = kNone;
  int joint = -1;
  double value = 0.0, limit = 0.0;
  explicit operator bool() const { return quantity != kNone; }
};
const char* to_string(LimitExcess::Quantity quantity);
/// rad, rad/s, rad/s² or rad/s³ (the prismatic joint's m are left to the joint's type).
const char* unit_of(LimitExcess::Quantity quantity);

/// The least and greatest of Σ_k c_k t^k for t in [0, T], degree ≤ 5: at an end or where the
/// derivative vanishes, its roots bracketed by those of the next derivative and bisected, so
/// exact to rounding.
void polynomial_range(const double* c, int degree, double T, double& low, double& high);
/// max |Σ_k c_k t^k| for t in [0, T], degree ≤ 5.
double max_abs_polynomial(const double* c, int degree, double T);

/// The fastest speed from which a stop at acceleration limit A and jerk limit J, starting at zero
/// acceleration, takes at most d (the stop's exact distance v²/(2A) + vA/(2J) inverted, an upper
/// bound of it below v = A²/J): the fastest a joint may head toward a limit d away. 0 for d ≤ 0.
double speed_that_stops_within(double d, double A, double J);

/// Velocity v at position p in [lower, upper], cut to at most `fastest` and, heading toward a
/// limit, to what can still stop before it.
double velocity_that_stops_in_range(double v, double p, double lower, double upper, double fastest, double A,
                                    double J);

/// The guard on a measured state: a joint faster than its velocity limit by more than the
/// tolerance, or one that has just crossed a position limit outward (from q_before inside to q
/// outside: a joint that starts outside may be brought back). The first such joint; none: false.
LimitExcess measured_excess(const MotionLimits& limits, const Eigen::VectorXd& q_before, const Eigen::VectorXd& q,
                            const Eigen::VectorXd& qd);

}  // namespace chasles::motion
