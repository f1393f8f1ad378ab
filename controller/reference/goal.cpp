#include "controller/reference/goal.hpp"

#include <algorithm>
#include <cmath>

namespace chasles::controller {
namespace {

// The longest quintic the search for a feasible duration tries, s.
constexpr double kLongestMotion = 3600.0;

}  // namespace

GoalMotion::GoalMotion(int dof, const motion::MotionLimits& limits)
    : limits_(limits), trajectory_(dof), candidate_(dof) {}

double GoalMotion::plan(const motion::Reference& from, const Eigen::VectorXd& goal, double requested,
                        motion::LimitExcess& excess) {
  candidate_.start(from, goal, requested);
  excess = candidate_.excess(limits_);
  if (!excess) return requested;
  // From rest the peaks of a quintic over d in T are known, 1.875 d/T, (10/√3) d/T² and
  // 60 d/T³, so the shortest duration is too, and is tried first. From a motion, slower is within
  // the limits past some duration: found by doubling, then by bisection.
  double from_rest = requested;
  for (int i = 0; i < candidate_.dof(); ++i) {
    const double d = std::abs(goal(i) - from.q(i));
    from_rest = std::max({from_rest, 1.875 * d / limits_.velocity(i),
                          std::sqrt(10.0 / std::sqrt(3.0) * d / limits_.acceleration(i)),
                          std::cbrt(60.0 * d / limits_.jerk(i))});
  }
  double infeasible = requested;
  if (const double T = from_rest * (1.0 + 1e-9); T > requested) {
    candidate_.start(from, goal, T);
    if (!candidate_.excess(limits_)) return T;
    infeasible = T;
  }
  return least_fitting(infeasible, kLongestMotion, [&](double T) {
    candidate_.start(from, goal, T);
    return !candidate_.excess(limits_);
  });
}

void GoalMotion::start(int64_t now_ns) {
  trajectory_.swap(candidate_);
  start_ns_ = now_ns;
}

ReferenceSource::Progress GoalMotion::advance(const Tick& tick, motion::Reference& ref) {
  return sample_at(trajectory_, start_ns_, tick.now_ns, ref);  // the goal at rest once past the end
}

}  // namespace chasles::controller
