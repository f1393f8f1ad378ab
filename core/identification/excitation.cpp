#include "core/identification/excitation.hpp"

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>

#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

namespace chasles {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A number for a message: six significant digits, no trailing zeros.
std::string text(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", x);
  return buffer;
}

// The optimiser's grid: points per cycle of the highest harmonic. A sinusoid sampled 24 times a
// cycle peaks at most 1 − cos(π/24) = 0.9 % above its samples, well inside the margins.
constexpr int kGridPerCycle = 24;
// Weight of the squared relative excesses against log cond: at equilibrium an excess is about
// (gradient of log cond) / (2 kPenalty), some 1e-4 of a limit, again well inside the margins.
constexpr double kPenalty = 1e3;
// λ_min / λ_max of W_bᵀW_b below which W_b counts as rank deficient (cond > 1e6): rounding in
// WᵀW is about r ε λ_max, a percent of such a λ_min, and the rank can no longer be told.
constexpr double kRankRatio = 1e-12;
// Y's derivative in q by central differences: truncation h² |Y'''| / 6 and rounding ε |Y| / h
// balance near 1e-5 rad (m). In q̇ (Y quadratic) and q̈ (Y affine) any step is exact; 1 is used.
constexpr double kPositionStep = 1e-5;

/// 53-bit uniforms from mt19937_64 and Box–Muller normals: the same draws with every standard
/// library (std:: distributions are implementation-defined).
class Random {
 public:
  explicit Random(uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double normal() {
    const double u = 1.0 - uniform();  // (0, 1]
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * kPi * uniform());
  }

