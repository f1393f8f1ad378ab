#include "core/motion/waypoints.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace chasles::motion {

WaypointSpline::WaypointSpline(int n)
    : n_(n),
      t_(Eigen::VectorXd::Zero(Waypoints::kMaxPoints + 1)),
      p_(Eigen::MatrixXd::Zero(n, Waypoints::kMaxPoints + 1)),
      v_(Eigen::MatrixXd::Zero(n, Waypoints::kMaxPoints + 1)),
      a_(Eigen::MatrixXd::Zero(n, Waypoints::kMaxPoints + 1)),
      c_(Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>::Zero(n * Waypoints::kMaxPoints, 6)),
      solve_(Eigen::VectorXd::Zero(Waypoints::kMaxPoints + 1)) {}

// How a joint's velocities and accelerations at the waypoints are chosen where the sender gives
// none. The waypoints are read as samples of a smooth curve, and the curve is the C² cubic spline
// through them (spline_derivatives): it reproduces any smooth curve to O(h⁴), whatever the
// spacing, so a planner's densely sampled path is followed as sent. Shape-keeping velocities
// (Fritsch–Butland, 0 at every sampled extremum) flattened each peak of such a path and caught up
// between with more acceleration and jerk than it has: 4–7 mrad off it, refused unless slowed
// 1.2–1.6× (waypoints_test, SmoothPaths).
//
// Where the waypoints are not samples of a smooth curve, the spline through them can swing far
// past them:
// - a pause, a joint sent to the same position twice (or first to where its reference is): the
//   sender says it stands there, which only velocity and acceleration 0 at both ends give. The
//   spline is clamped to rest there, as at the last waypoint, and each run between such knots
//   solved on its own.
// - a short segment next to a long one (10 ms, then 2 s): a C² curve leaves the short one at its
//   speed and coasts on, 4 rad past the next waypoint.
// - via points, few and far between, each move timed on its own: the spline turns wide at each
//   extremum, out of the range where a waypoint is on its edge (17 mrad for the Panda's first
//   joint up to its limit and back in 1.5 s each way).
// A smooth curve sampled at the waypoints passes a segment's end positions (about an extremum
// between them) by at most 1/8 of the largest move among it and the segments beside it (a parabola,
// even spacing), and keeps the range the waypoints keep if it is to be followed at any speed. A
// joint whose spline passes a segment's waypoints by more than twice that (kSampledSwing), or
// leaves the range, keeps the waypoints' shape instead (shape_keeping_derivatives): at rest at each
// extremum, it turns there, not past. Via points whose spline turns less wide keep it: 50 random
// moves of the Panda timed one by one pass their waypoints by up to 0.2 rad (under a quarter of the
// moves beside them), smooth paths sampled every 0.1 s by at most 0.12 of theirs.
constexpr double kSampledSwing = 0.25;

// The C² cubic spline through joint i's positions, clamped at knot 0 (the current reference), at
// the last waypoint (rest) and at both ends of each pause (rest): the knot velocities that make
// the cubics' accelerations meet at every inner knot (one tridiagonal row per knot, solved by
// Thomas's algorithm), and those accelerations.
void WaypointSpline::spline_derivatives(int i) {
  const int K = knots_ - 1;
  auto h = [this](int k) { return t_(k + 1) - t_(k); };
  auto slope = [&](int k) { return (p_(i, k + 1) - p_(i, k)) / h(k); };
  auto paused = [&](int k) { return (k < K && p_(i, k + 1) == p_(i, k)) || p_(i, k - 1) == p_(i, k); };
  int from = 0;  // the run's first knot, its velocity known
  for (int to = 1; to <= K; ++to) {
    if (to < K && !paused(to)) continue;
    v_(i, to) = 0.0;
    a_(i, to) = 0.0;
    // Forward sweep: each row's coefficient on the next knot's velocity in solve_, its right-hand
    // side in v_; then back substitution in place.
    for (int k = from + 1; k < to; ++k) {
      const double lower = h(k), upper = h(k - 1);
      double pivot = 2.0 * (h(k - 1) + h(k)), rhs = 3.0 * (h(k) * slope(k - 1) + h(k - 1) * slope(k));
      if (k == from + 1) {
        rhs -= lower * v_(i, from);
      } else {
        pivot -= lower * solve_(k - 1);
        rhs -= lower * v_(i, k - 1);
      }
      if (k == to - 1) rhs -= upper * v_(i, to);
      solve_(k) = k == to - 1 ? 0.0 : upper / pivot;
      v_(i, k) = rhs / pivot;
    }
    for (int k = to - 2; k > from; --k) v_(i, k) -= solve_(k) * v_(i, k + 1);
    // The spline's acceleration at each inner knot: its cubic's at the start of the segment.
    for (int k = from + 1; k < to; ++k) a_(i, k) = (6.0 * slope(k) - 4.0 * v_(i, k) - 2.0 * v_(i, k + 1)) / h(k);
    from = to;
  }
}

