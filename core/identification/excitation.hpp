// An excitation trajectory for dynamic identification: the motion an arm runs so that its logged
// torques determine the base parameters β as well as they can (Swevers, Ganseman, Tükel, De
// Schutter and Van Brussel, IEEE T-RA 1997; Gaz, Cognetti, Oliva, Robuffo Giordano and De Luca,
// RA-L 2019). Each joint follows a finite Fourier series of period T_f = 2π/ω_f,
//   q_i(t) = q0_i + Σ_{l=1..L} [ a_il/(ω_f l) sin(ω_f l t) − b_il/(ω_f l) cos(ω_f l t) ],
// and the coefficients are chosen to minimise the condition number of W_b, the base regressor Y_b
// stacked over states along one period, within the arm's position, velocity, acceleration and
// jerk limits.
//
// Rest at both ends by the choice of coefficients, not by a window or a polynomial correction:
//   q̇_i(0) = Σ_l a_il = 0 and q̈_i(0) = ω_f Σ_l l b_il = 0,
// so a_i1 and b_i1 are fixed by the others. The series stays periodic, so it is at rest at every
// multiple of T_f, every period of a run is the same motion (the periods' torques can be averaged
// against noise, Swevers's reason for periodic excitation), and its spectrum is the L harmonics and
// nothing else; a window or a correction polynomial would give up both. The constant is chosen so
// that the series starts at the arm's pose: q0_i = start_i + Σ_l b_il/(ω_f l), that is
//   q_i(t) = start_i + Σ_l [ a_il S_l(t) + b_il C_l(t) ],  S_l = sin(ω_f l t)/(ω_f l),
//   C_l = (1 − cos(ω_f l t))/(ω_f l),
// which is the form this code evaluates (exact at t = 0: q = start, q̇ = q̈ = 0 to rounding).
#pragma once

#include <cstdint>
#include <string>

#include "core/identification/base_parameters.hpp"