 private:
  std::mt19937_64 engine_;
};

// The d-th derivatives of S_l = sin(w t)/w and C_l = (1 − cos(w t))/w, w = ω_f l. 1 − cos is
// taken as 2 sin²(w t / 2), exact near t = 0 where the series must start at rest.
void harmonic(double w, double t, int d, double& S, double& C) {
  const double s = std::sin(w * t), c = std::cos(w * t);
  switch (d) {
    case 0: {
      const double half = std::sin(0.5 * w * t);
      S = s / w, C = 2.0 * half * half / w;
      break;
    }
    case 1: S = c, C = s; break;
    case 2: S = -w * s, C = w * c; break;
    default: S = -w * w * c, C = -w * w * s; break;
  }
}

// The free coefficients are, per joint, (a_i2 … a_iL, b_i2 … b_iL): θ_i, 2 (L − 1) of them.
// With a_i1 = −Σ a_il and b_i1 = −Σ l b_il, q_i − start_i = Σ_{l≥2} a_il (S_l − S_1) +
// b_il (C_l − l C_1): row m of the basis at t, derivative d.
Eigen::MatrixXd free_basis(double omega, int L, const Eigen::VectorXd& times, int d) {
  Eigen::MatrixXd B(times.size(), 2 * (L - 1));
  for (Eigen::Index k = 0; k < times.size(); ++k) {
    double S1 = 0.0, C1 = 0.0;
    harmonic(omega, times(k), d, S1, C1);
    for (int l = 2; l <= L; ++l) {
      double S = 0.0, C = 0.0;
      harmonic(omega * l, times(k), d, S, C);
      B(k, l - 2) = S - S1;
      B(k, L - 1 + l - 2) = C - l * C1;
    }
  }
  return B;
}

Eigen::VectorXd uniform_times(double period, int count, double offset) {
  Eigen::VectorXd t(count);
  for (int k = 0; k < count; ++k) t(k) = (k + offset) * period / count;
  return t;
}

FourierTrajectory trajectory_from(const Eigen::VectorXd& theta, const Eigen::VectorXd& start,
                                  const ExcitationOptions& options) {
  const int n = static_cast<int>(start.size()), L = options.harmonics, p = 2 * (L - 1);
  FourierTrajectory trajectory;
  trajectory.period = options.period;
  trajectory.periods = options.periods;
  trajectory.start = start;
  trajectory.a = Eigen::MatrixXd::Zero(n, L);
  trajectory.b = Eigen::MatrixXd::Zero(n, L);
  for (int i = 0; i < n; ++i) {
    for (int l = 1; l < L; ++l) {
      trajectory.a(i, l) = theta(i * p + l - 1);
      trajectory.b(i, l) = theta(i * p + L - 1 + l - 1);
    }
  }
  make_rest_to_rest(trajectory);
  return trajectory;
}

// Y_b at `times`, stacked: W (times × n rows, r columns).
Eigen::MatrixXd stacked_base_regressor(const RobotModel& model, const BaseParameters& base,
                                       const FourierTrajectory& trajectory, const Eigen::VectorXd& times) {
  const int n = model.dof();
  RegressorWorkspace workspace(model);
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  Eigen::MatrixXd W(times.size() * n, base.count), Y_b(n, base.count);
  for (Eigen::Index k = 0; k < times.size(); ++k) {
    sample_fourier(trajectory, times(k), q, qd, qdd, qddd);
    base_regressor(base, joint_torque_regressor(model, workspace, q, qd, qdd), Y_b);
    W.middleRows(k * n, n) = Y_b;
  }
  return W;
}

// cond(W) from the extreme eigenvalues of WᵀW (columns scaled to unit norm first if asked).
double condition_of(const Eigen::MatrixXd& W, bool normalize_columns) {
  Eigen::MatrixXd G = W.transpose() * W;
  if (normalize_columns) {
    const Eigen::VectorXd d = G.diagonal().cwiseSqrt().cwiseInverse();
    G = d.asDiagonal() * G * d.asDiagonal();
  }
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(G, Eigen::EigenvaluesOnly).eigenvalues();
  const double low = lambda(0), high = lambda(lambda.size() - 1);
  return std::isfinite(low) && low > kRankRatio * high ? std::sqrt(high / low) : kInf;
}

// The limits the optimiser aims for: the given ones less the margins.
struct Targets {
  Eigen::VectorXd lower, upper, half_range;  // half_range: the scale of a position excess
  Eigen::VectorXd rate[3];                   // velocity, acceleration, jerk
};

Targets targets_of(const ExcitationLimits& limits, const ExcitationOptions& options) {
  Targets t;
  t.lower = limits.lower.array() + options.position_margin;
  t.upper = limits.upper.array() - options.position_margin;
  t.half_range = 0.5 * (t.upper - t.lower);
  t.rate[0] = (1.0 - options.rate_margin) * limits.velocity;
  t.rate[1] = (1.0 - options.rate_margin) * limits.acceleration;
  t.rate[2] = (1.0 - options.rate_margin) * limits.jerk;
  return t;
}

// log cond(W_b) over one period plus the penalty on the targets, and its gradient in θ.
//
// With G = W_bᵀW_b, D = diag(G)^(−½) (or 1 unscaled) and an eigenpair (λ, v) of D G D,
//   dλ = 2 (W w)ᵀ (dW w) − λ Σ_j v_j² dG_jj / G_jj,  w = D v,  dG_jj = 2 W_jᵀ dW_j
// (the second term is the scaling's; the eigenvalue is simple at the extremes of a full-rank W).
// So d log cond = ½ (dλ_max / λ_max − dλ_min / λ_min) = Σ_k ⟨M_k, dY_b,k⟩ for one n × r matrix
// M_k per sample, and the gradient is ⟨M_k, ∂Y_b/∂x⟩ for x in q, q̇, q̈, chained through the basis.
class ExcitationCost final : public ceres::FirstOrderFunction {
 public:
  ExcitationCost(const RobotModel& model, const BaseParameters& base, const Targets& targets,
                 const Eigen::VectorXd& start, const ExcitationOptions& options)
      : model_(model),
        base_(base),
        targets_(targets),
        start_(start),
        normalize_(options.normalize_columns),
        n_(model.dof()),
        p_(2 * (options.harmonics - 1)),
        r_(base.count),
        K_(options.samples),
        workspace_(model),
        q_(n_),
        qd_(n_),
        qdd_(n_),
        Y_b_(n_, r_),
        W_(K_ * n_, r_),
        M_(K_ * n_, r_),
        Y_(K_),
        G_(r_, r_),
        eigen_(r_) {
    const double omega = 2.0 * kPi / options.period;
    const Eigen::VectorXd samples = uniform_times(options.period, K_, 0.5);
    const Eigen::VectorXd grid = uniform_times(options.period, kGridPerCycle * options.harmonics, 0.0);
    for (int d = 0; d < 4; ++d) {
      if (d < 3) sample_basis_[d] = free_basis(omega, options.harmonics, samples, d);
      grid_basis_[d] = free_basis(omega, options.harmonics, grid, d);
    }
    coulomb_.assign(static_cast<size_t>(r_), false);
    const ParameterLayout layout = parameter_layout(model);
    for (int c = 0; c < r_; ++c) {
      const int index = base.independent[static_cast<size_t>(c)];
      coulomb_[static_cast<size_t>(c)] = index >= layout.coulomb(0) && index < layout.coulomb(0) + n_;
    }
  }

