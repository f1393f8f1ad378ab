// The online generator's class (online_generator.hpp): the input checks and refusals, the brake
// back within the limits, the two steps run axis by axis — each axis's minimal duration
// (time_optimal.cpp), then every axis at the common duration (fixed_duration.cpp) with the search
// for a duration all of them can reach — the velocity interface, and sampling. What is here runs
// once per axis and plan; the solvers' inner loops are in those two files, their shared one-axis
// pieces inline in axis_profile.hpp.
#include "core/motion/online_generator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "core/error.hpp"
#include "core/motion/axis_profile.hpp"

namespace chasles::motion {

using detail::advance;
using detail::Axis;
using detail::Best;
using detail::lay_out;
using detail::Phases;
using detail::velocity_ramp;

namespace {

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
    if (!detail::time_optimal(x, best, fastest)) {
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
      if (!detail::fixed_duration(x, duration - t_brake, out) && !detail::two_ramps(x, duration - t_brake, out) &&
          !detail::reduced_jerk(x, duration - t_brake, out, best, scratch)) {
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