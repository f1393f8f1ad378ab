#include "core/ik/ik.hpp"

#include <ceres/ceres.h>

#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "core/lie/jacobians.hpp"

namespace chasles {

namespace {

using Clock = std::chrono::steady_clock;

/// CPU time of the calling thread, ns: what the time budget counts. A solve that the scheduler
/// preempts is not cut short by the time it spent waiting (on a loaded machine wall-clock budgets
/// failed 7 % of reachable targets that the same solver reaches alone).
std::int64_t thread_cpu_ns() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}
using RowMajor6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>;

// An attempt still more than kAbandonError (m or rad) away after kAbandonIteration iterations is
// abandoned for a restart. Measured on the reference targets (UR5): by iteration 8, 84 % of the
// attempts that go on to converge are within 0.03, and 95 % of those that fail are not; the
// successes it cuts are slow ones a restart usually beats. Cutting at 8 rather than 12 or 15
// saved 10-20 % of the work (iterations and Ceres solves) for the same success.
constexpr int kAbandonIteration = 8;
constexpr double kAbandonError = 0.03;
// A restart starts from the best of this many random draws: a draw whose tip is already near the
// target converges more often. One draw costs an FK (~0.3 µs), an attempt ~10 iterations of ~5 µs.
// On the reference targets, 8 draws cut the Ceres solves by a quarter (UR5 678 → 510, Panda 770
// → 576 for 200 targets); 16 or more saved no further solves.
constexpr int kRestartCandidates = 8;
constexpr double kRestartRotationWeight = 0.1;  // m per rad: 0.1 rad of tilt counts as 1 cm
// A start this close to the target (m, rad) takes undamped first steps.
constexpr double kNearPosition = 0.05;
constexpr double kNearRotation = 0.1;
// The regularisation toward the seed is switched off within this distance (m and rad).
constexpr double kRegularizationOff = 1e-3;

/// splitmix64's finaliser: mixes a 64-bit state into a well-spread one.
std::uint64_t mix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

std::uint64_t bits(double x) {
  std::uint64_t out;
  std::memcpy(&out, &x, sizeof out);
  return out;
}

/// The pose residual: W log(T_sd⁻¹ T_sb(q)), or (0, w_v ⊙ (p_sb − p_sd)) for position only.
/// Reads the target, weights and mode from the solver's storage, so one instance serves every
/// solve, and computes FK and J_b into the solver's Data, noting in fk_q where data.T_sb is from.
class PoseCost final : public ceres::CostFunction {
 public:
  PoseCost(const RobotModel& model, Data& data, Eigen::VectorXd& fk_q, const Transform& T_sd, const Vector6d& weights,
           const bool& position_only)
      : model_(model), data_(data), fk_q_(fk_q), T_sd_(T_sd), weights_(weights), position_only_(position_only) {
    set_num_residuals(6);
    mutable_parameter_block_sizes()->push_back(model.dof());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::VectorXd> q(parameters[0], model_.dof());
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    if (want_jacobian) {
      body_jacobian(model_, data_, q);  // runs forward_kinematics too
    } else {
      forward_kinematics(model_, data_, q);
    }
    fk_q_ = q;
    Eigen::Map<Vector6d> r(residuals);
    if (position_only_) {
      r.head<3>().setZero();
      r.tail<3>() = weights_.tail<3>().cwiseProduct(data_.T_sb.translation() - T_sd_.translation());
      if (want_jacobian) {
        Eigen::Map<RowMajor6Xd> J(jacobians[0], 6, model_.dof());
        J.topRows<3>().setZero();
        // ṗ_sb = R_sb v_b.
        J.bottomRows<3>().noalias() =
            weights_.tail<3>().asDiagonal() * (data_.T_sb.linear() * data_.J_b.bottomRows<3>());
      }
      return true;
    }
    const Vector6d xi = log6(inverse(T_sd_) * data_.T_sb);
    r = weights_.cwiseProduct(xi);
    if (want_jacobian) {
      Eigen::Map<RowMajor6Xd> J(jacobians[0], 6, model_.dof());
      const Matrix6d WJr = weights_.asDiagonal() * se3_right_jacobian_inverse(xi);
      J.noalias() = WJr * data_.J_b;
    }
    return true;
  }