// Whether joint i's cubic (from its knot velocities) passes some segment's end positions by more
// than kSampledSwing of the largest move among that segment and the two beside it, or leaves
// [lower, upper].
bool WaypointSpline::swings_past(int i, double lower, double upper) const {
  const int K = knots_ - 1;
  auto move = [&](int k) { return k < 0 || k >= K ? 0.0 : std::abs(p_(i, k + 1) - p_(i, k)); };
  for (int k = 0; k < K; ++k) {
    const double h = t_(k + 1) - t_(k), p0 = p_(i, k), d = p_(i, k + 1) - p0;
    const double v0 = v_(i, k) * h, v1 = v_(i, k + 1) * h;  // per unit of τ = (t − t_k)/h
    // q(τ) = p0 + v0 τ + b τ² + c τ³; its turning points in (0, 1) are where 3c τ² + 2b τ + v0 = 0.
    const double b = 3.0 * d - 2.0 * v0 - v1, c = v0 + v1 - 2.0 * d;
    double roots[2];
    int count = 0;
    if (std::abs(c) < 1e-12 * (std::abs(b) + std::abs(v0))) {
      if (b != 0.0) roots[count++] = -v0 / (2.0 * b);
    } else if (const double disc = b * b - 3.0 * c * v0; disc >= 0.0) {
      roots[count++] = (-b + std::sqrt(disc)) / (3.0 * c);
      roots[count++] = (-b - std::sqrt(disc)) / (3.0 * c);
    }
    const double allowed = kSampledSwing * std::max({move(k - 1), move(k), move(k + 1)});
    for (int r = 0; r < count; ++r) {
      const double tau = roots[r];
      if (!(tau > 0.0 && tau < 1.0)) continue;
      const double q = p0 + tau * (v0 + tau * (b + tau * c));
      if (q > std::max(p0, p0 + d) + allowed || q < std::min(p0, p0 + d) - allowed || q > upper || q < lower) {
        return true;
      }
    }
  }
  return false;
}

// Velocities that keep the shape of the waypoints (Fritsch and Butland's harmonic mean of the two
// slopes, weighted for uneven spacing; 0 where the slopes change sign, at a local extremum or a
// pause), so the curve does not overshoot between them, however unevenly they are timed. The
// accelerations are the velocities' central differences, which keeps the quintics gentle; any
// values at the knots give C², since every quintic meets them.
void WaypointSpline::shape_keeping_derivatives(int i) {
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

void WaypointSpline::build(const Reference& start, const Waypoints& waypoints, const MotionLimits& limits,
                           double scale) {
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
  // The sender's, where given (with velocities and no accelerations, their central differences).
  if (!waypoints.has_velocities) {
    for (int i = 0; i < n_; ++i) {
      spline_derivatives(i);
      if (swings_past(i, limits.lower(i), limits.upper(i))) shape_keeping_derivatives(i);
    }
  } else {
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
  WaypointExcess worst;
  for (int k = 0; k + 1 < knots_; ++k) {
    for (int i = 0; i < n_; ++i) {
      const LimitExcess e = quintic_worst_excess(c_.row(k * n_ + i).data(), t_(k + 1) - t_(k), limits, i);
      if (worse_excess(e, worst.excess)) worst = {k, e};
    }
  }
  return worst;
}

bool WaypointSpline::fits(const MotionLimits& limits) const {
  for (int k = 0; k + 1 < knots_; ++k) {
    for (int i = 0; i < n_; ++i) {
      if (quintic_excess(c_.row(k * n_ + i).data(), t_(k + 1) - t_(k), limits, i)) return false;
    }
  }
  return true;
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

}  // namespace chasles::motion
