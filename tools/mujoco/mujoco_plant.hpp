// The arm simulated by MuJoCo (tools/mujoco.sh pins and installs its C library): an engine people
// test controllers in before hardware, independent of chasles's own dynamics, with contact on any
// link of the arm. The same URDF is compiled by MuJoCo's own parser (inertias, joint frames, axes
// and limits are MuJoCo's reading of the file, not chasles's); chasles adds what URDF cannot say
// to MuJoCo: each joint's armature (the model's), its viscous damping (the caller's, as for
// chasles's plant), the collision geometry as chasles reads it (core/geometry: boxes, cylinders,
// spheres, capsules, convex hulls of meshes), and a scene — fixed boxes (a table is one) and a
// pusher, a small ball that presses any link with a set force.
//
// Joints that are not the model's (a gripper's fingers) are removed, so that what they carry is
// welded where q = 0 puts it, as chasles's model and its geometry take it. Integration: MuJoCo's
// implicitfast integrator (the damping and the contacts implicit, stable at a millisecond), its
// soft contacts with pyramidal friction cones, μ = 1 unless the scene says.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/geometry/collision_model.hpp"
#include "core/model/model.hpp"

namespace chasles::plant {

/// A fixed box of the scene, in the model's base frame.
struct SceneBox {
  std::string name;
  Transform T_base_box = Transform::Identity();
  Vector3d half_extents = Vector3d::Constant(0.1);
  double friction = 1.0;  ///< Coulomb's μ between it and the arm
};

/// What surrounds the arm in the MuJoCo plant.
struct MujocoScene {
  std::vector<SceneBox> boxes;
  /// A pusher: a ball of this radius (m) that press() drives against the arm; 0: none.
  double pusher_radius = 0.01;
  double friction = 1.0;  ///< μ between the pusher and the arm
};

/// One contact on the arm, as MuJoCo resolved it at the latest step.
struct ArmContact {
  /// The URDF link whose collision object is touched, and what touches it (a scene box's name or
  /// "pusher"); views of names the plant holds, valid while it lives.
  std::string_view link, other;
  Vector3d point = Vector3d::Zero();   ///< m, base frame
  Vector3d normal = Vector3d::Zero();  ///< unit, base frame, into the arm (the direction a push acts in)
  Vector3d force = Vector3d::Zero();   ///< N, base frame: the force on the arm at `point`
};

class MujocoPlant {
 public:
  /// Compiles `urdf_path` with MuJoCo, adds `geometry` (chasles's reading of the same URDF's
  /// collisions) and `scene`, starts at rest at q0. Every step() is `dt` s of MuJoCo's. Keeps a
  /// reference to `model`. Throws chasles::ArgumentError naming the file and MuJoCo's message when
  /// MuJoCo cannot read or compile the URDF, when a joint of `model` is not in it, or a size does
  /// not match the model's dof.
  MujocoPlant(const RobotModel& model, const std::string& urdf_path, const geometry::CollisionModel& geometry,
              const MujocoScene& scene, const Eigen::VectorXd& q0, const Eigen::VectorXd& damping, double dt);
  ~MujocoPlant();
  MujocoPlant(const MujocoPlant&) = delete;
  MujocoPlant& operator=(const MujocoPlant&) = delete;

  /// Advances by dt with the joint torque tau (model order), clamped to the URDF effort limits,
  /// held over the step; then reads the contacts (contacts(), tau_ext()). Allocates nothing.
  void step(const Eigen::Ref<const Eigen::VectorXd>& tau);

  /// Presses the pusher on `link` along `direction` (base frame, normalised here) with `force` N:
  /// the ball is put just outside the link's surface on the line through `aim` (a point in the
  /// link's frame) along `direction`, and pushed along it with that force until release(). Throws
  /// ArgumentError for a link without collision geometry, a scene without a pusher, a force that is
  /// not finite and > 0, or a line that meets another body of the arm or the scene first.
  void press(const std::string& link, const Vector3d& aim, const Vector3d& direction, double force);
  /// Takes the pusher away from the arm.
  void release();

  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& qd() const { return qd_; }
  /// The torque applied over the last step, after clamping.
  const Eigen::VectorXd& effort() const { return effort_; }
  double time() const;
  /// The contacts on the arm at the latest step, with the scene and the pusher (the arm's links do
  /// not collide with each other here).
  const std::vector<ArmContact>& contacts() const { return contacts_; }
  /// The true external joint torque: Σ J_p(point)ᵀ force over contacts() with the scene, N·m, by
  /// MuJoCo's Jacobians, model order.
  const Eigen::VectorXd& tau_ext() const { return tau_ext_; }

 private:
  struct Engine;  // MuJoCo's model and data, and the index maps
  void read_state();
  void read_contacts();

  const RobotModel& model_;
  const double dt_;
  std::unique_ptr<Engine> engine_;
  Eigen::VectorXd q_, qd_, effort_, effort_limit_, tau_ext_;
  std::vector<ArmContact> contacts_;
};

}  // namespace chasles::plant
