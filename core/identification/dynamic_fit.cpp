// The fits themselves (dynamic_fit.hpp's steps 4 and 5, and the payload's): the least-squares
// start and the excitation check, the physically consistent fit in log-Cholesky coordinates with
// Ceres, and the result's parameters by name. The log they take is prepared in fit_log.cpp and the
// fit judged in fit_statistics.cpp, so that what remains here is what decides the parameters.
#include "core/identification/dynamic_fit.hpp"

#include <ceres/ceres.h>
#include <ceres/normal_prior.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <tuple>

#include "core/identification/fit_log.hpp"
#include "core/identification/fit_statistics.hpp"
#include "core/identification/log_cholesky.hpp"
#include "core/identification/zero_phase_filter.hpp"
#include "core/model/inertia.hpp"

namespace chasles {

using detail::check_length;
using detail::correlation_inflation;
using detail::floored;
using detail::holdout_rms;
using detail::joint_name;
using detail::joint_rms;
using detail::LogSplit;
using detail::number;
using detail::Prepared;
using detail::split_log;
using detail::standard_errors;
using detail::unit_column_svd;
using detail::whitened;

namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// ---------------------------------------------------------------------------------------------
// Step 5: the physically consistent fit
// ---------------------------------------------------------------------------------------------

// π_j(θ_j) and, when wanted, dπ_j/dθ_j (10 × 10, row-major), by forward-mode differentiation of
// the templated map: ten dual numbers, one pass.
void body_parameters_and_jacobian(const double* theta, double* pi, double* dpi_dtheta) {
  if (dpi_dtheta == nullptr) {
    inertia_from_log_cholesky(theta, pi);
    return;
  }
  using Jet = ceres::Jet<double, 10>;
  Jet theta_jet[10], pi_jet[10];
  for (int k = 0; k < 10; ++k) theta_jet[k] = Jet(theta[k], k);
  inertia_from_log_cholesky(theta_jet, pi_jet);
  for (int k = 0; k < 10; ++k) {
    pi[k] = pi_jet[k].a;
    for (int l = 0; l < 10; ++l) dpi_dtheta[10 * k + l] = pi_jet[k].v[l];
  }
}

// One torque sample: joint i at one instant, (Y_i π(θ) − τ_i) / σ_i. Row i of Y involves the
// bodies i … n−1 (the joint carries them) and joint i's own friction and rotor, so its blocks are
// θ_i … θ_{n−1} and φ_i = (f_v, f_c, a).
class TorqueRow final : public ceres::CostFunction {
 public:
  TorqueRow(const double* row, const ParameterLayout& layout, int joint, double torque, double weight)
      : row_(row), layout_(layout), joint_(joint), torque_(torque), weight_(weight) {
    set_num_residuals(1);
    for (int j = joint; j < layout.n; ++j) mutable_parameter_block_sizes()->push_back(10);
    mutable_parameter_block_sizes()->push_back(3);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int bodies = layout_.n - joint_;
    double r = -torque_;
    double pi[10], dpi[100];
    for (int b = 0; b < bodies; ++b) {
      const double* c = row_ + layout_.inertial(joint_ + b);
      double* J = jacobians != nullptr ? jacobians[b] : nullptr;
      body_parameters_and_jacobian(parameters[b], pi, J != nullptr ? dpi : nullptr);
      for (int k = 0; k < 10; ++k) r += c[k] * pi[k];
      if (J == nullptr) continue;
      for (int l = 0; l < 10; ++l) {
        double sum = 0.0;
        for (int k = 0; k < 10; ++k) sum += c[k] * dpi[10 * k + l];
        J[l] = weight_ * sum;
      }
    }
    const double* phi = parameters[bodies];
    const double c_phi[3] = {row_[layout_.viscous(joint_)], row_[layout_.coulomb(joint_)],
                             row_[layout_.armature(joint_)]};
    r += c_phi[0] * phi[0] + c_phi[1] * phi[1] + c_phi[2] * phi[2];
    residuals[0] = weight_ * r;
    if (jacobians != nullptr && jacobians[bodies] != nullptr) {
      for (int k = 0; k < 3; ++k) jacobians[bodies][k] = weight_ * c_phi[k];
    }
    return true;
  }

