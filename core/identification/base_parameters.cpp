#include "core/identification/base_parameters.hpp"

#include <Eigen/QR>
#include <random>
#include <string>

namespace chasles {

BaseParameters base_parameters(const RobotModel& model, int samples, uint64_t seed, double tolerance) {
  const int n = model.dof();
  const int p = parameter_layout(model).size();
  if (samples < 13 || samples * n < p) {
    throw ArgumentError("base_parameters: " + std::to_string(samples) + " samples of " + std::to_string(n) +
                        " torques cannot determine " + std::to_string(p) + " parameters; give at least 13");
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal;
  RegressorWorkspace workspace(model);
  Eigen::MatrixXd W(samples * n, p);
  Eigen::VectorXd q(n), qd(n), qdd(n);
  for (int k = 0; k < samples; ++k) {
    for (int i = 0; i < n; ++i) {
      const JointLimits& l = model.joint(i).limits;
      q(i) = l.lower + (l.upper - l.lower) * unit(rng);
      qd(i) = normal(rng);
      qdd(i) = normal(rng);
    }
    W.middleRows(k * n, n) = joint_torque_regressor(model, workspace, q, qd, qdd);
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(W);
  const Eigen::MatrixXd R = qr.matrixR().topRows(p).triangularView<Eigen::Upper>();
  const double top = std::abs(R(0, 0));
  int r = 0;
  while (r < p && std::abs(R(r, r)) > tolerance * top) ++r;
  // The inertial parameters alone: what the literature counts (friction and rotors apart).
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> inertial_qr(W.leftCols(10 * n));
  inertial_qr.setThreshold(tolerance);

  BaseParameters base;
  base.count = r;
  base.inertial_count = static_cast<int>(inertial_qr.rank());
  base.rows = samples * n;
  base.smallest_kept = r > 0 ? std::abs(R(r - 1, r - 1)) / top : 0.0;
  base.largest_dropped = r < p ? std::abs(R(r, r)) / top : 0.0;
  const auto& permutation = qr.colsPermutation().indices();
  for (int k = 0; k < p; ++k) (k < r ? base.independent : base.dependent).push_back(permutation(k));
  base.K = R.topLeftCorner(r, r).triangularView<Eigen::Upper>().solve(R.topRightCorner(r, p - r));
  base.projection = Eigen::MatrixXd::Zero(r, p);
  for (int k = 0; k < r; ++k) base.projection(k, base.independent[static_cast<size_t>(k)]) = 1.0;
  for (int k = 0; k < p - r; ++k) base.projection.col(base.dependent[static_cast<size_t>(k)]) = base.K.col(k);
  return base;
}

Eigen::VectorXd base_parameter_values(const BaseParameters& base, const Eigen::VectorXd& pi) {
  return base.projection * pi;
}

void base_regressor(const BaseParameters& base, const Eigen::MatrixXd& Y, Eigen::MatrixXd& Y_b) {
  for (int k = 0; k < base.count; ++k) Y_b.col(k) = Y.col(base.independent[static_cast<size_t>(k)]);
}

}  // namespace chasles
