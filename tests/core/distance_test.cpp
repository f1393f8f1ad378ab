// The signed distance between convex shapes (core/geometry/distance.hpp) against what is known
// without it: closed forms for spheres, boxes, cylinders and capsules apart and overlapping; the
// same box given as a box and as the hull of its corners; the support of a hull found by climbing
// against a scan of every vertex; witness points that lie on their shapes, |p_a − p_b| = |d|.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "core/geometry/distance.hpp"

namespace chasles::geometry {
namespace {

Transform at(double x, double y, double z, const Matrix3d& R = Matrix3d::Identity()) {
  Transform T = Transform::Identity();
  T.linear() = R;
  T.translation() << x, y, z;
  return T;
}

Shape sphere(double r) {
  Shape s;
  s.kind = ShapeKind::kSphere;
  s.radius = r;
  return s;
}

Shape box(double x, double y, double z) {
  Shape s;
  s.kind = ShapeKind::kBox;
  s.half_extents << x, y, z;
  return s;
}

Shape cylinder(double r, double half_length) {
  Shape s;
  s.kind = ShapeKind::kCylinder;
  s.radius = r;
  s.half_length = half_length;
  return s;
}

Shape capsule(double r, double half_length) {
  Shape s = cylinder(r, half_length);
  s.kind = ShapeKind::kCapsule;
  return s;
}

// The box as the hull of its eight corners, each joined to the three it shares an edge with.
Shape hull_of_box(double x, double y, double z) {
  Shape s;
  s.kind = ShapeKind::kConvex;
  for (int i = 0; i < 8; ++i) s.vertices.emplace_back(i & 1 ? x : -x, i & 2 ? y : -y, i & 4 ? z : -z);
  for (int i = 0; i < 8; ++i) s.neighbours.push_back({i ^ 1, i ^ 2, i ^ 4});
  return s;
}

Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

Distance distance(const Shape& a, const Transform& T_a, const Shape& b, const Transform& T_b) {
  DistanceCache cache;
  return signed_distance(a, T_a, b, T_b, cache);
}

// The largest value of n·x over shape at pose T, brute force for a hull, closed form otherwise.
double support_value(const Shape& shape, const Transform& T, const Vector3d& n) {
  const Vector3d local = T.linear().transpose() * n;
  int vertex = 0;
  double value = local.dot(support_of_core(shape, local, vertex)) + margin_of(shape) * local.norm();
  if (shape.kind == ShapeKind::kConvex) {
    value = -INFINITY;
    for (const Vector3d& v : shape.vertices) value = std::max(value, local.dot(v));
  }
  return value + n.dot(T.translation());
}

TEST(SignedDistance, SpheresApartAndOverlapping) {
  const Distance apart = distance(sphere(0.1), at(0, 0, 0), sphere(0.2), at(0.3, 0.4, 0.0));
  EXPECT_NEAR(apart.distance, 0.5 - 0.3, 1e-15);
  EXPECT_LT((apart.p_a - Vector3d(0.06, 0.08, 0.0)).norm(), 1e-15);
  EXPECT_LT((apart.p_b - Vector3d(0.18, 0.24, 0.0)).norm(), 1e-15);
  EXPECT_LT((apart.normal - Vector3d(0.6, 0.8, 0.0)).norm(), 1e-15);
  const Distance overlapping = distance(sphere(0.1), at(0, 0, 0), sphere(0.2), at(0.0, 0.0, 0.25));
  EXPECT_NEAR(overlapping.distance, -0.05, 1e-15);
  // Overlapping, p_a is a's point deepest in b.
  EXPECT_LT((overlapping.p_a - Vector3d(0, 0, 0.1)).norm(), 1e-15);
  EXPECT_LT((overlapping.p_b - Vector3d(0, 0, 0.05)).norm(), 1e-15);
}

TEST(SignedDistance, BoxesFaceToFaceEdgeToEdgeAndOverlapping) {
  const Shape b = box(0.1, 0.2, 0.3);
  EXPECT_NEAR(distance(b, at(0, 0, 0), b, at(0.5, 0.1, -0.2)).distance, 0.3, 1e-12);
  // Corner regions: the gap is the diagonal of the two gaps.
  EXPECT_NEAR(distance(b, at(0, 0, 0), b, at(0.25, 0.41, 0.0)).distance, std::hypot(0.05, 0.01), 1e-12);
  // Overlapping by 0.05 along x, less than along y and z: the depth is 0.05, along x.
  const Distance d = distance(b, at(0, 0, 0), b, at(0.15, 0.01, 0.02));
  EXPECT_NEAR(d.distance, -0.05, 1e-12);
  EXPECT_LT((d.normal - Vector3d::UnitX()).norm(), 1e-9);
}

TEST(SignedDistance, ASpheresCentreInsideABoxIsAsDeepAsTheNearestFacePlusItsRadius) {
  const Distance d = distance(box(0.5, 0.5, 0.5), at(0, 0, 0), sphere(0.1), at(0.1, 0.3, -0.2));
  EXPECT_NEAR(d.distance, -(0.2 + 0.1), 1e-12);
  EXPECT_LT((d.normal - Vector3d::UnitY()).norm(), 1e-9);
}

TEST(SignedDistance, CylindersAndCapsulesAgainstTheirClosedForms) {
  const Shape c = cylinder(0.1, 0.2);
  EXPECT_NEAR(distance(c, at(0, 0, 0), sphere(0.1), at(0.3, 0.3, 0.0)).distance, std::hypot(0.3, 0.3) - 0.2, 1e-9);
  EXPECT_NEAR(distance(c, at(0, 0, 0), sphere(0.05), at(0.0, 0.0, 0.5)).distance, 0.25, 1e-12);
  // Past the rim: the nearest point is on the circle.
  EXPECT_NEAR(distance(c, at(0, 0, 0), sphere(0.05), at(0.4, 0.0, 0.6)).distance, std::hypot(0.3, 0.4) - 0.05, 1e-9);
  // Two capsules whose axes cross at right angles, 0.3 apart: the gap between segments, less the radii.
  const Matrix3d across = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()).toRotationMatrix();
  EXPECT_NEAR(distance(capsule(0.05, 0.5), at(0, 0, 0), capsule(0.1, 0.5), at(0.3, 0.0, 0.0, across)).distance,
              0.3 - 0.15, 1e-12);
  // The same capsules crossing: their axes meet, so they overlap by both radii.
  EXPECT_NEAR(distance(capsule(0.05, 0.5), at(0, 0, 0), capsule(0.1, 0.5), at(0.0, 0.0, 0.0, across)).distance,
              -0.15, 1e-12);
}

TEST(SignedDistance, ABoxAndTheHullOfItsCornersAreTheSameShapeAtEveryPose) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.7, 0.7);
  const Shape b = box(0.1, 0.2, 0.3), h = hull_of_box(0.1, 0.2, 0.3);
  int overlapping = 0;
  for (int k = 0; k < 20000; ++k) {
    const Transform T = at(u(rng), u(rng), u(rng), random_rotation(rng));
    const Distance from_box = distance(b, at(0, 0, 0), b, T);
    const Distance from_hull = distance(h, at(0, 0, 0), h, T);
    ASSERT_NEAR(from_box.distance, from_hull.distance, 1e-9) << k;
    overlapping += from_box.distance < 0.0;
  }
  EXPECT_GT(overlapping, 2000);
  EXPECT_LT(overlapping, 18000);
}

