#include "core/motion/online_generator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "core/error.hpp"

namespace chasles::motion {
namespace {

// One axis's problem: from (p0, v0, a0) to (pf, vf, af) within v_max, a_max, j_max.
struct Axis {
  double p0, v0, a0, pf, vf, af;
  double V, A, J;
};

// How far a profile may end from its target and still count as reaching it, and how far past a
// limit a profile may go (round-off of the durations; the tests ask 1e-8 and 1e-9 relative).
constexpr double kEndTolerance = 1e-9;
constexpr double kLimitTolerance = 1e-11;

// A short list of phases of constant jerk, before they are laid out into an AxisProfile.
struct Phases {
  int n = 0;
  double j[AxisProfile::kMaxPhases];
  double t[AxisProfile::kMaxPhases];
  void add(double jerk, double duration) {
    if (duration > 0.0) {
      j[n] = jerk;
      t[n] = duration;
      ++n;
    }
  }
  void append(const Phases& other) {
    for (int k = 0; k < other.n; ++k) add(other.j[k], other.t[k]);
  }
};

// The state after `t` of constant jerk from (p, v, a): the exact cubic.
inline void advance(double& p, double& v, double& a, double j, double t) {
  p += t * (v + t * (a / 2.0 + t * j / 6.0));
  v += t * (a + t * j / 2.0);
  a += t * j;
}

// Lays the phases out from (p, v, a), each phase's start state by the exact cubic of the one
// before, so that sampling never integrates.
void lay_out(const Phases& phases, double p, double v, double a, AxisProfile& out) {
  out.phases = phases.n;
  out.p[0] = p;
  out.v[0] = v;
  out.a[0] = a;
  out.start[0] = 0.0;
  for (int k = 0; k < phases.n; ++k) {
    out.t[k] = phases.t[k];
    out.j[k] = phases.j[k];
    advance(p, v, a, phases.j[k], phases.t[k]);
    out.p[k + 1] = p;
    out.v[k + 1] = v;
    out.a[k + 1] = a;
    out.start[k + 1] = out.start[k] + phases.t[k];
  }
}

// Whether the laid-out profile reaches the axis's target and stays within its limits: |a| at
// every phase boundary (a is linear in a phase) and |v| at the boundaries and where a crosses 0
// inside a phase (v's only interior extremum).
bool within_limits_and_reaches(const AxisProfile& pr, const Axis& x) {
  const double v_tol = x.V * (1.0 + kLimitTolerance) + 1e-12;
  const double a_tol = x.A * (1.0 + kLimitTolerance) + 1e-12;
  for (int k = 0; k <= pr.phases; ++k) {
    if (std::abs(pr.a[k]) > a_tol || std::abs(pr.v[k]) > v_tol) return false;
  }
  for (int k = 0; k < pr.phases; ++k) {
    const double j = pr.j[k];
    if (j == 0.0) continue;
    const double tz = -pr.a[k] / j;  // when a crosses 0
    if (tz > 0.0 && tz < pr.t[k]) {
      const double v_extreme = pr.v[k] + pr.a[k] * tz + j * tz * tz / 2.0;
      if (std::abs(v_extreme) > v_tol) return false;
    }
  }
  const int n = pr.phases;
  const double p_scale = std::max(1.0, std::abs(x.pf));
  return std::abs(pr.p[n] - x.pf) <= kEndTolerance * p_scale && std::abs(pr.v[n] - x.vf) <= kEndTolerance &&
         std::abs(pr.a[n] - x.af) <= kEndTolerance * std::max(1.0, x.A * 1e-3);
}

// ---------------------------------------------------------------------------------------------
// Velocity ramps: the time-optimal change of (v, a) alone, the building block of every profile.

// The fastest jerk-limited change from (v0, a0) to (v1, a1) with |a| ≤ A: jerk s·J up to a peak
// acceleration s·ap, held there only if that peak is the limit A, then −s·J down to a1. s is
// chosen so that the velocity change asks for more (s = +1) or less (s = −1) than moving a
// straight from a0 to a1 gives.
// The ramp's three phases: jerk s·J for t1, 0 for hold, −s·J for t3.
struct Ramp {
  double s, t1, hold, t3;
};
inline Ramp ramp_of(double v0, double a0, double v1, double a1, double A, double J) {
  const double straight = (a0 + a1) / 2.0 * std::abs(a1 - a0) / J;  // (a1² − a0²)/(2J) in the ramp's direction
  const double s = (v1 - v0 >= straight) ? 1.0 : -1.0;
  // In the mirrored frame (s = +1): the peak ap ≥ max(b0, b1) from Δw = (2ap² − b0² − b1²)/(2J).
  const double b0 = s * a0, b1 = s * a1, dw = s * (v1 - v0);
  double ap = std::sqrt(std::max(0.0, J * dw + (b0 * b0 + b1 * b1) / 2.0));
  double hold = 0.0;
  if (ap > A) {
    ap = A;
    hold = (dw - (2.0 * A * A - b0 * b0 - b1 * b1) / (2.0 * J)) / A;
  }
  return {s, std::max(0.0, (ap - b0) / J), std::max(0.0, hold), std::max(0.0, (ap - b1) / J)};
}

Phases velocity_ramp(double v0, double a0, double v1, double a1, double A, double J) {
  const Ramp r = ramp_of(v0, a0, v1, a1, A, J);
  Phases out;
  out.add(r.s * J, r.t1);
  out.add(0.0, r.hold);
  out.add(-r.s * J, r.t3);
  return out;
}

// The duration and displacement of velocity_ramp(v0, a0, v1, a1, A, J), without laying its phases
// out: the inner loop of the fixed-duration search.
inline void ramp_time_distance(double v0, double a0, double v1, double a1, double A, double J, double& duration,
                               double& distance) {
  const Ramp r = ramp_of(v0, a0, v1, a1, A, J);
  double p = 0.0, v = v0, a = a0;
  advance(p, v, a, r.s * J, r.t1);
  advance(p, v, a, 0.0, r.hold);
  advance(p, v, a, -r.s * J, r.t3);
  duration = r.t1 + r.hold + r.t3;
  distance = p;
}

// Duration and displacement of phases started at velocity v and acceleration a.
inline void measure(const Phases& ph, double v, double a, double& duration, double& distance) {
  double p = 0.0;
  duration = 0.0;
  for (int k = 0; k < ph.n; ++k) {
    advance(p, v, a, ph.j[k], ph.t[k]);
    duration += ph.t[k];
  }
  distance = p;
}

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

struct Best {
  double duration = std::numeric_limits<double>::infinity();
  AxisProfile profile;
};

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

// ---------------------------------------------------------------------------------------------
// Step 2: a profile of exactly duration T: a ramp to a cruise velocity vc with a = 0, the cruise
// for what time is left, a ramp to the target. Both ramps are time-optimal for their velocity
// change, so each takes its own shape (UDDU, UDUD and their mirror images as vc moves); the
// position reached is continuous in vc, and vc is found by bracketing its root. The ramps' total
// time is smallest at one of two kinks (vc where a ramp is a single jerk phase), which are
// sampled with a uniform grid over [−V, V].

struct CruisePoint {
  double vc, cruise, miss;  // cruise < 0: the ramps alone take longer than T
};

CruisePoint cruise_point(const Axis& x, double T, double vc) {
  double t1, d1, t2, d2;
  ramp_time_distance(x.v0, x.a0, vc, 0.0, x.A, x.J, t1, d1);
  ramp_time_distance(vc, 0.0, x.vf, x.af, x.A, x.J, t2, d2);
  const double cruise = T - t1 - t2;
  return {vc, cruise, x.p0 + d1 + d2 + vc * std::max(0.0, cruise) - x.pf};
}

bool build_cruise(const Axis& x, double T, double vc, AxisProfile& out) {
  Phases ph = velocity_ramp(x.v0, x.a0, vc, 0.0, x.A, x.J);
  double t1, d1, t2, d2;
  const Phases down = velocity_ramp(vc, 0.0, x.vf, x.af, x.A, x.J);
  measure(ph, x.v0, x.a0, t1, d1);
  measure(down, vc, 0.0, t2, d2);
  ph.add(0.0, std::max(0.0, T - t1 - t2));
  ph.append(down);
  lay_out(ph, x.p0, x.v0, x.a0, out);
  return within_limits_and_reaches(out, x) && std::abs(out.duration() - T) <= 1e-12 * std::max(1.0, T);
}

// Where f changes sign between lo and hi (f(lo), f(hi) of opposite signs, or one of them 0), by the
// Illinois variant of regula falsi (superlinear, and never leaves the bracket); f returns false
// where it cannot be evaluated, which ends the search (false).
template <typename F>
bool sign_change(F f, double lo, double f_lo, double hi, double f_hi, double tolerance, double& root) {
  int side = 0;
  for (int it = 0; it < 100; ++it) {
    if (f_lo == 0.0 || std::abs(hi - lo) <= tolerance) {
      root = f_lo == 0.0 ? lo : (std::abs(f_lo) < std::abs(f_hi) ? lo : hi);
      return true;
    }
    if (f_hi == 0.0) {
      root = hi;
      return true;
    }
    double x = hi - f_hi * (hi - lo) / (f_hi - f_lo);
    if (!(x > std::min(lo, hi) && x < std::max(lo, hi))) x = 0.5 * (lo + hi);
    double fx;
    if (!f(x, fx)) return false;
    if ((fx < 0.0) == (f_hi < 0.0)) {
      hi = x;
      f_hi = fx;
      if (side == -1) f_lo /= 2.0;
      side = -1;
    } else {
      lo = x;
      f_lo = fx;
      if (side == 1) f_hi /= 2.0;
      side = 1;
    }
  }
  root = std::abs(f_lo) < std::abs(f_hi) ? lo : hi;
  return true;
}

// The root of miss(vc) between two feasible points of opposite sign.
bool solve_between(const Axis& x, double T, const CruisePoint& lo, const CruisePoint& hi, AxisProfile& out) {
  const auto miss = [&](double vc, double& value) {
    const CruisePoint point = cruise_point(x, T, vc);
    value = point.miss;
    return point.cruise >= 0.0;  // the feasible set is not an interval here: give this bracket up
  };
  double vc;
  return sign_change(miss, lo.vc, lo.miss, hi.vc, hi.miss, 1e-15 * x.V, vc) && build_cruise(x, T, vc, out);
}

// The edge of the feasible set (cruise = 0) between a feasible and an infeasible point, on the
// feasible side, by Illinois steps that keep one point on each side.
CruisePoint edge_between(const Axis& x, double T, CruisePoint in, CruisePoint out) {
  double f_in = in.cruise, f_out = out.cruise;
  int side = 0;
  for (int it = 0; it < 100 && std::abs(in.vc - out.vc) > 1e-15 * x.V && in.cruise > 0.0; ++it) {
    double vc = out.vc - f_out * (out.vc - in.vc) / (f_out - f_in);
    if (!(vc > std::min(in.vc, out.vc) && vc < std::max(in.vc, out.vc))) vc = 0.5 * (in.vc + out.vc);
    const CruisePoint p = cruise_point(x, T, vc);
    if (p.cruise >= 0.0) {
      in = p;
      f_in = p.cruise;
      if (side == 1) f_out /= 2.0;
      side = 1;
    } else {
      out = p;
      f_out = p.cruise;
      if (side == -1) f_in /= 2.0;
      side = -1;
    }
  }
  return in;
}

// A cruise profile of duration T over the sample points vs (sorted): between each two, the edge
// of the feasible set if one of them is outside it, then the root of the miss if it changes sign.
bool cruise_over(const Axis& x, double T, const double* vs, int n, AxisProfile& out) {
  CruisePoint prev = cruise_point(x, T, vs[0]);
  if (prev.cruise >= 0.0 && prev.miss == 0.0 && build_cruise(x, T, prev.vc, out)) return true;
  for (int k = 1; k < n; ++k) {
    const CruisePoint cur = cruise_point(x, T, vs[k]);
    // The miss is continuous across the feasible set's edge (no cruise there, and none counted
    // beyond it): when it changes sign, its root is tried first, without finding the edge, and
    // kept if it is feasible.
    if ((prev.cruise >= 0.0 || cur.cruise >= 0.0) && (prev.miss < 0.0) != (cur.miss < 0.0)) {
      const auto miss = [&](double vc, double& value) {
        value = cruise_point(x, T, vc).miss;
        return true;
      };
      double vc;
      if (sign_change(miss, prev.vc, prev.miss, cur.vc, cur.miss, 1e-15 * x.V, vc) &&
          cruise_point(x, T, vc).cruise >= 0.0 && build_cruise(x, T, vc, out)) {
        return true;
      }
    }
    CruisePoint a = prev, b = cur;
    if ((a.cruise >= 0.0) != (b.cruise >= 0.0)) {
      // One side is infeasible: move it to the edge.
      if (a.cruise < 0.0) {
        a = edge_between(x, T, b, a);
      } else {
        b = edge_between(x, T, a, b);
      }
    }
    if (a.cruise >= 0.0 && b.cruise >= 0.0) {
      if (a.miss == 0.0 && build_cruise(x, T, a.vc, out)) return true;
      if (b.miss == 0.0 && build_cruise(x, T, b.vc, out)) return true;
      if ((a.miss < 0.0) != (b.miss < 0.0) && solve_between(x, T, a, b, out)) return true;
    }
    prev = cur;
  }
  return false;
}

bool fixed_duration(const Axis& x, double T, AxisProfile& out) {
  // The kinks: the velocity a ramp reaches by one jerk phase to or from a = 0.
  const double k1 = std::clamp(x.v0 + x.a0 * std::abs(x.a0) / (2.0 * x.J), -x.V, x.V);
  const double k2 = std::clamp(x.vf - x.af * std::abs(x.af) / (2.0 * x.J), -x.V, x.V);
  // First the ends and the kinks alone (the feasible set is one or two intervals about the kinks,
  // and the miss is monotone on each in all but rare cases), then a grid over [−V, V] with them.
  double vs[4 + 25] = {-x.V, std::min(k1, k2), std::max(k1, k2), x.V};
  if (cruise_over(x, T, vs, 4, out)) return true;
  int n = 0;
  for (int k = 0; k <= 24; ++k) vs[n++] = x.V * (-1.0 + 2.0 * k / 24);
  vs[n++] = k1;
  vs[n++] = k2;
  std::sort(vs, vs + n);
  return cruise_over(x, T, vs, n, out);
}

// Profiles of duration T made of two velocity ramps meeting at a junction (vm, am) with no
// cruise between them: the fixed-duration profiles whose acceleration does not pass through 0 where
// the velocity turns (Ruckig's step-2 UDUD and UDDU without a velocity plateau, e.g. jerk +, −, +,
// − with a junction at a > 0), which the cruise family misses. For a junction acceleration am the
// ramps' total time is V-shaped about two kinks in vm (decreasing left of both, increasing right
// of both, concave between, with a jump at a kink where a must dip through 0 and back), so the
// junction velocities of duration T are found region by region
// (left, between, right); the position each one ends at is then a function of am on each region,
// whose sign change over a grid of am is refined by Illinois steps.
struct Junction {
  bool found;
  double vm, miss;
};

inline double ramps_time(const Axis& x, double vm, double am, double& distance) {
  double t1, d1, t2, d2;
  ramp_time_distance(x.v0, x.a0, vm, am, x.A, x.J, t1, d1);
  ramp_time_distance(vm, am, x.vf, x.af, x.A, x.J, t2, d2);
  distance = d1 + d2;
  return t1 + t2;
}

// The junction velocities of duration T in each region: 0 left of both kinks, 1 and 2 between
// them left and right of where the (concave) total time peaks, 3 right of both kinks.
void junctions(const Axis& x, double T, double am, Junction* out) {
  const double k1 = x.v0 + (x.a0 + am) / 2.0 * std::abs(am - x.a0) / x.J;
  const double k2 = x.vf - (am + x.af) / 2.0 * std::abs(x.af - am) / x.J;
  const double lo_k = std::clamp(std::min(k1, k2), -x.V, x.V), hi_k = std::clamp(std::max(k1, k2), -x.V, x.V);
  double d;
  // The peak of the concave total time between the kinks, by golden-section search (it only
  // splits the regions: no need of full precision).
  double a = lo_k, b = hi_k;
  constexpr double g = 0.6180339887498949;
  double c = b - g * (b - a), e = a + g * (b - a);
  double fc = ramps_time(x, c, am, d), fe = ramps_time(x, e, am, d);
  for (int it = 0; it < 60 && b - a > 1e-9 * x.V; ++it) {
    if (fc > fe) {
      b = e;
      e = c;
      fe = fc;
      c = b - g * (b - a);
      fc = ramps_time(x, c, am, d);
    } else {
      a = c;
      c = e;
      fc = fe;
      e = a + g * (b - a);
      fe = ramps_time(x, e, am, d);
    }
  }
  const double peak = 0.5 * (a + b);
  // A ramp's time jumps at its kink when the straight move does not change the acceleration's
  // sign (a0, am > 0 and a velocity a hair below the straight one: a must dip below 0 and come
  // back), so the regions stop just short of the kinks, each with its one-sided value.
  const double off = 1e-12 * x.V;
  const double starts[4] = {-x.V, lo_k + off, peak, hi_k + off};
  const double ends[4] = {lo_k - off, peak, hi_k - off, x.V};
  const auto excess = [&](double vm, double& value) {
    value = ramps_time(x, vm, am, d) - T;
    return true;
  };
  for (int region = 0; region < 4; ++region) {
    out[region] = {false, 0.0, 0.0};
    const double lo = starts[region], hi = ends[region];
    if (!(hi > lo)) continue;
    double f_lo, f_hi, vm;
    excess(lo, f_lo);
    excess(hi, f_hi);
    if ((f_lo < 0.0) == (f_hi < 0.0)) continue;
    if (!sign_change(excess, lo, f_lo, hi, f_hi, 1e-15 * x.V, vm)) continue;
    ramps_time(x, vm, am, d);
    out[region] = {true, vm, x.p0 + d - x.pf};
  }
}

Junction junction(const Axis& x, double T, double am, int region) {
  Junction all[4];
  junctions(x, T, am, all);
  return all[region];
}

bool build_junction(const Axis& x, double T, double vm, double am, AxisProfile& out) {
  Phases ph = velocity_ramp(x.v0, x.a0, vm, am, x.A, x.J);
  ph.append(velocity_ramp(vm, am, x.vf, x.af, x.A, x.J));
  lay_out(ph, x.p0, x.v0, x.a0, out);
  return within_limits_and_reaches(out, x) && std::abs(out.duration() - T) <= 1e-12 * std::max(1.0, T);
}

bool two_ramps(const Axis& x, double T, AxisProfile& out) {
  constexpr int kGrid = 48;
  // Only junction accelerations the jerk can reach and leave in T: |am − a0| + |af − am| ≤ J T.
  const double am_lo = std::max(-x.A, (x.a0 + x.af - x.J * T) / 2.0);
  const double am_hi = std::min(x.A, (x.a0 + x.af + x.J * T) / 2.0);
  if (!(am_hi > am_lo)) return false;
  Junction prev[4], cur[4];
  double am_prev = am_lo;
  junctions(x, T, am_prev, prev);
  // The root of the miss in am on one region, between two grid points where it changes sign.
  const auto solve = [&](int region, double lo, double f_lo, double hi, double f_hi) {
    double vm = 0.0;
    const auto miss = [&](double at, double& value) {
      const Junction j = junction(x, T, at, region);
      value = j.miss;
      vm = j.vm;
      return j.found;
    };
    double am_root, ignored;
    return sign_change(miss, lo, f_lo, hi, f_hi, 1e-15 * (am_hi - am_lo), am_root) && miss(am_root, ignored) &&
           build_junction(x, T, vm, am_root, out);
  };
  for (int k = 1; k <= kGrid; ++k) {
    const double am = am_lo + (am_hi - am_lo) * k / kGrid;
    junctions(x, T, am, cur);
    for (int region = 0; region < 4; ++region) {
      const Junction& p = prev[region];
      const Junction& c = cur[region];
      if (p.found && c.found) {
        if ((p.miss < 0.0) != (c.miss < 0.0) && solve(region, am_prev, p.miss, am, c.miss)) return true;
      } else if (p.found != c.found) {
        // The region ends between the two: find its last point (bisection on whether it exists)
        // and look for the root between it and the grid point where it exists.
        double in = p.found ? am_prev : am, gone = p.found ? am : am_prev;
        Junction last = p.found ? p : c;
        for (int it = 0; it < 50; ++it) {
          const double mid = 0.5 * (in + gone);
          const Junction j = junction(x, T, mid, region);
          if (j.found) {
            in = mid;
            last = j;
          } else {
            gone = mid;
          }
        }
        const Junction& known = p.found ? p : c;
        const double am_known = p.found ? am_prev : am;
        if ((known.miss < 0.0) != (last.miss < 0.0) && solve(region, am_known, known.miss, in, last.miss)) return true;
      }
    }
    std::copy(cur, cur + 4, prev);
    am_prev = am;
  }
  return false;
}

// When no cruise profile has duration T (T in a gap of that family, e.g. just above a minimal
// duration whose profile never has a = 0 between its acceleration extremes): the time-optimal
// profile under a lower jerk limit J' ≤ J whose minimal duration is exactly T. The minimal duration
// grows as J' falls (fewer motions are allowed), so J' is found by Illinois steps on log J'.
// Expensive (a time-optimal solve per step) but rare.
bool reduced_jerk(const Axis& x, double T, AxisProfile& out, Best& best, AxisProfile& scratch) {
  Axis y = x;
  const auto excess = [&](double log_j, double& value) {
    y.J = std::exp(log_j);
    if (!time_optimal(y, best, scratch)) return false;
    value = best.duration - T;
    return true;
  };
  double hi = std::log(x.J), f_hi;
  if (!excess(hi, f_hi) || f_hi > 0.0) return false;
  double lo = hi, f_lo = f_hi;
  for (int k = 0; k < 40 && f_lo <= 0.0; ++k) {
    hi = lo;
    f_hi = f_lo;
    lo -= 1.0;
    if (!excess(lo, f_lo)) return false;
  }
  if (f_lo <= 0.0) return false;
  double log_j;
  if (!sign_change(excess, lo, f_lo, hi, f_hi, 1e-15, log_j)) return false;
  double f;
  if (!excess(log_j, f) || std::abs(f) > 1e-12 * std::max(1.0, T)) return false;
  out = best.profile;
  return true;
}

// ---------------------------------------------------------------------------------------------
// The brake pre-trajectory: from a state outside the limits (|a| > A, |v| > V, or a velocity that
// will pass V before a can be brought to 0) back within them, with full jerk: first |a| down to A,
// then the velocity brought back to ±V at a jerk toward the inside, holding −A (or +A) if it gets
// there. The limits are exceeded during the brake; that cannot be helped.

void brake(Axis& x, Phases& ph) {
  double p = x.p0, v = x.v0, a = x.a0;
  const auto step = [&](double j, double t) {
    if (t <= 0.0) return;
    ph.add(j, t);
    advance(p, v, a, j, t);
  };
  if (a > x.A) step(-x.J, (a - x.A) / x.J);
  if (a < -x.A) step(x.J, (-x.A - a) / x.J);
  for (const double d : {1.0, -1.0}) {
    // In direction d: is v above V now, or bound to pass it while a is brought to 0?
    const double w = d * v, b = d * a;
    const double w_peak = b > 0.0 ? w + b * b / (2.0 * x.J) : w;
    if (w_peak <= x.V) continue;
    // Jerk −d·J until w = V on the way down (w(t) = w + b t − J t²/2), or until a = −d·A first.
    const double t_v = (b + std::sqrt(b * b + 2.0 * x.J * (w - x.V))) / x.J;
    const double t_a = (b + x.A) / x.J;
    if (t_v <= t_a) {
      step(-d * x.J, t_v);
    } else {
      step(-d * x.J, t_a);
      step(0.0, (d * v - x.V) / x.A);
    }
    a = std::clamp(a, -x.A, x.A);
    v = std::clamp(v, -x.V, x.V);
  }
  x.p0 = p;
  x.v0 = v;
  x.a0 = a;
}

}  // namespace

OnlineGenerator::OnlineGenerator(int dof)
    : dof_(dof),
      profiles_(static_cast<std::size_t>(std::max(dof, 0))),
      fastest_(static_cast<std::size_t>(std::max(dof, 0))),
      minimal_(static_cast<std::size_t>(std::max(dof, 0)), 0.0) {
  if (dof < 1) throw ArgumentError("OnlineGenerator: the number of axes must be at least 1, not " + std::to_string(dof));
}

namespace {

// Formats a refusal into the generator's fixed buffer (no allocation) and returns false.
template <std::size_t N, typename... Args>
bool refuse(std::array<char, N>& reason, const char* format, Args... args) {
  if constexpr (sizeof...(Args) == 0) {
    std::snprintf(reason.data(), N, "%s", format);
  } else {
    std::snprintf(reason.data(), N, format, args...);
  }
  return false;
}

}  // namespace

bool OnlineGenerator::valid_input(const KinematicState& current, const Limits& limits) {
  const Eigen::Index n = dof_;
  for (const Eigen::VectorXd* vec : {&current.p, &current.v, &current.a, &limits.velocity, &limits.acceleration,
                                      &limits.jerk}) {
    if (vec->size() != n) return refuse(reason_, "a state or limit vector has not one entry per axis (%d axes)", dof_);
  }
  for (int i = 0; i < dof_; ++i) {
    const double V = limits.velocity[i], A = limits.acceleration[i], J = limits.jerk[i];
    if (!(std::isfinite(V) && V > 0.0 && std::isfinite(A) && A > 0.0 && std::isfinite(J) && J > 0.0)) {
      return refuse(reason_, "axis %d: every limit must be finite and > 0 (one is %g)", i, !(V > 0.0) ? V : !(A > 0.0) ? A : J);
    }
    if (!(std::isfinite(current.p[i]) && std::isfinite(current.v[i]) && std::isfinite(current.a[i]))) {
      return refuse(reason_, "axis %d: the current state is not finite", i);
    }
  }
  return true;
}

bool OnlineGenerator::plan(const KinematicState& current, const KinematicState& target, const Limits& limits,
                           double min_duration, Synchronization synchronization) {
  if (!valid_input(current, limits)) return false;
  const Eigen::Index n = dof_;
  for (const Eigen::VectorXd* vec : {&target.p, &target.v, &target.a}) {
    if (vec->size() != n) return refuse(reason_, "a state or limit vector has not one entry per axis (%d axes)", dof_);
  }
  if (!std::isfinite(min_duration) || min_duration < 0.0) {
    return refuse(reason_, "min_duration must be finite and >= 0, not %g", min_duration);
  }
  for (int i = 0; i < dof_; ++i) {
    const double V = limits.velocity[i], A = limits.acceleration[i], J = limits.jerk[i];
    if (!(std::isfinite(target.p[i]) && std::isfinite(target.v[i]) && std::isfinite(target.a[i]))) {
      return refuse(reason_, "axis %d: the target state is not finite", i);
    }
    const double vf = target.v[i], af = target.a[i];
    if (std::abs(af) > A) return refuse(reason_, "axis %d: the target acceleration %g exceeds its limit", i, af);
    if (std::abs(vf) > V) return refuse(reason_, "axis %d: the target velocity %g exceeds its limit", i, vf);
    // A target with a ≠ 0 is reached with v still moving: coming from a = 0 at full jerk it had
    // v − a|a|/(2j) before, which must be within the limit for the target to be reachable within it.
    if (std::abs(vf - af * std::abs(af) / (2.0 * J)) > V * (1.0 + 1e-12)) {
      return refuse(reason_, "axis %d: the target velocity %g cannot be held within the velocity limit with its acceleration", i, vf);
    }
  }

  // Step 1: each axis's brake (if it starts outside its limits) and its time-optimal profile.
  double T = min_duration;
  Best best;
  for (int i = 0; i < dof_; ++i) {
    Axis x{current.p[i], current.v[i], current.a[i], target.p[i], target.v[i], target.a[i],
           limits.velocity[i], limits.acceleration[i], limits.jerk[i]};
    Phases brake_phases;
    brake(x, brake_phases);
    AxisProfile& fastest = fastest_[static_cast<std::size_t>(i)];
    if (!time_optimal(x, best, fastest)) {
      return refuse(reason_, "axis %d: no time-optimal profile found (a numerical failure)", i);
    }
    // The brake's phases first, then the profile's.
    Phases all = brake_phases;
    for (int k = 0; k < best.profile.phases; ++k) all.add(best.profile.j[k], best.profile.t[k]);
    lay_out(all, current.p[i], current.v[i], current.a[i], fastest);
    minimal_[static_cast<std::size_t>(i)] = fastest.duration();
    T = std::max(T, fastest.duration());
  }

  if (synchronization == Synchronization::kNone) {  // each axis on its own, as fast as it can
    for (std::size_t k = 0; k < profiles_.size(); ++k) profiles_[k] = fastest_[k];
    duration_ = T;
    reason_[0] = '\0';
    return true;
  }

  // Step 2: every axis at exactly T. An axis that cannot arrive at exactly T (a blocked interval
  // of its durations, or a duration its fixed-duration family cannot reach) raises T: first by
  // growing steps until every axis can, then by bisection back toward the lowest such T.
  AxisProfile scratch;
  const auto synchronise = [&](double duration) {
    for (int i = 0; i < dof_; ++i) {
      const std::size_t k = static_cast<std::size_t>(i);
      const AxisProfile& fastest = fastest_[k];
      if (duration - fastest.duration() <= 1e-12 * std::max(1.0, duration)) {
        profiles_[k] = fastest;
        continue;
      }
      Axis x{current.p[i], current.v[i], current.a[i], target.p[i], target.v[i], target.a[i],
             limits.velocity[i], limits.acceleration[i], limits.jerk[i]};
      Phases brake_phases;
      brake(x, brake_phases);
      double t_brake = 0.0;
      for (int m = 0; m < brake_phases.n; ++m) t_brake += brake_phases.t[m];
      AxisProfile& out = profiles_[k];
      if (!fixed_duration(x, duration - t_brake, out) && !two_ramps(x, duration - t_brake, out) &&
          !reduced_jerk(x, duration - t_brake, out, best, scratch)) {
        return false;
      }
      if (brake_phases.n > 0) {
        Phases all = brake_phases;
        for (int m = 0; m < out.phases; ++m) all.add(out.j[m], out.t[m]);
        lay_out(all, current.p[i], current.v[i], current.a[i], out);
      }
    }
    return true;
  };
  if (!synchronise(T)) {
    double lo = T, step = 1e-3 * std::max(T, 1e-3), hi = T + step;
    while (!synchronise(hi)) {
      lo = hi;
      step *= 2.0;
      hi = T + step;
      if (step > 1e6 * std::max(T, 1.0)) return refuse(reason_, "no common duration found for all axes (a numerical failure)");
    }
    for (int it = 0; it < 30; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (synchronise(mid)) {
        hi = mid;
      } else {
        lo = mid;
      }
    }
    synchronise(hi);
    T = hi;
  }
  duration_ = T;
  reason_[0] = '\0';
  return true;
}

namespace {

// The brake back within the limits, then the velocity ramp to vf at a = 0: one axis of
// plan_velocity, as phases from (x.p0, x.v0, x.a0) before the brake.
Phases velocity_phases(Axis x, double vf) {
  Phases phases;
  brake(x, phases);
  phases.append(velocity_ramp(x.v0, x.a0, vf, 0.0, x.A, x.J));
  return phases;
}

}  // namespace

double stop_position(double p, double v, double a, double V, double A, double J) {
  const Phases phases = velocity_phases({p, v, a, 0.0, 0.0, 0.0, V, A, J}, 0.0);
  for (int k = 0; k < phases.n; ++k) advance(p, v, a, phases.j[k], phases.t[k]);
  return p;
}

bool OnlineGenerator::plan_velocity(const KinematicState& current, const Eigen::VectorXd& target_velocity,
                                    const Limits& limits) {
  if (!valid_input(current, limits)) return false;
  if (target_velocity.size() != dof_) return refuse(reason_, "the target velocity has not one entry per axis (%d axes)", dof_);
  for (int i = 0; i < dof_; ++i) {
    if (!(std::abs(target_velocity[i]) <= limits.velocity[i])) {
      return refuse(reason_, "axis %d: the target velocity %g is not finite or exceeds its limit", i, target_velocity[i]);
    }
  }
  double T = 0.0;
  for (int i = 0; i < dof_; ++i) {
    const Axis x{current.p[i], current.v[i], current.a[i], 0.0, 0.0, 0.0, limits.velocity[i], limits.acceleration[i],
                 limits.jerk[i]};
    AxisProfile& profile = profiles_[static_cast<std::size_t>(i)];
    lay_out(velocity_phases(x, target_velocity[i]), x.p0, x.v0, x.a0, profile);
    minimal_[static_cast<std::size_t>(i)] = profile.duration();
    T = std::max(T, profile.duration());
  }
  duration_ = T;
  reason_[0] = '\0';
  return true;
}

void OnlineGenerator::at_time(double t, KinematicState& out) const {
  if (out.p.size() != dof_) out.p.resize(dof_);
  if (out.v.size() != dof_) out.v.resize(dof_);
  if (out.a.size() != dof_) out.a.resize(dof_);
  for (int i = 0; i < dof_; ++i) {
    const AxisProfile& pr = profiles_[static_cast<std::size_t>(i)];
    double p, v, a;
    if (t <= 0.0) {
      p = pr.p[0];
      v = pr.v[0];
      a = pr.a[0];
    } else {
      // The phase t falls in; past the axis's end, the end state moving on at constant a.
      int k = 0;
      while (k < pr.phases && t >= pr.start[k + 1]) ++k;
      p = pr.p[k];
      v = pr.v[k];
      a = pr.a[k];
      advance(p, v, a, k < pr.phases ? pr.j[k] : 0.0, t - pr.start[k]);
    }
    out.p[i] = p;
    out.v[i] = v;
    out.a[i] = a;
  }
}

}  // namespace chasles::motion