namespace chasles {

/// The series of every joint, and how long it runs.
struct FourierTrajectory {
  double period = 10.0;     ///< T_f, s
  int periods = 1;          ///< it runs for periods × T_f
  Eigen::VectorXd start;    ///< q(0), rad (m): the pose the arm is at rest in when it starts
  Eigen::MatrixXd a, b;     ///< n × L: a_il, b_il (rad/s, m/s), harmonic l + 1 in column l
  int dof() const { return static_cast<int>(a.rows()); }
  int harmonics() const { return static_cast<int>(a.cols()); }
  double omega() const;     ///< ω_f = 2π / T_f
  double duration() const { return periods * period; }
};

/// Sets a_i1 = −Σ_{l≥2} a_il and b_i1 = −Σ_{l≥2} l b_il on every joint: the series is then at rest
/// (q̇ = q̈ = 0) at t = 0 and so at every multiple of the period.
void make_rest_to_rest(FourierTrajectory& trajectory);

/// q, q̇, q̈ and q⃛ at time t (each sized n by the caller; nothing is allocated).
void sample_fourier(const FourierTrajectory& trajectory, double t, Eigen::Ref<Eigen::VectorXd> q,
                    Eigen::Ref<Eigen::VectorXd> qd, Eigen::Ref<Eigen::VectorXd> qdd, Eigen::Ref<Eigen::VectorXd> qddd);

/// Where each joint may go and how fast, per joint (∞ where there is no limit). chasles's
/// controller derives them from a URDF and its configuration (controller/limits.hpp,
/// MotionLimits: position and velocity from the URDF, acceleration and jerk configured or derived);
/// core takes them as given, since core does not know the controller.
struct ExcitationLimits {
  Eigen::VectorXd lower, upper;                ///< rad (m)
  Eigen::VectorXd velocity, acceleration, jerk;  ///< rad/s, rad/s², rad/s³ (m/s, ...), > 0
  /// Throws ArgumentError naming the joint for wrong sizes, lower > upper, a rate limit ≤ 0 or NaN.
  void validate(const RobotModel& model) const;
};

struct ExcitationOptions {
  int harmonics = 5;             ///< L ≥ 2 (a_i1 and b_i1 are spent on rest at the ends)
  double period = 10.0;          ///< T_f, s
  int periods = 3;               ///< duration = periods × T_f
  int samples = 100;             ///< states per period stacked into W_b
  /// The optimiser keeps q within [lower + position_margin, upper − position_margin] (rad, m) and
  /// each rate within (1 − rate_margin) of its limit on its own grid; the result is then checked
  /// against the limits themselves every `check_step` seconds over the whole duration. The margins
  /// are the room between the two, and for the controller's spline through the waypoints.
  double position_margin = 0.05;
  double rate_margin = 0.05;
  double check_step = 1e-3;      ///< s
  /// Whether W_b's columns are scaled to unit norm before its condition number is taken: the
  /// condition number of W_b itself depends on the units of β (kg against kg·m²), the scaled one
  /// does not and is within √r of the best any column scaling gives (van der Sluis 1969).
  bool normalize_columns = true;
  int iterations = 200;          ///< the optimiser's (Ceres's L-BFGS) iteration limit
  uint64_t seed = 1;             ///< of the random start
  void validate() const;         ///< throws ArgumentError naming the setting
};

/// Each joint's extremes along a trajectory, sampled every `step` over its whole duration.
struct TrajectoryPeaks {
  Eigen::VectorXd lowest, highest;               ///< q
  Eigen::VectorXd velocity, acceleration, jerk;  ///< max |q̇|, |q̈|, |q⃛|
};
TrajectoryPeaks trajectory_peaks(const FourierTrajectory& trajectory, double step);

/// cond(W_b): W_b stacks Y_b at `samples` states of one period (at t = (k + ½) T_f / samples; one
/// period because the series repeats), columns scaled to unit norm if `normalize_columns`. ∞ when
/// W_b has not full column rank.
double excitation_condition_number(const RobotModel& model, const BaseParameters& base,
                                   const FourierTrajectory& trajectory, int samples, bool normalize_columns);

struct ExcitationResult {
  FourierTrajectory trajectory;
  double condition_number = 0.0;        ///< cond(W_b) as options.normalize_columns asks, optimised
  double start_condition_number = 0.0;  ///< the same of the seeded random start
  double raw_condition_number = 0.0;    ///< cond(W_b) unscaled
  double scaled_condition_number = 0.0; ///< cond(W_b) with unit-norm columns
  int iterations = 0;                   ///< L-BFGS iterations taken
  double seconds = 0.0;                 ///< the optimisation's wall time
  TrajectoryPeaks peaks;                ///< on the check grid
};

/// The rest-to-rest series from `start` (at rest there) whose W_b is best conditioned within the
/// limits: a seeded random start scaled to half the room the limits leave, then Ceres's L-BFGS on
/// log cond(W_b) plus a quadratic penalty on every excess over the margins on a grid of 24 points
/// per cycle of the highest harmonic (the gradient of log cond from the eigenvectors of W_bᵀW_b,
/// and Y_b's derivatives in q, q̇, q̈ by differences, exact in q̇ and q̈ where Y is polynomial).
/// Throws ArgumentError for options or limits that do not fit the model, a start outside the limits
/// less the margins, and a result that leaves a limit on the check grid (naming the joint, the
/// quantity and the time) or does not excite every base parameter. Deterministic for a seed.
/// Allocates: offline.
ExcitationResult optimize_excitation(const RobotModel& model, const BaseParameters& base, const ExcitationLimits& limits,
                                     const Eigen::VectorXd& start, const ExcitationOptions& options);

/// The first limit `trajectory` leaves on a grid of `step` over its duration, as a sentence naming
/// the joint, the quantity, the value, the limit and the time; empty when it keeps them all.
std::string excitation_limit_problem(const RobotModel& model, const FourierTrajectory& trajectory,
                                     const ExcitationLimits& limits, double step);

}  // namespace chasles
