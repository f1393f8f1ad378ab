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

#include "core/identification/log_cholesky.hpp"
#include "core/identification/zero_phase_filter.hpp"
#include "core/model/inertia.hpp"

namespace chasles {

namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

std::string number(double x, int digits = 3) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*g", digits, x);
  return text;
}

const std::string& joint_name(const RobotModel& model, int i) { return model.joint(i).name; }

// ---------------------------------------------------------------------------------------------
// Input checks
// ---------------------------------------------------------------------------------------------

void check_options(const DynamicFitOptions& o) {
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw IdentificationError("dynamic identification: " + what);
  };
  require(o.cutoff_hz > 0.0 && std::isfinite(o.cutoff_hz), "the cut-off frequency must be a positive number of Hz");
  require(o.filter_order >= 2 && o.filter_order <= 8 && o.filter_order % 2 == 0,
          "the filter order must be 2, 4, 6 or 8");
  require(o.holdout >= 0.0 && o.holdout <= 0.5, "the held-out fraction must be within [0, 0.5]");
  require(o.holdout_blocks >= 2, "the log must be cut into at least 2 blocks for the held-out split");
  require(o.huber > 0.0 && std::isfinite(o.huber), "Huber's threshold must be positive");
  require(o.prior_length > 0.0 && std::isfinite(o.prior_length), "the prior's length scale must be positive");
  require(o.prior_weight > 0.0 && std::isfinite(o.prior_weight), "the prior's weight must be positive");
  require(o.min_range >= 0.0 && std::isfinite(o.min_range), "the least joint range must be ≥ 0");
  require(o.max_condition > 1.0, "the largest condition number must exceed 1");
  require(o.max_iterations >= 1, "the solver needs at least one iteration");
  require(o.threads >= 1, "the solver needs at least one thread");
}

// An arm cannot leave its joints' ranges: a log that does is another arm's, or the URDF is the
// wrong one. (A hair of slack, 0.02 rad or m, for encoders read at the stops; a continuous joint,
// whose model gives ±π, may turn any number of times.)
void check_limits(const RobotModel& model, const Eigen::MatrixXd& q) {
  constexpr double kSlack = 0.02;
  std::string outside;
  for (int i = 0; i < model.dof(); ++i) {
    if (model.joint(i).type == JointType::Continuous) continue;
    const JointLimits& limits = model.joint(i).limits;
    const double low = q.row(i).minCoeff(), high = q.row(i).maxCoeff();
    if (low >= limits.lower - kSlack && high <= limits.upper + kSlack) continue;
    outside += (outside.empty() ? "'" : ", '") + joint_name(model, i) + "' spans [" + number(low) + ", " +
               number(high) + "] against [" + number(limits.lower) + ", " + number(limits.upper) + "]";
  }
  if (!outside.empty()) {
    throw IdentificationError("the log's joints leave the URDF's limits: " + outside + " (rad or m); a log of "
                              "another arm, or the wrong URDF or tip link?");
  }
}

void check_samples(const RobotModel& model, const JointSamples& s) {
  const int n = model.dof();
  const Eigen::Index N = s.t.size();
  if (s.q.rows() != n || s.qd.rows() != n || s.tau.rows() != n) {
    throw IdentificationError("the samples carry " + std::to_string(s.q.rows()) + " joint positions, " +
                              std::to_string(s.qd.rows()) + " velocities and " + std::to_string(s.tau.rows()) +
                              " torques each; the chain '" + model.base_link() + "' -> '" + model.tip_link() +
                              "' has " + std::to_string(n) + " joints (another tip link, or another robot's log?)");
  }
  if (s.q.cols() != N || s.qd.cols() != N || s.tau.cols() != N) {
    throw IdentificationError("the samples hold " + std::to_string(N) + " times but " + std::to_string(s.q.cols()) +
                              " positions, " + std::to_string(s.qd.cols()) + " velocities and " +
                              std::to_string(s.tau.cols()) + " torques: one of each per time");
  }
  const auto at = [&](Eigen::Index k) {
    return "sample " + std::to_string(k) + (std::isfinite(s.t[k]) ? " (t = " + number(s.t[k], 9) + " s)" : "");
  };
  for (Eigen::Index k = 0; k < N; ++k) {
    if (!std::isfinite(s.t[k])) throw IdentificationError(at(k) + ": its time is not finite");
    const struct {
      const Eigen::MatrixXd& values;
      const char* what;
    } fields[] = {{s.q, "position"}, {s.qd, "velocity"}, {s.tau, "torque"}};
    for (const auto& field : fields) {
      for (int i = 0; i < n; ++i) {
        if (!std::isfinite(field.values(i, k))) {
          throw IdentificationError(at(k) + ": joint '" + joint_name(model, i) + "' " + field.what + " is " +
                                    number(field.values(i, k)) + "; every value must be finite");
        }
      }
    }
    if (k > 0 && !(s.t[k] > s.t[k - 1])) {
      throw IdentificationError(at(k) + " is not after sample " + std::to_string(k - 1) + " (t = " +
                                number(s.t[k - 1], 9) + " s): times must increase");
    }
  }
  check_limits(model, s.q);
}

