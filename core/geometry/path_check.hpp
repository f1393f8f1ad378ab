// Before moving: whether a joint path keeps every pair of a Proximity at or beyond its stop
// distance for the whole of its duration, and if not, when a pair first comes below it and which.
// Runs before the motion starts, not in the tick: it allocates a little (the pairs' rates, a few
// vectors), and the caller's Data and ProximityData are its workspaces.
//
// The method is conservative advancement (Mirtich 1996; Schwarzer, Saha and Latombe 2005 for
// joint-space paths; Tang, Kim and Manocha's C2A): from the distances at time t and a bound w_p on
// how fast pair p's distance can shrink, no pair can lose its margin d_p − stop_p in less than
// (d_p − stop_p) / w_p, so the next configuration is computed there, and nothing between two
// samples is missed. The bound w_p = Σ_k R_pk s_k comes from the joints' speed bounds s_k and, for
// each joint, the farthest any point of the pair's moving object can be from the joint's axis,
// bounded from the chain's link lengths and the objects' bounding spheres so that it holds in
// every configuration, hence over the whole step (distance_rates says how). Near a contact the
// steps shrink with the margin; a least step (PathCheckOptions::min_step of the duration) ends
// that, and is the resolution of the answer: see PathClearance for what is then guaranteed.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <limits>

#include "core/geometry/proximity.hpp"
#include "core/model/model.hpp"

namespace chasles::geometry {

/// A joint path q(t) for t in [0, duration] and a bound on how fast it moves.
struct JointPath {
  double duration = 0.0;  ///< T, s; finite, ≥ 0 (0: the one configuration q(0))
  /// Writes q(t) into q (sized to the model's joints before the call). Called with t in [0, T],
  /// t = 0 first and t increasing.
  std::function<void(double t, Eigen::VectorXd& q)> position;
  /// Per joint, a bound on |q̇_i(t)| over [0, T], rad/s (m/s). It is what makes the check sound: a
  /// path faster than it somewhere may slip through a gap between samples. Empty: the model's
  /// velocity limits, which every motion the controller runs keeps to (core/motion/limits.hpp checks
  /// quintics and splines against them); an exact bound is tighter and takes fewer samples.
  Eigen::VectorXd speed;
};

struct PathCheckOptions {
  /// The least step, as a fraction of the duration: the answer's time resolution and, with the
  /// start, the bound on the number of samples (1 / min_step + 2). In (0, 1].
  double min_step = 1e-4;
  /// At most this many configurations are computed; a path still unfinished then is not clear
  /// (PathClearance::complete false). ≥ 2.
  int max_samples = 20000;
};

/// What check_path found. Pairs are indices into Proximity::pairs() (Proximity::name_pair).
struct PathClearance {
  /// No pair was below its stop distance at any sample, none can have been between samples (up to
  /// `shortfall`), and the whole path was checked.
  bool clear = true;
  /// Not clear because a pair came below its stop distance: the earliest time, s, any pair can have
  /// done so since the sample before `time_seen` (a bound from that sample's margins), at most
  /// min_step · T before `time_seen`. No pair came below its stop distance before it, bar a dip of
  /// less than `shortfall` in an earlier least step.
  double time = 0.0;
  double time_seen = 0.0;  ///< the sample at which a pair was seen below its stop distance, s
  int pair = -1;           ///< that pair (−1 when clear, or when the samples ran out)
  double distance = 0.0;   ///< its distance at time_seen, m (signed: < 0 overlapping)

  /// The pair that came nearest its stop distance (least d − stop) over the samples, when, and its
  /// distance then: the note for a path that is clear, the approach for one that is not.
  int least_pair = -1;
  double least_time = 0.0;
  double least_distance = std::numeric_limits<double>::infinity();

