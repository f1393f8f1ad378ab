// Dynamic identification from an arm's own log: joint positions, velocities and torques in; the
// inertial parameters of every body and each joint's friction and rotor out, physically consistent
// by construction, with the standard errors of what the data determines and the torque error on
// data the fit never saw. Gautier's recipe (filter, decimate, stack the base regressor: Gautier
// 1997, Khalil and Dombre ch. 12) with the physically consistent fit of Wensing, Kim and Slotine
// (RA-L 2017) in Rucker and Wensing's log-Cholesky coordinates (log_cholesky.hpp).
//
// The steps (identify_dynamics):
//   1. The log is cut into segments at gaps (lost messages: a step of more than 1.5 sample
//      periods). In each, the torque τ_k — applied over the step that ended at t_k, as
//      robot_state_t.effort is — is moved to the sample instant, ½ (τ_k + τ_{k+1}), the torque
//      applied around t_k; then q̇ and τ pass through one zero-phase Butterworth low-pass
//      (zero_phase_filter.hpp) and q̈ is the central difference of the filtered q̇. The first and
//      last 2 / f_c s of each segment are left out, where the filter sees its reflection of the
//      signal beyond the end more than the arm; segments under 5 / f_c s are left out whole.
//   2. Coulomb friction, f_c sign(q̇), is the one term of τ that jumps; its regressor column is
//      built as τ's Coulomb term is — the mean of sign q̇ over each step (up to the crossing, q̇
//      linear between samples), centred, filtered (Gautier's parallel filtering) — so that the
//      fit compares a smoothed step with a smoothed step. Every other column is a smooth function
//      of q, q̇, q̈.
//   3. A joint's torque is one the model explains only while the joint moves: at rest or stuck,
//      static friction holds whatever the rest of the arm leaves, up to its breakaway, and at a
//      creep the Stribeck effect lifts friction above Coulomb's. So joint i's torque at a sample is
//      left out, of the fit and of the judgement, where its filtered |q̇_i| is under `min_speed` or
//      was within 1 / f_c s (the filter's reach); samples where no joint moves are rest, left out
//      whole. Rows are kept every 1 / (2.5 f_c) s (Gautier's decimation: nothing above f_c is left
//      to lose, and rows that far apart share little of the filtered noise). The motion (the log
//      less its rest) is cut into `holdout_blocks` equal blocks and the last `holdout` of them are
//      held out: whole blocks at the end, motion the fit neither saw nor neighboured, so that a
//      log too short to cover the arm's motion shows it there.
//   4. Ordinary least squares for the base parameters β (base_parameters.hpp), then weighted least
//      squares with each joint's rows scaled by its residual σ (Gautier and Poignet 2001): the start
//      of the fit, and the check that the log excites every base parameter.
//   5. The fit: each body's log-Cholesky θ (10) and each joint's viscous f_v, Coulomb f_c and
//      armature a, bounded below by 0, by Levenberg-Marquardt (Ceres). One residual per torque
//      sample, (Y π(θ) − τ) / σ_i, under a Huber loss (δ = 1.345, 95 % efficient for Gaussian
//      noise, bounded for the rest). The torques determine only β; the other 13 n − r directions
//      are settled by a prior holding each body's θ to the nominal body's (one the URDF leaves on
//      the boundary of the physical set — massless, a point mass — with a small ball added: 1 % of
//      the mean body mass, radius ℓ, at its centre of mass): residuals
//      w (θ − θ_nominal), the log-mass and log-radii as they are, the centre of mass and the
//      Cholesky factor's off-diagonal in units of ℓ = 0.1 m, w = 1 — a body twice or half the
//      size, or its centre of mass 10 cm away, costs as much as one torque sample one σ off. The
//      thousands of samples that fix β outweigh it by orders of magnitude (its pull on β is far
//      below the standard errors), so it decides only what the data leaves open. It is a prior in
//      θ rather than in π because θ puts the boundary of the physical set (point masses, rods,
//      plates) at infinity: where the data and the nominal model pull a body towards that
//      boundary, the prior's cost grows without bound and keeps it a body with some thickness.
//      Friction and the rotors have no prior: the torques determine each joint's f_v and f_c,
//      and the armature of a joint whose rotor folds into a body (the first two of an arm whose
//      first axis is vertical) is settled by that body's prior.
//   6. Standard errors of β from the weighted least-squares covariance at the fit, σ_i estimated
//      from its residuals: Cov β = κ s² (W̃_bᵀ W̃_b)⁻¹, with κ = 1.39 (the defaults) for rows
//      1 / (2.5 f_c) apart sharing filtered noise: the long-run variance of white noise on the
//      logged torques passed through the centring and the filter, over its variance (the bounds and
//      the physical constraint are not in it; where they bind the error is smaller).
//   7. Held out: the torque RMS of the nominal and the identified model against the logged τ, each
//      predicting the torque applied over the step, ½ (τ̂(t_{k−1}) + τ̂(t_k)) — but for Coulomb
//      friction, whose mean over a step where q̇ changes sign is taken up to the crossing (q̇
//      linear over the step) — at every held-out sample, each joint where it moves (step 3).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/identification/base_parameters.hpp"
#include "core/model/payload.hpp"