 private:
  const double* row_;  // Y's row, 13 n entries, owned by the fit
  ParameterLayout layout_;
  int joint_;
  double torque_, weight_;
};

// One torque sample of the payload fit: (Y_i,last body π(θ) − (τ_i − what the arm explains)) / σ_i.
class PayloadRow final : public ceres::SizedCostFunction<1, 10> {
 public:
  PayloadRow(const double* coefficients, double torque, double weight)
      : c_(coefficients), torque_(torque), weight_(weight) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double pi[10], dpi[100];
    const bool jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    body_parameters_and_jacobian(parameters[0], pi, jacobian ? dpi : nullptr);
    double r = -torque_;
    for (int k = 0; k < 10; ++k) r += c_[k] * pi[k];
    residuals[0] = weight_ * r;
    if (jacobian) {
      for (int l = 0; l < 10; ++l) {
        double sum = 0.0;
        for (int k = 0; k < 10; ++k) sum += c_[k] * dpi[10 * k + l];
        jacobians[0][l] = weight_ * sum;
      }
    }
    return true;
  }

 private:
  const double* c_;  // the row's ten coefficients, owned by the fit
  double torque_, weight_;
};

// θ of a body for the fit to start from or to fall back on: its own, or, for a body on the
// boundary of the physical set (massless, a point mass, a rod), the body with a small ball added —
// 1 % of the arm's mean body mass, radius ℓ, at its centre of mass — which θ can represent.
Vector10d start_theta(const Vector10d& pi, double ball_mass, double radius) {
  try {
    return log_cholesky_from_inertia(pi);
  } catch (const ArgumentError&) {
    const Vector3d c = pi(0) > 0.0 ? Vector3d(pi.segment<3>(1) / pi(0)) : Vector3d::Zero();
    const Matrix3d I_ball =
        (0.4 * ball_mass * radius * radius + ball_mass * c.squaredNorm()) * Matrix3d::Identity() -
        ball_mass * c * c.transpose();
    SpatialInertia ball;
    ball.mass = ball_mass;
    ball.h = ball_mass * c;
    ball.I = I_ball;
    return log_cholesky_from_inertia(pi + body_parameters(ball));
  }
}

struct Timer {
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
};

