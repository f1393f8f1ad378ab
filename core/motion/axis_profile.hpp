// The one-axis pieces the online generator (online_generator.hpp) is built from, shared by its
// three sources: an axis's problem, a profile as a list of constant-jerk phases laid out by the exact
// cubic, the check that a laid-out profile reaches its target within the limits, and the velocity
// ramp every profile is made of. Here as inline functions, because the searches of both steps call
// them in their innermost loops (a call per candidate); internal, not installed.
// time_optimal.cpp solves step 1 (an axis's time-optimal profile), fixed_duration.cpp step 2 (a
// profile of a given duration); online_generator.cpp holds the class that runs them per axis.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/motion/online_generator.hpp"

namespace chasles::motion::detail {

// One axis's problem: from (p0, v0, a0) to (pf, vf, af) within v_max, a_max, j_max.
struct Axis {
  double p0, v0, a0, pf, vf, af;
  double V, A, J;
};

// How far a profile may end from its target and still count as reaching it, and how far past a
// limit a profile may go (round-off of the durations; the tests ask 1e-8 and 1e-9 relative).
inline constexpr double kEndTolerance = 1e-9;
inline constexpr double kLimitTolerance = 1e-11;

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
inline void lay_out(const Phases& phases, double p, double v, double a, AxisProfile& out) {
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
inline bool within_limits_and_reaches(const AxisProfile& pr, const Axis& x) {
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

inline Phases velocity_ramp(double v0, double a0, double v1, double a1, double A, double J) {
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

// The fastest candidate so far of a time-optimal search, with its duration.
struct Best {
  double duration = std::numeric_limits<double>::infinity();
  AxisProfile profile;
};

/// Step 1: the time-optimal profile of one axis whose start is within its limits, into best
/// (scratch: work space); false if none was found (a numerical failure: there always is one).
bool time_optimal(const Axis& x, Best& best, AxisProfile& scratch);

/// Step 2: a profile of exactly duration T ≥ the axis's minimal one, into out. fixed_duration
/// tries a cruise at a = 0 between two ramps, two_ramps two ramps meeting at a ≠ 0, reduced_jerk
/// the time-optimal profile under a lower jerk (expensive, rare); each returns false if it finds none.
bool fixed_duration(const Axis& x, double T, AxisProfile& out);
bool two_ramps(const Axis& x, double T, AxisProfile& out);
bool reduced_jerk(const Axis& x, double T, AxisProfile& out, Best& best, AxisProfile& scratch);

}  // namespace chasles::motion::detail