namespace chasles {

/// Input the fit cannot use: samples of the wrong size or not finite, a log too short or that
/// does not excite the arm, options out of range. what() says which and what to do instead.
class IdentificationError : public Error {
 public:
  using Error::Error;
};

/// An arm's log, one column per sample, joints in the model's chain order.
struct JointSamples {
  Eigen::VectorXd t;    ///< s, strictly increasing; uniformly spaced but for gaps
  Eigen::MatrixXd q;    ///< n × N joint positions, rad or m
  Eigen::MatrixXd qd;   ///< n × N joint velocities, rad/s or m/s
  Eigen::MatrixXd tau;  ///< n × N torques applied over the step that ended at t(k), N·m or N
};

struct DynamicFitOptions {
  double cutoff_hz = 10.0;     ///< the low-pass's −3 dB point: an arm's excitation stays below a few Hz
  int filter_order = 4;        ///< Butterworth order (even, 2–8); filtfilt doubles it
  double holdout = 0.2;        ///< fraction of the motion held out, its end, in [0, 0.5]
  int holdout_blocks = 10;     ///< blocks the motion is cut into for the split
  double huber = 1.345;        ///< Huber's δ, in multiples of each joint's residual σ
  double prior_length = 0.1;   ///< ℓ, m: the prior's unit for θ's centre of mass and shape terms
  double prior_weight = 1.0;   ///< w: multiplies the prior's residuals
  double min_range = 0.0175;   ///< a joint that moves less (rad or m) does not excite the arm
  /// rad/s or m/s: joint i's torque is left out of the fit and of the held-out judgement where
  /// |q̇_i| (filtered) is below this, and within 1 / f_c s of it — at rest or stuck, static friction
  /// holds an unknown torque up to its breakaway, and creeping, Stribeck friction exceeds Coulomb's
  double min_speed = 0.1;
  double max_condition = 1e6;  ///< of the column-scaled, weighted W_b: above, the log does not excite
  /// Of the solver; a fit that needs more is refused. The UR5 of tests/world/identification_test
  /// takes 320–470 (3–5 s) along the prior's shallow valley, the Panda fewer than 50.
  int max_iterations = 1000;
  int threads = 2;
  uint64_t seed = 1;           ///< of the random states base_parameters factors
};

/// How a fit used the log (steps 1 and 3).
struct LogUse {
  double sample_rate_hz = 0.0;     ///< of the log (median step)
  double duration_s = 0.0;
  int samples = 0;                 ///< in the log
  double motion_seconds = 0.0;     ///< of the used segments, where some joint moves (min_speed)
  double rest_seconds = 0.0;       ///< of the used segments, where none does: left out
  Eigen::VectorXd moving_share;    ///< n: the share of the motion in which each joint moves
  int segments = 0;                ///< stretches between gaps that were used
  int dropped_samples = 0;         ///< in segments too short to filter (under 5 / f_c s)
  int decimation = 0;              ///< one fit row every this many samples
  int fit_samples = 0;             ///< samples whose torques the fit used
  int fit_torques = 0;             ///< their torques of joints that move: the fit's rows
  int holdout_samples = 0;         ///< samples judged on held-out data (each joint where it moves)
  double holdout_seconds = 0.0;
  std::vector<int> holdout_blocks; ///< which of the blocks of the motion were held out: the last
};

struct DynamicFitResult {
  BaseParameters base;             ///< the structure: which combinations β of π the torques determine
  int rank = 0;                    ///< numerical rank of the log's W_b (equals base.count, or the fit refuses)
  Eigen::VectorXd pi_nominal;      ///< 13 n: the model's, with zero friction
  Eigen::VectorXd pi;              ///< 13 n: identified (every body physical, friction and armature ≥ 0)
  Eigen::VectorXd beta_nominal;    ///< r: base.projection π_nominal
  Eigen::VectorXd beta_wls;        ///< r: the weighted least-squares solution (not constrained)
  Eigen::VectorXd beta;            ///< r: base.projection π
  Eigen::VectorXd beta_standard_error;  ///< r
  double correlation_inflation = 1.0;   ///< κ, by which the rows' correlated noise grows the covariance
  Eigen::VectorXd sigma;           ///< n: residual RMS of each joint at the fit, N·m (filtered torques)
  Eigen::VectorXd holdout_rms_nominal;  ///< n: N·m, against the logged torques where the joint moves
  Eigen::VectorXd holdout_rms;          ///< n
  /// n: the identified model's over every held-out sample of the motion, the joint slow or stuck
  /// included: what stiction and the Stribeck effect, which no fitted model has, add to it.
  Eigen::VectorXd holdout_rms_every_sample;
  double condition_number = 0.0;        ///< of the stacked base regressor W_b as it is (SI units)
  double condition_number_scaled = 0.0; ///< of W_b weighted by 1/σ_i and with unit columns
  LogUse log;                      ///< how the log was used
  int iterations = 0;
  bool converged = false;
  std::string termination;         ///< Ceres's message
  double seconds = 0.0;            ///< wall-clock time of identify_dynamics
  double solver_seconds = 0.0;     ///< of the Ceres fit alone
};

/// The fit of the file comment. Throws IdentificationError for samples of the wrong shape (the
/// count names the model's joints), a non-finite value (naming the sample, its time and the joint),
/// times that do not increase, positions outside the model's joint limits (another arm's log),
/// options out of range, a log without motion, joints stuck for most of it, too few torques of
/// moving joints (saying how much rest and stuck time was left out), a log that does not excite the
/// arm (naming the joints that barely move, or else the worst-determined combination), or a fit
/// that does not converge.
/// Allocates: offline.
DynamicFitResult identify_dynamics(const RobotModel& nominal, const JointSamples& samples,
                                   const DynamicFitOptions& options = {});

/// The torque RMS per joint (N·m or N) of the model π (13 n, regressor.hpp's layout) against a whole
/// log as step 7 judges held-out samples: each joint where it moves, the log filtered and trimmed as
/// the fit's. What a fit's held_out RMS claims, measured on another log. Throws IdentificationError
/// as identify_dynamics does for samples it cannot use, or a log without motion.
Eigen::VectorXd prediction_rms(const RobotModel& model, const Eigen::VectorXd& pi, const JointSamples& samples,
                               const DynamicFitOptions& options = {});

/// A payload fitted with the arm known (issue [Q], item 4): what the tip carries, in the form
/// `chasles payload` and payload_t give it, and how well it explains the torques.
struct PayloadFitResult {
  LogUse log;
  Payload payload;                  ///< mass, centre of mass and inertia about it, tip frame
  Vector10d pi = Vector10d::Zero();  ///< the payload's ten parameters in the last body's frame (regressor.hpp)
  Vector10d pi_ls = Vector10d::Zero();  ///< the weighted least-squares solution (not constrained)
  Vector10d standard_error = Vector10d::Zero();  ///< of pi, from the least-squares covariance at the fit
  double mass_standard_error = 0.0;  ///< kg (pi's first)
  double correlation_inflation = 1.0;  ///< κ, as DynamicFitResult's
  Eigen::VectorXd sigma;             ///< n: residual RMS of each joint at the fit (filtered torques)
  Eigen::VectorXd holdout_rms_without;  ///< n: the arm alone, against the logged torques
  Eigen::VectorXd holdout_rms;          ///< n: the arm with the payload
  double condition_number = 0.0;     ///< of the payload's ten columns, weighted, unit columns
  int iterations = 0;
  bool converged = false;
  std::string termination;
  double seconds = 0.0;
};

/// The load at the tip from a log of the arm moving with it, the arm itself known: `arm` (its
/// bodies and armature, identified_model of an identify_dynamics) and its joint friction
/// (`viscous`, `coulomb`, one per joint; zeros for none). The same steps as identify_dynamics,
/// with the torques the known arm explains taken off and the ten parameters of one more body on
/// the last fitted: least squares, then Ceres over its log-Cholesky θ under the Huber loss, with
/// the same weak prior, here towards a ball of the least-squares mass (or 1 kg) at its centre of
/// mass, radius 5 cm — the data determine all ten, the prior only keeps a light load off the
/// boundary of the physical set. Throws IdentificationError as identify_dynamics does (too short
/// below 3 torques per parameter; not exciting when the payload's columns, weighted and with unit
/// columns, have a condition number above max_condition), ArgumentError for friction of the wrong
/// size.
PayloadFitResult identify_payload(const RobotModel& arm, const Eigen::VectorXd& viscous, const Eigen::VectorXd& coulomb,
                                  const JointSamples& samples, const DynamicFitOptions& options = {});

/// The ten parameters of a payload in the last body's frame (regressor.hpp's order), and back.
Vector10d payload_parameters(const RobotModel& model, const Payload& payload);
Payload payload_from_parameters(const RobotModel& model, const Vector10d& pi);

/// The nominal model with the identified bodies and armature of π (13 n; its friction has no place
/// in a RobotModel). Throws ModelError for a body that is not physical.
RobotModel identified_model(const RobotModel& nominal, const Eigen::VectorXd& pi);

/// "panda_link3.Ixx", "panda_joint2.viscous", ".coulomb", ".armature": parameter `index` of π,
/// bodies named by the link that carries them.
std::string parameter_name(const RobotModel& model, int index);

/// Its unit: "kg", "kg*m", "kg*m^2", "N*m*s/rad", "N*m" (prismatic joints: "N*s/m", "N", "kg").
std::string parameter_unit(const RobotModel& model, int index);

/// β_k as text, "panda_link2.Izz + 0.0924*panda_link3.m - ...": its base column and the dependent
/// parameters folded into it (coefficients of magnitude below 1e-12 left out, ±1 as a sign alone).
std::string base_parameter_expression(const RobotModel& model, const BaseParameters& base, int k);

}  // namespace chasles
