// Step 1 of the online generator: one axis's time-optimal profile from a state within its limits
// (detail::time_optimal). The candidates are the UDDU family's shapes: a cruise at the velocity
// limit, or the cruise-less shapes, each the root of a polynomial in one unknown solved here with
// its own small root finder. Apart from the class (online_generator.cpp) and from step 2
// (fixed_duration.cpp) because it is a closed-form solver of its own, with its own derivation
// (docs/motion.md), that step 2 only calls as a whole.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/motion/axis_profile.hpp"

namespace chasles::motion::detail {
namespace {

// ---------------------------------------------------------------------------------------------
// Real roots of small polynomials.

inline double polynomial(const double* c, int n, double x) {
  double y = c[n];
  for (int k = n - 1; k >= 0; --k) y = y * x + c[k];
  return y;
}

// The real roots of c[0] + c[1] x + … + c[n] x^n (n ≤ 4) in [lo, hi], ascending, into roots
// (returns how many). Isolated by the roots of the derivative (between two of its consecutive
// roots the polynomial is monotone: at most one root, found by bisection), so that no root is
// missed, and a double root (a touching extremum) counts when the polynomial is zero there to
// round-off. Recursion on the degree; nothing is allocated.
int polynomial_roots(const double* c, int n, double lo, double hi, double* roots, double precision = 1e-16) {
  if (!(lo <= hi)) return 0;
  double scale = 0.0;
  const double xm = std::max(std::abs(lo), std::abs(hi));
  double power[5] = {1.0, 0.0, 0.0, 0.0, 0.0};  // max(1, |x|)^k on the interval
  for (int k = 1; k <= n; ++k) power[k] = power[k - 1] * std::max(1.0, xm);
  for (int k = 0; k <= n; ++k) scale = std::max(scale, std::abs(c[k]) * power[k]);
  if (scale == 0.0) return 0;
  // Drop leading coefficients that are round-off on the interval.
  while (n > 0 && std::abs(c[n]) * power[n] <= 1e-15 * scale) --n;
  if (n == 0) return 0;
  if (n == 1) {
    const double x = -c[0] / c[1];
    if (x >= lo && x <= hi) {
      roots[0] = x;
      return 1;
    }
    return 0;
  }
  double d[4];
  for (int k = 0; k < n; ++k) d[k] = (k + 1) * c[k + 1];
  double points[6];
  int m = 0;
  points[m++] = lo;
  double critical[4];
  // The derivative's roots only bound the brackets: they need less precision.
  const int nc = polynomial_roots(d, n - 1, lo, hi, critical, 1e-11);
  for (int k = 0; k < nc; ++k) points[m++] = critical[k];
  points[m++] = hi;
  // Zero to round-off: small against the terms it sums at that x (not against the largest
  // coefficient: a root near 0 has terms far smaller than that).
  const auto is_zero = [&](double x, double f) {
    double terms = 0.0, power_x = 1.0;
    for (int k = 0; k <= n; ++k) {
      terms += std::abs(c[k]) * power_x;
      power_x *= std::abs(x);
    }
    return std::abs(f) <= 1e-13 * terms;
  };
  int count = 0;
  auto push = [&](double x) {
    if (count == 0 || x - roots[count - 1] > 1e-13 * std::max(1.0, std::abs(x))) roots[count++] = x;
  };
  for (int k = 0; k + 1 < m; ++k) {
    double a = points[k], b = points[k + 1];
    double fa = polynomial(c, n, a), fb = polynomial(c, n, b);
    if (is_zero(a, fa)) {
      push(a);
      continue;
    }
    if (is_zero(b, fb)) continue;  // pushed as the next interval's left end
    if ((fa < 0.0) == (fb < 0.0)) continue;
    // Newton from the bracket's middle, kept inside the bracket (bisection when a step leaves it
    // or does not halve it): one root, monotone in between.
    double x = 0.5 * (a + b), last_step = b - a;
    for (int it = 0; it < 100; ++it) {
      double f = c[n], df = 0.0;
      for (int q = n - 1; q >= 0; --q) {
        df = df * x + f;
        f = f * x + c[q];
      }
      if (f == 0.0) break;
      if ((f < 0.0) == (fa < 0.0)) {
        a = x;
      } else {
        b = x;
      }
      double next = df != 0.0 ? x - f / df : 0.5 * (a + b);
      if (!(next > a && next < b) || std::abs(next - x) > 0.5 * last_step) next = 0.5 * (a + b);
      last_step = std::abs(next - x);
      x = next;
      if (last_step <= precision * std::max(1.0, std::abs(x)) || b - a <= precision * std::max(1.0, std::abs(x))) break;
    }
    push(x);
  }
  if (is_zero(points[m - 1], polynomial(c, n, points[m - 1]))) push(points[m - 1]);
  return count;
}

// ---------------------------------------------------------------------------------------------
// Step 1: an axis's time-optimal profile, among the UDDU profiles (jerk +, 0, −, 0, −, 0, + in the
// direction of the motion, and its mirror image): with the velocity limit reached (a cruise at
// ±V, by two velocity ramps) or without a cruise (phases 3 and 5 merged), the acceleration limit
// reached in the first half (ACC0), in the second (ACC1), in both, or in neither (NONE). The
// cruise-less families are polynomials in one unknown, derived in units where J = A = 1 (time
// A/J, velocity A²/J, position A³/J²) to keep their coefficients of order one.

// Lays a candidate out from the axis's start and keeps it if it is valid and the fastest yet.
void consider(const Phases& ph, const Axis& x, Best& best, AxisProfile& scratch) {
  double duration = 0.0;
  for (int k = 0; k < ph.n; ++k) duration += ph.t[k];
  if (duration >= best.duration) return;
  lay_out(ph, x.p0, x.v0, x.a0, scratch);
  if (within_limits_and_reaches(scratch, x)) {
    best.duration = duration;
    best.profile = scratch;
  }
}

// The cruise-less families in units where J = A = 1, mirrored into direction +1.
struct Unit {
  double a0, af, v0, vf, dv, dp, K;  // K = a1² − a5² in NONE, from the velocity
};

enum class Family { Acc0Acc1, Acc0, Acc1, NoneBelow, NoneAbove };

// The unit phases of a family at its unknown x (t2 for ACC0_ACC1, a5 for ACC0, a1 for ACC1 and
// NONE; NONE's a5 = ∓√(a1² − K), below or above 0). The plateau durations follow from the velocity
// equation; false if one is negative beyond round-off.
bool unit_phases(Family family, double x, const Unit& u, double* sign, double* t, int& n) {
  const double a02 = u.a0 * u.a0, af2 = u.af * u.af;
  switch (family) {
    case Family::Acc0Acc1: {  // a1 = 1, a5 = −1
      const double t6 = x - u.dv - a02 / 2.0 + af2 / 2.0;
      const double s[5] = {1.0, 0.0, -1.0, 0.0, 1.0}, d[5] = {1.0 - u.a0, x, 2.0, t6, u.af + 1.0};
      std::copy(s, s + 5, sign);
      std::copy(d, d + 5, t);
      n = 5;
      break;
    }
    case Family::Acc0: {  // a1 = 1, a5 = x
      const double t2 = -1.0 + u.dv + a02 / 2.0 + x * x - af2 / 2.0;
      const double s[4] = {1.0, 0.0, -1.0, 1.0}, d[4] = {1.0 - u.a0, t2, 1.0 - x, u.af - x};
      std::copy(s, s + 4, sign);
      std::copy(d, d + 4, t);
      n = 4;
      break;
    }
    case Family::Acc1: {  // a1 = x, a5 = −1
      const double t6 = -1.0 - u.dv - a02 / 2.0 + x * x + af2 / 2.0;
      const double s[4] = {1.0, -1.0, 0.0, 1.0}, d[4] = {x - u.a0, x + 1.0, t6, u.af + 1.0};
      std::copy(s, s + 4, sign);
      std::copy(d, d + 4, t);
      n = 4;
      break;
    }
    case Family::NoneBelow:
    case Family::NoneAbove: {  // a1 = x
      const double r = std::sqrt(std::max(0.0, x * x - u.K));
      const double a5 = family == Family::NoneBelow ? -r : r;
      const double s[3] = {1.0, -1.0, 1.0}, d[3] = {x - u.a0, x - a5, u.af - a5};
      std::copy(s, s + 3, sign);
      std::copy(d, d + 3, t);
      n = 3;
      break;
    }
  }
  for (int k = 0; k < n; ++k) {
    if (t[k] < -1e-7) return false;
    t[k] = std::max(0.0, t[k]);
  }
  return true;
}

// The phases of a family at x in the axis's own units and direction d; false if invalid.
bool family_phases(Family family, double x, const Unit& u, double d, const Axis& ax, Phases& ph) {
  double sign[5], t[5];
  int n = 0;
  if (!unit_phases(family, x, u, sign, t, n)) return false;
  const double tau = ax.A / ax.J;
  ph.n = 0;
  for (int k = 0; k < n; ++k) ph.add(d * sign[k] * ax.J, t[k] * tau);
  return true;
}

// A root x of a family's polynomial, clamped into its domain [lo, hi], polished by Newton steps
// on the position the laid-out profile ends at (the polynomial was squared or is flat near a
// double root, where its root is only good to √ε), then considered.
void consider_root(Family family, double x, double lo, double hi, const Unit& u, double d, const Axis& ax,
                   Best& best, AxisProfile& scratch) {
  x = std::clamp(x, lo, hi);
  Phases ph;
  const auto miss = [&](double at, double& out) {
    if (!family_phases(family, at, u, d, ax, ph)) return false;
    lay_out(ph, ax.p0, ax.v0, ax.a0, scratch);
    out = scratch.p[scratch.phases] - ax.pf;
    return true;
  };
  double e;
  if (!miss(x, e)) return;
  const double tol = 0.1 * kEndTolerance * std::max(1.0, std::abs(ax.pf));
  for (int it = 0; it < 6 && std::abs(e) > tol; ++it) {
    const double h = 1e-7 * std::max(1.0, std::abs(x));
    double e_h;
    const double x_h = x + h <= hi ? x + h : x - h;
    if (!miss(x_h, e_h) || e_h == e) break;
    const double x_new = std::clamp(x - e * (x_h - x) / (e_h - e), lo, hi);
    double e_new;
    if (!miss(x_new, e_new) || std::abs(e_new) >= std::abs(e)) break;
    x = x_new;
    e = e_new;
  }
  if (family_phases(family, x, u, d, ax, ph)) consider(ph, ax, best, scratch);
}

// The real roots of a family's polynomial over its domain widened a little (a root on the
// domain's edge, e.g. a phase of zero duration, must not be lost to round-off), each considered.
void consider_family(Family family, const double* c, int degree, double lo, double hi, const Unit& u, double d,
                     const Axis& ax, Best& best, AxisProfile& scratch, Family also = Family::Acc0Acc1) {
  if (lo > hi) return;
  double roots[4];
  const double widen = 1e-6 * std::max(1.0, hi - lo);
  const int n = polynomial_roots(c, degree, lo - widen, hi + widen, roots);
  for (int k = 0; k < n; ++k) {
    consider_root(family, roots[k], lo, hi, u, d, ax, best, scratch);
    // NONE's two signs of a5 share one polynomial.
    if (also != Family::Acc0Acc1) consider_root(also, roots[k], lo, hi, u, d, ax, best, scratch);
  }
}

// The profile that cruises at the velocity limit d·V: a ramp to (d·V, 0), the cruise, a ramp to
// the target. True if it is valid with a cruise of positive duration: then it is the time-optimal
// profile, and the cruise-less families need no solving. In its own direction, because the ramps'
// distance grows with the peak velocity, so a profile without a cruise would need a peak beyond V;
// in the other, because every such profile first moves away from a target it then reaches at the
// limit's speed at best (Ruckig's profiles agreed on every one of 10⁵ random problems and 4·10⁵
// edge cases; see docs/motion.md).
bool cruise_at_limit(const Axis& x, double d, Best& best, AxisProfile& scratch) {
  const double vc = d * x.V;
  Phases up = velocity_ramp(x.v0, x.a0, vc, 0.0, x.A, x.J);
  const Phases down = velocity_ramp(vc, 0.0, x.vf, x.af, x.A, x.J);
  double t1, d1, t2, d2;
  measure(up, x.v0, x.a0, t1, d1);
  measure(down, vc, 0.0, t2, d2);
  const double cruise = (x.pf - x.p0 - d1 - d2) / vc;
  if (cruise > 0.0) {
    up.add(0.0, cruise);
    up.append(down);
    const double before = best.duration;
    consider(up, x, best, scratch);
    return best.duration < before;
  }
  if (cruise >= -1e-12 * std::max(1.0, std::abs(x.pf - x.p0) / x.V)) {
    up.append(down);
    consider(up, x, best, scratch);
  }
  return false;
}

void cruise_less(const Axis& x, double d, Best& best, AxisProfile& scratch) {
  // The cruise-less families, mirrored into direction +1 and normalised.
  const double vs = x.A * x.A / x.J, ps = vs * x.A / x.J;
  const double a0 = d * x.a0 / x.A, af = d * x.af / x.A;
  const double v0 = d * x.v0 / vs, vf = d * x.vf / vs;
  const double dv = vf - v0, dp = d * (x.pf - x.p0) / ps;
  const double a02 = a0 * a0, af2 = af * af;
  double c[5];
  const Unit u{a0, af, v0, vf, dv, dp, dv + a02 / 2.0 - af2 / 2.0};
  // ACC0_ACC1: a1 = 1, a5 = −1; t6 = t2 + (v0 − vf) − a0²/2 + af²/2, a quadratic in t2.
  {
    c[0] = a02 * a02 / 8.0 + a02 * a0 / 3.0 - a0 * v0 - af2 * af2 / 8.0 - af2 * af / 3.0 + af * dv + af * v0 - dp -
           dv * dv / 2.0 - dv * v0 + 4.0 * v0 + dv * af2 / 2.0 + dv / 2.0 - a02 * v0 / 2.0 - 7.0 / 4.0 * a02 +
           af2 * v0 / 2.0 - af2 / 4.0 + 2.0;
    c[1] = 2.0 * v0 - a02 + 3.0;
    c[2] = 1.0;
    const double hi = std::max(1.0, std::abs(c[1]) + std::sqrt(std::abs(c[0])) + 1.0);
    consider_family(Family::Acc0Acc1, c, 2, 0.0, hi, u, d, x, best, scratch);
  }
  // ACC0: a1 = 1, no second plateau; quartic in a5, t2 = −1 + dv + a0²/2 + a5² − af²/2 = a5² − (1 − K),
  // which needs K ≥ 0 as |a5| ≤ 1 (and ACC1 below the opposite): at most one of them is solved.
  if (u.K >= -1e-9) {
    c[0] = -a02 * a02 / 8.0 + a02 * a0 / 3.0 - a0 * v0 + af2 * af2 / 8.0 - af2 * af / 3.0 + af * dv + af * v0 - dp +
           dv * dv / 2.0 + dv * v0 + v0 * a02 / 2.0 - v0 * af2 / 2.0 + v0 - dv * af2 / 2.0 + dv / 2.0 - a02 / 4.0 -
           af2 / 4.0;
    c[1] = -2.0 * dv - 2.0 * v0 + af2;
    c[2] = dv + v0 - af2 / 2.0 + 0.5;
    c[3] = -1.0;
    c[4] = 0.5;
    consider_family(Family::Acc0, c, 4, -1.0, std::min(1.0, af), u, d, x, best, scratch);
  }
  // ACC1: a5 = −1, no first plateau; quartic in a1, t6 = −1 − dv − a0²/2 + a1² + af²/2 = a1² − (1 + K).
  if (u.K <= 1e-9) {
    c[0] = a02 * a02 / 8.0 + a02 * a0 / 3.0 - a0 * v0 - af2 * af2 / 8.0 - af2 * af / 3.0 + af * dv + af * v0 - dp -
           dv * dv / 2.0 - dv * v0 + dv * af2 / 2.0 + dv / 2.0 + v0 * af2 / 2.0 - v0 * a02 / 2.0 + v0 - a02 / 4.0 -
           af2 / 4.0;
    c[1] = 2.0 * v0 - a02;
    c[2] = v0 - a02 / 2.0 + 0.5;
    c[3] = 1.0;
    c[4] = 0.5;
    consider_family(Family::Acc1, c, 4, std::max(-1.0, a0), 1.0, u, d, x, best, scratch);
  }
  // NONE: no plateau; a5² = a1² − K from the velocity, and the position's a5-odd part squared
  // away: a quartic in a1. Both signs of a5 are tried (the squaring lost which one holds).
  {
    const double K = dv + a02 / 2.0 - af2 / 2.0;
    const double K2 = K * K;
    const double a03 = a02 * a0, af3 = af2 * af, a04 = a02 * a02, af4 = af2 * af2, v02 = v0 * v0;
    c[0] = K2 * K + K * a04 - 4.0 * K * a02 * v0 + 2.0 * K * af2 * v0 - K * a02 * af2 + K * af4 / 3.0 +
           4.0 * K * v02 + a04 * a02 / 9.0 - 2.0 * a0 * af * v02 - a0 * v0 * af3 / 3.0 + 2.0 * a0 * dp * v0 +
           af4 * af2 / 36.0 + 5.0 / 3.0 * af * v0 * a03 - af * a04 * a0 / 3.0 - 2.0 * af * dp * v0 + dp * dp -
           2.0 / 3.0 * dp * a03 - dp * af3 / 3.0 + dp * af * a02 - 2.0 / 3.0 * v0 * a04 - v0 * a02 * af2 +
           v0 * af4 / 3.0 + a04 * af2 / 4.0 - 2.0 * dp * K * af + a03 * af3 / 9.0 + 2.0 / 3.0 * a03 * K * af -
           a02 * af4 / 6.0 + a02 * v02 - 2.0 * a02 * K2 - 2.0 * a0 * v0 * K * af + af2 * v02 + af2 * K2 +
           4.0 * v0 * K2;
    c[1] = 4.0 * K * af * v0 - 2.0 * K * af * a02 - 4.0 * a0 * v02 + af * a04 + 4.0 * af * v02 + 2.0 * dp * a02 -
           4.0 * dp * v0 + 10.0 / 3.0 * v0 * a03 + 2.0 / 3.0 * v0 * af3 - 2.0 / 3.0 * a04 * a0 - af3 * a02 / 3.0 -
           4.0 * v0 * af * a02;
    c[2] = K2;
    c[3] = 2.0 * af * v0 - 2.0 * dp + 2.0 / 3.0 * a03 + af3 / 3.0 - af * a02 - 2.0 * a0 * v0 + 2.0 * K * af;
    c[4] = -K;
    consider_family(Family::NoneBelow, c, 4, std::max(-1.0, a0), 1.0, u, d, x, best, scratch, Family::NoneAbove);
  }
}

}  // namespace

// The time-optimal profile of one axis (whose start is within its limits); false if none was
// found (a numerical failure: there always is one).
bool time_optimal(const Axis& x, Best& best, AxisProfile& scratch) {
  best.duration = std::numeric_limits<double>::infinity();
  // Already there (to the end tolerance): the empty profile.
  Phases none;
  consider(none, x, best, scratch);
  if (best.duration == 0.0) return true;
  // The fastest change of (v, a) alone, when it happens to end at the target position: the lower
  // bound of every profile, and the edge of several families at once.
  consider(velocity_ramp(x.v0, x.a0, x.vf, x.af, x.A, x.J), x, best, scratch);
  if (cruise_at_limit(x, 1.0, best, scratch) || cruise_at_limit(x, -1.0, best, scratch)) return true;
  cruise_less(x, 1.0, best, scratch);
  cruise_less(x, -1.0, best, scratch);
  return best.duration < std::numeric_limits<double>::infinity();
}

}  // namespace chasles::motion::detail
