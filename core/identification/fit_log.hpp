// What a fit from an arm's log does before it fits (dynamic_fit.hpp's steps 1 to 3): the log's
// checks and the refusals that say what is wrong with it, its segments filtered and aligned, and its
// split into the torques fitted and the blocks held out. Shared by the arm's fit, the payload's and
// prediction_rms, which all take a log the same way; internal to chasles::identification, not
// installed.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/identification/dynamic_fit.hpp"
#include "core/identification/zero_phase_filter.hpp"

namespace chasles::detail {

/// x with `digits` significant digits, as the refusals print numbers.
std::string number(double x, int digits = 3);

inline const std::string& joint_name(const RobotModel& model, int i) { return model.joint(i).name; }

// The log after filtering, one column per kept sample: each segment less 2 / f_c s at either end,
// where the filter sees its own reflection of the signal more than the arm (an error of 1e-3 of
// the signal's curvature × 1 / ω_c² at 0.1 s from the end, 5e-5 at 0.2 s).
struct Prepared {
  Eigen::VectorXd t;
  Eigen::MatrixXd q, qd, qdd;     ///< q as logged; q̇ filtered; q̈ its central difference
  Eigen::MatrixXd tau;            ///< as logged (applied over the step ending at t)
  Eigen::MatrixXd tau_filtered;   ///< centred on t, then filtered
  Eigen::MatrixXd coulomb;        ///< sign(q̇) filtered as τ is
  /// Whether joint i's torque at the column is one the model can explain: the joint moves at
  /// |q̇| ≥ min_speed there and within 1 / f_c s either side (joint_moves).
  Eigen::Array<bool, Eigen::Dynamic, Eigen::Dynamic> moving;
  std::vector<int> segment;       ///< first column of each segment, then the column count
  int dropped = 0;
};

/// The mean of sign(q̇) over a step with q̇ going linearly from `before` to `after`: where it
/// changes sign, the share of the step on either side of the crossing.
double mean_sign(double before, double after);

/// A centred, filtered torque moved to its sample's instant (fit_log.cpp says how).
Eigen::VectorXd at_the_instant(Eigen::VectorXd x);

// Steps 1 and 3, what every fit from a log does first: the checks, the filtering, the split.
struct LogSplit {
  LowPassFilter filter;
  Prepared data;
  std::vector<int> fit, holdout;  ///< columns of data; each held-out one has its predecessor in data
  /// The fit's torque rows: fit column s's joints that move (Prepared::moving), s after s.
  std::vector<int> row_sample, row_joint;
};

/// Steps 1 to 3: checks `options` and `samples` against `model`, filters the log and splits it,
/// reporting what was used in `use`; throws IdentificationError for a log that cannot be fitted,
/// saying why and what to log instead.
LogSplit split_log(const RobotModel& model, const JointSamples& samples, const DynamicFitOptions& options,
                   LogUse& use);

/// Refuses a log that gives too few torques for `parameters` (`what` names them), or nothing to
/// judge the fit on, saying how long a log would do.
void check_length(const LogUse& use, int joints, int parameters, const std::string& what,
                  const DynamicFitOptions& options);

}  // namespace chasles::detail
