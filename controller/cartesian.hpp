// Cartesian goals, turned into joint paths off the real-time thread (DESIGN, "One tick"): the tip
// follows the straight-line screw motion from where it is to the goal, T(s) = T_0 exp([V] s) with
// V = log(T_0⁻¹ T_goal) (MR §9.2.1), timed by a quintic s(t); IK is solved at waypoints along it,
// each warm-started from the last, with the path's own joint velocities there (the body twist is
// V ṡ, so q̇ = J_b⁺ V ṡ) and accelerations. The real-time thread joins the waypoints by quintics
// that match all three, which is C² and keeps the path's shape, and the planner checks those
// quintics against every limit before anything moves.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "core/motion/quintic.hpp"
#include "core/ik/ik.hpp"

namespace chasles::controller {

/// What the real-time thread asks the IK worker for.
struct CartesianRequest {
  int64_t id = 0;
  Eigen::VectorXd q_start;  ///< the reference where the motion starts, at rest
  Transform T_goal;         ///< T_sd, tip in the base frame
  double duration = 0.0;    ///< s
  explicit CartesianRequest(int n = 0) : q_start(Eigen::VectorXd::Zero(n)) {}
};

/// Waypoints q_k at t_k = k·dt, k < count, with the path's velocities and accelerations there,
/// and how the planning went.
struct JointPath {
  static constexpr int kMaxWaypoints = 1001;
  static constexpr double kMinSpacing = 0.01;  ///< s; longer motions space waypoints wider

  int64_t request_id = 0;
  bool ok = false;
  char reason[192] = {};  ///< why not ok
  Eigen::MatrixXd q, qd, qdd;  ///< n × kMaxWaypoints; rad, rad/s, rad/s² (m for a prismatic joint)
  int count = 0;
  double dt = 0.0;
  int ik_iterations = 0;       ///< summed over the waypoints
  double ik_residual = 0.0;    ///< the largest position error over the waypoints, m
  double ik_rot_residual = 0.0;  ///< the largest rotation error, rad
  explicit JointPath(int n = 0)
      : q(Eigen::MatrixXd::Zero(n, n > 0 ? kMaxWaypoints : 0)), qd(q), qdd(q) {}
  double duration() const { return dt * (count - 1); }
};

/// Plans `request` into `path` with `solver` (whose options it uses, restarts off along the path:
/// a restart could jump to another IK branch). Fails — path.ok false, reason set — when a
/// waypoint does not converge; when consecutive waypoints would need a joint faster than its
/// velocity limit (a branch flip or a singularity on the way); or when the joint path would leave
/// `limits` (position, velocity, acceleration or jerk, exact on the quintics the sampler follows),
/// naming the duration that would do: the same poses at times stretched by c divide velocities by
/// c, accelerations by c², jerks by c³.
void plan_cartesian_path(IkSolver& solver, const motion::MotionLimits& limits, const CartesianRequest& request,
                         JointPath& path);

/// Samples a joint path: the quintic between two waypoints that matches their positions,
/// velocities and accelerations (at rest at both ends). Allocates nothing once sized.
class JointPathSampler {
 public:
  explicit JointPathSampler(int n = 0) : path_(n) {}
  /// Copies the path (the caller's buffer can be reused at once).
  void start(const JointPath& path) {
    path_.q.leftCols(path.count) = path.q.leftCols(path.count);
    path_.qd.leftCols(path.count) = path.qd.leftCols(path.count);
    path_.qdd.leftCols(path.count) = path.qdd.leftCols(path.count);
    path_.count = path.count;
    path_.dt = path.dt;
  }
  void sample(double t, motion::Reference& out) const;
  double duration() const { return path_.duration(); }
  const JointPath& path() const { return path_; }

 private:
  JointPath path_;
};

}  // namespace chasles::controller
