#include "core/geometry/contact_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"

namespace chasles::geometry {
namespace {

Matrix3d skew(const Vector3d& p) {
  Matrix3d P;
  P << 0.0, -p.z(), p.y(), p.z(), 0.0, -p.x(), -p.y(), p.x(), 0.0;
  return P;
}

int count_for(double length, double spacing) { return std::max(1, static_cast<int>(std::ceil(length / spacing))); }

// n directions spread evenly over the sphere (a Fibonacci spiral); over the upper half only
// (z ≥ 0) when `half`.
void fibonacci(int n, bool half, std::vector<Vector3d>& out) {
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = half ? 1.0 - (i + 0.5) / n : 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    out.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
}

// A ring-and-height grid on the side of a z-axis cylinder of radius r from z = −h to h.
void sample_side(double r, double h, double spacing, std::vector<Vector3d>& points, std::vector<Vector3d>& normals) {
  const int around = count_for(2.0 * M_PI * r, spacing), along = count_for(2.0 * h, spacing);
  for (int a = 0; a < around; ++a) {
    const double t = 2.0 * M_PI * (a + 0.5) / around;
    const Vector3d n(std::cos(t), std::sin(t), 0.0);
    for (int k = 0; k < along; ++k) {
      points.push_back(r * n + Vector3d(0.0, 0.0, -h + 2.0 * h * (k + 0.5) / along));
      normals.push_back(n);
    }
  }
}

}  // namespace

void sample_surface(const Shape& shape, double spacing, std::vector<Vector3d>& points, std::vector<Vector3d>& normals) {
  switch (shape.kind) {
    case ShapeKind::kSphere: {
      std::vector<Vector3d> directions;
      fibonacci(count_for(4.0 * M_PI * shape.radius * shape.radius, spacing * spacing), false, directions);
      for (const Vector3d& u : directions) points.push_back(shape.radius * u), normals.push_back(u);
      return;
    }
    case ShapeKind::kBox:
      for (int axis = 0; axis < 3; ++axis)
        for (const double side : {-1.0, 1.0}) {
          const int u = (axis + 1) % 3, v = (axis + 2) % 3;
          const int nu = count_for(2.0 * shape.half_extents[u], spacing), nv = count_for(2.0 * shape.half_extents[v], spacing);
          Vector3d n = Vector3d::Zero();
          n[axis] = side;
          for (int i = 0; i < nu; ++i)
            for (int j = 0; j < nv; ++j) {
              Vector3d p = Vector3d::Zero();
              p[axis] = side * shape.half_extents[axis];
              p[u] = shape.half_extents[u] * (2.0 * (i + 0.5) / nu - 1.0);
              p[v] = shape.half_extents[v] * (2.0 * (j + 0.5) / nv - 1.0);
              points.push_back(p), normals.push_back(n);
            }
        }
      return;
    case ShapeKind::kCylinder: {
      sample_side(shape.radius, shape.half_length, spacing, points, normals);
      const int rings = count_for(shape.radius, spacing);
      for (const double side : {-1.0, 1.0})
        for (int k = 0; k < rings; ++k) {
          const double r = shape.radius * (k + 0.5) / rings;
          const int around = count_for(2.0 * M_PI * r, spacing);
          for (int a = 0; a < around; ++a) {
            const double t = 2.0 * M_PI * (a + 0.5) / around;
            points.emplace_back(r * std::cos(t), r * std::sin(t), side * shape.half_length);
            normals.emplace_back(0.0, 0.0, side);
          }
        }
      return;
    }
    case ShapeKind::kCapsule: {
      sample_side(shape.radius, shape.half_length, spacing, points, normals);
      std::vector<Vector3d> cap;
      fibonacci(count_for(2.0 * M_PI * shape.radius * shape.radius, spacing * spacing), true, cap);
      for (const double side : {-1.0, 1.0})
        for (const Vector3d& u : cap) {
          const Vector3d n(u.x(), u.y(), side * u.z());
          points.push_back(Vector3d(0.0, 0.0, side * shape.half_length) + shape.radius * n), normals.push_back(n);
        }
      return;
    }
    case ShapeKind::kConvex: {
      // The hull's triangles are the triples of vertices that are each other's neighbours (qhull's
      // triangulated output: on a convex surface a 3-cycle of edges bounds a face); each is
      // sampled on a barycentric grid, with its outward normal.
      const std::vector<Vector3d>& v = shape.vertices;
      Vector3d centre = Vector3d::Zero();
      for (const Vector3d& x : v) centre += x / static_cast<double>(v.size());
      auto adjacent = [&](int a, int b) {
        const std::vector<int>& na = shape.neighbours[static_cast<size_t>(a)];
        return std::find(na.begin(), na.end(), b) != na.end();
      };
      for (int i = 0; i < static_cast<int>(v.size()); ++i)
        for (const int j : shape.neighbours[static_cast<size_t>(i)])
          for (const int k : shape.neighbours[static_cast<size_t>(i)]) {
            if (!(i < j && j < k) || !adjacent(j, k)) continue;
            const Vector3d &a = v[static_cast<size_t>(i)], &b = v[static_cast<size_t>(j)], &c = v[static_cast<size_t>(k)];
            Vector3d n = (b - a).cross(c - a);
            if (!(n.norm() > 0.0)) continue;
            n.normalize();
            if (n.dot(a - centre) < 0.0) n = -n;
            const int m = count_for(std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}), spacing);
            for (int p = 0; p < m; ++p)
              for (int q = 0; p + q < m; ++q) {
                // Cell centres of the grid of m² small triangles (those pointing the same way).
                const double wb = (p + 1.0 / 3.0) / m, wc = (q + 1.0 / 3.0) / m;
                points.push_back(a + wb * (b - a) + wc * (c - a)), normals.push_back(n);
              }
          }
      return;
    }
  }
}