  int NumParameters() const override { return n_ * p_; }

  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    const Eigen::Map<const Eigen::VectorXd> theta(parameters, n_ * p_);
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Theta(parameters, n_, p_);
    for (int d = 0; d < 3; ++d) X_[d].noalias() = sample_basis_[d] * Theta.transpose();  // K × n
    for (int k = 0; k < K_; ++k) {
      set_state(k);
      Y_[static_cast<size_t>(k)] = joint_torque_regressor(model_, workspace_, q_, qd_, qdd_);
      base_regressor(base_, Y_[static_cast<size_t>(k)], Y_b_);
      W_.middleRows(k * n_, n_) = Y_b_;
    }
    G_.noalias() = W_.transpose() * W_;
    scale_ = normalize_ ? Eigen::VectorXd(G_.diagonal().cwiseSqrt().cwiseInverse()) : Eigen::VectorXd::Ones(r_);
    eigen_.compute(scale_.asDiagonal() * G_ * scale_.asDiagonal());
    const Eigen::VectorXd& lambda = eigen_.eigenvalues();
    const double low = lambda(0), high = lambda(r_ - 1);
    if (!std::isfinite(low) || !(low > kRankRatio * high)) return false;
    *cost = 0.5 * std::log(high / low);
    if (gradient) {
      Eigen::Map<Eigen::VectorXd> g(gradient, n_ * p_);
      g.setZero();
      M_.setZero();
      add_eigenvalue_term(0, -0.5 / low);
      add_eigenvalue_term(r_ - 1, 0.5 / high);
      // sign(q̇) has no derivative where it is defined, and a difference across a crossing would
      // be a spike: the Coulomb columns move nothing here.
      for (int c = 0; c < r_; ++c) {
        if (coulomb_[static_cast<size_t>(c)]) M_.col(c).setZero();
      }
      for (int k = 0; k < K_; ++k) add_state_gradient(k, g);
    }
    *cost += penalty(theta, gradient);
    return true;
  }

 private:
  void set_state(int k) const {
    q_ = start_ + X_[0].row(k).transpose();
    qd_ = X_[1].row(k).transpose();
    qdd_ = X_[2].row(k).transpose();
  }

  // weight · dλ_e as Σ_k ⟨M_k, dY_b,k⟩, added into M_.
  void add_eigenvalue_term(int e, double weight) const {
    const double lambda = eigen_.eigenvalues()(e);
    const Eigen::VectorXd w = scale_.cwiseProduct(eigen_.eigenvectors().col(e));
    const Eigen::VectorXd Ww = W_ * w;
    M_.noalias() += (2.0 * weight) * Ww * w.transpose();
    if (normalize_) {
      const Eigen::VectorXd c = eigen_.eigenvectors().col(e).cwiseAbs2().cwiseQuotient(G_.diagonal());
      M_.noalias() -= (2.0 * weight * lambda) * W_ * c.asDiagonal();
    }
  }

  // ⟨M_k, Y_b⟩ with Y_b read from the full regressor's base columns.
  double contract(int k, const Eigen::MatrixXd& Y) const {
    double sum = 0.0;
    for (int c = 0; c < r_; ++c) {
      sum += M_.col(c).segment(k * n_, n_).dot(Y.col(base_.independent[static_cast<size_t>(c)]));
    }
    return sum;
  }

  double at(int k) const { return contract(k, joint_torque_regressor(model_, workspace_, q_, qd_, qdd_)); }

  void add_state_gradient(int k, Eigen::Map<Eigen::VectorXd>& g) const {
    set_state(k);
    const double here = contract(k, Y_[static_cast<size_t>(k)]);
    for (int j = 0; j < n_; ++j) {
      qdd_(j) += 1.0;
      const double d_qdd = at(k) - here;
      qdd_(j) -= 1.0;
      qd_(j) += 1.0;
      const double qd_plus = at(k);
      qd_(j) -= 2.0;
      const double d_qd = 0.5 * (qd_plus - at(k));
      qd_(j) += 1.0;
      const double qj = q_(j);
      q_(j) = qj + kPositionStep;
      const double q_plus = at(k);
      q_(j) = qj - kPositionStep;
      const double d_q = (q_plus - at(k)) / (2.0 * kPositionStep);
      q_(j) = qj;
      g.segment(j * p_, p_) += d_q * sample_basis_[0].row(k).transpose() + d_qd * sample_basis_[1].row(k).transpose() +
                               d_qdd * sample_basis_[2].row(k).transpose();
    }
    set_state(k);
  }