// ---------------------------------------------------------------------------------------------
// Step 1–2: segments, alignment, filtering
// ---------------------------------------------------------------------------------------------

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

// The mean of sign(q̇) over a step with q̇ going linearly from `before` to `after`: where it
// changes sign, the share of the step on either side of the crossing.
double mean_sign(double before, double after) {
  const double s0 = (before > 0.0) - (before < 0.0), s1 = (after > 0.0) - (after < 0.0);
  if (s0 * s1 >= 0.0) return 0.5 * (s0 + s1);
  const double u = std::abs(before) / (std::abs(before) + std::abs(after));
  return s0 * u + s1 * (1.0 - u);
}

double median_step(const Eigen::VectorXd& t) {
  std::vector<double> steps(static_cast<size_t>(t.size() - 1));
  for (Eigen::Index k = 1; k < t.size(); ++k) steps[static_cast<size_t>(k - 1)] = t[k] - t[k - 1];
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

// A centred torque is the mean over the two steps about t_k, τ(t_k) + dt²/6 τ̈(t_k) + O(dt⁴); once
// filtered, τ̈ dt² is its second difference, and taking a sixth of it off leaves the instant's
// torque (at 500 Hz the difference is 1e-3 of a fast arm's torque, a tenth of the noise's standard
// error on a load's mass). The ends, where there is no second difference, are trimmed anyway.
Eigen::VectorXd at_the_instant(Eigen::VectorXd x) {
  const Eigen::VectorXd centred = x;
  for (Eigen::Index k = 1; k + 1 < x.size(); ++k) x[k] -= (centred[k + 1] - 2.0 * centred[k] + centred[k - 1]) / 6.0;
  return x;
}

// Whether a joint's torque at each sample is one the model explains: not while the joint is slow
// (|q̇| < min_speed), nor within `reach` samples of it. At rest or stuck, static friction holds
// whatever torque the rest of the arm leaves, up to its breakaway, and at creeping speeds the
// Stribeck effect lifts friction above Coulomb's f_c; the filter spreads either over its reach.
Eigen::Array<bool, Eigen::Dynamic, 1> joint_moves(const Eigen::VectorXd& qd, double min_speed, Eigen::Index reach) {
  const Eigen::Index L = qd.size();
  Eigen::Array<bool, Eigen::Dynamic, 1> moves = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(L, true);
  Eigen::Index last_slow = -reach - 1;
  for (Eigen::Index k = 0; k < L; ++k) {
    if (std::abs(qd[k]) < min_speed) last_slow = k;
    if (k - last_slow <= reach) moves[k] = false;
  }
  Eigen::Index next_slow = L + reach + 1;
  for (Eigen::Index k = L - 1; k >= 0; --k) {
    if (std::abs(qd[k]) < min_speed) next_slow = k;
    if (next_slow - k <= reach) moves[k] = false;
  }
  return moves;
}

Prepared prepare(const JointSamples& s, const LowPassFilter& filter, double dt, double min_speed) {
  const Eigen::Index N = s.t.size(), n = s.q.rows();
  const Eigen::Index trim = static_cast<Eigen::Index>(std::ceil(2.0 * filter.sample_rate_hz / filter.cutoff_hz));
  const Eigen::Index shortest = 2 * trim + std::max<Eigen::Index>(4, trim / 2);  // 5 / f_c s
  std::vector<std::pair<Eigen::Index, Eigen::Index>> spans;  // [first, end) in the log
  Eigen::Index first = 0;
  int dropped = 0;
  for (Eigen::Index k = 1; k <= N; ++k) {
    if (k < N && s.t[k] - s.t[k - 1] <= 1.5 * dt) continue;
    if (k - first >= shortest) {
      spans.emplace_back(first, k);
    } else {
      dropped += static_cast<int>(k - first);
    }
    first = k;
  }
  Eigen::Index columns = 0;
  for (const auto& [a, b] : spans) columns += b - a - 1 - 2 * trim;
  Prepared p;
  p.dropped = dropped;
  p.t.resize(columns);
  for (Eigen::MatrixXd* m : {&p.q, &p.qd, &p.qdd, &p.tau, &p.tau_filtered, &p.coulomb}) m->resize(n, columns);
  p.moving.resize(n, columns);
  const Eigen::Index reach = static_cast<Eigen::Index>(std::ceil(filter.sample_rate_hz / filter.cutoff_hz));
  Eigen::Index column = 0;
  for (const auto& [a, b] : spans) {
    // The segment's last sample has no successor to centre its torque with.
    const Eigen::Index L = b - a - 1, kept = L - 2 * trim;
    p.segment.push_back(static_cast<int>(column));
    p.t.segment(column, kept) = s.t.segment(a + trim, kept);
    p.q.middleCols(column, kept) = s.q.middleCols(a + trim, kept);
    p.tau.middleCols(column, kept) = s.tau.middleCols(a + trim, kept);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::VectorXd qd = zero_phase_filter(filter, s.qd.row(i).segment(a, L).transpose());
      // τ_k acts over (t_{k−1}, t_k] and τ_{k+1} over (t_k, t_{k+1}]: their mean is what acted about t_k.
      const Eigen::VectorXd centred =
          0.5 * (s.tau.row(i).segment(a, L) + s.tau.row(i).segment(a + 1, L)).transpose();
      // Coulomb's column as τ's Coulomb term is built: its mean over each step (up to the crossing
      // where q̇ changes sign), centred on t_k as τ is, then filtered.
      Eigen::VectorXd sign(L);
      for (Eigen::Index k = 0; k < L; ++k) {
        const double before = k > 0 ? qd[k - 1] : qd[k], after = k + 1 < L ? qd[k + 1] : qd[k];
        sign[k] = 0.5 * (mean_sign(before, qd[k]) + mean_sign(qd[k], after));
      }
      p.qd.row(i).segment(column, kept) = qd.segment(trim, kept).transpose();
      p.moving.row(i).segment(column, kept) = joint_moves(qd, min_speed, reach).segment(trim, kept).transpose();
      p.qdd.row(i).segment(column, kept) = central_difference(qd, dt).segment(trim, kept).transpose();
      p.tau_filtered.row(i).segment(column, kept) =
          at_the_instant(zero_phase_filter(filter, centred)).segment(trim, kept).transpose();
      p.coulomb.row(i).segment(column, kept) =
          at_the_instant(zero_phase_filter(filter, sign)).segment(trim, kept).transpose();
    }
    column += kept;
  }
  p.segment.push_back(static_cast<int>(column));
  return p;
}

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

