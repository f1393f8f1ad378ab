// The judgement of a fit (fit_statistics.hpp): σ per joint, whitening, conditioning, standard
// errors and the held-out RMS. Apart from the fit (dynamic_fit.cpp) because none of it changes
// what is fitted, only what the report claims of it; the arm's fit and the payload's share it.
#include "core/identification/fit_statistics.hpp"

#include <cmath>
#include <limits>

#include "core/identification/regressor.hpp"

namespace chasles::detail {

// Each joint's RMS of e, row k being joint joint_of[k]'s.
Eigen::VectorXd joint_rms(const Eigen::VectorXd& e, const std::vector<int>& joint_of, int n) {
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(n), count = Eigen::VectorXd::Zero(n);
  for (Eigen::Index row = 0; row < e.size(); ++row) {
    sum[joint_of[static_cast<size_t>(row)]] += e[row] * e[row];
    count[joint_of[static_cast<size_t>(row)]] += 1.0;
  }
  return sum.cwiseQuotient(count.cwiseMax(1.0)).cwiseSqrt();
}

// σ_i floored, so that a joint the model fits exactly does not weigh infinitely.
Eigen::VectorXd floored(const Eigen::VectorXd& sigma) { return sigma.cwiseMax(1e-9 + 1e-6 * sigma.maxCoeff()); }

// W with each row divided by its joint's σ.
Eigen::MatrixXd whitened(Eigen::MatrixXd W, const Eigen::VectorXd& sigma, const std::vector<int>& joint_of) {
  for (Eigen::Index row = 0; row < W.rows(); ++row) W.row(row) /= sigma[joint_of[static_cast<size_t>(row)]];
  return W;
}

// The filtered noise of neighbouring fit rows is correlated — they lie 1 / (2.5 f_c) apart, within
// the filter's memory — which (W̃ᵀ W̃)⁻¹ alone ignores. For regressors that change slowly beside
// that memory the covariance grows by κ = Σ_l a(l D) / a(0) over all integer l, a the
// autocorrelation of what white noise on the logged torques becomes on its way to the rows (the
// centring, the filter, the correction to the instant: their impulse response) and D the
// decimation: 1.39 for the defaults at 500 Hz or 1 kHz. From the filter rather than the residuals,
// whose estimate over a short log scatters more than the correction is worth.
double correlation_inflation(const LowPassFilter& filter, int decimation) {
  const int pad = zero_phase_padding(filter, std::numeric_limits<Eigen::Index>::max() / 4);
  const Eigen::Index length = 4 * static_cast<Eigen::Index>(pad) + 2, middle = 2 * static_cast<Eigen::Index>(pad);
  Eigen::VectorXd centred = Eigen::VectorXd::Zero(length);
  centred[middle - 1] = centred[middle] = 0.5;  // ½ (x_k + x_{k+1}) of a unit impulse at `middle`
  const Eigen::VectorXd h = at_the_instant(zero_phase_filter(filter, centred));
  const auto a = [&](Eigen::Index lag) { return h.head(length - lag).dot(h.tail(length - lag)); };
  double kappa = 1.0;
  for (Eigen::Index lag = decimation; lag < length; lag += decimation) kappa += 2.0 * a(lag) / a(0);
  return kappa;
}

// Standard errors of x in W x ≈ y, each joint's rows weighed by its σ: √diag(κ s² (W̃ᵀ W̃)⁻¹), κ the
// inflation for correlated rows above.
Eigen::VectorXd standard_errors(const Eigen::MatrixXd& W, const Eigen::VectorXd& y, const Eigen::VectorXd& x,
                                const Eigen::VectorXd& sigma, const std::vector<int>& joint_of, double kappa) {
  const Eigen::Index rows = W.rows(), r = W.cols();
  const Eigen::MatrixXd Wt = whitened(W, sigma, joint_of);
  const Eigen::VectorXd e = whitened(Eigen::MatrixXd(W * x - y), sigma, joint_of);
  const double s2 = e.squaredNorm() / static_cast<double>(rows - r);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(Wt);
  const Eigen::MatrixXd R_inverse =
      qr.matrixQR().topRows(r).triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(r, r));
  return (R_inverse.rowwise().squaredNorm() * kappa * s2).cwiseSqrt();
}