ceres::Solver::Options solver_options(const DynamicFitOptions& options, int rows) {
  ceres::Solver::Options o;
  // Dogleg rather than Levenberg-Marquardt: the directions only the prior holds form a long,
  // shallow, curved valley, which LM's damped steps creep along (at a tolerance of 1e-12, 117
  // iterations on the test's Panda, against 29 for the same optimum).
  o.trust_region_strategy_type = ceres::DOGLEG;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = options.max_iterations;
  o.num_threads = options.threads;
  // Stop when an iteration gains less than 1e-4 of the whitened cost ½ Σ r², which is about half
  // the number of rows: parameters then sit within a hundredth of a standard error of the optimum.
  o.function_tolerance = 2e-4 / rows;
  o.parameter_tolerance = 1e-12;
  o.gradient_tolerance = 1e-14;
  o.logging_type = ceres::SILENT;
  return o;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Names
// ---------------------------------------------------------------------------------------------

std::string parameter_name(const RobotModel& model, int index) {
  const ParameterLayout layout = parameter_layout(model);
  if (index < 0 || index >= layout.size()) {
    throw ArgumentError("parameter index " + std::to_string(index) + " is outside π's " +
                        std::to_string(layout.size()) + " entries");
  }
  if (index < layout.viscous(0)) {
    const int body = index / ParameterLayout::kInertial;
    for (const ChainLink& link : model.links()) {
      if (link.body == body + 1) return link.name + "." + kInertialParameterNames[index % ParameterLayout::kInertial];
    }
  }
  const int n = layout.n;
  const int kind = (index - layout.viscous(0)) / n;
  static const char* const kinds[3] = {"viscous", "coulomb", "armature"};
  return joint_name(model, (index - layout.viscous(0)) % n) + "." + kinds[kind];
}

std::string parameter_unit(const RobotModel& model, int index) {
  const ParameterLayout layout = parameter_layout(model);
  if (index < layout.viscous(0)) {
    const int k = index % ParameterLayout::kInertial;
    return k == 0 ? "kg" : k < 4 ? "kg*m" : "kg*m^2";
  }
  const int n = layout.n;
  const bool prismatic = model.joint((index - layout.viscous(0)) % n).type == JointType::Prismatic;
  switch ((index - layout.viscous(0)) / n) {
    case 0: return prismatic ? "N*s/m" : "N*m*s/rad";
    case 1: return prismatic ? "N" : "N*m";
    default: return prismatic ? "kg" : "kg*m^2";
  }
}

std::string base_parameter_expression(const RobotModel& model, const BaseParameters& base, int k) {
  std::string text = parameter_name(model, base.independent[static_cast<size_t>(k)]);
  for (size_t j = 0; j < base.dependent.size(); ++j) {
    const double c = base.K(k, static_cast<Eigen::Index>(j));
    if (std::abs(c) <= 1e-12) continue;
    const std::string coefficient = std::abs(std::abs(c) - 1.0) < 1e-9 ? "" : number(std::abs(c), 6) + "*";
    text += (c < 0.0 ? " - " : " + ") + coefficient +
            parameter_name(model, base.dependent[j]);
  }
  return text;
}

RobotModel identified_model(const RobotModel& nominal, const Eigen::VectorXd& pi) {
  const ParameterLayout layout = parameter_layout(nominal);
  if (pi.size() != layout.size()) {
    throw ArgumentError("identified_model: π has " + std::to_string(pi.size()) + " entries; the chain needs " +
                        std::to_string(layout.size()));
  }
  Eigen::MatrixXd inertial(layout.n, 10);
  for (int i = 0; i < layout.n; ++i) inertial.row(i) = pi.segment<10>(layout.inertial(i)).transpose();
  return with_armature(with_inertial_parameters(nominal, inertial), pi.segment(layout.armature(0), layout.n));
}

// ---------------------------------------------------------------------------------------------
// The fit
// ---------------------------------------------------------------------------------------------

DynamicFitResult identify_dynamics(const RobotModel& nominal, const JointSamples& samples,
                                   const DynamicFitOptions& options) {
  const Timer timer;
  DynamicFitResult result;
  const LogSplit split = split_log(nominal, samples, options, result.log);
  const Prepared& data = split.data;
  const std::vector<int>& fit_columns = split.fit;
  const std::vector<int>& holdout_columns = split.holdout;
  const int n = nominal.dof();
  const ParameterLayout layout = parameter_layout(nominal);
  const int p = layout.size();
  result.base = base_parameters(nominal, 100, options.seed);
  const BaseParameters& base = result.base;
  const int r = base.count;
  check_length(result.log, n, r, "base parameters", options);
  const std::vector<int>& joint_of = split.row_joint;
  const int rows = result.log.fit_torques;

  // Step 4: the stacked regressor, Coulomb's columns filtered as τ is; a row for each joint that
  // moves at each fit sample.
  RegressorWorkspace workspace(nominal);
  RowMajorMatrix W(rows, p);
  Eigen::VectorXd y(rows);
  for (int row = 0; row < rows;) {
    const int s = split.row_sample[static_cast<size_t>(row)];
    const int c = fit_columns[static_cast<size_t>(s)];
    const Eigen::MatrixXd& Y =
        joint_torque_regressor(nominal, workspace, data.q.col(c), data.qd.col(c), data.qdd.col(c));
    for (; row < rows && split.row_sample[static_cast<size_t>(row)] == s; ++row) {
      const int i = joint_of[static_cast<size_t>(row)];
      W.row(row) = Y.row(i);
      W(row, layout.coulomb(i)) = data.coulomb(i, c);
      y[row] = data.tau_filtered(i, c);
    }
  }
  Eigen::MatrixXd W_b(rows, r);
  for (int k = 0; k < r; ++k) W_b.col(k) = W.col(base.independent[static_cast<size_t>(k)]);

  const Eigen::HouseholderQR<Eigen::MatrixXd> ols(W_b);
  const Eigen::VectorXd sigma = floored(joint_rms(y - W_b * ols.solve(y), joint_of, n));
  const Eigen::HouseholderQR<Eigen::MatrixXd> wls(whitened(W_b, sigma, joint_of));
  result.beta_wls = wls.solve(whitened(y, sigma, joint_of));

  // Excitation: the singular values of the weighted W_b with unit columns (those of R D⁻¹).
  {
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd = unit_column_svd(wls, r);
    const Eigen::VectorXd& s = svd.singularValues();
    result.condition_number_scaled = s[0] / s[r - 1];
    result.rank = 0;
    while (result.rank < r && s[result.rank] * options.max_condition > s[0]) ++result.rank;
    if (result.rank < r) {
      // The direction the log leaves undetermined, its largest terms first.
      const Eigen::VectorXd v = svd.matrixV().col(r - 1);
      std::vector<int> order(static_cast<size_t>(r));
      for (int k = 0; k < r; ++k) order[static_cast<size_t>(k)] = k;
      std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(v[a]) > std::abs(v[b]); });
      std::string combination;
      for (size_t m = 0; m < std::min<size_t>(3, order.size()); ++m) {
        const int k = order[m];
        combination += (m > 0 ? (v[k] * v[order[0]] < 0.0 ? " - " : " + ") : "") + number(std::abs(v[k]), 2) + "*(" +
                       base_parameter_expression(nominal, base, k) + ")";
      }
      throw IdentificationError(
          "the log does not excite the arm: the torques determine " + std::to_string(result.rank) + " of its " +
          std::to_string(r) + " base parameters (condition number " + number(result.condition_number_scaled) +
          " with unit columns, above " + number(options.max_condition) + "); the least determined combination is " +
          combination + "; run an excitation trajectory that moves every joint faster and farther");
    }
  }
  {
    const Eigen::MatrixXd R = ols.matrixQR().topRows(r).triangularView<Eigen::Upper>();
    const Eigen::VectorXd s = Eigen::JacobiSVD<Eigen::MatrixXd>(R).singularValues();
    result.condition_number = s[0] / s[r - 1];
  }

  // Step 5. The start: π_b = β_WLS − K π_d,nominal, each body that makes physical, the nominal else.
  result.pi_nominal = model_parameters(nominal);
  const Eigen::VectorXd& pi_nominal = result.pi_nominal;
  result.beta_nominal = base_parameter_values(base, pi_nominal);
  Eigen::VectorXd pi_start = pi_nominal;
  {
    Eigen::VectorXd pi_d(p - r);
    for (int j = 0; j < p - r; ++j) pi_d[j] = pi_nominal[base.dependent[static_cast<size_t>(j)]];
    const Eigen::VectorXd pi_b = result.beta_wls - base.K * pi_d;
    for (int k = 0; k < r; ++k) pi_start[base.independent[static_cast<size_t>(k)]] = pi_b[k];
  }
  double mean_mass = 0.0;
  for (int i = 0; i < n; ++i) mean_mass += pi_nominal[layout.inertial(i)] / n;
  const double ball_mass = 0.01 * (mean_mass > 0.0 ? mean_mass : 1.0);
  std::vector<Vector10d> theta(static_cast<size_t>(n)), nominal_theta(static_cast<size_t>(n));
  std::vector<Eigen::Vector3d> phi(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    nominal_theta[static_cast<size_t>(i)] =
        start_theta(pi_nominal.segment<10>(layout.inertial(i)), ball_mass, options.prior_length);
    try {
      theta[static_cast<size_t>(i)] = log_cholesky_from_inertia(pi_start.segment<10>(layout.inertial(i)));
    } catch (const ArgumentError&) {
      theta[static_cast<size_t>(i)] = nominal_theta[static_cast<size_t>(i)];
    }
    phi[static_cast<size_t>(i)] << std::max(0.0, pi_start[layout.viscous(i)]),
        std::max(0.0, pi_start[layout.coulomb(i)]), std::max(0.0, pi_start[layout.armature(i)]);
  }

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss huber(options.huber);
  for (int row = 0; row < rows; ++row) {
    const int i = joint_of[static_cast<size_t>(row)];
    std::vector<double*> blocks;
    for (int j = i; j < n; ++j) blocks.push_back(theta[static_cast<size_t>(j)].data());
    blocks.push_back(phi[static_cast<size_t>(i)].data());
    problem.AddResidualBlock(new TorqueRow(W.row(row).data(), layout, i, y[row], 1.0 / sigma[i]), &huber, blocks);
  }
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) problem.SetParameterLowerBound(phi[static_cast<size_t>(i)].data(), k, 0.0);
  }
  // The prior: each body's θ held to the nominal's, log-mass and log-radii as they are, the
  // centre of mass and the shape terms in units of ℓ.
  {
    ceres::Matrix A = ceres::Matrix::Zero(10, 10);
    for (int k = 0; k < 10; ++k) A(k, k) = options.prior_weight / (k < 4 ? 1.0 : options.prior_length);
    for (int i = 0; i < n; ++i) {
      problem.AddResidualBlock(new ceres::NormalPrior(A, ceres::Vector(nominal_theta[static_cast<size_t>(i)])), nullptr,
                               theta[static_cast<size_t>(i)].data());
    }
  }
  ceres::Solver::Summary summary;
  const Timer solver_timer;
  ceres::Solve(solver_options(options, rows), &problem, &summary);
  result.solver_seconds = solver_timer.seconds();
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = summary.message;
  if (!result.converged) {
    throw IdentificationError("dynamic identification: the fit did not converge (" + std::to_string(result.iterations) +
                              " iterations: " + summary.message + "); its bodies would be a guess. A log of "
                              "another arm, or one the model cannot explain (a load it does not know of, contact)?");
  }

  result.pi = Eigen::VectorXd(p);
  for (int i = 0; i < n; ++i) {
    result.pi.segment<10>(layout.inertial(i)) = inertia_from_log_cholesky(theta[static_cast<size_t>(i)]);
    result.pi[layout.viscous(i)] = phi[static_cast<size_t>(i)][0];
    result.pi[layout.coulomb(i)] = phi[static_cast<size_t>(i)][1];
    result.pi[layout.armature(i)] = phi[static_cast<size_t>(i)][2];
  }
  result.beta = base_parameter_values(base, result.pi);

  // Step 6: standard errors at the fit, each joint weighed by its own residual σ.
  result.sigma = floored(joint_rms(W_b * result.beta - y, joint_of, n));
  result.correlation_inflation = correlation_inflation(split.filter, result.log.decimation);
  result.beta_standard_error =
      standard_errors(W_b, y, result.beta, result.sigma, joint_of, result.correlation_inflation);
  std::tie(result.holdout_rms_nominal, result.holdout_rms) =
      holdout_rms(nominal, data, holdout_columns, pi_nominal, result.pi);
  result.holdout_rms_every_sample = holdout_rms(nominal, data, holdout_columns, result.pi, result.pi, true).second;
  result.seconds = timer.seconds();
  return result;
}

