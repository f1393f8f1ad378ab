// A quintic from the current reference to a joint goal at rest (a JOINT target, a reflex's
// retreat), over the shortest duration from the one asked that keeps every limit.
#pragma once

#include <Eigen/Core>

#include "controller/reference/source.hpp"

namespace chasles::controller {

class GoalMotion final : public ReferenceSource {
 public:
  GoalMotion(int dof, const motion::MotionLimits& limits);
  /// The shortest duration from `requested` up whose quintic from `from` to `goal` stays within the
  /// limits, that quintic kept for start(); 0 when none does up to an hour. `excess`: what the
  /// requested duration broke (none: it fits). Allocates nothing.
  double plan(const motion::Reference& from, const Eigen::VectorXd& goal, double requested,
              motion::LimitExcess& excess);
  /// Follows the quintic the last plan() found, from now_ns.
  void start(int64_t now_ns);
  /// The quintic the last plan() found, before start() takes it.
  const motion::QuinticTrajectory& planned() const { return candidate_; }
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  void delay(int64_t ns) override { start_ns_ += ns; }

 private:
  const motion::MotionLimits& limits_;
  motion::QuinticTrajectory trajectory_, candidate_;  // the one followed; the one being checked
  int64_t start_ns_ = 0;
};

/// The least x in (infeasible, largest], to kDurationPrecision relative, for which fits(x) holds,
/// fits(infeasible) being false: by doubling up to largest, then bisection (fits is taken to hold
/// from some x on); 0 when it holds nowhere up to largest. fits(x) is called last with the x
/// returned, so what it builds is the answer's.
template <typename Fits>
double least_fitting(double infeasible, double largest, Fits fits) {
  constexpr double kDurationPrecision = 1e-3;
  double feasible = 0.0;
  for (double x = std::min(2.0 * infeasible, largest); feasible == 0.0; x = std::min(2.0 * x, largest)) {
    if (fits(x)) {
      feasible = x;
    } else if (x == largest) {
      return 0.0;
    } else {
      infeasible = x;
    }
  }
  while (feasible - infeasible > kDurationPrecision * feasible) {
    const double x = 0.5 * (infeasible + feasible);
    (fits(x) ? feasible : infeasible) = x;
  }
  fits(feasible);
  return feasible;
}

}  // namespace chasles::controller
