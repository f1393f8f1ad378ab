// What a fit is judged by (dynamic_fit.hpp's steps 4, 6 and 7): each joint's residual σ and the
// rows weighed by it, the regressor's conditioning with unit columns, the standard errors inflated
// for the filtered noise that neighbouring rows share, and the held-out torque RMS of two models.
// Shared by the arm's fit and the payload's; internal to chasles::identification, not installed.
#pragma once

#include <Eigen/Core>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <utility>
#include <vector>

#include "core/identification/fit_log.hpp"

namespace chasles::detail {

/// Each joint's RMS of e, row k being joint joint_of[k]'s.
Eigen::VectorXd joint_rms(const Eigen::VectorXd& e, const std::vector<int>& joint_of, int n);

/// σ_i floored, so that a joint the model fits exactly does not weigh infinitely.
Eigen::VectorXd floored(const Eigen::VectorXd& sigma);

/// W with each row divided by its joint's σ.
Eigen::MatrixXd whitened(Eigen::MatrixXd W, const Eigen::VectorXd& sigma, const std::vector<int>& joint_of);

/// κ, how much more the covariance of rows `decimation` samples apart is than (W̃ᵀ W̃)⁻¹ says,
/// from the impulse response of what the log's torques pass through (fit_statistics.cpp says why).
double correlation_inflation(const LowPassFilter& filter, int decimation);

/// Standard errors of x in W x ≈ y, each joint's rows weighed by its σ: √diag(κ s² (W̃ᵀ W̃)⁻¹).
Eigen::VectorXd standard_errors(const Eigen::MatrixXd& W, const Eigen::VectorXd& y, const Eigen::VectorXd& x,
                                const Eigen::VectorXd& sigma, const std::vector<int>& joint_of, double kappa);

/// The singular values of W with unit columns, from the R of its QR (those of R D⁻¹), and V.
Eigen::JacobiSVD<Eigen::MatrixXd> unit_column_svd(const Eigen::HouseholderQR<Eigen::MatrixXd>& qr, Eigen::Index r);

/// Step 7: the held-out torque RMS per joint of two models (π_a, π_b) against the logged τ over
/// `columns`, each joint where it moves, or everywhere when `every_sample`.
std::pair<Eigen::VectorXd, Eigen::VectorXd> holdout_rms(const RobotModel& model, const Prepared& data,
                                                        const std::vector<int>& columns, const Eigen::VectorXd& pi_a,
                                                        const Eigen::VectorXd& pi_b, bool every_sample = false);

}  // namespace chasles::detail
