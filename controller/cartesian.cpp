#include "controller/cartesian.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "controller/jog.hpp"

#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"
#include "core/lie/so3.hpp"

namespace chasles::controller {
namespace {

// s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (MR eq. 9.11), and ds/dτ.
double quintic(double tau) { return tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau)); }
double quintic_rate(double tau) { return 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau); }

// The joint velocity that moves the tip along the screw line at time t: the body twist there is
// V ṡ(t), so q̇ = J_b⁺ V ṡ, weighted as the IK weighs its errors (position-only: the tip point's
// velocity in the base's axes, R J_v q̇ = R v_b), least-norm on a redundant arm and least-squares
// on one with fewer than six joints.
class ScrewLineRate {
 public:
  ScrewLineRate(const RobotModel& model, const IkOptions& options, const Vector6d& V, double duration)
      : model_(model),
        data_(model),
        options_(options),
        V_(V),
        duration_(duration),
        A_(6, model.dof()),
        qd_(Eigen::VectorXd::Zero(model.dof())) {}

  const Eigen::VectorXd& operator()(const Eigen::VectorXd& q, double t) {
    const double s_dot = quintic_rate(std::clamp(t / duration_, 0.0, 1.0)) / duration_;
    const Matrix6Xd& J = body_jacobian(model_, data_, q);
    Vector6d b;
    if (options_.position_only) {
      const Matrix3d W_R = options_.weights.tail<3>().asDiagonal() * data_.T_sb.linear();
      A_.topRows<3>().setZero();
      A_.bottomRows<3>().noalias() = W_R * J.bottomRows<3>();
      b << Vector3d::Zero(), W_R * V_.tail<3>() * s_dot;
    } else {
      A_.noalias() = options_.weights.asDiagonal() * J;
      b = options_.weights.cwiseProduct(V_) * s_dot;
    }
    spectrum_.compute(A_);
    spectrum_.solve(A_, b, qd_);
    return qd_;
  }

 private:
  const RobotModel& model_;
  Data data_;
  const IkOptions& options_;
  const Vector6d V_;
  const double duration_;
  Matrix6Xd A_;
  JacobianSpectrum spectrum_;
  Eigen::VectorXd qd_;
};

// rad (m): how far the IK may move a joint from where the joint rate carried it (the rate's own
// error is below 1e-8 rad a waypoint, the IK's corrections within its tolerance).
constexpr double kLeftThePath = 1e-3;

void fail(JointPath& path, const char* format, double a, double b, double c = 0.0) {
  path.ok = false;
  std::snprintf(path.reason, sizeof(path.reason), format, a, b, c);
}

// The joint path's accelerations at the waypoints, whose velocities (the rate there) the planning
// loop set: the rate's derivative along the motion, d/dt q̇(q(t), t), by a central difference over
// a step short enough to be exact to rounding; at rest at both ends, where the quintic timing has
// ṡ = s̈ = 0.
void path_accelerations(ScrewLineRate& rate, JointPath& path) {
  const int last = path.count - 1;
  constexpr double kStep = 1e-6;  // s
  path.qd.col(0).setZero();
  path.qdd.col(0).setZero();
  path.qd.col(last).setZero();
  path.qdd.col(last).setZero();
  for (int k = 1; k < last; ++k) {
    const double t = k * path.dt;
    const Eigen::VectorXd ahead = rate(path.q.col(k) + kStep * path.qd.col(k), t + kStep);
    path.qdd.col(k) = (ahead - rate(path.q.col(k) - kStep * path.qd.col(k), t - kStep)) / (2.0 * kStep);
  }
}