  // kPenalty Σ (relative excess over the targets)² on the grid, and its gradient added in.
  double penalty(const Eigen::VectorXd& theta, double* gradient) const {
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Theta(theta.data(), n_, p_);
    double sum = 0.0;
    for (int d = 0; d < 4; ++d) {
      const Eigen::MatrixXd X = grid_basis_[d] * Theta.transpose();  // grid × n, q less the start for d = 0
      for (Eigen::Index t = 0; t < X.rows(); ++t) {
        for (int i = 0; i < n_; ++i) {
          double excess = 0.0, slope = 0.0;  // relative excess and its derivative in the value
          if (d == 0) {
            const double x = start_(i) + X(t, i), scale = targets_.half_range(i);
            if (x > targets_.upper(i)) excess = (x - targets_.upper(i)) / scale, slope = 1.0 / scale;
            if (x < targets_.lower(i)) excess = (targets_.lower(i) - x) / scale, slope = -1.0 / scale;
          } else {
            const double x = X(t, i), limit = targets_.rate[d - 1](i);
            if (std::abs(x) > limit) excess = (std::abs(x) - limit) / limit, slope = std::copysign(1.0 / limit, x);
          }
          if (excess <= 0.0) continue;
          sum += kPenalty * excess * excess;
          if (gradient) {
            Eigen::Map<Eigen::VectorXd>(gradient + i * p_, p_) += 2.0 * kPenalty * excess * slope * grid_basis_[d].row(t).transpose();
          }
        }
      }
    }
    return sum;
  }

  const RobotModel& model_;
  const BaseParameters& base_;
  const Targets& targets_;
  const Eigen::VectorXd start_;
  const bool normalize_;
  const int n_, p_, r_, K_;
  Eigen::MatrixXd sample_basis_[3], grid_basis_[4];
  std::vector<bool> coulomb_;  // base column c is a Coulomb friction parameter
  // Ceres calls Evaluate const; these are its scratch, sized once.
  mutable RegressorWorkspace workspace_;
  mutable Eigen::VectorXd q_, qd_, qdd_, scale_;
  mutable Eigen::MatrixXd X_[3];
  mutable Eigen::MatrixXd Y_b_, W_, M_;
  mutable std::vector<Eigen::MatrixXd> Y_;
  mutable Eigen::MatrixXd G_;
  mutable Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen_;
};

// The largest s for which start + s Δ(t) keeps the targets at every grid point.
double room_scale(const Eigen::VectorXd& theta, const Eigen::VectorXd& start, const Targets& targets,
                  const ExcitationOptions& options) {
  const int n = static_cast<int>(start.size()), p = 2 * (options.harmonics - 1);
  const double omega = 2.0 * kPi / options.period;
  const Eigen::VectorXd grid = uniform_times(options.period, kGridPerCycle * options.harmonics, 0.0);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Theta(theta.data(), n, p);
  double s = kInf;
  for (int d = 0; d < 4; ++d) {
    const Eigen::MatrixXd X = free_basis(omega, options.harmonics, grid, d) * Theta.transpose();
    for (Eigen::Index t = 0; t < X.rows(); ++t) {
      for (int i = 0; i < n; ++i) {
        const double x = X(t, i);
        if (d == 0) {
          if (x > 0.0) s = std::min(s, (targets.upper(i) - start(i)) / x);
          if (x < 0.0) s = std::min(s, (targets.lower(i) - start(i)) / x);
        } else if (x != 0.0) {
          s = std::min(s, targets.rate[d - 1](i) / std::abs(x));
        }
      }
    }
  }
  return s;
}

}  // namespace

double FourierTrajectory::omega() const { return 2.0 * kPi / period; }

void make_rest_to_rest(FourierTrajectory& trajectory) {
  const int L = trajectory.harmonics();
  trajectory.a.col(0).setZero();
  trajectory.b.col(0).setZero();
  for (int l = 1; l < L; ++l) {
    trajectory.a.col(0) -= trajectory.a.col(l);
    trajectory.b.col(0) -= (l + 1) * trajectory.b.col(l);
  }
}