  /// Where the least step was taken (a margin too small for a step of min_step · T to be proven
  /// safe) and no pair was below its stop at the next sample, a pair may still have dipped below it
  /// in between and come back, by at most this much, m: the largest such dip the bound allows, over
  /// the steps before the answer. 0: every step proven. At most w · min_step · T / 2 for the
  /// fastest pair's rate w (m/s).
  double shortfall = 0.0;
  int least_steps = 0;  ///< how many steps were the least step

  bool complete = true;        ///< false: max_samples ran out before the end of the path
  double checked_until = 0.0;  ///< s: the duration, or where the samples ran out or the pair was seen
  int samples = 0;             ///< configurations computed
};

/// The first time along `path` a pair of `proximity` comes below its stop distance, by
/// conservative advancement (see the file's comment): missing none between samples (but for a dip
/// of less than PathClearance::shortfall where the least step was taken), the time found at most
/// min_step · T before the first sample that sees it. `data` and `pdata` are
/// the workspaces (for `model` and `proximity`); they are left at the last sample. Throws
/// ArgumentError for a path without a position function, a duration that is negative or not
/// finite, a speed bound of the wrong size, negative or not finite (or, with none given, a joint
/// without a finite velocity limit), a q(t) of the wrong size or not finite, or options out of
/// range.
PathClearance check_path(const RobotModel& model, const Proximity& proximity, Data& data, ProximityData& pdata,
                         const JointPath& path, const PathCheckOptions& options = {});

/// check_path with its workspaces kept: built once for a model and a Proximity (it allocates the
/// pairs' rates), then each check allocates nothing but what the path's position function does —
/// for a controller that checks every goal it is given.
class PathChecker {
 public:
  PathChecker(const RobotModel& model, const Proximity& proximity);
  /// check_path for the model and Proximity it was built for (ArgumentError for another's).
  PathClearance check(const RobotModel& model, const Proximity& proximity, Data& data, ProximityData& pdata,
                      const JointPath& path, const PathCheckOptions& options = {});

 private:
  Eigen::MatrixXd rates_;  // distance_rates
  Eigen::VectorXd rate_, stop_, margin_, next_;  // per pair
  Eigen::VectorXd speed_, q_;                    // per joint
};

/// How fast each pair's distance can change with each joint's motion: entry (p, k) bounds
/// |∂d_p / ∂q_k| in every configuration, m/rad (m/m for a prismatic joint), so that over any
/// motion |Δd_p| ≤ Σ_k R_pk ∫|q̇_k| dt.
///
/// A point x carried by joint k moves at |q̇_k| times its distance from the joint's axis (a
/// revolute joint; a prismatic one moves it at |q̇_k| itself). That distance changes with the
/// joints beyond k, so it is bounded over every configuration: the distance from axis k of the
/// next joint's origin (fixed in body k) plus the lengths between the origins of the joints up to
/// the object's body (fixed in each body; a prismatic joint's stroke added) plus the farthest point
/// of the object's bounding sphere from its body's origin; on its own body's joint, the sphere's
/// distance from that axis. A pair with a scene object or a plane moves with every joint up to its
/// arm object's body; a self pair with the joints between its two bodies only (the distance is the
/// same seen from the nearer body, in whose frame the other joints move nothing).
Eigen::MatrixXd distance_rates(const RobotModel& model, const Proximity& proximity);

/// The pair nearest its stop distance at one configuration.
struct ConfigurationClearance {
  /// The least d_p − stop_p over the pairs, m: ≥ 0 when every pair keeps its stop distance.
  double margin = std::numeric_limits<double>::infinity();
  int pair = -1;          ///< that pair (−1 with no pair)
  double distance = 0.0;  ///< its distance, m
};

/// The clearance at q: forward kinematics into `data`, the distances into `pdata`, and the pair
/// with the least margin. What IkSolver::solve's margin callback is given to prefer collision-free
/// answers (docs/geometry.md shows how). Allocates nothing.
ConfigurationClearance configuration_clearance(const RobotModel& model, const Proximity& proximity, Data& data,
                                               ProximityData& pdata, const Eigen::Ref<const Eigen::VectorXd>& q);

}  // namespace chasles::geometry
