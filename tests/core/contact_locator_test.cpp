// ContactLocator (core/geometry/contact_locator.hpp) on torques made exactly from a known contact:
// τ = J_p(p)ᵀ f for a force f at a point p of body b, through the space Jacobian's columns 1…b.
// Where the torques determine the contact (a body with six joints or more before it: b equations
// for the five unknowns of a point on the surface and a force), the one that made them is found;
// where they do not, the most proximal body that explains them is. Against MuJoCo's contacts, and in
// the loop, see tests/mujoco.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/contact_locator.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/reference.hpp"

namespace chasles::geometry {
namespace {

using chasles::testing::data_path;
using Eigen::VectorXd;

struct Panda {
  RobotModel model;
  CollisionModel collision;
};

const Panda& panda() {
  static const Panda arm = [] {
    UrdfOptions options;
    options.tip_link = "panda_hand";
    RobotModel model = load_urdf_file(data_path("panda.urdf"), options);
    CollisionModel collision = load_collision_model(data_path("panda.urdf"), model, {{data_path("packages")}, ""});
    return Panda{std::move(model), std::move(collision)};
  }();
  return arm;
}

VectorXd bent() {
  VectorXd q(7);
  q << 0.3, -0.4, 0.2, -2.0, 0.3, 1.8, 0.6;
  return q;
}

// The joint torque of a force f at the base-frame point p of body b.
VectorXd torque_of(const Data& data, int body, const Vector3d& p, const Vector3d& f) {
  Vector6d F;
  F << p.cross(f), f;
  VectorXd tau = VectorXd::Zero(data.J_s.cols());
  tau.head(body) = data.J_s.leftCols(body).transpose() * F;
  return tau;
}

// A force at one of the locator's own candidates on the hand and the wrist (bodies 6 and 7), inside
// the friction cone: that point and that force, to the solver's precision, and no residual.
TEST(ContactLocator, AContactTheTorquesDetermineIsFoundWhereItIs) {
  const Panda& arm = panda();
  Data data(arm.model);
  space_jacobian(arm.model, data, bent());
  ContactLocator locator(arm.model, arm.collision);
  std::mt19937 random(6);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int found = 0, tried = 0;
  for (size_t o = 0; o < arm.collision.objects.size(); ++o) {
    const CollisionObject& object = arm.collision.objects[o];
    if (object.body < 6) continue;
    std::vector<Vector3d> points, normals;
    sample_surface(object.shape, 0.01, points, normals);  // the locator's own spacing
    for (int draw = 0; draw < 4; ++draw) {
      const size_t k = std::uniform_int_distribution<size_t>(0, points.size() - 1)(random);
      const Transform& T = data.T_body[static_cast<size_t>(object.body)];
      const Vector3d p = T * (object.T_body_object * points[k]);
      const Vector3d inward = -(T.linear() * (object.T_body_object.linear() * normals[k]));
      Vector3d tangent = Vector3d(unit(random), unit(random), unit(random));
      tangent -= tangent.dot(inward) * inward;
      const Vector3d f = 20.0 * (inward + 0.5 * tangent.normalized()).normalized();  // 27° off the normal
      const VectorXd tau = torque_of(data, object.body, p, f);
      const ContactEstimate& e = locator.locate(data, tau);
      ++tried;
      // Another object of the body may pass through the same point (the hand's hull and the
      // fingers'): the point and the force, not the object, are what the torques fix.
      const bool here = (e.point - p).norm() < 1e-9 && (e.force - f).norm() < 1e-6 * f.norm();
      found += here;
      EXPECT_TRUE(here) << object.link << " point " << k << ": found " << e.link << " at " << e.point.transpose()
                        << " (" << (e.point - p).norm() << " m off), force " << e.force.transpose() << " against "
                        << f.transpose();
      EXPECT_EQ(e.body, object.body);
      // The residual comes from the expanded form τ² − 2 f·g + f·H f, whose cancellation leaves
      // √ε |τ| (1.5e-8 |τ|) where it is zero.
      EXPECT_LT(e.residual, 1e-7 * tau.norm());
    }
  }
  EXPECT_GE(tried, 12);
  EXPECT_EQ(found, tried);
}

// A torque on the first joint alone is explained by a push on body 1 and, as well, by one somewhere
// beyond it whose force happens to leave the joints between at zero: the locator names body 1.
// Joints 1 and 2 alone: body 2.
TEST(ContactLocator, WhereTorquesCannotTellTheMostProximalBodyThatExplainsThemIsNamed) {
  const Panda& arm = panda();
  Data data(arm.model);
  space_jacobian(arm.model, data, bent());
  ContactLocator locator(arm.model, arm.collision);
  VectorXd tau = VectorXd::Zero(7);
  tau(0) = 0.26;
  EXPECT_EQ(locator.locate(data, tau).body, 1);
  EXPECT_LT(locator.locate(data, tau).residual, 1e-9);
  tau(1) = -0.4;
  EXPECT_EQ(locator.locate(data, tau).body, 2);
  // No torque, no contact.
  const ContactEstimate& none = locator.locate(data, VectorXd::Zero(7));
  EXPECT_EQ(none.object, -1);
  EXPECT_EQ(none.residual, 0.0);
}

// A force outside the friction cone: what comes back is inside it (|f_t| ≤ μ f_n about the inward
// normal at the point found), and a torque the cone cannot make leaves a residual.
TEST(ContactLocator, TheForceFoundIsInsideTheFrictionCone) {
  const Panda& arm = panda();
  Data data(arm.model);
  space_jacobian(arm.model, data, bent());
  ContactLocatorOptions options;
  options.friction = 0.3;
  ContactLocator locator(arm.model, arm.collision, options);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int draw = 0; draw < 20; ++draw) {
    VectorXd tau(7);
    for (int i = 0; i < 7; ++i) tau(i) = 3.0 * unit(random);
    const ContactEstimate& e = locator.locate(data, tau);
    ASSERT_GE(e.object, 0);
    const double fn = -e.force.dot(e.normal);
    const double ft = (e.force + fn * e.normal).norm();
    EXPECT_GE(fn, -1e-12);
    EXPECT_LE(ft, options.friction * fn + 1e-9) << "draw " << draw;
    // The residual is the fit's: ‖τ − J_pᵀ f‖ at the point and force returned.
    EXPECT_NEAR(e.residual, (tau - torque_of(data, e.body, e.point, e.force)).norm(), 1e-9 * (1.0 + tau.norm()));
  }
}

TEST(ContactLocator, LocatingAllocatesNothingAndBadOptionsAreRefused) {
  const Panda& arm = panda();
  Data data(arm.model);
  space_jacobian(arm.model, data, bent());
  ContactLocator locator(arm.model, arm.collision);
  VectorXd tau = VectorXd::LinSpaced(7, -1.0, 1.0);
  locator.locate(data, tau);
  {
    chasles::testing::AllocationCounter counter;
    locator.locate(data, tau);
    EXPECT_EQ(counter.count(), 0);
  }
  for (const auto& [friction, spacing, share] :
       std::vector<std::tuple<double, double, double>>{{-1.0, 0.01, 0.0}, {1.0, 0.0, 0.0}, {1.0, 0.01, -0.1},
                                                        {std::nan(""), 0.01, 0.0}}) {
    ContactLocatorOptions options;
    options.friction = friction;
    options.spacing = spacing;
    options.tolerance_share = share;
    EXPECT_THROW(ContactLocator(arm.model, arm.collision, options), ArgumentError);
  }
}

}  // namespace
}  // namespace chasles::geometry