// Whether the quintics the sampler will follow keep every limit; if not, fails the path naming
// the first joint and quantity over, and the duration that would do. Stretching the times by c
// leaves the positions and divides the velocities, accelerations and jerks by c, c², c³, so the
// least c is the largest of the velocity ratio and the square and cube roots of the others.
bool within_limits(const RobotModel& model, const motion::MotionLimits& limits, double duration, JointPath& path) {
  const int n = model.dof();
  const double h = path.dt;
  double stretch = 1.0;
  motion::LimitExcess first;
  int first_waypoint = 0;
  double c[6];
  for (int k = 0; k + 1 < path.count; ++k) {
    for (int i = 0; i < n; ++i) {
      motion::quintic_hermite(path.q(i, k), path.qd(i, k), path.qdd(i, k), path.q(i, k + 1), path.qd(i, k + 1),
                      path.qdd(i, k + 1), h, c);
      const motion::LimitExcess e = motion::quintic_excess(c, h, limits, i);
      if (!e) continue;
      if (e.quantity == motion::LimitExcess::kPosition) {
        std::snprintf(path.reason, sizeof(path.reason),
                      "joint %s would reach %.4g on the way, outside [%.4g, %.4g] (its limits less the margin), "
                      "%.0f%% of the way",
                      model.joint(i).name.c_str(), e.value, limits.lower(i), limits.upper(i),
                      100.0 * k / (path.count - 1));
        return false;
      }
      const double v[5] = {c[1], 2 * c[2], 3 * c[3], 4 * c[4], 5 * c[5]};
      const double a[4] = {2 * c[2], 6 * c[3], 12 * c[4], 20 * c[5]};
      const double j[3] = {6 * c[3], 24 * c[4], 60 * c[5]};
      stretch = std::max({stretch, motion::max_abs_polynomial(v, 4, h) / limits.velocity(i),
                          std::sqrt(motion::max_abs_polynomial(a, 3, h) / limits.acceleration(i)),
                          std::cbrt(motion::max_abs_polynomial(j, 2, h) / limits.jerk(i))});
      if (!first) {
        first = e;
        first_waypoint = k;
      }
    }
  }
  if (!first) return true;
  if (!std::isfinite(stretch)) {  // the rate is unbounded: J_b lost rank on the way
    std::snprintf(path.reason, sizeof(path.reason),
                  "joint %s: unbounded %s %.0f%% of the way: the line passes a singularity",
                  model.joint(first.joint).name.c_str(), to_string(first.quantity),
                  100.0 * first_waypoint / (path.count - 1));
    return false;
  }
  std::snprintf(path.reason, sizeof(path.reason),
                "joint %s: its %s would reach %.4g %s (limit %.4g) %.0f%% of the way; %.4g s would do",
                model.joint(first.joint).name.c_str(), to_string(first.quantity), first.value,
                unit_of(first.quantity), first.limit, 100.0 * first_waypoint / (path.count - 1),
                duration * stretch * (1.0 + 1e-6));
  return false;
}

}  // namespace