Eigen::VectorXd prediction_rms(const RobotModel& model, const Eigen::VectorXd& pi, const JointSamples& samples,
                               const DynamicFitOptions& options) {
  LogUse use;
  const LogSplit split = split_log(model, samples, options, use);  // its checks; its split is not used
  std::vector<int> columns;
  for (size_t s = 0; s + 1 < split.data.segment.size(); ++s) {
    for (int c = split.data.segment[s] + 1; c < split.data.segment[s + 1]; ++c) {
      if (split.data.moving.col(c).any()) columns.push_back(c);
    }
  }
  return holdout_rms(model, split.data, columns, pi, pi).second;
}

// ---------------------------------------------------------------------------------------------
// The payload
// ---------------------------------------------------------------------------------------------

Vector10d payload_parameters(const RobotModel& model, const Payload& payload) {
  const Transform& T = model.T_last_tip();
  const Vector3d c = T.linear() * payload.centre + T.translation();
  SpatialInertia G;
  G.mass = payload.mass;
  G.h = payload.mass * c;
  G.I = T.linear() * payload.inertia * T.linear().transpose() +
        payload.mass * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
  return body_parameters(G);
}

Payload payload_from_parameters(const RobotModel& model, const Vector10d& pi) {
  const SpatialInertia G = spatial_inertia(pi);
  const Transform& T = model.T_last_tip();
  const Vector3d c = G.mass > 0.0 ? Vector3d(G.h / G.mass) : Vector3d::Zero();
  Payload payload;
  payload.mass = G.mass;
  payload.centre = T.linear().transpose() * (c - T.translation());
  payload.inertia = T.linear().transpose() * inertia_about_centre_of_mass(G.mass, G.h, G.I) * T.linear();
  return payload;
}