ContactLocator::ContactLocator(const RobotModel& model, const CollisionModel& collision,
                               const ContactLocatorOptions& options)
    : friction_(options.friction), tolerance_share_(options.tolerance_share), tolerance_(options.tolerance) {
  if (!(options.friction >= 0.0) || !std::isfinite(options.friction))
    throw ArgumentError("contact locator: the friction coefficient must be a finite number >= 0");
  if (!(options.spacing > 0.0) || !std::isfinite(options.spacing))
    throw ArgumentError("contact locator: the spacing must be a finite length > 0");
  if (!(options.tolerance_share >= 0.0) || !std::isfinite(options.tolerance_share) || !(options.tolerance >= 0.0) ||
      !std::isfinite(options.tolerance))
    throw ArgumentError("contact locator: the fit's tolerances must be finite and >= 0");
  std::vector<Vector3d> points, normals;
  for (size_t o = 0; o < collision.objects.size(); ++o) {
    const CollisionObject& object = collision.objects[o];
    links_.push_back(object.link);
    if (object.body == 0) continue;  // the fixed base: no force on it reaches a joint
    points.clear(), normals.clear();
    sample_surface(object.shape, options.spacing, points, normals);
    for (size_t k = 0; k < points.size(); ++k)
      samples_.push_back({object.T_body_object * points[k], object.T_body_object.linear() * normals[k], object.body,
                          static_cast<int>(o)});
  }
  std::stable_sort(samples_.begin(), samples_.end(), [](const Sample& a, const Sample& b) { return a.body > b.body; });
  const size_t n = static_cast<size_t>(model.dof()) + 1;
  tail_.assign(n, 0.0);
  fits_.assign(n, Fit{});
  V_.assign(n, Matrix3d::Zero()), X_.assign(n, Matrix3d::Zero()), W_.assign(n, Matrix3d::Zero());
  gv_.assign(n, Vector3d::Zero()), gw_.assign(n, Vector3d::Zero());
}

