#include "core/calibration/calibration.hpp"

#include <ceres/ceres.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>

#include "core/lie/jacobians.hpp"

namespace chasles {

namespace {

using RowMajorXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

const char* const kComponent[6] = {"wx", "wy", "wz", "vx", "vy", "vz"};

/// The joint's own screw axis A_i in its frame: (axis, 0) revolute, (0, axis) prismatic.
Vector6d local_screw(const Joint& joint) {
  Vector6d A;
  if (joint.type == JointType::Prismatic) {
    A << Vector3d::Zero(), joint.axis;
  } else {
    A << joint.axis, Vector3d::Zero();
  }
  return A;
}

/// exp([A] t) for a joint's unit screw: a rotation about or a translation along the axis.
Transform joint_motion(const Joint& joint, double t) {
  if (joint.type == JointType::Prismatic) return Transform(Matrix3d::Identity(), joint.axis * t);
  return Transform(exp3_unit(joint.axis, t), Vector3d::Zero());
}

Matrix3d project_to_rotation(const Matrix3d& M) {
  const Eigen::JacobiSVD<Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3d D = Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

std::string format_number(double x) {
  std::ostringstream out;
  out.precision(3);
  out << x;
  return out.str();
}

std::string line_range(const std::vector<Measurement>& rows) {
  int first = std::numeric_limits<int>::max(), last = 0;
  for (const Measurement& m : rows) {
    if (m.line <= 0) continue;
    first = std::min(first, m.line);
    last = std::max(last, m.line);
  }
  if (last == 0) return "";
  return " (lines " + std::to_string(first) + "-" + std::to_string(last) + ")";
}

std::string where(const Measurement& m, size_t index) {
  return m.line > 0 ? "line " + std::to_string(m.line) : "row " + std::to_string(index);
}

void check_rows(const RobotModel& model, const std::vector<Measurement>& rows, const char* set) {
  for (size_t k = 0; k < rows.size(); ++k) {
    const Measurement& m = rows[k];
    const std::string at = std::string(set) + " " + where(m, k) + ": ";
    if (m.q.size() != model.dof()) {
      throw CalibrationError(at + std::to_string(m.q.size()) + " joint positions, expected " +
                             std::to_string(model.dof()));
    }
    if (!m.q.allFinite() || !m.p_tracker_marker.allFinite()) throw CalibrationError(at + "a value is not finite");
    if (m.has_orientation) {
      const Matrix3d& R = m.R_tracker_marker;
      if (!R.allFinite() || (R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
          std::abs(R.determinant() - 1.0) > 1e-6) {
        throw CalibrationError(at + "the orientation is not a rotation");
      }
    }
  }
}

}  // namespace

// --- corrections and prediction ------------------------------------------------------------------

KinematicCorrections KinematicCorrections::zero(const RobotModel& model) {
  KinematicCorrections c;
  c.origin.assign(static_cast<size_t>(model.dof()), Vector6d::Zero());
  c.offset = Eigen::VectorXd::Zero(model.dof());
  return c;
}

RobotModel corrected_model(const RobotModel& nominal, const KinematicCorrections& corrections) {
  const int n = nominal.dof();
  if (static_cast<int>(corrections.origin.size()) != n || corrections.offset.size() != n) {
    throw ArgumentError("corrected_model: one origin twist and one offset per joint are required");
  }
  ChainDescription d = nominal.description();
  for (int i = 0; i < n; ++i) {
    Joint& joint = d.joints[static_cast<size_t>(i)];
    joint.T_parent_joint = joint.T_parent_joint * exp6(corrections.origin[static_cast<size_t>(i)]) *
                           joint_motion(joint, corrections.offset[i]);
  }
  return RobotModel(std::move(d));
}

Transform predict_marker(const RobotModel& corrected, const KinematicCorrections& corrections, const JointVector& q) {
  return corrections.T_tracker_base * forward_kinematics_space(corrected, q) * corrections.T_tip_marker;
}

// --- parameters ---------------------------------------------------------------------------------

std::string CalibrationLayout::name(const RobotModel& model, int index) const {
  if (index < 6 * n) return model.joint(index / 6).name + ".origin." + kComponent[index % 6];
  if (index < 7 * n) return model.joint(index - 6 * n).name + ".offset";
  if (index < 7 * n + 6) return std::string("base.") + kComponent[index - 7 * n];
  return std::string("tool.") + kComponent[index - 7 * n - 6];
}

const char* CalibrationLayout::unit(const RobotModel& model, int index) const {
  if (index >= 6 * n && index < 7 * n) {
    return model.joint(index - 6 * n).type == JointType::Prismatic ? "m" : "rad";
  }
  const int k = index < 6 * n ? index % 6 : (index - 7 * n) % 6;
  return k < 3 ? "rad" : "m";
}

// --- the measurement function --------------------------------------------------------------------

MeasurementModel::MeasurementModel(const RobotModel& nominal, const Transform& T_tracker_base,
                                   const Transform& T_tip_marker, double sigma_position, double sigma_rotation)
    : nominal_(nominal), B0_(T_tracker_base), K0_(T_tip_marker), sigma_p_(sigma_position), sigma_r_(sigma_rotation) {
  if (!(sigma_position > 0.0) || !(sigma_rotation > 0.0) || !std::isfinite(sigma_position) ||
      !std::isfinite(sigma_rotation)) {
    throw CalibrationError("the noise levels sigma_position and sigma_rotation must be positive and finite");
  }
  layout_.n = nominal.dof();
  const size_t n = static_cast<size_t>(nominal.dof());
  for (const Joint& joint : nominal.joints()) A_.push_back(local_screw(joint));
  C_.resize(n);
  E_.resize(n);
  P_.resize(n);
  J_body_.resize(6, layout_.size());
}

void MeasurementModel::evaluate(const double* x_data, const Measurement& m, bool use_orientation, double* residual,
                                double* jacobian) const {
  const int n = layout_.n, p = layout_.size();
  const Eigen::Map<const Eigen::VectorXd> x(x_data, p);
  for (int i = 0; i < n; ++i) {
    const size_t s = static_cast<size_t>(i);
    C_[s] = nominal_.joint(i).T_parent_joint * exp6(x.segment<6>(layout_.origin(i, 0)));
    E_[s] = joint_motion(nominal_.joint(i), m.q[i] + x[layout_.offset(i)]);
  }
  const Vector6d beta = x.segment<6>(layout_.base(0)), tau = x.segment<6>(layout_.tool(0));
  // Backwards from the marker: P_i is the pose of the marker in joint frame i (after e^[δξ_i],
  // before the joint's motion); what is left at the end is the marker in the base frame.
  Transform P = nominal_.T_last_tip() * (K0_ * exp6(tau));
  for (int i = n - 1; i >= 0; --i) {
    const size_t s = static_cast<size_t>(i);
    P = E_[s] * P;
    P_[s] = P;
    P = C_[s] * P;
  }
  const Transform T_base = B0_ * exp6(beta);
  const Transform T = T_base * P;  // T_tracker_marker

  const bool pose = m.has_orientation && use_orientation;
  Vector3d phi = Vector3d::Zero();
  if (pose) {
    phi = log3(m.R_tracker_marker.transpose() * T.linear());
    Eigen::Map<Vector6d> r(residual);
    r.head<3>() = phi / sigma_r_;
    r.tail<3>() = (T.translation() - m.p_tracker_marker) / sigma_p_;
  } else {
    Eigen::Map<Vector3d> r(residual);
    r = (T.translation() - m.p_tracker_marker) / sigma_p_;
  }
  if (jacobian == nullptr) return;

  // Each parameter as a body twist of the marker: a twist η applied in frame F moves the marker by
  // [Ad_{T_F,marker⁻¹}] η in its own frame.
  Eigen::Matrix<double, 6, Eigen::Dynamic>& J_body = J_body_;
  for (int i = 0; i < n; ++i) {
    const size_t s = static_cast<size_t>(i);
    J_body.middleCols<6>(layout_.origin(i, 0)).noalias() =
        adjoint(inverse(P_[s])) * se3_right_jacobian(x.segment<6>(layout_.origin(i, 0)));
    // e^[A(q + δθ)]: A is invariant under its own motion, so the twist may be taken before it.
    J_body.col(layout_.offset(i)) = adjoint_inverse_times(P_[s], A_[s]);
  }
  J_body.middleCols<6>(layout_.base(0)).noalias() = adjoint(inverse(P)) * se3_right_jacobian(beta);
  J_body.middleCols<6>(layout_.tool(0)) = se3_right_jacobian(tau);

  // Position: ṗ = R v_body in the tracker frame. Rotation: log(R_measᵀ R e^[ω]) ≈ φ + Jr⁻¹(φ) ω.
  if (pose) {
    Eigen::Map<RowMajorXd> J(jacobian, 6, p);
    J.topRows<3>().noalias() = (so3_right_jacobian_inverse(phi) / sigma_r_) * J_body.topRows<3>();
    J.bottomRows<3>().noalias() = (T.linear() / sigma_p_) * J_body.bottomRows<3>();
  } else {
    Eigen::Map<RowMajorXd> J(jacobian, 3, p);
    J.noalias() = (T.linear() / sigma_p_) * J_body.bottomRows<3>();
  }
}

Transform MeasurementModel::predict(const Eigen::Ref<const Eigen::VectorXd>& x, const JointVector& q) const {
  const KinematicCorrections c = corrections(x);
  Transform T = c.T_tracker_base;
  for (int i = 0; i < layout_.n; ++i) {
    T = T * nominal_.joint(i).T_parent_joint * exp6(c.origin[static_cast<size_t>(i)]) *
        joint_motion(nominal_.joint(i), q[i] + c.offset[i]);
  }
  return T * nominal_.T_last_tip() * c.T_tip_marker;
}

KinematicCorrections MeasurementModel::corrections(const Eigen::Ref<const Eigen::VectorXd>& x) const {
  if (x.size() != layout_.size()) throw ArgumentError("parameter vector of the wrong size");
  KinematicCorrections c = KinematicCorrections::zero(nominal_);
  for (int i = 0; i < layout_.n; ++i) {
    c.origin[static_cast<size_t>(i)] = x.segment<6>(layout_.origin(i, 0));
    c.offset[i] = x[layout_.offset(i)];
  }
  c.T_tracker_base = B0_ * exp6(x.segment<6>(layout_.base(0)));
  c.T_tip_marker = K0_ * exp6(x.segment<6>(layout_.tool(0)));
  return c;
}

// --- identifiability -----------------------------------------------------------------------------

int theoretical_identifiable_count(const RobotModel& model, bool pose_data) {
  int count = pose_data ? 6 : 3;
  for (const Joint& joint : model.joints()) count += joint.type == JointType::Prismatic ? 2 : 4;
  return count;
}

namespace {

int residual_count(const std::vector<Measurement>& rows, bool use_orientation) {
  int m = 0;
  for (const Measurement& row : rows) m += MeasurementModel::residual_size(row, use_orientation);
  return m;
}

bool any_orientation(const std::vector<Measurement>& rows, bool use_orientation) {
  if (!use_orientation) return false;
  for (const Measurement& row : rows) {
    if (row.has_orientation) return true;
  }
  return false;
}

Eigen::MatrixXd stacked_jacobian(const MeasurementModel& model, const std::vector<Measurement>& rows,
                                 const Eigen::VectorXd& x, bool use_orientation) {
  const int p = model.num_parameters();
  Eigen::MatrixXd J(residual_count(rows, use_orientation), p);
  RowMajorXd block(6, p);
  double r[6];
  Eigen::Index row = 0;
  for (const Measurement& m : rows) {
    const int k = MeasurementModel::residual_size(m, use_orientation);
    model.evaluate(x.data(), m, use_orientation, r, block.data());
    J.middleRows(row, k) = block.topRows(k);
    row += k;
  }
  return J;
}

/// The order in which parameters are offered a free place: the base and tool (always meaningful
/// to a user), the joint zero offsets (what an encoder gets wrong), then the joint origins from the
/// tip down, so that a redundancy between neighbours fixes the upstream joint's component.
std::vector<int> preference_order(const CalibrationLayout& layout) {
  std::vector<int> order;
  for (int k = 0; k < 6; ++k) order.push_back(layout.base(k));
  for (int k = 0; k < 6; ++k) order.push_back(layout.tool(k));
  for (int i = 0; i < layout.n; ++i) order.push_back(layout.offset(i));
  for (int i = layout.n - 1; i >= 0; --i) {
    for (int k = 0; k < 6; ++k) order.push_back(layout.origin(i, k));
  }
  return order;
}

double smallest_singular_value(const Eigen::MatrixXd& R, const std::vector<int>& columns) {
  Eigen::MatrixXd sub(R.rows(), static_cast<Eigen::Index>(columns.size()));
  for (size_t c = 0; c < columns.size(); ++c) sub.col(static_cast<Eigen::Index>(c)) = R.col(columns[c]);
  return Eigen::JacobiSVD<Eigen::MatrixXd>(sub).singularValues().minCoeff();
}

}  // namespace

Identifiability analyse_identifiability(const MeasurementModel& model, const std::vector<Measurement>& rows,
                                        const Eigen::VectorXd& x, bool use_orientation, double tolerance) {
  const RobotModel& robot = model.nominal();
  const CalibrationLayout& layout = model.layout();
  const int p = layout.size();
  if (!(tolerance > 0.0 && tolerance < 1.0)) throw CalibrationError("the rank tolerance must be in (0, 1)");
  const int m = residual_count(rows, use_orientation);
  if (m <= p) {
    throw CalibrationError(std::to_string(rows.size()) + " rows" + line_range(rows) + " give " + std::to_string(m) +
                           " residuals, not more than the " + std::to_string(p) +
                           " parameters of the model: measure more configurations");
  }
  Identifiability out;
  out.num_parameters = p;
  out.tolerance = tolerance;
  out.theoretical = theoretical_identifiable_count(robot, any_orientation(rows, use_orientation));

  // Columns scaled to unit norm: the rank must not depend on metres versus radians.
  Eigen::MatrixXd J = stacked_jacobian(model, rows, x, use_orientation);
  const Eigen::VectorXd norms = J.colwise().norm().transpose();
  const double largest = norms.maxCoeff();
  std::vector<bool> no_effect(static_cast<size_t>(p), false);
  for (int j = 0; j < p; ++j) {
    if (norms[j] <= 1e-12 * largest) {
      no_effect[static_cast<size_t>(j)] = true;
      J.col(j).setZero();
    } else {
      J.col(j) /= norms[j];
    }
  }
  // Everything below works on R of J = QR (p × p): the same singular values, a fraction of the rows.
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(J);
  const Eigen::MatrixXd R = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  const Eigen::VectorXd sigma = Eigen::JacobiSVD<Eigen::MatrixXd>(R).singularValues();
  const double sigma_max = sigma[0];
  out.singular_values = sigma / sigma_max;
  out.rank = static_cast<int>((out.singular_values.array() >= tolerance).count());

  std::vector<int> chosen;
  for (int j : preference_order(layout)) {
    if (no_effect[static_cast<size_t>(j)]) continue;
    chosen.push_back(j);
    if (smallest_singular_value(R, chosen) < tolerance * sigma_max) chosen.pop_back();
  }
  out.free = chosen;
  std::sort(out.free.begin(), out.free.end());

  // Explain each fixed parameter by the free combination that reproduces its column.
  Eigen::MatrixXd R_free(p, static_cast<Eigen::Index>(out.free.size()));
  for (size_t c = 0; c < out.free.size(); ++c) R_free.col(static_cast<Eigen::Index>(c)) = R.col(out.free[c]);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> free_qr(R_free);
  for (int j = 0; j < p; ++j) {
    if (std::binary_search(out.free.begin(), out.free.end(), j)) continue;
    FixedParameter f;
    f.index = j;
    const std::string name = layout.name(robot, j);
    if (no_effect[static_cast<size_t>(j)]) {
      f.reason = FixedParameter::Reason::NoEffect;
      f.misfit = 1.0;
      f.explanation = name + ": the measurements do not depend on it" +
                      (j >= layout.tool(0) && j < layout.tool(3) && !any_orientation(rows, use_orientation)
                           ? " (position data carry no marker orientation)"
                           : "");
      out.fixed.push_back(std::move(f));
      continue;
    }
    const Eigen::VectorXd c = free_qr.solve(R.col(j));
    f.misfit = (R_free * c - R.col(j)).norm();
    f.reason = f.misfit < 1e-8 ? FixedParameter::Reason::Redundant : FixedParameter::Reason::PoorlyObservable;
    std::vector<int> order(static_cast<size_t>(c.size()));
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(c[a]) > std::abs(c[b]); });
    const double biggest = order.empty() ? 0.0 : std::abs(c[order[0]]);
    std::string terms;
    for (int k : order) {
      if (std::abs(c[k]) < 0.05 * biggest || f.equivalent.size() >= 4) break;
      const int free_index = out.free[static_cast<size_t>(k)];
      // Back to physical units: column_j = Σ c_k (n_j / n_k) column_k of the unscaled Jacobian.
      const double coefficient = c[k] * norms[j] / norms[free_index];
      f.equivalent.emplace_back(free_index, coefficient);
      terms += (terms.empty() ? "" : coefficient < 0.0 ? " - " : " + ") +
               format_number(terms.empty() ? coefficient : std::abs(coefficient)) + " " +
               layout.name(robot, free_index);
    }
    if (f.reason == FixedParameter::Reason::Redundant) {
      f.explanation = name + ": redundant, a change of it acts like " + terms;
    } else {
      f.explanation = name + ": nearly redundant (misfit " + format_number(f.misfit) +
                      "), these configurations do not separate it from " + terms;
    }
    out.fixed.push_back(std::move(f));
  }
  return out;
}

const char* to_string(LossType loss) {
  switch (loss) {
    case LossType::None: return "none";
    case LossType::Huber: return "huber";
    case LossType::Cauchy: return "cauchy";
  }
  return "unknown";
}

// --- statistics and the split ------------------------------------------------------------------

std::vector<bool> holdout_split(int rows, double fraction, std::uint64_t seed) {
  if (!(fraction >= 0.0 && fraction < 1.0)) throw CalibrationError("the held-out fraction must be in [0, 1)");
  if (rows < 0) throw CalibrationError("negative row count");
  // splitmix64: the same sequence everywhere (std:: distributions are implementation-defined).
  std::uint64_t state = seed;
  auto next = [&state]() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  std::vector<int> order(static_cast<size_t>(rows));
  std::iota(order.begin(), order.end(), 0);
  for (int i = rows - 1; i > 0; --i) {
    std::swap(order[static_cast<size_t>(i)], order[next() % static_cast<std::uint64_t>(i + 1)]);
  }
  const int held = static_cast<int>(std::lround(fraction * rows));
  std::vector<bool> out(static_cast<size_t>(rows), false);
  for (int k = 0; k < held; ++k) out[static_cast<size_t>(order[static_cast<size_t>(k)])] = true;
  return out;
}

ResidualStats residual_stats(const RobotModel& corrected, const KinematicCorrections& corrections,
                             const std::vector<Measurement>& rows, bool use_orientation,
                             const std::vector<int>& excluded) {
  ResidualStats s;
  double sum_p = 0.0, sum_r = 0.0;
  int rotations = 0;
  for (size_t k = 0; k < rows.size(); ++k) {
    if (std::find(excluded.begin(), excluded.end(), static_cast<int>(k)) != excluded.end()) {
      ++s.outliers;
      continue;
    }
    const Measurement& m = rows[k];
    const Transform T = predict_marker(corrected, corrections, m.q);
    const double e_p = (T.translation() - m.p_tracker_marker).norm();
    sum_p += e_p * e_p;
    s.max_position = std::max(s.max_position, e_p);
    if (use_orientation && m.has_orientation) {
      const double e_r = log3(m.R_tracker_marker.transpose() * T.linear()).norm();
      sum_r += e_r * e_r;
      s.max_rotation = std::max(s.max_rotation, e_r);
      ++rotations;
    }
    ++s.rows;
  }
  s.rms_position = s.rows > 0 ? std::sqrt(sum_p / s.rows) : 0.0;
  if (rotations > 0) {
    s.rms_rotation = std::sqrt(sum_r / rotations);
  } else {
    s.rms_rotation = s.max_rotation = std::numeric_limits<double>::quiet_NaN();
  }
  return s;
}

// --- the fit ------------------------------------------------------------------------------------

namespace {

/// One row's whitened residual for Ceres; the Jacobian is the MeasurementModel's.
class RowCost final : public ceres::CostFunction {
 public:
  RowCost(const MeasurementModel& model, const Measurement& row, bool use_orientation)
      : model_(model), row_(row), use_orientation_(use_orientation) {
    set_num_residuals(MeasurementModel::residual_size(row, use_orientation));
    mutable_parameter_block_sizes()->push_back(model.num_parameters());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    model_.evaluate(parameters[0], row_, use_orientation_, residuals,
                    jacobians != nullptr ? jacobians[0] : nullptr);
    return true;
  }

