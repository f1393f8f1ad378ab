// Inverse kinematics by Ceres: the joint positions q that put the tip at a target pose T_sd.
// Its own library, chasles::ik, so that only code that asks for IK links Ceres.
//
// The residual is the body-frame pose error r(q) = W log(T_sd⁻¹ T_sb(q)) (MR §6.2, the error
// twist of the Newton-Raphson method there), with per-component weights W, angular first. Its
// Jacobian is analytic: T_sb(q + δ) ≈ T_sb(q) exp([J_b δ]), so
//   ∂r/∂q = W Jr⁻¹(log T_err) J_b(q),
// with Jr⁻¹ the exact inverse right Jacobian of SE(3) (Barfoot, *State Estimation for Robotics*,
// §7.1.5); it tends to the identity as the error vanishes and matters far from the target.
// Joint limits are Ceres parameter bounds; continuous joints are unbounded and wrapped to
// (−π, π] in the answer. For a redundant task (more joints than constrained pose components) a
// small second residual λ (q − q_seed) keeps the solution near the seed in the null space while
// the arm approaches the target; within 1e-3 of it the term is switched off, so it leaves no bias
// in the pose error.
//
// Search: Levenberg-Marquardt from the seed; when that attempt fails, random restarts, each from
// the best of a few uniform draws within the limits (the draw whose tip is nearest the target),
// until one converges, the restart cap or the time budget runs out. An attempt
// still far from the target (> 0.03 m or rad) after 8 iterations is abandoned for the next one.
// When nothing converges the answer is the best pose found (smallest pos_err + rot_err), with
// converged = false. Given a margin (a caller's test of a configuration: collision-free, say), a
// converged attempt that fails it does not end the search: the restarts go on for one that passes.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>

#include "core/kinematics/kinematics.hpp"

namespace chasles {

struct IkOptions {
  /// Weights of the pose error components (ω, v): rotation in rad, position in m. Positive.
  Vector6d weights = Vector6d::Ones();
  /// Solve for the tip position only; the orientation is free and rot_err is only reported.
  bool position_only = false;
  /// Converged means pos_err ≤ position_tolerance (m) and rot_err ≤ rotation_tolerance (rad).
  double position_tolerance = 1e-6;
  double rotation_tolerance = 1e-6;
  /// Budget of one solve(), seed and restarts together, in CPU time of the calling thread (time
  /// preempted by other work does not count; IkResult::time_us is wall clock). Restarts stop when
  /// it is spent; the attempt from the seed always runs, and an attempt overruns it by at most one
  /// iteration.
  std::chrono::microseconds time_budget{5000};
  /// At most this many random restarts after the attempt from the seed.
  int max_restarts = 1000;
  /// Levenberg-Marquardt iterations per attempt.
  int max_iterations = 100;
  /// λ of the regularisation residual λ (q − q_seed) on redundant tasks (more joints than 6, or
  /// than 3 position-only); 0 turns it off.
  double regularization = 1e-3;
  /// Seed of the random restarts. Each solve() seeds its generator from it mixed with the target
  /// and q_seed (so targets do not share one sequence of starts), so a call's answer depends only
  /// on its inputs — unless the time budget, rather than max_restarts, ends the search: then
  /// a slower machine tries fewer restarts and may answer differently.
  std::uint64_t rng_seed = 1;
};

/// A caller's measure of how acceptable a configuration is: ≥ 0 acceptable, and the larger the
/// better. What a solve given one (IkSolver::solve's third argument) keeps searching for — as
/// geometry::configuration_clearance's margin over every pair's stop distance, to prefer
/// collision-free answers — without chasles::ik knowing what it measures.
using IkMargin = std::function<double(const Eigen::VectorXd& q)>;

struct IkResult {
  Eigen::VectorXd q;        ///< the solution, or the best pose found; within the limits
  bool converged = false;   ///< pos_err and rot_err (or pos_err alone, position-only) within tolerance
  /// With a margin: whether the answer's margin is ≥ 0 (without one, always true).
  bool accepted = true;
  /// With a margin: the answer's; without one, +∞.
  double margin = std::numeric_limits<double>::infinity();
  /// With a margin: how many converged attempts it refused (margin < 0), the answer among them
  /// when it is not accepted.
  int refused = 0;
  double pos_err = 0.0;     ///< |p_sb(q) − p_sd|, m
  double rot_err = 0.0;     ///< angle of R_sdᵀ R_sb(q), rad
  int iterations = 0;       ///< Levenberg-Marquardt iterations, every attempt together
  int restarts = 0;         ///< random restarts after the attempt from the seed
  double time_us = 0.0;     ///< wall-clock time of the solve
};

/// Throws ArgumentError unless T is a finite rigid transform: bottom row (0, 0, 0, 1),
/// R orthonormal within 1e-6 (|RᵀR − I| entries) and det R = 1 within 1e-6.
void check_rigid_transform(const Matrix4d& T, const char* name = "target");

/// The solver for one model. Build it once: it owns the Ceres problem, the cost function, the
/// target and the parameter storage, and every solve() reuses them. One solver per thread. Ceres
/// itself allocates inside each Solve, so solve() is for a worker thread, not a 1 kHz tick.
class IkSolver {
 public:
  explicit IkSolver(const RobotModel& model, IkOptions options = {});
  ~IkSolver();
  IkSolver(const IkSolver&) = delete;
  IkSolver& operator=(const IkSolver&) = delete;

  const RobotModel& model() const { return model_; }
  const IkOptions& options() const { return options_; }
  /// Checks and sets the options (ArgumentError on a non-positive weight, tolerance or
  /// budget, or a negative cap or λ).
  void set_options(const IkOptions& options);

  /// Solves for the target T_sd from q_seed (one entry per joint; clamped into the limits).
  /// Throws ArgumentError for a target that is not a finite rigid transform (see
  /// check_rigid_transform) or a seed of the wrong size or not finite. R_sd is projected onto
  /// SO(3) (it may be off by up to 1e-6).
  IkResult solve(const Matrix4d& T_sd, const JointVector& q_seed);
  IkResult solve(const Transform& T_sd, const JointVector& q_seed);

  /// The same, preferring answers whose `margin` is ≥ 0: the attempts run in the same order (the
  /// seed, then the restarts), and a converged one with margin(q) < 0 is refused and the search goes
  /// on. The answer is the first converged attempt with margin ≥ 0 (accepted); when the restart cap
  /// or the time budget ends the search first, the converged attempt with the greatest margin
  /// (accepted = false); when none converged, the best pose found, as solve() without it. The
  /// margin is called for each converged attempt, and for the answer when none converged, with the
  /// joints as an answer gives them (within their limits, continuous ones wrapped). A margin that
  /// accepts every q answers as solve() without one; an empty function is an ArgumentError.
  IkResult solve(const Matrix4d& T_sd, const JointVector& q_seed, const IkMargin& margin);
  IkResult solve(const Transform& T_sd, const JointVector& q_seed, const IkMargin& margin);

  /// Sets the target (checked as solve() does) without solving, and evaluates the weighted
  /// residual and its 6×n Jacobian at q exactly as Ceres sees them: for tests against finite
  /// differences. The position-only residual is (0, 0, 0, w_v ⊙ (p_sb − p_sd)).
  void set_target(const Matrix4d& T_sd);
  void evaluate(const JointVector& q, Vector6d& residual, Matrix6Xd& jacobian);

  struct Impl;  ///< the Ceres problem and its storage (ik.cpp)

 private:
  IkResult solve_with(const Matrix4d& T_sd, const JointVector& q_seed, const IkMargin* margin);

  const RobotModel& model_;
  IkOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace chasles
