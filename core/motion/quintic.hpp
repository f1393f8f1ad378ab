// Joint-space reference motions (Modern Robotics ch. 9): a quintic polynomial per joint from the
// current reference (position, velocity, acceleration) to a goal at rest, so that a new goal
// taken mid-motion continues the reference without a jump in velocity or acceleration.
#pragma once

#include <Eigen/Core>
#include <utility>

#include "core/motion/limits.hpp"

namespace chasles::motion {

/// q_d(t), q̇_d(t), q̈_d(t).
struct Reference {
  Eigen::VectorXd q, qd, qdd;
  explicit Reference(int n = 0) : q(Eigen::VectorXd::Zero(n)), qd(Eigen::VectorXd::Zero(n)), qdd(Eigen::VectorXd::Zero(n)) {}
  /// At rest at q.
  void hold(const Eigen::Ref<const Eigen::VectorXd>& position) {
    q = position;
    qd.setZero();
    qdd.setZero();
  }
};

/// The quintic c_0..c_5 over [0, h] from (p0, v0, a0) to (p1, v1, a1): position, velocity and
/// acceleration match at both ends, which is what keeps pieces joined by it C².
void quintic_hermite(double p0, double v0, double a0, double p1, double v1, double a1, double h, double* c);
/// q, q̇, q̈ of the quintic c_0..c_5 at t.
void sample_quintic(const double* c, double t, double& q, double& qd, double& qdd);
/// The first limit of `joint` the quintic c_0..c_5 leaves anywhere in [0, T]: its position range,
/// velocity, acceleration or jerk (exact: each polynomial's extrema). None: false.
LimitExcess quintic_excess(const double* c, double T, const MotionLimits& limits, int joint);
/// The limit of `joint` the quintic c_0..c_5 leaves the most in [0, T] (worse_excess), exact as
/// quintic_excess. None: false.
LimitExcess quintic_worst_excess(const double* c, double T, const MotionLimits& limits, int joint);
/// Whether a leaves its limit more than b: any excess more than none; the position range more
/// than any rate (slowing down does not bring a curve back into range), the further past the
/// more; rates by value / limit, whatever the quantity.
bool worse_excess(const LimitExcess& a, const LimitExcess& b);

/// q(t) = Σ a_k t^k, k = 0..5, per joint, with the boundary conditions (q, q̇, q̈) = start at
/// t = 0 and (goal, 0, 0) at t = T. With start at rest this is the familiar
/// q0 + (q1 − q0)(10s³ − 15s⁴ + 6s⁵), s = t/T (MR eq. 9.11).
class QuinticTrajectory {
 public:
  explicit QuinticTrajectory(int n = 0) : a_(Coefficients::Zero(n, 6)) {}

  /// Allocates nothing once sized. duration > 0.
  void start(const Reference& from, const Eigen::VectorXd& goal, double duration);
  /// The reference at time t after start; t is clamped to [0, T], so past the end the goal holds.
  void sample(double t, Reference& out) const;

  double duration() const { return duration_; }
  int dof() const { return static_cast<int>(a_.rows()); }

  /// The first joint whose motion leaves `limits` anywhere in [0, T]: its position range, its
  /// velocity, acceleration or jerk (exact: each polynomial's extrema). None: false.
  LimitExcess excess(const MotionLimits& limits) const;
  /// Swaps the two motions' contents (buffers of the same size: nothing is allocated).
  void swap(QuinticTrajectory& other) {
    a_.swap(other.a_);
    std::swap(duration_, other.duration_);
  }

 private:
  using Coefficients = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;
  Coefficients a_;  // n × 6: a joint's a_0..a_5 side by side
  double duration_ = 0.0;
};

}  // namespace chasles::motion