 private:
  const RobotModel& model_;
  Data& data_;
  Eigen::VectorXd& fk_q_;
  const Transform& T_sd_;
  const Vector6d& weights_;
  const bool& position_only_;
};

/// λ (q − q_seed): keeps a redundant arm near its seed in the null space of the task.
class RegularizationCost final : public ceres::CostFunction {
 public:
  RegularizationCost(int n, const Eigen::VectorXd& q_seed, const double& lambda)
      : q_seed_(q_seed), lambda_(lambda) {
    set_num_residuals(n);
    mutable_parameter_block_sizes()->push_back(n);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Index n = q_seed_.size();
    const Eigen::Map<const Eigen::VectorXd> q(parameters[0], n);
    Eigen::Map<Eigen::VectorXd>(residuals, n) = lambda_ * (q - q_seed_);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::MatrixXd> J(jacobians[0], n, n);  // diagonal: the layout does not matter
      J.setZero();
      J.diagonal().setConstant(lambda_);
    }
    return true;
  }

 private:
  const Eigen::VectorXd& q_seed_;
  const double& lambda_;
};

}  // namespace

void check_rigid_transform(const Matrix4d& T, const char* name) {
  const std::string what(name);
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      if (!std::isfinite(T(i, j))) {
        throw ArgumentError(what + ": entry (" + std::to_string(i) + ", " + std::to_string(j) +
                                    ") is not finite");
      }
    }
  }
  constexpr double kTolerance = 1e-6;
  if ((T.row(3) - Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0)).cwiseAbs().maxCoeff() > 1e-12) {
    throw ArgumentError(what + ": the bottom row is (" + std::to_string(T(3, 0)) + ", " +
                                std::to_string(T(3, 1)) + ", " + std::to_string(T(3, 2)) + ", " +
                                std::to_string(T(3, 3)) + "), expected (0, 0, 0, 1)");
  }
  const Matrix3d R = T.topLeftCorner<3, 3>();
  const double orthonormality = (R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthonormality > kTolerance) {
    throw ArgumentError(what + ": the rotation is not orthonormal (largest entry of |R^T R - I| is " +
                                std::to_string(orthonormality) + ", allowed 1e-6)");
  }
  const double det = R.determinant();
  if (std::abs(det - 1.0) > kTolerance) {
    throw ArgumentError(what + ": det R = " + std::to_string(det) +
                                ", expected 1 (a reflection is not a rotation)");
  }
}

/// Ends an attempt as soon as the tip is well within tolerance (a tenth of it), rather than
/// iterating on to Ceres's own convergence tests: with Levenberg-Marquardt's quadratic convergence
/// that is one step early, and the answer's error is still far below the tolerance.
class StopWhenReached final : public ceres::IterationCallback {
 public:
  explicit StopWhenReached(IkSolver::Impl& impl) : impl_(impl) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;

 private:
  IkSolver::Impl& impl_;
};

struct IkSolver::Impl {
  explicit Impl(const RobotModel& model_in)
      : model(model_in),
        data(model_in),
        fk_q(Eigen::VectorXd::Constant(model_in.dof(), std::numeric_limits<double>::quiet_NaN())),
        q(model_in.dof()),
        q_seed(model_in.dof()),
        candidate(model_in.dof()),
        answer(model_in.dof()) {}

  const RobotModel& model;
  Data data;
  // The configuration data.T_sb was computed at. The callback asks for the tip at the iterate
  // Ceres has just evaluated (after an accepted step), so it is there already.
  Eigen::VectorXd fk_q;
  Transform T_sd;
  Vector6d weights = Vector6d::Ones();
  bool position_only = false;
  double lambda = 0.0;     // λ of the regularisation now; StopWhenReached zeroes it near the target
  Eigen::VectorXd q;       // the parameter block Ceres works on
  Eigen::VectorXd q_seed;  // the seed within the limits: the regularisation's anchor
  Eigen::VectorXd candidate;  // a restart's draw
  Eigen::VectorXd answer;     // an attempt's end as the answer would be: clamped and wrapped
  std::unique_ptr<PoseCost> pose_cost;
  std::unique_ptr<RegularizationCost> regularization_cost;
  std::unique_ptr<ceres::Problem> problem;
  ceres::Solver::Options solver_options;
  std::unique_ptr<StopWhenReached> stop;
  bool regularized = false;  // the problem has the regularisation block
  double stop_position = 0.0, stop_rotation = 0.0;
  std::int64_t deadline_ns = 0;  // thread CPU time at which the budget is spent
  Clock::time_point next_reading;  // before it, the budget cannot be spent (see budget_spent)
  std::mt19937_64 rng;

  void start_budget(std::chrono::microseconds budget) {
    deadline_ns = thread_cpu_ns() + std::chrono::nanoseconds(budget).count();
    next_reading = Clock::now() + budget;
  }

