// Space in the tick (docs/controller.md, "Clearance"): the arm kept away from itself, from the
// scene's obstacles and behind its safety planes.
//
//   at the state      the distances (the status: the closest pair); a pair inside its stop
//                     distance — the arm was pushed there — starts the reflex
//   the reference     as a source moved it, cut so that no pair closes faster than it may: within a
//                     pair's influence distance d_i its distance d may shrink at most at
//                     min((d − d_s)/τ, √(2 a (d − d_s))) — the velocity damper of Faverjon and
//                     Tournassoud, and a stop within the deceleration a — where d_s is the stop
//                     distance plus a margin the state needs to lag the reference by. The rate of
//                     a pair's distance is n·(ṗ_other − ṗ_arm) at its witness points, a row of the
//                     joint velocity; the source's step is slowed along its own path by the least
//                     factor that keeps every pair within its rate (a jog stops, it does not
//                     slide along the wall; a goal's quintic waits along its path). Far from
//                     everything nothing is touched: the motion is exactly the source's.
//   free drive and    a repulsive torque, Jᵀ f with f growing linearly from 0 at the influence
//   impedance         distance to Config's repulsion at the stop distance: the person guiding the
//                     arm feels the wall before it.
//
// The world (the pairs and their workspaces) is built off the tick for each scene, and handed over
// by pointer: a new scene takes effect at the next tick, with no allocation in it.
#pragma once

#include <Eigen/Core>
#include <memory>

#include "core/geometry/path_check.hpp"
#include "core/geometry/proximity.hpp"
#include "core/model/model.hpp"
#include "core/motion/quintic.hpp"

namespace chasles::controller {

struct ClearanceConfig {
  double time_constant = 0.05;      ///< τ, s: the damper's; a pair closes at most (d − d_s)/τ
  double deceleration = 1.0;        ///< a, m/s²: a closing pair is stopped within it
  double reference_margin = 0.003;  ///< m: the reference keeps this much beyond each stop distance
  double repulsion = 20.0;          ///< N: the repulsive force at the stop distance (free drive, impedance)
};

/// What the clearance computes with for one arm and one scene. Built off the tick: allocates.
struct ClearanceWorld {
  ClearanceWorld(const RobotModel& model, geometry::Proximity proximity);
  geometry::Proximity proximity;
  geometry::ProximityData at_state, at_reference, along_path;
  geometry::PathChecker path_checker;  // a goal's or a trajectory's path, before it moves
  Eigen::MatrixXd rates;      // per pair and joint, how fast its distance can change (distance_rates)
  Eigen::VectorXd free_step;  // the source's step, joint velocity
  Eigen::VectorXd speed;      // |free_step|
  Eigen::VectorXd row;        // a pair's ∂d/∂q
  Eigen::Matrix<double, 6, Eigen::Dynamic> twists;  // each joint's space twist at the q at hand
};

/// A planned motion's path (a goal's quintic, a trajectory's spline), checked before it moves, and
/// the workspaces the check needs: allocated with the controller.
struct PlannedPath {
  explicit PlannedPath(const RobotModel& model) : data(model), sampled(model.dof()) {}
  Data data;
  motion::Reference sampled;
  geometry::JointPath path;  // its position function samples the planned motion into `sampled`
  bool trajectory = false;   // which planned motion: a trajectory's spline, else a goal's quintic
};

/// The clearance at the latest tick, for the status.
struct ClearanceStatus {
  int closest = -1;               ///< the closest pair at the state, −1 without a world
  double closest_distance = 0.0;  ///< its signed distance, m
  char closest_name[128] = {};    ///< "<arm object> and <other>"
  /// Its witness points, base frame, m: on the arm's object and on the other.
  Eigen::Vector3d closest_arm = Eigen::Vector3d::Zero(), closest_other = Eigen::Vector3d::Zero();
  /// The pair that cut the reference the most at the latest tick that cut it, within the last
  /// kSlowingHold ticks (−1: none did), and the share of the source's joint-velocity step the
  /// reference kept then (1: uncut). A reference held against a wall is cut at most ticks, not
  /// all: the source asks a little less than the room left at some.
  static constexpr int kSlowingHold = 100;
  int slowing = -1;
  double kept = 1.0;
  char slowing_name[128] = {};
};

class Clearance {
 public:
  Clearance(const RobotModel& model, const ClearanceConfig& config);
  /// The world from the next tick; nullptr: none (no geometry, nothing checked). The caller keeps
  /// it alive while it is in force. Allocates nothing.
  void set_world(ClearanceWorld* world);
  bool active() const { return world_ != nullptr; }
  const ClearanceConfig& config() const { return config_; }

  /// The distances at the measured state (`at_state` holds its body poses). Returns the pair
  /// inside its stop distance, the deepest, or −1 (inside() until the next). Allocates nothing.
  int observe(const Data& at_state);
  int inside() const { return inside_; }
  /// Cuts the reference a source moved from `from` (where `at_from` holds the body poses) to
  /// `ref` over dt, so that no pair within its influence closes faster than it may. Returns
  /// whether it cut it; then ref.q is from.q plus the share of the step kept, ref.qd the source's
  /// velocity times that share, and ref.qdd the change from from.qd over dt within
  /// ±`acceleration`: the acceleration the cut reference makes. Allocates nothing.
  bool shape(const RobotModel& model, const Data& at_from, const motion::Reference& from, double dt,
             const Eigen::VectorXd& acceleration, motion::Reference& ref);
  /// At the next tick, before the source moves `ref`: if it is still the reference shape() cut,
  /// gives it back the source's own acceleration, scaled by the share kept — what the source's
  /// generator plans its next step from. Allocates nothing.
  void hand_back(motion::Reference& ref);
  /// Adds the repulsive torque at the state (after observe) to tau. Allocates nothing.
  void repel(const RobotModel& model, const Data& at_state, Eigen::VectorXd& tau);

  const ClearanceStatus& status() const { return status_; }
  /// "<pair> at <d> m, inside its stop distance <s> m" for the pair observe() returned.
  const char* inside_reason(int pair);
  /// Whether `path` keeps every pair at or beyond its stop distance (geometry::check_path, with
  /// `data` a workspace); if not, why into `why`: "<pair> would come within its stop distance <s> m
  /// at t = <t> s of <T> s". True without a world. Allocates nothing.
  bool path_clear(const RobotModel& model, Data& data, const geometry::JointPath& path, char* why, size_t size);

 private:
  /// ∂d/∂q of a pair at distance d, from the joint twists at hand (world_->twists), into `row`.
  void distance_row(const RobotModel& model, const geometry::PairDistance& d, const geometry::ProximityPair& pair,
                    Eigen::VectorXd& row) const;

  ClearanceConfig config_;
  ClearanceWorld* world_ = nullptr;
  ClearanceStatus status_;
  int uncut_ticks_ = 0;  // since the reference was last cut
  int inside_ = -1;      // the pair the state is inside the stop distance of
  char reason_[192] = {};
  motion::Reference cut_;        // the reference as shape() left it
  Eigen::VectorXd carried_qdd_;  // the source's acceleration, scaled, to plan on from it
  bool carried_ = false;         // cut at the latest tick, not yet handed back
};

}  // namespace chasles::controller