 private:
  const MeasurementModel& model_;
  const Measurement& row_;
  bool use_orientation_;
};

std::unique_ptr<ceres::LossFunction> make_loss(LossType type, double scale) {
  switch (type) {
    case LossType::Huber: return std::make_unique<ceres::HuberLoss>(scale);
    case LossType::Cauchy: return std::make_unique<ceres::CauchyLoss>(scale);
    case LossType::None: break;
  }
  return nullptr;
}

/// A least-squares problem over x with only `free` parameters moving.
class Fit {
 public:
  Fit(const MeasurementModel& model, const std::vector<Measurement>& rows, bool use_orientation,
      Eigen::VectorXd& x, const std::vector<int>& free) {
    const int p = model.num_parameters();
    std::vector<int> constant;
    for (int j = 0; j < p; ++j) {
      if (!std::binary_search(free.begin(), free.end(), j)) constant.push_back(j);
    }
    ceres::Problem::Options options;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_ = std::make_unique<ceres::Problem>(options);
    loss_ = std::make_unique<ceres::LossFunctionWrapper>(nullptr, ceres::DO_NOT_TAKE_OWNERSHIP);
    for (const Measurement& row : rows) {
      problem_->AddResidualBlock(new RowCost(model, row, use_orientation), loss_.get(), x.data());
    }
    if (!constant.empty()) {
      manifold_ = std::make_unique<ceres::SubsetManifold>(p, constant);
      problem_->SetManifold(x.data(), manifold_.get());
    }
    x_ = x.data();
  }