  /// Reading the thread's CPU time is a system call (~0.4 µs here, a tenth of an iteration); the
  /// steady clock is not. CPU time never runs faster than wall time, so after a reading that
  /// leaves L ns of budget, the budget cannot be spent before L ns of wall time have passed: only
  /// then is the CPU time read again. The answer is the same as reading it every time.
  bool budget_spent() {
    const Clock::time_point now = Clock::now();
    if (now < next_reading) return false;
    const std::int64_t left_ns = deadline_ns - thread_cpu_ns();
    if (left_ns <= 0) return true;
    next_reading = now + std::chrono::nanoseconds(left_ns);
    return false;
  }

  /// Position and orientation errors of the tip at q_at.
  void errors(const Eigen::VectorXd& q_at, double& pos_err, double& rot_err) {
    if (q_at != fk_q) {
      forward_kinematics(model, data, q_at);
      fk_q = q_at;
    }
    pos_err = (data.T_sb.translation() - T_sd.translation()).norm();
    rot_err = log3(T_sd.linear().transpose() * data.T_sb.linear()).norm();
  }

  bool within(double pos_err, double rot_err, double pos_tol, double rot_tol) const {
    return pos_err <= pos_tol && (position_only || rot_err <= rot_tol);
  }

  /// Sets q to the best of kRestartCandidates uniform draws within the limits: the one whose tip
  /// is nearest the target (pos_err + kRestartRotationWeight rot_err).
  void draw_restart() {
    double best = std::numeric_limits<double>::infinity();
    for (int k = 0; k < kRestartCandidates; ++k) {
      for (int i = 0; i < model.dof(); ++i) {
        const Joint& joint = model.joint(i);
        const double u = uniform();
        candidate[i] = joint.type == JointType::Continuous
                           ? wrap_angle(kPi - 2.0 * kPi * u)
                           : joint.limits.lower + u * (joint.limits.upper - joint.limits.lower);
      }
      double pos_err, rot_err;
      errors(candidate, pos_err, rot_err);
      const double score = pos_err + (position_only ? 0.0 : kRestartRotationWeight * rot_err);
      if (score < best) {
        best = score;
        q = candidate;
      }
    }
  }

  /// A uniform double in [0, 1) from the top 53 bits: the same sequence with every standard
  /// library (std::uniform_real_distribution's is implementation-defined).
  double uniform() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
};

