// Where on the arm a contact is, from the external joint torque alone (isolation and
// localisation, after Manuelli & Tedrake 2016 and the survey of Haddadin et al. 2017): the link,
// the point on its surface and the force that best explain τ_ext, within a friction cone.
//
// A force f on the arm at a point p of body b gives τ_j = a_j(p) · f on the joints j ≤ b, with
// a_j(p) = v_j + ω_j × p from joint j's column (ω_j, v_j) of the space Jacobian, and nothing on the
// joints beyond b. For every candidate point (the surface samples below), the force is the least
// squares fit of those rows, projected onto the friction cone about the inward normal; the
// candidate whose fit leaves the smallest residual over all n joints wins on its body. The normal equations of
// a point of body b are sums over joints 1…b of terms quadratic in p: kept as prefix sums over the
// joints, each candidate costs a 3 × 3 solve whatever its body. Among the bodies whose best fit is
// within a tolerance of the best, the most proximal wins (see locate()).
//
// Candidates are fixed at construction: points on every collision object's surface, in its body's
// frame, with their outward normals — a grid on each face of a box, rings on a cylinder or a
// capsule, a Fibonacci spiral on a sphere, a barycentric grid on each of a hull's triangles.
//
// What torques cannot tell: a push on body b constrains b equations, so on a proximal link (b ≤ 3
// for 3 force components) many points explain τ_ext exactly and the friction cone alone chooses;
// a force along a line through joint axes leaves those joints' torque at zero and can read as a
// more proximal link.
#pragma once

#include <Eigen/Core>
#include <string_view>
#include <vector>

#include "core/geometry/shape.hpp"
#include "core/model/model.hpp"

namespace chasles::geometry {

struct CollisionModel;

struct ContactLocatorOptions {
  double friction = 1.0;   ///< μ of the friction cone the force is kept in
  double spacing = 0.01;   ///< m between neighbouring candidate points, about
  /// How much worse than the best a more proximal body's fit may be and still be chosen: this share
  /// of |τ_ext| plus `tolerance` N·m on the residual. Measured on a draw of the push campaign
  /// (docs/simulation.md), links right at rest: none, 63 %; 0.1 % + 0.005, 90 %; 1 % + 0.02, 80 %;
  /// 3 % + 0.05, 62 %.
  double tolerance_share = 0.001;
  double tolerance = 0.005;
};

/// The contact that best explains an external joint torque.
struct ContactEstimate {
  int object = -1;         ///< index in CollisionModel::objects; −1 when τ_ext is zero
  std::string_view link;   ///< that object's URDF link (a view of the locator's copy)
  int body = 0;            ///< the chain body it rides on
  Vector3d point = Vector3d::Zero();   ///< m, base frame
  Vector3d normal = Vector3d::Zero();  ///< unit, base frame, outward
  Vector3d force = Vector3d::Zero();   ///< N, base frame, on the arm at `point`
  double residual = 0.0;   ///< ‖τ_ext − J_p(point)ᵀ force‖, N·m
};

class ContactLocator {
 public:
  /// Samples every object's surface (see the header's comment). Throws ArgumentError for μ < 0 or a
  /// spacing that is not > 0.
  ContactLocator(const RobotModel& model, const CollisionModel& collision, const ContactLocatorOptions& options = {});

  /// The best contact for tau_ext at the poses and space Jacobian in `data` (as space_jacobian
  /// leaves them). Allocates nothing.
  const ContactEstimate& locate(const Data& data, const Eigen::Ref<const Eigen::VectorXd>& tau_ext);

  int candidates() const { return static_cast<int>(samples_.size()); }

 private:
  struct Sample {
    Vector3d point, normal;  // in the body's frame
    int body, object;
  };
  std::vector<Sample> samples_;
  std::vector<std::string> links_;  // per object
  double friction_;
  // Prefix sums over joints 1…b (index b): Σ v vᵀ, Σ v ωᵀ, Σ ω ωᵀ, Σ v τ, Σ ω τ, Σ τ².
  std::vector<Matrix3d> V_, X_, W_;
  std::vector<Vector3d> gv_, gw_;
  std::vector<double> tail_;  // index b: Σ τ_j² over the joints beyond body b
  struct Fit {
    double cost = 0.0;
    int object = -1;
    Vector3d point, normal, force;
  };
  std::vector<Fit> fits_;  // index b: body b's best candidate
  double tolerance_share_, tolerance_;
  ContactEstimate best_;
};

/// Points on the surface of `shape` about `spacing` apart, with their outward normals, in the
/// shape's frame.
void sample_surface(const Shape& shape, double spacing, std::vector<Vector3d>& points, std::vector<Vector3d>& normals);

}  // namespace chasles::geometry
