// A planner's trajectory (waypoints with times, as ros2_controllers' joint_trajectory_controller
// takes them) turned into a reference that is C² from the current one: one quintic per joint and
// segment, joining (position, velocity, acceleration) at every knot. Knot 0 is the reference
// where the trajectory is taken, so it starts without a jump; the waypoints' velocities and
// accelerations are the sender's where given, else the C² cubic spline's through the positions,
// unless that swings far past them (waypoints.cpp says when, and what instead).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "core/motion/limits.hpp"
#include "core/motion/quintic.hpp"

namespace chasles::motion {

/// A trajectory as received, in the arm's joint order (Controller::set_trajectory checks it).
struct Waypoints {
  static constexpr int kMaxPoints = 1000;
  int64_t id = 0;                  ///< the sender's, echoed in the status
  int count = 0;                   ///< waypoints used
  Eigen::VectorXd time;            ///< from the start, s, strictly increasing, the first > 0
  Eigen::MatrixXd q, qd, qdd;      ///< n × kMaxPoints, rad (m)
  bool has_velocities = false, has_accelerations = false;
  /// Per joint, rad (m); 0: none. Past the path tolerance while running, or past the goal
  /// tolerance goal_time after the end: ABORTED.
  Eigen::VectorXd path_tolerance, goal_tolerance;
  double goal_time = 0.0;          ///< s
  /// Whether the trajectory may be slowed down (all its times scaled by one factor) to fit the
  /// limits; else one that does not fit is refused.
  bool time_scaling = false;
  explicit Waypoints(int n = 0)
      : time(Eigen::VectorXd::Zero(kMaxPoints)),
        q(Eigen::MatrixXd::Zero(n, kMaxPoints)),
        qd(Eigen::MatrixXd::Zero(n, kMaxPoints)),
        qdd(Eigen::MatrixXd::Zero(n, kMaxPoints)),
        path_tolerance(Eigen::VectorXd::Zero(n)),
        goal_tolerance(Eigen::VectorXd::Zero(n)) {}
  int dof() const { return static_cast<int>(q.rows()); }
};

/// Where a waypoint trajectory leaves the limits: the segment ending at waypoint `waypoint`
/// (0-based, as sent) and the excess.
struct WaypointExcess {
  int waypoint = -1;
  LimitExcess excess;
  explicit operator bool() const { return static_cast<bool>(excess); }
};

class WaypointSpline {
 public:
  /// Allocates for n joints and Waypoints::kMaxPoints waypoints.
  explicit WaypointSpline(int n = 0);

  /// Builds the spline from `start` through `waypoints` with every time multiplied by `scale`
  /// (≥ 1; their velocities divided by it, accelerations by its square). Without velocities, a
  /// joint whose spline would leave its position range in `limits` (or swing far past the
  /// waypoints) keeps the waypoints' shape instead (waypoints.cpp). Allocates nothing.
  void build(const Reference& start, const Waypoints& waypoints, const MotionLimits& limits, double scale = 1.0);
  /// Where it leaves `limits` the most (exact extrema of each quintic; worse_excess). None: false.
  WaypointExcess excess(const MotionLimits& limits) const;
  /// Whether it keeps `limits`: !excess(limits), sooner where it does not.
  bool fits(const MotionLimits& limits) const;
  /// The reference at t from the start; past the end, the last waypoint at rest (a trajectory
  /// ends at rest: Controller::set_trajectory refuses a last waypoint that moves).
  void sample(double t, Reference& out) const;
  double duration() const { return knots_ > 0 ? t_(knots_ - 1) : 0.0; }
  /// The segment in force at t: the waypoint being approached (0-based), or count at the end.
  int waypoint_at(double t) const;
  /// Swaps two splines' contents (buffers of the same size: nothing is allocated).
  void swap(WaypointSpline& other);

 private:
  int segment_at(double t) const;
  // Joint i's velocities and accelerations at the inner knots, from the positions
  // (waypoints.cpp says which and why).
  void spline_derivatives(int i);
  bool swings_past(int i, double lower, double upper) const;
  void shape_keeping_derivatives(int i);

  int n_ = 0, knots_ = 0;
  Eigen::VectorXd t_;                                  // knot times, t_0 = 0
  Eigen::MatrixXd p_, v_, a_;                          // n × knots
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> c_;  // (segment · n + joint) × 6
  mutable int cursor_ = 0;                             // the last segment sampled: ticks go forward
  Eigen::VectorXd solve_;                              // spline_derivatives' scratch, one per knot
};

}  // namespace chasles::motion