// The singular values of W with unit columns, from the R of its QR (those of R D⁻¹), and V.
Eigen::JacobiSVD<Eigen::MatrixXd> unit_column_svd(const Eigen::HouseholderQR<Eigen::MatrixXd>& qr, Eigen::Index r) {
  const Eigen::MatrixXd R = qr.matrixQR().topRows(r).triangularView<Eigen::Upper>();
  const Eigen::VectorXd norms = R.colwise().norm().transpose();
  return Eigen::JacobiSVD<Eigen::MatrixXd>(R * norms.cwiseMax(1e-300).cwiseInverse().asDiagonal(), Eigen::ComputeFullV);
}

// Step 7: the held-out torque RMS of two models (π_a, π_b) against the logged τ, each predicting
// the torque applied over each step: the trapezoid ½ (τ̂_{k−1} + τ̂_k) for every smooth term, and
// Coulomb's mean taken up to the crossing over a step where q̇ changes sign. Each joint over the
// samples where it moves (Prepared::moving), the torques the fit claims to explain, or over all of
// `columns` when `every_sample`.
std::pair<Eigen::VectorXd, Eigen::VectorXd> holdout_rms(const RobotModel& model, const Prepared& data,
                                                        const std::vector<int>& columns, const Eigen::VectorXd& pi_a,
                                                        const Eigen::VectorXd& pi_b, bool every_sample) {
  const int n = model.dof();
  const ParameterLayout layout = parameter_layout(model);
  RegressorWorkspace workspace(model);
  Eigen::VectorXd sum_a = Eigen::VectorXd::Zero(n), sum_b = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd previous_a(n), previous_b(n), now_a(n), now_b(n), step(n), count = Eigen::VectorXd::Zero(n);
  const auto predict = [&](int c, Eigen::VectorXd& tau_a, Eigen::VectorXd& tau_b) {
    const Eigen::MatrixXd& Y = joint_torque_regressor(model, workspace, data.q.col(c), data.qd.col(c), data.qdd.col(c));
    tau_a.noalias() = Y * pi_a;
    tau_b.noalias() = Y * pi_b;
  };
  int previous_column = -2;
  for (const int c : columns) {
    if (previous_column != c - 1) predict(c - 1, previous_a, previous_b);
    predict(c, now_a, now_b);
    for (int i = 0; i < n; ++i) {
      const double before = data.qd(i, c - 1), after = data.qd(i, c);
      step[i] = mean_sign(before, after) - 0.5 * (((before > 0.0) - (before < 0.0)) + ((after > 0.0) - (after < 0.0)));
    }
    const auto coulomb = [&](const Eigen::VectorXd& pi) {
      return Eigen::VectorXd(pi.segment(layout.coulomb(0), n).cwiseProduct(step));
    };
    const Eigen::ArrayXd moving =
        every_sample ? Eigen::ArrayXd::Ones(n) : Eigen::ArrayXd(data.moving.col(c).cast<double>());
    sum_a.array() += moving * (data.tau.col(c) - 0.5 * (previous_a + now_a) - coulomb(pi_a)).array().abs2();
    sum_b.array() += moving * (data.tau.col(c) - 0.5 * (previous_b + now_b) - coulomb(pi_b)).array().abs2();
    count += moving.matrix();
    previous_a.swap(now_a);
    previous_b.swap(now_b);
    previous_column = c;
  }
  count = count.cwiseMax(1.0);
  return {sum_a.cwiseQuotient(count).cwiseSqrt(), sum_b.cwiseQuotient(count).cwiseSqrt()};
}

}  // namespace chasles::detail
