#include "chasles/controller/cartesian.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "chasles/core/kinematics/kinematics.hpp"
#include "chasles/core/lie/se3.hpp"
#include "chasles/core/lie/so3.hpp"

namespace chasles::controller {
namespace {

// s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (MR eq. 9.11).
double quintic(double tau) { return tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau)); }

void fail(JointPath& path, const char* format, double a, double b, double c = 0.0) {
  path.ok = false;
  std::snprintf(path.reason, sizeof(path.reason), format, a, b, c);
}

}  // namespace

void plan_cartesian_path(IkSolver& solver, const CartesianRequest& request, JointPath& path) {
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
  for (int k = 1; k < path.count; ++k) {
    const double s = quintic(static_cast<double>(k) / (path.count - 1));
    const Transform T = k + 1 == path.count ? request.T_goal : T_start * exp6(V * s);
    IkResult result = solver.solve(T, previous);
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
      if (step) continue;
      const double speed = std::abs(result.q(i) - previous(i)) / path.dt;
      // The path's own speed peaks at 1.875× its average; a jump well past the joint's limit is
      // an IK branch flip or a singularity, not motion the arm can make.
      if (speed > model.joint(i).limits.velocity) {
        solver.set_options(saved);
        return fail(path, "joint %.0f would need %.3g rad/s (limit %.3g) on the way: a singularity, or allow more time",
                    i + 1.0, speed, model.joint(i).limits.velocity);
      }
    }
    path.q.col(k) = result.q;
    previous = result.q;
  }
  solver.set_options(saved);
  path.ok = true;
}

void JointPathSampler::sample(double t, Reference& out) const {
  const int last = path_.count - 1;
  if (t >= duration()) {  // at rest at the goal; also the whole of a path of duration 0
    out.hold(path_.q.col(last));
    return;
  }
  const double h = path_.dt;
  const double x = std::clamp(t / h, 0.0, static_cast<double>(last));
  const int k = std::min(static_cast<int>(x), last - 1);
  const double u = x - k;
  // Waypoint velocities by central differences; zero at both ends, where the path is at rest.
  const auto velocity = [&](int j, Eigen::Index i) {
    if (j == 0 || j == last) return 0.0;
    return (path_.q(i, j + 1) - path_.q(i, j - 1)) / (2.0 * h);
  };
  const double u2 = u * u, u3 = u2 * u;
  for (Eigen::Index i = 0; i < path_.q.rows(); ++i) {
    const double p0 = path_.q(i, k), p1 = path_.q(i, k + 1);
    const double m0 = velocity(k, i) * h, m1 = velocity(k + 1, i) * h;
    // Cubic Hermite basis and its derivatives in u; d/dt = (1/h) d/du.
    out.q(i) = (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1;
    out.qd(i) = ((6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * m0 + (-6 * u2 + 6 * u) * p1 + (3 * u2 - 2 * u) * m1) / h;
    out.qdd(i) = ((12 * u - 6) * p0 + (6 * u - 4) * m0 + (-12 * u + 6) * p1 + (6 * u - 2) * m1) / (h * h);
  }
}

}  // namespace chasles::controller
