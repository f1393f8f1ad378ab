// The simulated arm: rigid-body dynamics of the chain, M(q) q̈ = τ − c(q, q̇) − g(q) − D q̇,
// integrated with classic fourth-order Runge-Kutta (RK4).
//
// RK4 rather than semi-implicit Euler, measured on the Panda swinging freely from a bent pose with
// no damping, one step per millisecond (the plant's default): after 0.5 s RK4 is within 8e-9 rad
// of a 1e-5 s reference integration and drifts 2e-5 J in total energy over 10 s; semi-implicit
// Euler is 1.6e-2 rad off and drifts 100 J, because M(q) makes the Hamiltonian non-separable and
// the method loses its symplectic character. RK4 costs four forward-dynamics solves (≈ 9 µs per
// step for the Panda), which a 1 kHz loop affords.
#pragma once

#include <Eigen/Core>
#include <array>

#include "chasles/core/model/model.hpp"

namespace chasles::plant {

class Plant {
 public:
  /// Starts at rest at q0. `damping` is the viscous joint damping D, one entry per joint
  /// (N·m·s/rad or N·s/m). Keeps a reference to `model`.
  Plant(const RobotModel& model, const Eigen::VectorXd& q0, const Eigen::VectorXd& damping);

  /// Advances the arm by dt seconds with the joint torque tau, clamped to the URDF effort
  /// limits, held constant over the step (zero-order hold), in `substeps` RK4 steps.
  void step(const Eigen::Ref<const Eigen::VectorXd>& tau, double dt, int substeps);

  /// The torque that brings the arm to rest where it is: τ = g(q) − K q̇ with K = M(q) / T, so
  /// that each joint's velocity decays as exp(−t / T) whatever its inertia (MR eq. 8.1 with
  /// q̈ = −q̇ / T, the small Coriolis term left to the decay). Effort limits apply in step().
  const Eigen::VectorXd& brake_torque(double time_constant);

  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& qd() const { return qd_; }
  /// The torque applied over the last step, after clamping; zero before the first step.
  const Eigen::VectorXd& effort() const { return effort_; }

 private:
  /// q̈ = M⁻¹(τ − D q̇ − c − g) at (q, q̇) with the held torque τ = effort_.
  void acceleration(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, Eigen::VectorXd& qdd);
  void rk4_step(double h);

  const RobotModel& model_;
  Data data_;
  Eigen::VectorXd q_, qd_, effort_, damping_, effort_limit_, brake_;
  // RK4 scratch: the stage state, the stage torque and the four stages' q̇ and q̈.
  Eigen::VectorXd q_stage_, tau_stage_;
  std::array<Eigen::VectorXd, 4> qd_k_, qdd_k_;
};

}  // namespace chasles::plant