void sample_fourier(const FourierTrajectory& trajectory, double t, Eigen::Ref<Eigen::VectorXd> q,
                    Eigen::Ref<Eigen::VectorXd> qd, Eigen::Ref<Eigen::VectorXd> qdd, Eigen::Ref<Eigen::VectorXd> qddd) {
  q = trajectory.start;
  qd.setZero();
  qdd.setZero();
  qddd.setZero();
  const double omega = trajectory.omega();
  for (int l = 0; l < trajectory.harmonics(); ++l) {
    const double w = omega * (l + 1), s = std::sin(w * t), c = std::cos(w * t), half = std::sin(0.5 * w * t);
    // S_l, C_l and their derivatives (see harmonic()), shared by every joint.
    const double S[4] = {s / w, c, -w * s, -w * w * c};
    const double C[4] = {2.0 * half * half / w, s, w * c, -w * w * s};
    const auto a = trajectory.a.col(l), b = trajectory.b.col(l);
    q += S[0] * a + C[0] * b;
    qd += S[1] * a + C[1] * b;
    qdd += S[2] * a + C[2] * b;
    qddd += S[3] * a + C[3] * b;
  }
}

void ExcitationLimits::validate(const RobotModel& model) const {
  const int dof = model.dof();
  for (const auto* v : {&lower, &upper, &velocity, &acceleration, &jerk}) {
    if (v->size() != dof) {
      throw ArgumentError("excitation limits: " + std::to_string(v->size()) + " values where the arm has " +
                          std::to_string(dof) + " joints");
    }
  }
  for (int i = 0; i < dof; ++i) {
    const std::string joint = "excitation limits, joint " + model.joint(i).name + ": ";
    if (std::isnan(lower(i)) || std::isnan(upper(i)) || !(lower(i) <= upper(i))) {
      throw ArgumentError(joint + "position limits [" + text(lower(i)) + ", " + text(upper(i)) +
                          "] are not a range");
    }
    if (!(velocity(i) > 0.0) || !(acceleration(i) > 0.0) || !(jerk(i) > 0.0)) {
      throw ArgumentError(joint + "velocity, acceleration and jerk limits must be positive");
    }
  }
}

void ExcitationOptions::validate() const {
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw ArgumentError("excitation options: " + what);
  };
  require(harmonics >= 2 && harmonics <= 50, "harmonics must be 2 to 50 (the first is spent on rest at the ends)");
  require(std::isfinite(period) && period > 0.0, "the period must be positive");
  require(periods >= 1, "the trajectory must last at least one period");
  require(samples >= 1, "samples must be positive");
  require(std::isfinite(position_margin) && position_margin >= 0.0, "the position margin must be >= 0");
  require(std::isfinite(rate_margin) && rate_margin >= 0.0 && rate_margin < 1.0, "the rate margin must be in [0, 1)");
  require(std::isfinite(check_step) && check_step > 0.0 && check_step <= period, "the check step must be in (0, period]");
  require(iterations >= 0, "iterations must be >= 0");
}

TrajectoryPeaks trajectory_peaks(const FourierTrajectory& trajectory, double step) {
  const int n = trajectory.dof();
  TrajectoryPeaks peaks;
  peaks.lowest = Eigen::VectorXd::Constant(n, kInf);
  peaks.highest = Eigen::VectorXd::Constant(n, -kInf);
  peaks.velocity = peaks.acceleration = peaks.jerk = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  const long steps = std::lround(std::ceil(trajectory.duration() / step));
  for (long k = 0; k <= steps; ++k) {
    sample_fourier(trajectory, std::min(k * step, trajectory.duration()), q, qd, qdd, qddd);
    peaks.lowest = peaks.lowest.cwiseMin(q);
    peaks.highest = peaks.highest.cwiseMax(q);
    peaks.velocity = peaks.velocity.cwiseMax(qd.cwiseAbs());
    peaks.acceleration = peaks.acceleration.cwiseMax(qdd.cwiseAbs());
    peaks.jerk = peaks.jerk.cwiseMax(qddd.cwiseAbs());
  }
  return peaks;
}

std::string excitation_limit_problem(const RobotModel& model, const FourierTrajectory& trajectory,
                                     const ExcitationLimits& limits, double step) {
  const int n = trajectory.dof();
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  const long steps = std::lround(std::ceil(trajectory.duration() / step));
  for (long k = 0; k <= steps; ++k) {
    const double t = std::min(k * step, trajectory.duration());
    sample_fourier(trajectory, t, q, qd, qdd, qddd);
    for (int i = 0; i < n; ++i) {
      const std::string at = " at t = " + text(t) + " s";
      const std::string joint = "joint " + model.joint(i).name + ": ";
      if (q(i) < limits.lower(i) || q(i) > limits.upper(i)) {
        return joint + "position " + text(q(i)) + at + " outside [" + text(limits.lower(i)) + ", " +
               text(limits.upper(i)) + "]";
      }
      const struct {
        const char* name;
        double value, limit;
      } rates[3] = {{"velocity", qd(i), limits.velocity(i)},
                    {"acceleration", qdd(i), limits.acceleration(i)},
                    {"jerk", qddd(i), limits.jerk(i)}};
      for (const auto& rate : rates) {
        if (std::abs(rate.value) > rate.limit) {
          return joint + rate.name + " " + text(rate.value) + at + " beyond its limit " +
                 text(rate.limit);
        }
      }
    }
  }
  return "";
}

