#include "chasles/controller/waypoints.hpp"

#include <algorithm>
#include <utility>

namespace chasles::controller {

WaypointSpline::WaypointSpline(int n)
    : n_(n),
      t_(Eigen::VectorXd::Zero(Waypoints::kMaxPoints + 1)),
      p_(Eigen::MatrixXd::Zero(n, Waypoints::kMaxPoints + 1)),
      v_(Eigen::MatrixXd::Zero(n, Waypoints::kMaxPoints + 1)),
      a_(Eigen::MatrixXd::Zero(n, Waypoints::kMaxPoints + 1)),
      c_(Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>::Zero(n * Waypoints::kMaxPoints, 6)) {}

// Velocities that keep the shape of the waypoints (Fritsch and Butland's harmonic mean of the two
// slopes, weighted for uneven spacing; 0 where the slopes change sign, at a local extremum), so
// the curve does not overshoot between them, however unevenly they are timed: the C² cubic spline
// through the same points swings far past them when a short segment meets a long one. The
// accelerations are the velocities' central differences, which keeps the quintics gentle; any
// values at the knots give C², since every quintic meets them.
void WaypointSpline::knot_derivatives(int i) {
  const int K = knots_ - 1;
  auto h = [this](int k) { return t_(k + 1) - t_(k); };
  auto slope = [&](int k) { return (p_(i, k + 1) - p_(i, k)) / h(k); };
  for (int k = 1; k < K; ++k) {
    const double before = slope(k - 1), after = slope(k);
    if (before * after <= 0.0) {
      v_(i, k) = 0.0;
    } else {
      const double w_before = 2.0 * h(k) + h(k - 1), w_after = h(k) + 2.0 * h(k - 1);
      v_(i, k) = (w_before + w_after) / (w_before / before + w_after / after);
    }
  }
  // At rest at a waypoint (an extremum, or a pause), also unaccelerated: an acceleration there
  // would carry the curve past the waypoint.
  for (int k = 1; k < K; ++k) {
    a_(i, k) = v_(i, k) == 0.0 ? 0.0 : (v_(i, k + 1) - v_(i, k - 1)) / (t_(k + 1) - t_(k - 1));
  }
}

void WaypointSpline::build(const Reference& start, const Waypoints& waypoints, double scale) {
  knots_ = waypoints.count + 1;
  cursor_ = 0;
  t_(0) = 0.0;
  t_.segment(1, waypoints.count) = scale * waypoints.time.head(waypoints.count);
  p_.col(0) = start.q;
  v_.col(0) = start.qd;
  a_.col(0) = start.qdd;
  p_.middleCols(1, waypoints.count) = waypoints.q.leftCols(waypoints.count);
  const int K = knots_ - 1;
  // The last waypoint is at rest (set_trajectory refuses one that is not).
  v_.col(K).setZero();
  a_.col(K).setZero();
  for (int i = 0; i < n_; ++i) knot_derivatives(i);
  // The sender's, where given (with velocities and no accelerations, their central differences).
  if (waypoints.has_velocities) {
    v_.middleCols(1, K - 1) = waypoints.qd.leftCols(K - 1) / scale;
    for (int k = 1; k < K; ++k) a_.col(k) = (v_.col(k + 1) - v_.col(k - 1)) / (t_(k + 1) - t_(k - 1));
  }
  if (waypoints.has_accelerations) a_.middleCols(1, K - 1) = waypoints.qdd.leftCols(K - 1) / (scale * scale);
  for (int k = 0; k < K; ++k) {
    const double h = t_(k + 1) - t_(k);
    for (int i = 0; i < n_; ++i) {
      quintic_hermite(p_(i, k), v_(i, k), a_(i, k), p_(i, k + 1), v_(i, k + 1), a_(i, k + 1), h,
                      c_.row(k * n_ + i).data());
    }
  }
}

WaypointExcess WaypointSpline::excess(const MotionLimits& limits) const {
  for (int k = 0; k + 1 < knots_; ++k) {
    for (int i = 0; i < n_; ++i) {
      if (const LimitExcess e = quintic_excess(c_.row(k * n_ + i).data(), t_(k + 1) - t_(k), limits, i)) {
        return {k, e};
      }
    }
  }
  return {};
}

void WaypointSpline::swap(WaypointSpline& other) {
  std::swap(n_, other.n_);
  std::swap(knots_, other.knots_);
  std::swap(cursor_, other.cursor_);
  t_.swap(other.t_);
  p_.swap(other.p_);
  v_.swap(other.v_);
  a_.swap(other.a_);
  c_.swap(other.c_);
}

int WaypointSpline::segment_at(double t) const {
  const int last = knots_ - 2;
  if (cursor_ > last || t < t_(cursor_)) cursor_ = 0;
  while (cursor_ < last && t >= t_(cursor_ + 1)) ++cursor_;
  return cursor_;
}

int WaypointSpline::waypoint_at(double t) const {
  return t >= duration() ? knots_ - 1 : segment_at(t);
}

void WaypointSpline::sample(double t, Reference& out) const {
  if (t >= duration()) {
    out.hold(p_.col(knots_ - 1));
    return;
  }
  const int k = segment_at(std::max(t, 0.0));
  const double local = std::max(t, 0.0) - t_(k);
  for (int i = 0; i < n_; ++i) sample_quintic(c_.row(k * n_ + i).data(), local, out.q(i), out.qd(i), out.qdd(i));
}

}  // namespace chasles::controller
