// What a simulated arm is to whoever steps it (tools/simulation's Simulation): joint torques in,
// the joint state out, a brake, and the truth the controller is held against. Two engines
// implement it: chasles's own rigid-body RK4 (Plant, plant.hpp: exact, contact only at the tip)
// and MuJoCo (tools/mujoco's MujocoPlant: contact on any link, with a scene). The controller
// cannot tell which one it drives: both speak through the same Simulation and the same wire.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/lie/types.hpp"

namespace chasles::plant {

/// One contact on the arm at a sample, as the engine resolved it.
struct ArmContact {
  /// The URDF link touched, and what touches it (a scene object's name, "pusher"); views of names
  /// the engine holds, valid while it lives.
  std::string_view link, other;
  Vector3d point = Vector3d::Zero();   ///< m, base frame
  Vector3d normal = Vector3d::Zero();  ///< unit, base frame, into the arm (the way a push acts)
  Vector3d force = Vector3d::Zero();   ///< N, base frame: the force on the arm at `point`
};

/// What the nominal model (the one the plant was given, with the known damping D) leaves out, at
/// one sample; see lcmtypes/chasles_sim_truth_t.lcm, which carries it.
struct Truth {
  int64_t steps = -1;  ///< steps taken when sampled (the state's seq); −1: none yet
  double time = 0.0;   ///< s of simulated time, steps × period
  /// N·m or N: everything the nominal model does not explain. chasles's plant: ID_nominal(q, q̇,
  /// q̈_true) + D q̇ − τ (contact, payload, friction, the error of perturbed inertias); MuJoCo's:
  /// Σ J_p(point)ᵀ force over the contacts.
  Eigen::VectorXd tau_ext;
  /// The contact wrench on the tip's body, (m, f) base-aligned about the tip origin.
  Vector6d tip_wrench_ext = Vector6d::Zero();
  bool contact = false;  ///< something touches the arm (a push acts, a wall is penetrated)
  /// Every point contact on the arm (MuJoCo's; chasles's plant has only the tip's wrench, and
  /// none here). Reserved at construction: filling it allocates nothing.
  std::vector<ArmContact> contacts;
};

class Physics {
 public:
  virtual ~Physics() = default;

  /// Advances the arm by one step with the joint torque tau, clamped to the URDF effort limits,
  /// held over the step (zero-order hold). Allocates nothing.
  virtual void step(const Eigen::Ref<const Eigen::VectorXd>& tau) = 0;
  /// The torque that brings the arm to rest where it is: τ = g(q) − M(q) q̇ / T (the arm's own
  /// brake; effort limits apply in step()).
  virtual const Eigen::VectorXd& brake_torque(double time_constant) = 0;
  /// Samples the truth at the present state, with the effort of the last step as τ, and returns
  /// it. Allocates nothing.
  virtual const Truth& sample_truth() = 0;
  /// The latest sample_truth().
  virtual const Truth& truth() const = 0;
  /// Whether anything the controller's model does not know can act (contact, a payload, friction):
  /// then the truth goes out with every state.
  virtual bool has_environment() const = 0;

  virtual const Eigen::VectorXd& q() const = 0;
  virtual const Eigen::VectorXd& qd() const = 0;
  /// The torque applied over the last step, after clamping; zero before the first step.
  virtual const Eigen::VectorXd& effort() const = 0;
  virtual int64_t steps() const = 0;
  /// Simulated time since the first step, s.
  virtual double time() const = 0;
};

}  // namespace chasles::plant
