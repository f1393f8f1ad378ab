// A planner's waypoint trajectory (core/motion/waypoints.hpp): checked against the arm and every
// limit — slowed by the least factor that fits, if the sender allows it — followed, and judged as
// control_msgs' FollowJointTrajectory judges it: a path tolerance while it runs, a goal tolerance
// within goal_time after, one outcome at the end.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "controller/reference/source.hpp"
#include "controller/signals.hpp"
#include "core/motion/waypoints.hpp"

namespace chasles::controller {

class TrajectoryMotion final : public ReferenceSource {
 public:
  TrajectoryMotion(int dof, const motion::MotionLimits& limits);
  /// Checks `w` for `model` on its own: counts, finite values, times increasing from > 0, every
  /// waypoint within the position limits less the margin, a last waypoint at rest, tolerances.
  /// False: rejected (reject()), `why` says why. Allocates nothing.
  bool check(const RobotModel& model, const motion::Waypoints& w, char (&why)[192]);
  /// Builds the path from the reference `from` through `w` and checks it against every limit,
  /// slowed by the least factor that fits if the sender allows it. False: rejected, `why` names
  /// the largest excess and the duration that would fit. Allocates nothing.
  bool fit(const RobotModel& model, const motion::Reference& from, const motion::Waypoints& w, char (&why)[192]);
  /// Trajectory `id` refused for `why`: REJECTED, unless one is active (it goes on, and the status
  /// says so once this one is reported).
  void reject(int64_t id, const char* why);
  /// Follows the trajectory fit() passed last, from now_ns: ACTIVE (one active before is PREEMPTED).
  void start(const motion::Waypoints& w, int64_t now_ns);
  /// The path fit() passed last, before start() takes it.
  const motion::WaypointSpline& planned() const { return candidate_; }
  Progress advance(const Tick& tick, motion::Reference& ref) override;
  void delay(int64_t ns) override { start_ns_ += ns; }
  /// Judges the tracking error e = q_d − q after the reference moved: the path tolerance while
  /// `running`, else the goal tolerance within goal_time. Returns false when the path tolerance
  /// aborted it (the arm is to hold where it is).
  bool judge(const RobotModel& model, const Eigen::VectorXd& error, bool running, int64_t now_ns);
  /// Ends an active trajectory with `outcome`, saying why; nothing when none is active.
  void end(TrajectoryProgress::Outcome outcome, const char* format, ...) __attribute__((format(printf, 3, 4)));
  bool active() const { return progress_.outcome == TrajectoryProgress::kActive; }
  const TrajectoryProgress& progress() const { return progress_; }

 private:
  /// The least factor (≥ 1, to 1e-3) by which w's times scaled fit the limits, left built in
  /// candidate_; 0 if none up to kMaxTimeScale.
  double least_time_scale(const motion::Reference& from, const motion::Waypoints& w);

  const motion::MotionLimits& limits_;
  motion::WaypointSpline spline_, candidate_;  // the one followed; the one being checked
  double candidate_scale_ = 1.0;
  Eigen::VectorXd path_tolerance_, goal_tolerance_;
  double goal_time_ = 0.0;
  int64_t start_ns_ = 0;
  TrajectoryProgress progress_;
};

}  // namespace chasles::controller
