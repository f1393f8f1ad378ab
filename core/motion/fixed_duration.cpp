// Step 2 of the online generator: a profile of one axis of exactly a given duration, longer than
// its minimal one, so that the axes of a time-synchronised plan arrive together. Three searches, each
// tried when the one before finds nothing: a cruise at a = 0 between two ramps (fixed_duration), two
// ramps meeting at a ≠ 0 (two_ramps), the time-optimal profile under a lower jerk (reduced_jerk).
// Apart from step 1 (time_optimal.cpp) because these are bracketing searches over one unknown, not
// closed forms; they share the Illinois root finder below, which step 1 does not use.
#include <algorithm>
#include <cmath>

#include "core/motion/axis_profile.hpp"

namespace chasles::motion::detail {
namespace {

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

}  // namespace

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

namespace {

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

}  // namespace

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

}  // namespace chasles::motion::detail