  /// Solves from the current x; `tolerance` is Ceres's relative function tolerance.
  ceres::Solver::Summary solve(LossType type, double scale, int max_iterations, double tolerance = 1e-14) {
    current_loss_ = make_loss(type, scale);
    loss_->Reset(current_loss_.get(), ceres::DO_NOT_TAKE_OWNERSHIP);
    ceres::Solver::Options so;
    so.minimizer_type = ceres::TRUST_REGION;
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    so.linear_solver_type = ceres::DENSE_QR;
    so.num_threads = 1;
    so.max_num_iterations = max_iterations;
    so.logging_type = ceres::SILENT;
    // Noise-free data must converge to round-off, so the tolerances are far below Ceres's defaults;
    // Levenberg-Marquardt's quadratic convergence makes that a step or two more.
    so.function_tolerance = tolerance;
    so.parameter_tolerance = tolerance;
    so.gradient_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(so, problem_.get(), &summary);
    return summary;
  }

  ceres::Problem& problem() { return *problem_; }
  double* parameters() { return x_; }

 private:
  std::unique_ptr<ceres::Problem> problem_;
  std::unique_ptr<ceres::LossFunctionWrapper> loss_;
  std::unique_ptr<ceres::LossFunction> current_loss_;
  std::unique_ptr<ceres::Manifold> manifold_;
  double* x_ = nullptr;
};

/// T with R a, t: min Σ |R a_k + t − b_k|² (Kabsch; Horn 1987 in matrix form).
Transform register_points(const std::vector<Vector3d>& a, const std::vector<Vector3d>& b) {
  Vector3d a_mean = Vector3d::Zero(), b_mean = Vector3d::Zero();
  for (size_t k = 0; k < a.size(); ++k) {
    a_mean += a[k];
    b_mean += b[k];
  }
  a_mean /= static_cast<double>(a.size());
  b_mean /= static_cast<double>(b.size());
  Matrix3d H = Matrix3d::Zero();
  for (size_t k = 0; k < a.size(); ++k) H += (b[k] - b_mean) * (a[k] - a_mean).transpose();
  const Eigen::JacobiSVD<Matrix3d> svd(H);
  const Eigen::Vector3d s = svd.singularValues();
  if (s[1] <= 1e-9 * std::max(s[0], 1e-300)) {
    throw CalibrationError("the measured positions lie (nearly) on a line: the tracker frame cannot be registered");
  }
  const Matrix3d R = project_to_rotation(H);
  return Transform(R, b_mean - R * a_mean);
}

/// A first guess of base and tool for the nominal robot: register the tip positions, then solve
/// the tool position (and orientation, from pose rows) in closed form, a few times over.
void initial_registration(const RobotModel& nominal, const std::vector<Measurement>& rows, bool use_orientation,
                          Transform& T_tracker_base, Transform& T_tip_marker) {
  std::vector<Transform> T_fk;
  T_fk.reserve(rows.size());
  for (const Measurement& m : rows) T_fk.push_back(forward_kinematics_space(nominal, m.q));
  std::vector<Vector3d> a(rows.size()), b(rows.size());
  for (size_t k = 0; k < rows.size(); ++k) b[k] = rows[k].p_tracker_marker;
  Transform tool = Transform::Identity();
  Transform base;
  for (int pass = 0; pass < 3; ++pass) {
    for (size_t k = 0; k < rows.size(); ++k) a[k] = T_fk[k] * tool.translation();
    base = register_points(a, b);
    // The marker's orientation in the tip frame: the chordal mean of (R_base R_fk)ᵀ R_meas.
    Matrix3d sum = Matrix3d::Zero();
    bool oriented = false;
    for (size_t k = 0; k < rows.size(); ++k) {
      if (!use_orientation || !rows[k].has_orientation) continue;
      sum += (base.linear() * T_fk[k].linear()).transpose() * rows[k].R_tracker_marker;
      oriented = true;
    }
    if (oriented) tool.linear() = project_to_rotation(sum);
    // p_meas = R_B (R_fk p_tool + p_fk) + t: linear in (p_tool, t).
    Eigen::MatrixXd A(3 * static_cast<Eigen::Index>(rows.size()), 6);
    Eigen::VectorXd y(A.rows());
    for (size_t k = 0; k < rows.size(); ++k) {
      const Eigen::Index r = 3 * static_cast<Eigen::Index>(k);
      A.block<3, 3>(r, 0) = base.linear() * T_fk[k].linear();
      A.block<3, 3>(r, 3) = Matrix3d::Identity();
      y.segment<3>(r) = b[k] - base.linear() * T_fk[k].translation();
    }
    const Eigen::VectorXd solution = A.colPivHouseholderQr().solve(y);
    tool.translation() = solution.head<3>();
  }
  T_tracker_base = base;
  T_tip_marker = tool;
}

}  // namespace

CalibrationResult calibrate(const RobotModel& nominal, const std::vector<Measurement>& fit,
                            const std::vector<Measurement>& holdout, const CalibrationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (!(options.loss_scale > 0.0) || !std::isfinite(options.loss_scale)) {
    throw CalibrationError("the loss scale must be positive and finite");
  }
  if (options.max_iterations < 1) throw CalibrationError("at least one iteration is needed");
  if (!(options.outlier_threshold > 0.0)) throw CalibrationError("the outlier threshold must be positive");
  check_rows(nominal, fit, "fit");
  check_rows(nominal, holdout, "held-out");
  const bool use_orientation = options.use_orientation;

  CalibrationResult result;
  result.layout.n = nominal.dof();
  const CalibrationLayout& layout = result.layout;
  const int p = layout.size();
  result.pose_data = any_orientation(fit, use_orientation);
  const int m = residual_count(fit, use_orientation);
  if (m <= p) {
    const int per_row = result.pose_data ? 6 : 3;
    throw CalibrationError(std::to_string(fit.size()) + " fit rows" + line_range(fit) + " give " + std::to_string(m) +
                           " residuals, not more than the model's " + std::to_string(p) +
                           " parameters: at least " + std::to_string(p / per_row + 1) +
                           " rows are needed to fit, and several times that for a good fit");
  }

  // 1. The nominal robot's best base and tool: the "before" model.
  Transform B0, K0;
  initial_registration(nominal, fit, use_orientation, B0, K0);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(p);
  {
    const MeasurementModel model(nominal, B0, K0, options.sigma_position, options.sigma_rotation);
    std::vector<int> free;
    for (int k = 0; k < 6; ++k) free.push_back(layout.base(k));
    for (int k = result.pose_data ? 0 : 3; k < 6; ++k) free.push_back(layout.tool(k));
    Fit stage(model, fit, use_orientation, x, free);
    // The nominal robot misses its measurements by model error, far beyond σ: Cauchy's weights
    // would treat every row as an outlier and crawl. Huber (or none, as asked) is convex here and
    // settles quickly; a start and a "before" figure need no more.
    const LossType loss = options.loss == LossType::None ? LossType::None : LossType::Huber;
    stage.solve(loss, options.loss_scale, options.max_iterations, 1e-10);
    result.before = model.corrections(x);
  }

  // 2-3. Identifiability about the before model, then the free parameters.
  const MeasurementModel model(nominal, result.before.T_tracker_base, result.before.T_tip_marker,
                               options.sigma_position, options.sigma_rotation);
  x.setZero();
  result.identifiability = analyse_identifiability(model, fit, x, use_orientation, options.rank_tolerance);
  const std::vector<int>& free = result.identifiability.free;
  Fit stage(model, fit, use_orientation, x, free);
  if (options.loss == LossType::Cauchy) {
    const ceres::Solver::Summary s = stage.solve(LossType::Huber, options.loss_scale, options.max_iterations);
    result.iterations += static_cast<int>(s.iterations.size());
  }
  const ceres::Solver::Summary summary = stage.solve(options.loss, options.loss_scale, options.max_iterations);
  result.iterations += static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = summary.message;
  result.x = x;
  result.after = model.corrections(x);
  const int r = static_cast<int>(free.size());
  result.sigma0 = std::sqrt(2.0 * summary.final_cost / std::max(1, m - r));

  // 4. Standard deviations of the free parameters.
  result.stddev = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::quiet_NaN());
  if (options.covariance) {
    ceres::Covariance::Options co;
    // SPARSE_QR (SuiteSparseQR): the free set is well conditioned by construction, so no SVD is
    // needed. DENSE_SVD would run Eigen's BDCSVD inside the prebuilt libceres, whose JacobiSVD
    // instantiation the linker shares with ours; under AddressSanitizer Eigen allocates with
    // its own alignment offset (it does not trust ASan's malloc), and the two copies then free
    // each other's memory.
    co.algorithm_type = ceres::SPARSE_QR;
    co.num_threads = 1;
    ceres::Covariance covariance(co);
    const double* block = stage.parameters();
    std::vector<std::pair<const double*, const double*>> blocks{{block, block}};
    if (covariance.Compute(blocks, &stage.problem())) {
      RowMajorXd C(p, p);
      if (covariance.GetCovarianceBlock(block, block, C.data())) {
        result.covariance_ok = true;
        for (int j = 0; j < p; ++j) result.stddev[j] = std::sqrt(std::max(0.0, C(j, j))) * result.sigma0;
      }
    }
  }