TEST(SignedDistance, WitnessesLieOnTheirShapesAndAreTheDistanceApart) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  const Shape shapes[] = {sphere(0.1), box(0.1, 0.05, 0.2), cylinder(0.08, 0.15), capsule(0.05, 0.2),
                          hull_of_box(0.12, 0.07, 0.03)};
  for (int k = 0; k < 20000; ++k) {
    const Shape& a = shapes[k % 5];
    const Shape& b = shapes[(k / 5) % 5];
    const Transform T_a = at(u(rng), u(rng), u(rng), random_rotation(rng));
    const Transform T_b = at(u(rng), u(rng), u(rng), random_rotation(rng));
    const Distance d = distance(a, T_a, b, T_b);
    ASSERT_NEAR((d.p_a - d.p_b).norm(), std::abs(d.distance), 1e-7) << k;
    ASSERT_NEAR(d.normal.norm(), 1.0, 1e-12) << k;
    // p_a is where a reaches farthest toward b, p_b where b reaches farthest toward a.
    ASSERT_NEAR(d.normal.dot(d.p_a), support_value(a, T_a, d.normal), 1e-7) << k;
    ASSERT_NEAR(-d.normal.dot(d.p_b), support_value(b, T_b, -d.normal), 1e-7) << k;
    // The gap along the normal between the two supports is the signed distance.
    ASSERT_NEAR(-support_value(b, T_b, -d.normal) - support_value(a, T_a, d.normal), d.distance, 1e-7) << k;
  }
}

TEST(SupportOfCore, ClimbingAHullFindsTheVertexAScanFinds) {
  std::mt19937_64 rng(3);
  const Shape h = hull_of_box(0.3, 0.1, 0.2);
  Shape scanned = h;
  scanned.neighbours.clear();
  std::normal_distribution<double> n;
  int climbed = 0;
  for (int k = 0; k < 10000; ++k) {
    const Vector3d d(n(rng), n(rng), n(rng));
    int scan_vertex = 0;
    const Vector3d expected = support_of_core(scanned, d, scan_vertex);
    EXPECT_EQ(support_of_core(h, d, climbed), expected);
  }
}

}  // namespace
}  // namespace chasles::geometry
