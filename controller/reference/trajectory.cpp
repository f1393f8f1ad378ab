#include "controller/reference/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "controller/reference/goal.hpp"

namespace chasles::controller {
namespace {

// The largest factor a trajectory's times are scaled by to fit the limits.
constexpr double kMaxTimeScale = 1000.0;

// d s with three significant digits and at least two decimals (6.24, 40.43, 0.0123), rounded up
// or to nearest.
void format_duration(char (&out)[24], double d, bool up) {
  const int decimals = std::clamp(2 - static_cast<int>(std::floor(std::log10(d))), 2, 9);
  const double unit = std::pow(10.0, -decimals);
  std::snprintf(out, sizeof(out), "%.*f", decimals, up ? std::ceil(d / unit) * unit : d);
}

}  // namespace

TrajectoryMotion::TrajectoryMotion(int dof, const motion::MotionLimits& limits)
    : limits_(limits),
      spline_(dof),
      candidate_(dof),
      path_tolerance_(Eigen::VectorXd::Zero(dof)),
      goal_tolerance_(Eigen::VectorXd::Zero(dof)) {}

void TrajectoryMotion::reject(int64_t id, const char* why) {
  if (active()) return;
  progress_ = TrajectoryProgress{};
  progress_.id = id;
  progress_.outcome = TrajectoryProgress::kRejected;
  std::snprintf(progress_.message, sizeof(progress_.message), "%s", why);
}

bool TrajectoryMotion::check(const RobotModel& model, const motion::Waypoints& w, char (&why)[192]) {
  const auto refuse = [&](const char* format, auto... args) {
    std::snprintf(why, sizeof(why), format, args...);
    reject(w.id, why);
    return false;
  };
  const int n = model.dof();
  if (w.dof() != n) return refuse("sized for another arm");
  if (w.count < 1 || w.count > motion::Waypoints::kMaxPoints) {
    return refuse("%d waypoints; 1 to %d are taken", w.count, motion::Waypoints::kMaxPoints);
  }
  for (int k = 0; k < w.count; ++k) {
    const double before = k == 0 ? 0.0 : w.time(k - 1);
    if (!std::isfinite(w.time(k)) || !(w.time(k) > before)) {
      return refuse("waypoint %d: time %g s is not after %g s (times increase from > 0)", k, w.time(k), before);
    }
    for (int i = 0; i < n; ++i) {
      const char* name = model.joint(i).name.c_str();
      if (!std::isfinite(w.q(i, k)) || (w.has_velocities && !std::isfinite(w.qd(i, k))) ||
          (w.has_accelerations && !std::isfinite(w.qdd(i, k)))) {
        return refuse("waypoint %d, joint %s: a value that is not finite", k, name);
      }
      if (w.q(i, k) < limits_.lower(i) || w.q(i, k) > limits_.upper(i)) {
        return refuse("waypoint %d, joint %s: position %g outside [%g, %g], its limits less the margin", k, name,
                      w.q(i, k), limits_.lower(i), limits_.upper(i));
      }
    }
  }
  const int last = w.count - 1;
  if ((w.has_velocities && w.qd.col(last).cwiseAbs().maxCoeff() > 0.0) ||
      (w.has_accelerations && w.qdd.col(last).cwiseAbs().maxCoeff() > 0.0)) {
    return refuse("the last waypoint must be at rest (velocity and acceleration 0)");
  }
  if (!w.path_tolerance.allFinite() || !w.goal_tolerance.allFinite() || (w.path_tolerance.array() < 0.0).any() ||
      (w.goal_tolerance.array() < 0.0).any() || !(w.goal_time >= 0.0) || !std::isfinite(w.goal_time)) {
    return refuse("tolerances must be finite and non-negative");
  }
  return true;
}

double TrajectoryMotion::least_time_scale(const motion::Reference& from, const motion::Waypoints& w) {
  return least_fitting(1.0, kMaxTimeScale, [&](double scale) {
    candidate_.build(from, w, limits_, scale);
    return candidate_.fits(limits_);
  });
}

bool TrajectoryMotion::fit(const RobotModel& model, const motion::Reference& from, const motion::Waypoints& w,
                           char (&why)[192]) {
  candidate_scale_ = 1.0;
  candidate_.build(from, w, limits_, candidate_scale_);
  const motion::WaypointExcess e = candidate_.excess(limits_);
  if (!e) return true;
  const double scale = least_time_scale(from, w);
  if (w.time_scaling && scale > 0.0) {
    candidate_scale_ = scale;
    return true;
  }
  motion::WaypointExcess worst = e;
  if (scale == 0.0) {
    // What stays when it is slowed all it may be: its shape leaves the limits, not its speed.
    candidate_.build(from, w, limits_, kMaxTimeScale);
    worst = candidate_.excess(limits_);
  }
  const motion::LimitExcess& x = worst.excess;
  const int length = std::snprintf(why, sizeof(why), "waypoint %d, joint %s: %s %s %.4g %s, over its limit %.4g",
                                   worst.waypoint, model.joint(x.joint).name.c_str(), to_string(x.quantity),
                                   x.quantity == motion::LimitExcess::kPosition ? "reaches" : "peaks at", x.value,
                                   unit_of(x.quantity), x.limit);
  const size_t at = std::min(static_cast<size_t>(std::max(length, 0)), sizeof(why) - 1);
  if (scale == 0.0) {
    std::snprintf(why + at, sizeof(why) - at, ", even slowed %gx", kMaxTimeScale);
  } else {
    // Rounded up, so that the duration quoted fits.
    const double sent = w.time(w.count - 1);
    char fitting[24], as_sent[24];
    format_duration(fitting, scale * sent, true);
    format_duration(as_sent, sent, false);
    std::snprintf(why + at, sizeof(why) - at, "; fits in %s s instead of %s s (allow time scaling, or send it slower)",
                  fitting, as_sent);
  }
  reject(w.id, why);
  return false;
}

void TrajectoryMotion::start(const motion::Waypoints& w, int64_t now_ns) {
  end(TrajectoryProgress::kPreempted, "trajectory %lld", static_cast<long long>(w.id));
  progress_ = TrajectoryProgress{};
  progress_.id = w.id;
  progress_.outcome = TrajectoryProgress::kActive;
  progress_.duration = candidate_.duration();
  progress_.scale = candidate_scale_;
  if (candidate_scale_ > 1.0) {
    std::snprintf(progress_.message, sizeof(progress_.message), "slowed %.4gx to fit the limits", candidate_scale_);
  }
  spline_.swap(candidate_);
  path_tolerance_ = w.path_tolerance;
  goal_tolerance_ = w.goal_tolerance;
  goal_time_ = w.goal_time;
  start_ns_ = now_ns;
}

ReferenceSource::Progress TrajectoryMotion::advance(const Tick& tick, motion::Reference& ref) {
  return sample_at(spline_, start_ns_, tick.now_ns, ref);  // the goal at rest once past the end
}

bool TrajectoryMotion::judge(const RobotModel& model, const Eigen::VectorXd& error, bool running, int64_t now_ns) {
  const double t = 1e-9 * static_cast<double>(now_ns - start_ns_);
  progress_.elapsed = t;
  progress_.waypoint = spline_.waypoint_at(t);
  if (running) {
    for (int i = 0; i < error.size(); ++i) {
      if (path_tolerance_(i) > 0.0 && std::abs(error(i)) > path_tolerance_(i)) {
        end(TrajectoryProgress::kAborted, "joint %s: %g rad off the path at %.3f s, over its tolerance %g",
            model.joint(i).name.c_str(), std::abs(error(i)), t, path_tolerance_(i));
        return false;
      }
    }
    return true;
  }
  // Past the end: the reference holds the last waypoint; the arm must come within the goal
  // tolerance within goal_time.
  int off = -1;
  for (int i = 0; i < error.size(); ++i) {
    if (goal_tolerance_(i) > 0.0 && std::abs(error(i)) > goal_tolerance_(i)) off = i;
  }
  if (off < 0) {
    progress_.outcome = TrajectoryProgress::kSucceeded;  // its message, the scaling if any, stays
  } else if (t > progress_.duration + goal_time_) {
    end(TrajectoryProgress::kAborted, "joint %s: %g rad from its goal %.3f s after the end, over its tolerance %g",
        model.joint(off).name.c_str(), std::abs(error(off)), t - progress_.duration, goal_tolerance_(off));
  }
  return true;
}

void TrajectoryMotion::end(TrajectoryProgress::Outcome outcome, const char* format, ...) {
  if (!active()) return;
  progress_.outcome = outcome;
  va_list args;
  va_start(args, format);
  std::vsnprintf(progress_.message, sizeof(progress_.message), format, args);
  va_end(args);
}

}  // namespace chasles::controller