double excitation_condition_number(const RobotModel& model, const BaseParameters& base,
                                   const FourierTrajectory& trajectory, int samples, bool normalize_columns) {
  if (samples < 1) throw ArgumentError("excitation_condition_number: samples must be positive");
  if (trajectory.dof() != model.dof() || trajectory.start.size() != model.dof()) {
    throw ArgumentError("excitation_condition_number: a trajectory for " + std::to_string(trajectory.dof()) +
                        " joints and an arm with " + std::to_string(model.dof()));
  }
  return condition_of(stacked_base_regressor(model, base, trajectory, uniform_times(trajectory.period, samples, 0.5)),
                      normalize_columns);
}

ExcitationResult optimize_excitation(const RobotModel& model, const BaseParameters& base, const ExcitationLimits& limits,
                                     const Eigen::VectorXd& start, const ExcitationOptions& options) {
  const auto clock_start = std::chrono::steady_clock::now();
  const int n = model.dof();
  options.validate();
  limits.validate(model);
  if (start.size() != n) {
    throw ArgumentError("excitation start: " + std::to_string(start.size()) + " values where the arm has " +
                        std::to_string(n) + " joints");
  }
  if (options.samples * n < base.count) {
    throw ArgumentError("excitation options: " + std::to_string(options.samples) + " samples of " + std::to_string(n) +
                        " torques cannot determine " + std::to_string(base.count) + " base parameters");
  }
  const Targets targets = targets_of(limits, options);
  for (int i = 0; i < n; ++i) {
    if (!(start(i) >= targets.lower(i) && start(i) <= targets.upper(i))) {
      throw ArgumentError("excitation start: joint " + model.joint(i).name + " at " + text(start(i)) +
                          " is not within [" + text(targets.lower(i)) + ", " +
                          text(targets.upper(i)) + "], its limits less the margin");
    }
  }

  // The seeded start: random coefficients, scaled to half the room the targets leave about `start`.
  const int p = 2 * (options.harmonics - 1);
  Random random(options.seed);
  Eigen::VectorXd theta(n * p);
  for (Eigen::Index k = 0; k < theta.size(); ++k) theta(k) = random.normal();
  // (Unbounded everywhere, as a chain of continuous joints with no velocity limit: as drawn.)
  if (const double room = room_scale(theta, start, targets, options); std::isfinite(room)) theta *= 0.5 * room;

  ExcitationResult result;
  result.start_condition_number = excitation_condition_number(model, base, trajectory_from(theta, start, options),
                                                              options.samples, options.normalize_columns);
  if (!std::isfinite(result.start_condition_number)) {
    throw ArgumentError("excitation: the random start excites too few base parameters to begin from (no room within "
                        "the limits about the start, or too few samples)");
  }
  ceres::GradientProblem problem(new ExcitationCost(model, base, targets, start, options));
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  solver_options.max_num_iterations = options.iterations;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(solver_options, problem, theta.data(), &summary);

  result.trajectory = trajectory_from(theta, start, options);
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  const Eigen::MatrixXd W = stacked_base_regressor(model, base, result.trajectory,
                                                   uniform_times(options.period, options.samples, 0.5));
  result.raw_condition_number = condition_of(W, false);
  result.scaled_condition_number = condition_of(W, true);
  result.condition_number = options.normalize_columns ? result.scaled_condition_number : result.raw_condition_number;
  if (!std::isfinite(result.condition_number)) {
    throw ArgumentError("excitation: the optimised trajectory does not excite every base parameter");
  }
  if (const std::string problem_text = excitation_limit_problem(model, result.trajectory, limits, options.check_step);
      !problem_text.empty()) {
    throw ArgumentError("excitation: the optimised trajectory leaves a limit: " + problem_text +
                        " (a longer period or larger margins leave the optimiser more room)");
  }
  result.peaks = trajectory_peaks(result.trajectory, options.check_step);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  return result;
}

}  // namespace chasles