void plan_cartesian_path(IkSolver& solver, const motion::MotionLimits& limits, const CartesianRequest& request,
                         JointPath& path) {
  const RobotModel& model = solver.model();
  const int n = model.dof();
  path.request_id = request.id;
  path.ok = false;
  path.reason[0] = '\0';
  path.ik_iterations = 0;
  path.ik_residual = path.ik_rot_residual = 0.0;
  path.count = std::clamp(static_cast<int>(std::ceil(request.duration / JointPath::kMinSpacing)) + 1, 2,
                          JointPath::kMaxWaypoints);
  path.dt = request.duration / (path.count - 1);  // A duration of 0 (an impedance law's step of its equilibrium): the goal alone, no speed to check.
  const bool step = request.duration == 0.0;

  Data data(model);
  const Transform T_start = forward_kinematics(model, data, request.q_start);
  const Vector6d V = log6(inverse(T_start) * request.T_goal);

  IkOptions options = solver.options();
  const IkOptions saved = options;
  options.max_restarts = 0;
  solver.set_options(options);
  path.q.col(0) = request.q_start;
  Eigen::VectorXd previous = request.q_start;
  ScrewLineRate rate(model, saved, V, std::max(request.duration, 1e-9));
  const double h = path.dt;
  for (int k = 1; k < path.count; ++k) {
    const double s = quintic(static_cast<double>(k) / (path.count - 1));
    const Transform T = k + 1 == path.count ? request.T_goal : T_start * exp6(V * s);
    // The seed is the last waypoint carried along the joint rate (classic Runge-Kutta), which
    // lands within the IK's tolerance already: the IK then confirms it (or corrects a drift)
    // instead of choosing, so the waypoints lie on one smooth curve whose velocity is the rate
    // — what the sampler's quintics need. IK's own answers scatter within its tolerance, and a
    // redundant arm's in its null space, which differences of positions turn into jerk.
    Eigen::VectorXd seed = previous;
    if (!step) {
      const double t = (k - 1) * h;
      const Eigen::VectorXd k1 = rate(previous, t);
      path.qd.col(k - 1) = k1;  // the rate at the waypoint before, which the sampler needs too
      const Eigen::VectorXd k2 = rate(previous + 0.5 * h * k1, t + 0.5 * h);
      const Eigen::VectorXd k3 = rate(previous + 0.5 * h * k2, t + 0.5 * h);
      const Eigen::VectorXd k4 = rate(previous + h * k3, t + h);
      seed += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    IkResult result = solver.solve(T, seed);
    path.ik_iterations += result.iterations;
    path.ik_residual = std::max(path.ik_residual, result.pos_err);
    path.ik_rot_residual = std::max(path.ik_rot_residual, result.rot_err);
    if (!result.converged) {
      solver.set_options(saved);
      return fail(path, "the tip cannot follow the straight line: IK fails %.0f%% of the way (off by %.3g m, %.3g rad)",
                  100.0 * s, result.pos_err, result.rot_err);
    }
    for (int i = 0; i < n; ++i) {
      // IK answers a continuous joint in (−π, π]; along a path it must move on from where it is,
      // not jump by 2π when it crosses ±π.
      if (model.joint(i).type == JointType::Continuous) {
        result.q(i) = previous(i) + wrap_angle(result.q(i) - previous(i));
      }
      // The IK answers where the path leads to within its tolerance; a joint that lands far
      // from there has left the path: another IK branch, or a singularity the rate could not
      // carry it through.
      if (!step && std::abs(result.q(i) - seed(i)) > kLeftThePath) {
        solver.set_options(saved);
        return fail(path, "the tip cannot follow the straight line %.0f%% of the way: joint %.0f jumps %.3g rad off the "
                    "path (a singularity or another IK branch)", 100.0 * s, i + 1.0, result.q(i) - seed(i));
      }
    }
    path.q.col(k) = result.q;
    previous = result.q;
  }
  solver.set_options(saved);
  if (!step) path_accelerations(rate, path);
  if (!step && !within_limits(model, limits, request.duration, path)) return;
  path.ok = true;
}

void JointPathSampler::sample(double t, motion::Reference& out) const {
  const int last = path_.count - 1;
  if (t >= duration()) {  // at rest at the goal; also the whole of a path of duration 0
    out.hold(path_.q.col(last));
    return;
  }
  const double h = path_.dt;
  const double x = std::clamp(t / h, 0.0, static_cast<double>(last));
  const int k = std::min(static_cast<int>(x), last - 1);
  const double local = std::max(t, 0.0) - k * h;
  double c[6];
  for (Eigen::Index i = 0; i < path_.q.rows(); ++i) {
    motion::quintic_hermite(path_.q(i, k), path_.qd(i, k), path_.qdd(i, k), path_.q(i, k + 1), path_.qd(i, k + 1),
                    path_.qdd(i, k + 1), h, c);
    motion::sample_quintic(c, local, out.q(i), out.qd(i), out.qdd(i));
  }
}

}  // namespace chasles::controller