PayloadFitResult identify_payload(const RobotModel& arm, const Eigen::VectorXd& viscous, const Eigen::VectorXd& coulomb,
                                  const JointSamples& samples, const DynamicFitOptions& options) {
  const Timer timer;
  const int n = arm.dof();
  if (viscous.size() != n || coulomb.size() != n) {
    throw ArgumentError("identify_payload: " + std::to_string(viscous.size()) + " viscous and " +
                        std::to_string(coulomb.size()) + " Coulomb friction values for a chain of " +
                        std::to_string(n) + " joints");
  }
  PayloadFitResult result;
  const LogSplit split = split_log(arm, samples, options, result.log);
  const Prepared& data = split.data;
  check_length(result.log, n, 10, "payload parameters", options);
  const ParameterLayout layout = parameter_layout(arm);
  Eigen::VectorXd pi_arm = model_parameters(arm);
  pi_arm.segment(layout.viscous(0), n) = viscous;
  pi_arm.segment(layout.coulomb(0), n) = coulomb;

  // The rows: what the known arm leaves of each filtered torque, against the last body's columns.
  const std::vector<int>& joint_of = split.row_joint;
  const int rows = result.log.fit_torques;
  RegressorWorkspace workspace(arm);
  Eigen::MatrixXd Y(n, layout.size());
  RowMajorMatrix W(rows, 10);
  Eigen::VectorXd y(rows);
  for (int row = 0; row < rows;) {
    const int s = split.row_sample[static_cast<size_t>(row)];
    const int c = split.fit[static_cast<size_t>(s)];
    Y = joint_torque_regressor(arm, workspace, data.q.col(c), data.qd.col(c), data.qdd.col(c));
    for (int i = 0; i < n; ++i) Y(i, layout.coulomb(i)) = data.coulomb(i, c);
    const Eigen::VectorXd left = data.tau_filtered.col(c) - Y * pi_arm;
    for (; row < rows && split.row_sample[static_cast<size_t>(row)] == s; ++row) {
      const int i = joint_of[static_cast<size_t>(row)];
      W.row(row) = Y.row(i).segment<10>(layout.inertial(n - 1));
      y[row] = left[i];
    }
  }
  const Eigen::MatrixXd W_dense = W;
  const Eigen::HouseholderQR<Eigen::MatrixXd> ols(W_dense);
  const Eigen::VectorXd sigma = floored(joint_rms(y - W_dense * ols.solve(y), joint_of, n));
  const Eigen::HouseholderQR<Eigen::MatrixXd> wls(whitened(W_dense, sigma, joint_of));
  result.pi_ls = wls.solve(whitened(y, sigma, joint_of));
  {
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd = unit_column_svd(wls, 10);
    const Eigen::VectorXd& s = svd.singularValues();
    result.condition_number = s[0] / s[9];
    if (result.condition_number > options.max_condition) {
      const Eigen::VectorXd v = svd.matrixV().col(9);
      Eigen::Index worst = 0;
      v.cwiseAbs().maxCoeff(&worst);
      throw IdentificationError("the log does not excite the payload: its ten parameters' columns have a condition "
                                "number of " + number(result.condition_number) + " with unit columns, above " +
                                number(options.max_condition) + ", and its " + kInertialParameterNames[worst] +
                                " is the least determined; run a trajectory that turns the wrist about every axis");
    }
  }

  // The fit from the least-squares body if it is one, else from the ball the prior holds to.
  const double ball_mass = result.pi_ls[0] > 0.0 ? result.pi_ls[0] : 1.0;
  Vector10d ball = Vector10d::Zero();
  {
    const Vector3d c =
        result.pi_ls[0] > 0.0 ? Vector3d(result.pi_ls.segment<3>(1) / result.pi_ls[0]) : Vector3d::Zero();
    SpatialInertia G;
    G.mass = ball_mass;
    G.h = ball_mass * c;
    G.I = (0.4 * ball_mass * 0.05 * 0.05 + ball_mass * c.squaredNorm()) * Matrix3d::Identity() -
          ball_mass * c * c.transpose();
    ball = body_parameters(G);
  }
  const Vector10d reference = log_cholesky_from_inertia(ball);
  Vector10d theta;
  try {
    theta = log_cholesky_from_inertia(result.pi_ls);
  } catch (const ArgumentError&) {
    theta = reference;
  }
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss huber(options.huber);
  for (int row = 0; row < rows; ++row) {
    problem.AddResidualBlock(new PayloadRow(W.row(row).data(), y[row], 1.0 / sigma[joint_of[static_cast<size_t>(row)]]),
                             &huber, theta.data());
  }
  ceres::Matrix A = ceres::Matrix::Zero(10, 10);
  for (int k = 0; k < 10; ++k) A(k, k) = options.prior_weight / (k < 4 ? 1.0 : options.prior_length);
  problem.AddResidualBlock(new ceres::NormalPrior(A, ceres::Vector(reference)), nullptr, theta.data());
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(options, rows), &problem, &summary);
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = summary.message;
  if (!summary.IsSolutionUsable()) {
    throw IdentificationError("payload identification: the solver failed: " + summary.message);
  }
  result.pi = inertia_from_log_cholesky(theta);
  result.payload = payload_from_parameters(arm, result.pi);
  result.sigma = floored(joint_rms(W_dense * result.pi - y, joint_of, n));
  result.correlation_inflation = correlation_inflation(split.filter, result.log.decimation);
  result.standard_error = standard_errors(W_dense, y, result.pi, result.sigma, joint_of, result.correlation_inflation);
  result.mass_standard_error = result.standard_error[0];

  Eigen::VectorXd pi_with = pi_arm;
  pi_with.segment<10>(layout.inertial(n - 1)) += result.pi;
  std::tie(result.holdout_rms_without, result.holdout_rms) = holdout_rms(arm, data, split.holdout, pi_arm, pi_with);
  result.seconds = timer.seconds();
  return result;
}

}  // namespace chasles
