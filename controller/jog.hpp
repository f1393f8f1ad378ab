// Jogging (docs/controller.md, "Jogging"): joint velocities or a tip twist held until the next
// command, as a teach pendant, a space mouse or MoveIt Servo sends them, turned every tick into a
// reference that stays within every joint limit and stops short of a singularity.
//
// A twist is resolved into joint velocities at the reference by the pseudo-inverse of the body
// Jacobian, q̇ = J_b⁺ V_b (least squares, minimum norm). Near a singularity those velocities grow
// without bound, so a twist that drives the arm toward one (its condition number rising) is slowed
// linearly from JogConfig::slow_condition and stopped before JogConfig::stop_condition — MoveIt
// Servo's lower and hard-stop thresholds, 17 and 30 — while one that leads away keeps its speed.
// Joint velocities stay bounded at a singularity and are not slowed there. Either command's speed
// is cut, its direction kept, so that no joint exceeds its velocity limit and every joint can
// still stop before its position limit; the reference follows it through the online generator's
// velocity interface (jerk-limited, C²). Before each step is taken, the stop the reference could
// still make from it is checked: outside a position limit, or (for a twist) at a condition number
// past the stop threshold, the step becomes a halt, so the arm always stops in time. The condition
// numbers ahead — along the probe and at the stop — come from J_b at the reference and its first-
// order change along the way (body_jacobian_change), so a jog computes the chain's kinematics once
// per tick, at the reference.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <cstdint>

#include "core/motion/limits.hpp"
#include "core/motion/quintic.hpp"
#include "core/lie/types.hpp"
#include "core/model/model.hpp"
#include "core/motion/online_generator.hpp"
#include "controller/signals.hpp"

namespace chasles::controller {

struct JogConfig {
  /// Condition number of J_b where a twist toward a singularity starts slowing down (MoveIt
  /// Servo's lower_singularity_threshold)...
  double slow_condition = 17.0;
  /// ...and the one it stops before (its hard_stop_singularity_threshold).
  double stop_condition = 30.0;
  /// A Cartesian stream closes the gap to its pose in about this time, s: the twist asked is the
  /// pose's own plus the error over it. 50 ms: several times the generator's response to a change of
  /// velocity once its jerk is capped by the torque rate (10–20 ms on the Panda); a shorter one
  /// closes a loop around that lag and rings (20 ms: 11 mm RMS off a 5 cm circle, 50 ms: 1.2 mm).
  double pose_time_constant = 0.05;
  /// Throws ArgumentError unless 1 ≤ slow_condition < stop_condition, both finite, and the time
  /// constant is positive and finite.
  void validate() const;
};

/// The singular values of a 6 × n Jacobian J from the eigenvalues of J Jᵀ (6 × 6, fixed size: no
/// allocation), its condition number and its pseudo-inverse applied to a twist.
class JacobianSpectrum {
 public:
  void compute(const Matrix6Xd& J);
  /// σ_max / σ_min over the min(6, n) largest singular values; ∞ at a singularity.
  double condition() const { return condition_; }
  /// q̇ = J⁺ V: the joint velocity of least norm among those whose twist is closest to V.
  void solve(const Matrix6Xd& J, const Vector6d& V, Eigen::VectorXd& qd) const;

 private:
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen_;
  int rank_ = 0;  // min(6, n)
  double condition_ = 0.0;
};

/// Turns the latest jog into the reference, tick by tick. Reads the kinematics at the reference
/// from the caller's Data and keeps none of its own. Allocates everything when built.
class Jogger {
 public:
  Jogger(int dof, const JogConfig& config);
  /// Moves `ref` on by dt toward the jog's velocity (a zero command: a halt), within `limits`
  /// (`otg_limits`: the same, finite) and short of a singularity; says how in `progress`. Returns
  /// whether the reference has come to rest with a zero command (the jog is over). `at_reference`
  /// holds the tip pose and J_b at ref.q. Allocates nothing.
  bool step(const Data& at_reference, const Jog& jog, bool halt, const motion::MotionLimits& limits,
            const motion::Limits& otg_limits, double dt, motion::Reference& ref, JogProgress& progress);
  /// The same toward a tip pose `target` moving with `twist` (the tip's angular velocity and its
  /// origin's velocity in the base frame's axes): a Cartesian stream. The twist asked is the
  /// target's plus the body twist from the reference's tip to the target over the time constant,
  /// resolved and kept within limits as a twist jog.
  bool follow_pose(const Data& at_reference, const Transform& target, const Vector6d& twist, bool halt,
                   const motion::MotionLimits& limits, const motion::Limits& otg_limits, double dt,
                   motion::Reference& ref, JogProgress& progress);
  const JogConfig& config() const { return config_; }

 private:
  /// J_b and κ at the reference, progress started afresh.
  const Matrix6Xd& start_at(const Data& at_reference, JogProgress& progress);
  /// From the joint velocity asked (qd_): cut to the limits, slowed toward a singularity (`twist`),
  /// the reference moved on by dt, the step checked by the stop it leaves.
  bool advance(bool twist, bool halt, const motion::MotionLimits& limits, const motion::Limits& otg_limits,
               double dt, motion::Reference& ref, JogProgress& progress);
  /// κ(J_b) at the reference moved by `step`, to first order.
  double condition_ahead(const Eigen::VectorXd& step);

  JogConfig config_;
  JacobianSpectrum spectrum_;
  motion::OnlineGenerator otg_;
  motion::KinematicState from_, out_;
  Eigen::VectorXd qd_, step_, stop_;
  Matrix6Xd J_, dJ_, J_ahead_;  // J_b at the reference, its change along a step, J_b there
};

}  // namespace chasles::controller