ceres::CallbackReturnType StopWhenReached::operator()(const ceres::IterationSummary& summary) {
  // update_state_every_iteration is on: impl_.q holds the current iterate.
  double pos_err, rot_err;
  impl_.errors(impl_.q, pos_err, rot_err);
  if (impl_.within(pos_err, rot_err, impl_.stop_position, impl_.stop_rotation)) {
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  if (impl_.lambda > 0.0 && impl_.within(pos_err, rot_err, kRegularizationOff, kRegularizationOff)) {
    // Near the target the seed has done its job; from here the pose error alone is minimised, so
    // the regularisation leaves no bias (~λ²|q − q_seed|) in the answer. Ceres's next step was
    // computed with it, and its cost comparison counts the dropped term as a gain: one step, and
    // a step that is accepted either way, since the true pose error is what decides.
    impl_.lambda = 0.0;
  }
  if (impl_.budget_spent()) return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  if (summary.iteration >= kAbandonIteration &&
      !impl_.within(pos_err, rot_err, kAbandonError, kAbandonError)) {
    // Stuck far away: leave the budget to a restart. Not SOLVER_ABORT, after which Ceres hands
    // back the starting point: the iterate reached is the attempt's best pose.
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  return ceres::SOLVER_CONTINUE;
}

IkSolver::IkSolver(const RobotModel& model, IkOptions options)
    : model_(model), impl_(std::make_unique<Impl>(model)) {
  impl_->stop = std::make_unique<StopWhenReached>(*impl_);
  impl_->pose_cost =
      std::make_unique<PoseCost>(model, impl_->data, impl_->fk_q, impl_->T_sd, impl_->weights, impl_->position_only);
  impl_->regularization_cost = std::make_unique<RegularizationCost>(model.dof(), impl_->q_seed, impl_->lambda);
  impl_->q.setZero();
  impl_->q_seed.setZero();

  ceres::Solver::Options& so = impl_->solver_options;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  // The normal equations of a 6×n (or 6+n × n) problem: a 7×7 Cholesky costs less than QR, and
  // the Levenberg-Marquardt damping keeps them well conditioned near singular poses.
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  // Tight enough never to stop a run that is converging (StopWhenReached ends those), loose
  // enough to give up quickly in a local minimum and leave the budget to the restarts.
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-14;
  so.gradient_tolerance = 1e-16;
  so.update_state_every_iteration = true;
  // Ceres follows every step of a bounded problem with a projected line search (polynomial
  // interpolation through a companion-matrix eigensolve, and more cost evaluations). The step is
  // projected onto the limits anyway, and the trust region rejects a bad one; on the reference
  // targets the line search doubled the time per iteration and saved no iterations.
  so.max_num_line_search_step_size_iterations = 0;
  // Joint angles and lengths are all of order one: column scaling buys nothing here and costs a
  // pass over the Jacobian per iteration.
  so.jacobi_scaling = false;
  so.callbacks.push_back(impl_->stop.get());
  set_options(options);
}

IkSolver::~IkSolver() = default;

void IkSolver::set_options(const IkOptions& options) {
  for (int k = 0; k < 6; ++k) {
    if (!(options.weights[k] > 0.0) || !std::isfinite(options.weights[k]))
      throw ArgumentError("IK weights must be positive and finite");
  }
  if (!(options.position_tolerance > 0.0) || !(options.rotation_tolerance > 0.0))
    throw ArgumentError("IK tolerances must be positive");
  if (options.time_budget.count() <= 0) throw ArgumentError("the IK time budget must be positive");
  if (options.max_restarts < 0) throw ArgumentError("the IK restart cap must not be negative");
  if (options.max_iterations < 1) throw ArgumentError("IK needs at least one iteration per attempt");
  if (!(options.regularization >= 0.0) || !std::isfinite(options.regularization))
    throw ArgumentError("the IK regularisation must be finite and not negative");
  options_ = options;

  Impl& impl = *impl_;
  impl.weights = options.weights;
  impl.position_only = options.position_only;
  impl.solver_options.max_num_iterations = options.max_iterations;
  impl.stop_position = 0.1 * options.position_tolerance;
  impl.stop_rotation = 0.1 * options.rotation_tolerance;
  const int task_dimension = options.position_only ? 3 : 6;
  impl.regularized = model_.dof() > task_dimension && options.regularization > 0.0;

  // Rebuild the problem: the costs and the parameter storage are the solver's and outlive it.
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  impl.problem = std::make_unique<ceres::Problem>(problem_options);
  double* q = impl.q.data();
  impl.problem->AddResidualBlock(impl.pose_cost.get(), nullptr, q);
  if (impl.regularized) impl.problem->AddResidualBlock(impl.regularization_cost.get(), nullptr, q);
  for (int i = 0; i < model_.dof(); ++i) {
    const Joint& joint = model_.joint(i);
    if (joint.type == JointType::Continuous) continue;  // unbounded; wrapped in the answer
    impl.problem->SetParameterLowerBound(q, i, joint.limits.lower);
    impl.problem->SetParameterUpperBound(q, i, joint.limits.upper);
  }
}

void IkSolver::set_target(const Matrix4d& T_sd) {
  check_rigid_transform(T_sd, "IK target");
  // Project R onto SO(3) (it may be off by 1e-6): through a unit quaternion.
  const Eigen::Quaterniond rotation(Matrix3d(T_sd.topLeftCorner<3, 3>()));
  impl_->T_sd = Transform(rotation.normalized().toRotationMatrix(), T_sd.topRightCorner<3, 1>());
}

void IkSolver::evaluate(const JointVector& q, Vector6d& residual, Matrix6Xd& jacobian) {
  check_joint_vector(model_, q, "q");
  const Eigen::VectorXd q_copy = q;
  RowMajor6Xd J(6, model_.dof());
  const double* parameters[] = {q_copy.data()};
  double* jacobians[] = {J.data()};
  impl_->pose_cost->Evaluate(parameters, residual.data(), jacobians);
  jacobian = J;
}

IkResult IkSolver::solve(const Transform& T_sd, const JointVector& q_seed) {
  return solve(T_sd.matrix(), q_seed);
}

IkResult IkSolver::solve(const Matrix4d& T_sd, const JointVector& q_seed) { return solve_with(T_sd, q_seed, nullptr); }

IkResult IkSolver::solve(const Transform& T_sd, const JointVector& q_seed, const IkMargin& margin) {
  return solve_with(T_sd.matrix(), q_seed, &margin);
}

IkResult IkSolver::solve(const Matrix4d& T_sd, const JointVector& q_seed, const IkMargin& margin) {
  return solve_with(T_sd, q_seed, &margin);
}

IkResult IkSolver::solve_with(const Matrix4d& T_sd, const JointVector& q_seed, const IkMargin* margin) {
  if (margin != nullptr && !*margin) throw ArgumentError("the IK margin is an empty function");
  const Clock::time_point start = Clock::now();
  set_target(T_sd);
  check_joint_vector(model_, q_seed, "q_seed");
  if (!q_seed.allFinite()) throw ArgumentError("q_seed is not finite");
  Impl& impl = *impl_;
  const int n = model_.dof();
  for (int i = 0; i < n; ++i) {
    const Joint& joint = model_.joint(i);
    impl.q_seed[i] = joint.type == JointType::Continuous
                         ? wrap_angle(q_seed[i])
                         : std::min(std::max(q_seed[i], joint.limits.lower), joint.limits.upper);
  }
  // The restarts' generator starts from the RNG seed mixed with the target and the seed: the
  // same inputs give the same restarts, and different targets do not share one sequence of
  // starting points (with which the targets a given sequence misses would all be hard).
  std::uint64_t state = mix(options_.rng_seed);
  for (int j = 0; j < 3; ++j) {
    state = mix(state ^ bits(impl.T_sd.translation()[j]));
    for (int i = 0; i < 3; ++i) state = mix(state ^ bits(impl.T_sd.linear()(i, j)));
  }
  for (int i = 0; i < n; ++i) state = mix(state ^ bits(impl.q_seed[i]));
  impl.rng.seed(state);
  impl.start_budget(options_.time_budget);

  // Joints as an answer gives them: Ceres keeps bounded joints within their limits; continuous
  // ones are wrapped.
  auto as_answer = [&](const Eigen::VectorXd& q, Eigen::VectorXd& out) {
    for (int i = 0; i < n; ++i) {
      const Joint& joint = model_.joint(i);
      out[i] = joint.type == JointType::Continuous ? wrap_angle(q[i])
                                                   : std::min(std::max(q[i], joint.limits.lower), joint.limits.upper);
    }
  };

  IkResult result;
  result.q = impl.q_seed;
  double best_score = std::numeric_limits<double>::infinity();
  // With a margin, a converged attempt it refuses is kept only while nothing better comes: the
  // refused one with the greatest margin beats any attempt that did not converge.
  bool best_converged = false;
  double best_margin = -std::numeric_limits<double>::infinity();
  ceres::Solver::Summary summary;
  for (int attempt = 0;; ++attempt) {
    if (attempt == 0) {
      impl.q = impl.q_seed;
    } else {
      impl.draw_restart();
    }
    impl.lambda = impl.regularized ? options_.regularization : 0.0;
    // Levenberg-Marquardt's first damping is 1/radius. Near the target (a warm start) Gauss-Newton
    // steps (Ceres's default radius, 1e4) converge in a few iterations; from far away they throw
    // the arm about, and damped first steps (radius 10) halved the median time of cold starts on
    // the reference targets.
    {
      double pos_err, rot_err;
      impl.errors(impl.q, pos_err, rot_err);
      impl.solver_options.initial_trust_region_radius =
          impl.within(pos_err, rot_err, kNearPosition, kNearRotation) ? 1e4 : 10.0;
    }
    ceres::Solve(impl.solver_options, impl.problem.get(), &summary);
    result.iterations += summary.num_successful_steps + summary.num_unsuccessful_steps;
    double pos_err, rot_err;
    impl.errors(impl.q, pos_err, rot_err);
    const bool converged =
        impl.within(pos_err, rot_err, options_.position_tolerance, options_.rotation_tolerance);
    const double score = pos_err + (options_.position_only ? 0.0 : rot_err);
    bool acceptable = true;
    double attempt_margin = std::numeric_limits<double>::infinity();
    if (margin != nullptr && converged) {
      as_answer(impl.q, impl.answer);
      attempt_margin = (*margin)(impl.answer);
      acceptable = attempt_margin >= 0.0;
      if (!acceptable) ++result.refused;
    }
    const bool better = converged ? (acceptable || !best_converged || attempt_margin > best_margin)
                                  : (!best_converged && score < best_score);
    if (better) {
      best_score = score;
      best_converged = converged;
      best_margin = attempt_margin;
      result.q = impl.q;
      result.pos_err = pos_err;
      result.rot_err = rot_err;
      result.converged = converged;
    }
    if ((converged && acceptable) || attempt >= options_.max_restarts || impl.budget_spent()) {
      result.restarts = attempt;
      break;
    }
  }
  impl.answer = result.q;
  as_answer(impl.answer, result.q);
  if (margin != nullptr) {
    // The answer's own margin (a converged one's was computed already; one that did not converge
    // was never asked).
    result.margin = best_converged ? best_margin : (*margin)(result.q);
    result.accepted = result.margin >= 0.0;
  }
  result.time_us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
  return result;
}

}  // namespace chasles