  // Outliers under the calibrated model, then the statistics without them.
  auto whitened_norms = [&](const std::vector<Measurement>& rows) {
    std::vector<double> norms;
    double res[6];
    for (const Measurement& row : rows) {
      model.evaluate(x.data(), row, use_orientation, res, nullptr);
      norms.push_back(Eigen::Map<Eigen::VectorXd>(res, MeasurementModel::residual_size(row, use_orientation)).norm());
    }
    return norms;
  };
  const std::vector<double> fit_norms = whitened_norms(fit), holdout_norms = whitened_norms(holdout);
  std::vector<double> sorted = fit_norms;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double threshold = std::max(options.outlier_threshold, 5.0 * sorted[sorted.size() / 2]);
  for (size_t k = 0; k < fit_norms.size(); ++k) {
    if (fit_norms[k] > threshold) result.fit_outliers.push_back(static_cast<int>(k));
  }
  for (size_t k = 0; k < holdout_norms.size(); ++k) {
    if (holdout_norms[k] > threshold) result.holdout_outliers.push_back(static_cast<int>(k));
  }
  const RobotModel before_model = corrected_model(nominal, result.before);
  const RobotModel after_model = corrected_model(nominal, result.after);
  result.fit_before = residual_stats(before_model, result.before, fit, result.pose_data, result.fit_outliers);
  result.fit_after = residual_stats(after_model, result.after, fit, result.pose_data, result.fit_outliers);
  result.holdout_before =
      residual_stats(before_model, result.before, holdout, result.pose_data, result.holdout_outliers);
  result.holdout_after = residual_stats(after_model, result.after, holdout, result.pose_data, result.holdout_outliers);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace chasles
