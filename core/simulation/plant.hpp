// The simulated arm: rigid-body dynamics of the chain, M(q) q̈ = τ − c(q, q̇) − g(q) − D q̇, in an
// environment (environment.hpp) the controller does not know — pushes and walls at the tip, a
// hidden payload, hidden joint friction, inertias off the model's — integrated with classic
// fourth-order Runge-Kutta (RK4):
//   M_true(q) q̈ + c_true + g_true = τ − D q̇ + τ_f(q̇) + J_bᵀ F_env,
// M_true, c_true, g_true those of the true model (the perturbed inertias, the payload on top), τ_f
// the friction and F_env the contact wrench in the tip frame, both evaluated at every RK4 stage
// (they depend on the state).
//
// RK4 rather than semi-implicit Euler, measured on the Panda swinging freely from a bent pose with
// no damping, one step per millisecond (the plant's default): after 0.5 s RK4 is within 8e-9 rad
// of a 1e-5 s reference integration and drifts 2e-5 J in total energy over 10 s; semi-implicit
// Euler is 1.6e-2 rad off and drifts 100 J, because M(q) makes the Hamiltonian non-separable and
// the method loses its symplectic character. RK4 costs four forward-dynamics solves (≈ 9 µs per
// step for the Panda), which a 1 kHz loop affords. An empty environment adds nothing to that; a
// wall adds a body Jacobian per stage, a push a forward kinematics while it acts.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>

#include "core/model/model.hpp"
#include "core/simulation/environment.hpp"
#include "core/simulation/physics.hpp"

namespace chasles::plant {

class Plant final : public Physics {
 public:
  /// Starts at rest at q0. `damping` is the viscous joint damping D, one entry per joint
  /// (N·m·s/rad or N·s/m), which the controller knows. Every step() is `dt` seconds long, in
  /// `substeps` RK4 steps. Throws chasles::ArgumentError when the environment is not valid (see
  /// checked_environment). Keeps a reference to `model`, the nominal model; with a payload or
  /// perturbed inertias it integrates a model of its own (true_model()).
  Plant(const RobotModel& model, const Eigen::VectorXd& q0, const Eigen::VectorXd& damping, double dt, int substeps = 1,
        const EnvironmentOptions& environment = {});

  /// Advances the arm by dt with the joint torque tau, clamped to the URDF effort limits, held
  /// constant over the step (zero-order hold). Allocates nothing.
  void step(const Eigen::Ref<const Eigen::VectorXd>& tau) override;

  /// The torque that brings the arm to rest where it is: τ = g(q) − K q̇ with K = M(q) / T, so
  /// that each joint's velocity decays as exp(−t / T) whatever its inertia (MR eq. 8.1 with
  /// q̈ = −q̇ / T, the small Coriolis term left to the decay). The arm's own brake: it knows the
  /// payload (the true model), not the contact. Effort limits apply in step().
  const Eigen::VectorXd& brake_torque(double time_constant) override;

  /// Samples the truth at the present state and time, with the effort of the last step as τ, and
  /// returns it. Allocates nothing.
  const Truth& sample_truth() override;
  /// The latest sample_truth().
  const Truth& truth() const override { return truth_; }
  bool has_environment() const override { return environment_.any(); }

  const Eigen::VectorXd& q() const override { return q_; }
  const Eigen::VectorXd& qd() const override { return qd_; }
  /// The torque applied over the last step, after clamping; zero before the first step.
  const Eigen::VectorXd& effort() const override { return effort_; }
  int64_t steps() const override { return steps_; }
  /// Simulated time since the first step: steps × dt, s.
  double time() const override { return static_cast<double>(steps_) * dt_; }
  /// The model integrated: the nominal one with its inertias perturbed (with_perturbed_inertias of
  /// the environment's perturbation) and the payload on its last body; the nominal one without either.
  const RobotModel& true_model() const { return true_model_; }
  /// The contact wrench the environment applies to the tip at time t and state (q, q̇): (m, f),
  /// base-aligned at the tip origin; `contact` says whether a push acts or a wall is penetrated.
  /// Allocates nothing.
  Vector6d contact_wrench(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, bool& contact);
  /// v_s of the Coulomb friction's tanh, per joint (0 where there is none), rad/s or m/s: the
  /// largest slope f_s / v_s of every joint (f_s the breakaway, f_c without stiction) is 1 / (h κ), h = dt / substeps and κ the largest
  /// eigenvalue of M_true(q)⁻¹ over the configurations sampled at construction, so that the stiffest
  /// mode friction adds decays at |λ| ≤ 1/h: RK4 resolves it (stable to |λ h| ≤ 2.79 on the real
  /// axis) with room for the configurations not sampled and the damping on top. Smaller with
  /// --substeps.
  const Eigen::VectorXd& friction_velocity() const { return friction_velocity_; }

 private:
  /// q̈ at (t, q, q̇) with the held torque τ = effort_: M_true⁻¹(τ − D q̇ + τ_f − c − g + J_bᵀ F_env).
  const Eigen::VectorXd& acceleration(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd);
  void rk4_step(double t, double h);
  /// κ: the largest eigenvalue of M_true(q)⁻¹ over q0 and seeded samples of the joint ranges.
  double largest_inverse_inertia(const Eigen::VectorXd& q0);

  const RobotModel& model_;
  const EnvironmentOptions environment_;
  const std::unique_ptr<const RobotModel> own_model_;  // null without a payload or a perturbation
  const RobotModel& true_model_;
  Data data_;          // the true model's
  Data nominal_data_;  // the nominal model's, for the truth
  const double dt_;
  const int substeps_;
  int64_t steps_ = 0;
  Eigen::VectorXd q_, qd_, effort_, damping_, effort_limit_, brake_;
  Eigen::VectorXd friction_velocity_;
  const bool has_contact_, has_friction_;
  Truth truth_;
  // RK4 scratch: the stage state, the stage torque and the four stages' q̇ and q̈.
  Eigen::VectorXd q_stage_, tau_stage_;
  std::array<Eigen::VectorXd, 4> qd_k_, qdd_k_;
};

}  // namespace chasles::plant