const ContactEstimate& ContactLocator::locate(const Data& data, const Eigen::Ref<const Eigen::VectorXd>& tau_ext) {
  const int n = static_cast<int>(V_.size()) - 1;
  for (int j = 0; j < n; ++j) {
    const Vector3d w = data.J_s.col(j).head<3>(), v = data.J_s.col(j).tail<3>();
    V_[j + 1] = V_[j] + v * v.transpose();
    X_[j + 1] = X_[j] + v * w.transpose();
    W_[j + 1] = W_[j] + w * w.transpose();
    gv_[j + 1] = gv_[j] + v * tau_ext[j];
    gw_[j + 1] = gw_[j] + w * tau_ext[j];
  }
  const double tau2 = tau_ext.squaredNorm();
  best_ = ContactEstimate{};
  best_.residual = std::sqrt(tau2);
  if (tau2 == 0.0) return best_;
  // Each body's best fit, then the most proximal body whose fit is as good as the best within the
  // tolerance: a push on body b turns joints 1…b only, and a fit on a body beyond it needs a force
  // that happens to leave the joints between at zero — where torques alone cannot tell, the
  // coincidence is the less likely reading (a push on a UR5's shoulder, 0.26 N·m on joint 1 alone,
  // is also 0.5 N somewhere on its wrist). A point of body b leaves at least the torque of the
  // joints beyond b unexplained: samples come ordered from the tip's body to the base's, and once
  // that bound exceeds the best fit by more than the tolerance no body before it can be chosen.
  for (int b = n; b-- > 0;) tail_[b] = tail_[b + 1] + tau_ext[b] * tau_ext[b];
  const double tolerance = tolerance_share_ * std::sqrt(tau2) + tolerance_;  // N·m, on the residual
  for (Fit& fit : fits_) fit.cost = std::numeric_limits<double>::infinity();
  double best_cost = std::numeric_limits<double>::infinity();
  auto within = [&](double cost) {
    return std::sqrt(std::max(0.0, cost)) <= std::sqrt(std::max(0.0, best_cost)) + tolerance;
  };
  for (const Sample& s : samples_) {
    if (!within(tail_[s.body])) break;
    const Transform& T = data.T_body[static_cast<size_t>(s.body)];
    const Vector3d p = T * s.point, normal = T.linear() * s.normal;
    // a_j = v_j − [p] ω_j: H = Σ a aᵀ and g = Σ a τ from the prefix sums.
    const Matrix3d P = skew(p);
    const Matrix3d XPt = X_[s.body] * P.transpose();
    const Matrix3d H = V_[s.body] - XPt - XPt.transpose() + P * W_[s.body] * P.transpose();
    const Vector3d g = gv_[s.body] - P * gw_[s.body];
    // A body near the base has fewer joints than force components: the ridge picks the least force.
    const double ridge = 1e-9 * (H.trace() + 1e-12);
    Vector3d f = (H + ridge * Matrix3d::Identity()).ldlt().solve(g);
    // Into the cone about the inward normal −n: the closest point of {|f_t| ≤ μ f_n}.
    const double fn = -f.dot(normal);
    const Vector3d ft = f + fn * normal;
    const double t = ft.norm();
    if (t > friction_ * fn) {
      if (friction_ * t <= -fn) {
        f.setZero();
      } else {
        const double a = (fn + friction_ * t) / (1.0 + friction_ * friction_);
        f = -a * normal;
        if (t > 0.0) f += (friction_ * a / t) * ft;
      }
    }
    const double cost = tau2 - 2.0 * f.dot(g) + f.dot(H * f);
    best_cost = std::min(best_cost, cost);
    Fit& fit = fits_[static_cast<size_t>(s.body)];
    if (cost < fit.cost) fit = {cost, s.object, p, normal, f};
  }
  for (int b = 1; b <= n; ++b) {
    const Fit& fit = fits_[static_cast<size_t>(b)];
    if (fit.object < 0 || !within(fit.cost)) continue;
    best_.object = fit.object;
    best_.body = b;
    best_.point = fit.point;
    best_.normal = fit.normal;
    best_.force = fit.force;
    best_cost = fit.cost;
    break;
  }
  if (best_.object < 0) return best_;  // an arm with no collision object off its base
  best_.link = links_[static_cast<size_t>(best_.object)];
  best_.residual = std::sqrt(std::max(0.0, best_cost));
  return best_;
}

}  // namespace chasles::geometry
