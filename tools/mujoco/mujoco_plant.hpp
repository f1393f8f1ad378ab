// The arm simulated by MuJoCo (tools/mujoco.sh pins and installs its C library): an engine people
// test controllers in before hardware, independent of chasles's own dynamics, with contact on any
// link of the arm. The same URDF is compiled by MuJoCo's own parser (inertias, joint frames, axes
// and limits are MuJoCo's reading of the file, not chasles's); chasles adds what URDF cannot say
// to MuJoCo: each joint's armature (the model's), its viscous damping (the caller's, as for
// chasles's plant), the collision geometry as chasles reads it (core/geometry: boxes, cylinders,
// spheres, capsules, convex hulls of meshes), and a scene — fixed objects of any shape (a table, a
// wall: the scene file's) and a pusher, a small ball that presses any link with a set force, when a
// test or a schedule says.
//
// Joints that are not the model's (a gripper's fingers) are removed, so that what they carry is
// welded where q = 0 puts it, as chasles's model and its geometry take it. Integration: MuJoCo's
// implicitfast integrator (the damping and the contacts implicit, stable at a millisecond), its
// soft contacts with elliptic friction cones (and noslip iterations, without which a held press
// creeps along the surface), μ = 1 unless the scene says. It is a Physics (core/simulation): a
// Simulation steps it on the bus as it does chasles's own plant.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/geometry/collision_model.hpp"
#include "core/geometry/proximity.hpp"
#include "core/model/model.hpp"
#include "core/simulation/physics.hpp"

namespace chasles::plant {

/// The pusher pressing a link over a window of simulated time (chasles_plant --press): aimed as
/// MujocoPlant::press aims it, its force ramped in and out as a push's (trapezoid).
struct Press {
  std::string link;
  Vector3d aim = Vector3d::Zero();           ///< m, the link's frame: the line of the press goes through it
  Vector3d direction = -Vector3d::UnitZ();   ///< base frame, the way it pushes; normalised by the plant
  double force = 0.0;                        ///< N on the plateau, > 0
  double start = 0.0, duration = 0.0, ramp = 0.0;  ///< s, as Push's
};

/// chasles_plant's --press: "LINK,START,DURATION,RAMP,AX,AY,AZ,DX,DY,DZ,FORCE" (the link, s, s, s,
/// the aim in the link's frame in m, the direction in the base frame, N). Throws ArgumentError
/// naming the entry at fault; the link and the schedule are checked by MujocoPlant.
Press parse_press(const std::string& text);

/// What surrounds the arm in the MuJoCo plant.
struct MujocoScene {
  /// Fixed objects in the base frame (a table, a wall, boxes): the scene file's objects
  /// (core/geometry/scene_file.hpp), any shape. Their clearances are the controller's, not used here.
  std::vector<geometry::SceneObject> objects;
  double friction = 1.0;  ///< Coulomb's μ between the arm and anything it touches, ≥ 0
  /// A pusher: a ball of this radius (m) that press() drives against the arm; 0: none.
  double pusher_radius = 0.01;
  /// Presses at set times, one at a time (their windows may not overlap): each puts the pusher on
  /// its line when it starts and takes it away when it ends.
  std::vector<Press> presses;
};

class MujocoPlant final : public Physics {
 public:
  /// Compiles `urdf_path` with MuJoCo, adds `geometry` (chasles's reading of the same URDF's
  /// collisions) and `scene`, starts at rest at q0. Every step() is `dt` s of MuJoCo's. Keeps a
  /// reference to `model`. Throws chasles::ArgumentError naming the file and MuJoCo's message when
  /// MuJoCo cannot read or compile the URDF, when a joint of `model` is not in it, a size does not
  /// match the model's dof, or the scene is not valid (a name empty or given twice, a size or μ
  /// out of range, a press on a link without collision geometry, with a force or direction that
  /// cannot be, or overlapping another in time).
  MujocoPlant(const RobotModel& model, const std::string& urdf_path, const geometry::CollisionModel& geometry,
              const MujocoScene& scene, const Eigen::VectorXd& q0, const Eigen::VectorXd& damping, double dt);
  ~MujocoPlant() override;
  MujocoPlant(const MujocoPlant&) = delete;
  MujocoPlant& operator=(const MujocoPlant&) = delete;

  /// Advances by dt with the joint torque tau (model order), clamped to the URDF effort limits,
  /// held over the step, the scene's presses started, ramped and ended on their schedule; then
  /// reads the contacts (contacts(), tau_ext()). Allocates nothing.
  void step(const Eigen::Ref<const Eigen::VectorXd>& tau) override;
  /// g(q) − M(q) q̇ / T of the model (MuJoCo agrees with it to 1e-6: tests/mujoco).
  const Eigen::VectorXd& brake_torque(double time_constant) override;
  /// The contacts of the latest step, their τ_ext and the tip body's wrench. Allocates nothing.
  const Truth& sample_truth() override;
  const Truth& truth() const override { return truth_; }
  /// Whether anything can touch the arm: scene objects or a pusher.
  bool has_environment() const override { return has_environment_; }

  /// Presses the pusher on `link` along `direction` (base frame, normalised here) with `force` N:
  /// the ball is put just outside the link's surface on the line through `aim` (a point in the
  /// link's frame) along `direction`, and pushed along it with that force until release(). Throws
  /// ArgumentError for a link without collision geometry, a scene without a pusher, a force that is
  /// not finite and > 0, or a line that meets another body of the arm or the scene first.
  void press(const std::string& link, const Vector3d& aim, const Vector3d& direction, double force);
  /// Takes the pusher away from the arm.
  void release();
  /// Scheduled presses that could not start (their line met something else first; said on stderr).
  int64_t presses_skipped() const { return presses_skipped_; }

  const Eigen::VectorXd& q() const override { return q_; }
  const Eigen::VectorXd& qd() const override { return qd_; }
  /// The torque applied over the last step, after clamping.
  const Eigen::VectorXd& effort() const override { return effort_; }
  int64_t steps() const override { return steps_; }
  double time() const override;
  /// The contacts on the arm at the latest step, with the scene and the pusher (the arm's links do
  /// not collide with each other here).
  const std::vector<ArmContact>& contacts() const { return truth_.contacts; }
  /// The true external joint torque: Σ J_p(point)ᵀ force over contacts(), N·m, by MuJoCo's
  /// Jacobians, model order.
  const Eigen::VectorXd& tau_ext() const { return truth_.tau_ext; }

 private:
  struct Engine;  // MuJoCo's model and data, and the index maps
  void read_state();
  void read_contacts();
  void follow_presses();

  const RobotModel& model_;
  const double dt_;
  std::unique_ptr<Engine> engine_;
  Data data_;  // the model's, for the brake and the tip
  Eigen::VectorXd q_, qd_, effort_, effort_limit_, brake_;
  Truth truth_;
  std::vector<Press> presses_;
  int active_press_ = -1;  // the press under way, or −1
  std::vector<bool> press_started_;
  int64_t steps_ = 0, presses_skipped_ = 0;
  bool has_environment_ = false;
};

}  // namespace chasles::plant
