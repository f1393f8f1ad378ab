// Joint-space reference motions (Modern Robotics ch. 9): a quintic polynomial per joint from the
// current reference (position, velocity, acceleration) to a goal at rest, so that a new goal
// taken mid-motion continues the reference without a jump in velocity or acceleration.
#pragma once

#include <Eigen/Core>

namespace chasles::controller {

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

/// q(t) = Σ a_k t^k, k = 0..5, per joint, with the boundary conditions (q, q̇, q̈) = start at
/// t = 0 and (goal, 0, 0) at t = T. With start at rest this is the familiar
/// q0 + (q1 − q0)(10s³ − 15s⁴ + 6s⁵), s = t/T (MR eq. 9.11).
class QuinticTrajectory {
 public:
  explicit QuinticTrajectory(int n = 0) : a_(Eigen::MatrixXd::Zero(n, 6)) {}

  /// Allocates nothing once sized. duration > 0.
  void start(const Reference& from, const Eigen::VectorXd& goal, double duration);
  /// The reference at time t after start; t is clamped to [0, T], so past the end the goal holds.
  void sample(double t, Reference& out) const;

  double duration() const { return duration_; }

 private:
  Eigen::MatrixXd a_;  // n × 6 coefficients
  double duration_ = 0.0;
};

}  // namespace chasles::controller