namespace {

// Steps 1 and 3, what every fit from a log does first: the checks, the filtering, the split.
struct LogSplit {
  LowPassFilter filter;
  Prepared data;
  std::vector<int> fit, holdout;  ///< columns of data; each held-out one has its predecessor in data
  /// The fit's torque rows: fit column s's joints that move (Prepared::moving), s after s.
  std::vector<int> row_sample, row_joint;
};

// The log must give kTorquesPerParameter torques per fitted parameter, and something to judge the
// fit on. Three, as before, let a 3 s log of a Panda with stiction through (62 base parameters from
// 420 torques) whose report claimed 0.05-0.1 N·m where a different motion showed 0.39: the fit
// follows that short motion and nothing else. Fifteen is most of one 10 s period of the default
// excitation.
constexpr int kTorquesPerParameter = 15;

// The joints, in order, that move in less than `below` of the motion, each with its share: a
// joint stuck or still that long leaves too few of its torques to fit.
std::string stuck_joints(const RobotModel& model, const Eigen::VectorXd& share, double below) {
  std::string text;
  for (int i = 0; i < share.size(); ++i) {
    if (share[i] >= below) continue;
    text += (text.empty() ? "'" : ", '") + joint_name(model, i) + "' (moving " + number(100.0 * share[i], 2) + " %)";
  }
  return text;
}

LogSplit split_log(const RobotModel& model, const JointSamples& samples, const DynamicFitOptions& options,
                   LogUse& use) {
  check_options(options);
  check_samples(model, samples);
  const int n = model.dof();
  const Eigen::Index N = samples.t.size();
  if (N < 4) {
    throw IdentificationError("the log holds " + std::to_string(N) +
                              " samples; a fit needs seconds of an arm moving, thousands of samples");
  }
  use.samples = static_cast<int>(N);
  use.duration_s = samples.t[N - 1] - samples.t[0];
  const double dt = median_step(samples.t);
  use.sample_rate_hz = 1.0 / dt;
  if (!(options.cutoff_hz < 0.5 * use.sample_rate_hz)) {
    throw IdentificationError("the cut-off " + number(options.cutoff_hz) +
                              " Hz is not below the log's Nyquist frequency " + number(0.5 * use.sample_rate_hz) +
                              " Hz (a sample every " + number(dt * 1e3) + " ms): choose a lower cut-off");
  }

  // Every joint must move, or the torques say nothing of what it carries.
  std::string still;
  for (int i = 0; i < n; ++i) {
    const double range = samples.q.row(i).maxCoeff() - samples.q.row(i).minCoeff();
    if (range < options.min_range) {
      still += (still.empty() ? "" : ", ") + ("'" + joint_name(model, i) + "' (range " + number(range) + ")");
    }
  }
  if (!still.empty()) {
    throw IdentificationError("the log does not excite the arm: joints that barely move: " + still + ", under " +
                              number(options.min_range) +
                              " rad or m; run an excitation trajectory that moves every joint");
  }

  LogSplit split;
  split.filter = butterworth_low_pass(options.filter_order, options.cutoff_hz, use.sample_rate_hz);
  split.data = prepare(samples, split.filter, dt, options.min_speed);
  const Prepared& data = split.data;
  use.segments = static_cast<int>(data.segment.size()) - 1;
  use.dropped_samples = data.dropped;
  // (A hair over the quotient, so that 500 Hz over 25 Hz is 20 even when the times' rounding
  // makes the rate 499.99999 Hz.)
  use.decimation = std::max(1, static_cast<int>(std::floor(use.sample_rate_hz / (2.5 * options.cutoff_hz) + 1e-6)));

  // The motion: columns where some joint moves. Rest says nothing and is left out whole; the
  // blocks are cut in the motion alone, so that rest does not fill the held-out share.
  const Eigen::Index columns = data.t.size();
  std::vector<int> rank(static_cast<size_t>(columns), -1);
  int motion = 0;
  Eigen::VectorXd moving_count = Eigen::VectorXd::Zero(n);
  for (Eigen::Index c = 0; c < columns; ++c) {
    if (!data.moving.col(c).any()) continue;
    rank[static_cast<size_t>(c)] = motion++;
    for (int i = 0; i < n; ++i) moving_count[i] += data.moving(i, c) ? 1.0 : 0.0;
  }
  use.motion_seconds = motion * dt;
  use.rest_seconds = static_cast<double>(columns - motion) * dt;
  use.moving_share = moving_count / std::max(1.0, static_cast<double>(motion));
  if (columns > 0 && motion == 0) {  // (a log too short to filter has no columns: check_length says so)
    throw IdentificationError("the log holds no motion: no joint moves at " + number(options.min_speed) +
                              " rad/s or m/s or faster (over " + number(use.duration_s) +
                              " s); log the arm while it runs an excitation trajectory");
  }
  constexpr double kLeastShare = 0.2;
  if (const std::string stuck = stuck_joints(model, use.moving_share, kLeastShare); motion > 0 && !stuck.empty()) {
    throw IdentificationError(
        "joints stuck or still for most of the motion: " + stuck + " of its " + number(use.motion_seconds) +
        " s at " + number(options.min_speed) + " rad/s or m/s or faster; while a joint sticks, static friction holds "
        "a torque no model of the log can tell, so those torques are left out and too few remain (every joint must "
        "move in " + number(100.0 * kLeastShare) + " % of it): stiffen the controller's joint gains or run the "
        "excitation faster (a shorter --period) so that the joints break away");
  }

  // Held-out blocks: the last H of B blocks of the motion, so that the judgement is made on motion
  // the fit never saw nor neighbours.
  const int B = options.holdout_blocks;
  const int H = static_cast<int>(std::lround(options.holdout * B));
  for (int b = B - H; b < B; ++b) use.holdout_blocks.push_back(b);
  for (size_t s = 0; s + 1 < data.segment.size(); ++s) {
    for (int c = data.segment[s]; c < data.segment[s + 1]; ++c) {
      const int r = rank[static_cast<size_t>(c)];
      if (r < 0) continue;
      const int block = std::min(B - 1, static_cast<int>(static_cast<int64_t>(r) * B / motion));
      if (block >= B - H) {
        if (c > data.segment[s]) split.holdout.push_back(c);  // its predecessor is needed
      } else if ((c - data.segment[s]) % use.decimation == 0) {
        for (int i = 0; i < n; ++i) {
          if (!data.moving(i, c)) continue;
          split.row_sample.push_back(static_cast<int>(split.fit.size()));
          split.row_joint.push_back(i);
        }
        split.fit.push_back(c);
      }
    }
  }
  use.fit_samples = static_cast<int>(split.fit.size());
  use.fit_torques = static_cast<int>(split.row_joint.size());
  use.holdout_samples = static_cast<int>(split.holdout.size());
  use.holdout_seconds = use.holdout_samples * dt;
  return split;
}

// Refuses a log that gives too few torques for `parameters` (kTorquesPerParameter), or nothing to
// judge the fit on, saying how long a log would do.
void check_length(const LogUse& use, int joints, int parameters, const std::string& what,
                  const DynamicFitOptions& options) {
  const int rows = use.fit_torques;
  if (rows >= kTorquesPerParameter * parameters && (use.holdout_blocks.empty() || use.holdout_samples > 0)) return;
  const double dt = 1.0 / use.sample_rate_hz;
  const double used = use.fit_samples > 0 ? static_cast<double>(rows) / (use.fit_samples * joints) : 1.0;
  const double needed =
      std::ceil(kTorquesPerParameter * parameters / (joints * std::max(used, 0.5))) * use.decimation * dt /
          (1.0 - options.holdout) +
      4.0 / options.cutoff_hz;
  const std::string left_out =
      use.rest_seconds > 0.0 || used < 1.0
          ? "; left out: " + number(use.rest_seconds) + " s of rest and, in the motion, " +
                number(100.0 * (1.0 - used), 2) + " % of the joints' torques where they were slow or stuck"
          : "";
  throw IdentificationError("the log is too short: " + number(use.duration_s) + " s at " + number(use.sample_rate_hz) +
                            " Hz hold " + number(use.motion_seconds) + " s of motion, which give " +
                            std::to_string(use.fit_samples) + " samples to fit (" + std::to_string(rows) +
                            " torques) for " + std::to_string(parameters) + " " + what + ", and " +
                            std::to_string(use.holdout_samples) + " held out" + left_out + "; the fit needs " +
                            std::to_string(kTorquesPerParameter) + " torques per parameter: log at least " +
                            number(std::max(needed, 4.0 * options.holdout_blocks * dt)) + " s of motion" +
                            (use.dropped_samples > 0 ? ", in stretches without gaps of at least " +
                                                           number(5.0 / options.cutoff_hz) + " s (" +
                                                           std::to_string(use.dropped_samples) +
                                                           " samples lay in shorter ones, too short to filter)"
                                                     : ""));
}

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
                                                        const Eigen::VectorXd& pi_b, bool every_sample = false) {
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
