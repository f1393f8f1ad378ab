// The distances a tick watches (core/geometry/proximity.hpp): safety planes and workspace boxes
// against closed forms, the culled computation against every pair computed exactly at coal's
// configurations of the Panda, the closest pair, no allocation, the scene's refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/proximity.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/reference.hpp"

namespace chasles::geometry {
namespace {

using testing::data_path;

Transform at(double x, double y, double z) { return Transform(Matrix3d::Identity(), Vector3d(x, y, z)); }

Shape box(double x, double y, double z) {
  Shape s;
  s.kind = ShapeKind::kBox;
  s.half_extents << x, y, z;
  return s;
}

Shape sphere(double r) {
  Shape s;
  s.kind = ShapeKind::kSphere;
  s.radius = r;
  return s;
}

// Two boxes on a two-body "arm": body 1 and body 2, each with one object.
CollisionModel two_objects(const Shape& a, const Shape& b) {
  CollisionModel m;
  m.objects.push_back({"a/0", "a", 1, Transform::Identity(), a});
  m.objects.push_back({"b/0", "b", 2, Transform::Identity(), b});
  m.pairs.push_back({0, 1});
  return m;
}

struct Panda {
  RobotModel model;
  CollisionModel collision;
};

Panda panda() {
  UrdfOptions options;
  options.tip_link = "panda_hand";
  RobotModel model = load_urdf_file(data_path("panda.urdf"), options);
  CollisionModel collision = load_collision_model(
      data_path("panda.urdf"), model,
      {{data_path("packages")}, data_path("packages/example-robot-data/robots/panda_description/srdf/panda.srdf")});
  return {std::move(model), std::move(collision)};
}

TEST(Proximity, APlaneIsAsFarAsTheLowestPointOfEachObjectItBinds) {
  Scene scene;
  // The floor z = 0.1, allowed above; a tilted wall x + z = 1, allowed on the origin's side.
  scene.planes.push_back({"floor", Vector3d::UnitZ(), 0.1, {}, {}});
  scene.planes.push_back({"wall", -Vector3d(1, 0, 1).normalized(), -1.0 / std::sqrt(2.0), {"b"}, {}});
  const Proximity proximity(two_objects(box(0.1, 0.2, 0.3), sphere(0.05)), scene);
  ASSERT_EQ(proximity.pairs().size(), 1u + 2 + 1);  // the self pair, the floor on both, the wall on b
  ProximityData data(proximity);
  std::vector<Transform> T_body = {Transform::Identity(), at(0, 0, 1), at(0.2, 0.3, 0.5)};
  compute_distances(proximity, T_body, data);
  const auto& d = data.distance;
  EXPECT_NEAR(d[1].distance, 1.0 - 0.3 - 0.1, 1e-15);  // the box's bottom face
  EXPECT_NEAR(d[1].p_other.z(), 0.1, 1e-15);
  EXPECT_NEAR(d[2].distance, 0.5 - 0.05 - 0.1, 1e-15);  // the sphere's lowest point
  EXPECT_EQ(d[2].normal, -Vector3d::UnitZ());
  // The sphere's centre (0.2, 0.5): (1 − 0.7)/√2 from the wall, less its radius.
  EXPECT_NEAR(d[3].distance, (1.0 - 0.7) / std::sqrt(2.0) - 0.05, 1e-15);
  EXPECT_NEAR((d[3].p_arm - d[3].p_other).norm(), d[3].distance, 1e-15);
  for (int p = 1; p < 4; ++p) EXPECT_TRUE(d[p].exact);
  // Below the floor: a negative distance, the depth.
  T_body[1] = at(0, 0, 0.3);
  compute_distances(proximity, T_body, data);
  EXPECT_NEAR(data.distance[1].distance, 0.3 - 0.3 - 0.1, 1e-15);
  EXPECT_EQ(data.closest, 1);
}

TEST(Proximity, AWorkspaceBoxKeepsItsLinksInsideItsSixFaces) {
  Scene scene;
  Matrix3d R;  // the box turned 90° about z: its x along the base's y
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  add_workspace_box(scene, "cell", Transform(R, Vector3d(0.5, 0, 0.4)), Vector3d(0.3, 0.2, 0.4), {"b"}, {0.01, 0.1});
  ASSERT_EQ(scene.planes.size(), 6u);
  EXPECT_EQ(scene.planes[0].name, "cell/+x");
  const Proximity proximity(two_objects(box(0.1, 0.1, 0.1), sphere(0.05)), scene);
  ProximityData data(proximity);
  // The sphere at (0.6, 0.1, 0.3): from the box's centre (0.1, 0.1, −0.1) in the base, i.e.
  // (0.1, −0.1, −0.1) in the box's axes, whose half extents are (0.3, 0.2, 0.4).
  compute_distances(proximity, {Transform::Identity(), at(5, 5, 5), at(0.6, 0.1, 0.3)}, data);
  const double expected[6] = {0.3 - 0.1, 0.3 + 0.1, 0.2 + 0.1, 0.2 - 0.1, 0.4 + 0.1, 0.4 - 0.1};
  for (int face = 0; face < 6; ++face) {
    EXPECT_NEAR(data.distance[static_cast<size_t>(1 + face)].distance, expected[face] - 0.05, 1e-15) << face;
  }
  // Past the box's +x face (toward the base's +y): negative, by how far.
  compute_distances(proximity, {Transform::Identity(), at(5, 5, 5), at(0.5, 0.4, 0.4)}, data);
  EXPECT_NEAR(data.distance[1].distance, 0.3 - 0.4 - 0.05, 1e-15);
  EXPECT_EQ(data.closest, 1);
}

TEST(Proximity, CulledPairsAreLowerBoundsBeyondTheirInfluenceAndTheClosestIsExact) {
  const Panda arm = panda();
  Scene scene;
  scene.objects.push_back({"table", box(0.6, 0.6, 0.02), at(0.3, 0, -0.03), {0.01, 0.1}});
  scene.objects.push_back({"ball", sphere(0.1), at(0.4, 0.3, 0.5), {0.02, 0.15}});
  const Proximity proximity(arm.collision, scene);
  ASSERT_EQ(proximity.pairs().size(), 44u + 2 * 17);
  ProximityData data(proximity);
  Data kinematics(arm.model);
  std::vector<DistanceCache> caches(proximity.pairs().size());
  std::mt19937 random(7);
  int culled = 0;
  for (int trial = 0; trial < 500; ++trial) {
    Eigen::VectorXd q(7);
    for (int i = 0; i < 7; ++i) {
      const Joint& joint = arm.model.joint(i);
      q[i] = std::uniform_real_distribution<double>(joint.limits.lower, joint.limits.upper)(random);
    }
    forward_kinematics(arm.model, kinematics, q);
    compute_distances(proximity, kinematics.T_body, data);
    double least = std::numeric_limits<double>::infinity();
    int closest = -1;
    for (size_t p = 0; p < proximity.pairs().size(); ++p) {
      const ProximityPair& pair = proximity.pairs()[p];
      const auto& objects = proximity.arm().objects;
      const CollisionObject& a = objects[static_cast<size_t>(pair.arm)];
      const bool self = pair.kind == ProximityPair::kSelf;
      const Shape& b = self ? objects[static_cast<size_t>(pair.other)].shape : scene.objects[pair.other].shape;
      const Transform T_b = self ? kinematics.T_body[objects[static_cast<size_t>(pair.other)].body] *
                                       objects[static_cast<size_t>(pair.other)].T_body_object
                                 : scene.objects[pair.other].T_base_object;
      const double exact =
          signed_distance(a.shape, kinematics.T_body[a.body] * a.T_body_object, b, T_b, caches[p]).distance;
      if (exact < least) least = exact, closest = static_cast<int>(p);
      if (data.distance[p].exact) {
        EXPECT_NEAR(data.distance[p].distance, exact, 1e-9);
      } else {
        ++culled;
        EXPECT_LE(data.distance[p].distance, exact + 1e-12);
        EXPECT_GT(data.distance[p].distance, pair.clearance.influence);
      }
    }
    EXPECT_NEAR(data.distance[static_cast<size_t>(data.closest)].distance, least, 1e-9);
    if (std::abs(data.distance[static_cast<size_t>(data.closest)].distance - least) > 1e-9) {
      ADD_FAILURE() << "closest " << data.closest << ", exact " << closest;
    }
    EXPECT_TRUE(data.distance[static_cast<size_t>(data.closest)].exact);
  }
  EXPECT_GT(culled, 500 * 40);  // most pairs are far: the point of culling
}

TEST(Proximity, ComputingDistancesAllocatesNothing) {
  const Panda arm = panda();
  Scene scene;
  scene.objects.push_back({"table", box(0.6, 0.6, 0.02), at(0.3, 0, -0.03), {}});
  scene.planes.push_back({"wall", -Vector3d::UnitX(), -0.6, {"panda_hand"}, {}});
  const Proximity proximity(arm.collision, scene);
  ProximityData data(proximity);
  Data kinematics(arm.model);
  forward_kinematics(arm.model, kinematics, Eigen::VectorXd::Constant(7, 0.3));
  const testing::AllocationCounter counter;
  compute_distances(proximity, kinematics.T_body, data);
  EXPECT_EQ(counter.count(), 0);
}

TEST(Proximity, RefusesPlanesAndClearancesThatMeanNothing) {
  const auto refused = [](Scene scene) {
    try {
      const Proximity proximity(two_objects(sphere(0.1), sphere(0.1)), std::move(scene));
    } catch (const ArgumentError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  Scene scene;
  scene.planes.push_back({"wall", Vector3d(1, 1, 0), 0.0, {}, {}});
  EXPECT_EQ(refused(scene), "plane wall: its normal must be a unit vector and its offset finite");
  scene.planes[0] = {"wall", Vector3d::UnitX(), 0.0, {"c"}, {}};
  EXPECT_EQ(refused(scene), "plane wall: no collision object is on link c");
  scene.planes[0] = {"wall", Vector3d::UnitX(), 0.0, {}, {0.1, 0.1}};
  EXPECT_EQ(refused(scene).rfind("plane wall: a clearance needs 0 ≤ stop < influence (m)", 0), 0u);
  scene.planes.clear();
  scene.objects.push_back({"ball", sphere(0.1), Transform::Identity(), {-0.01, 0.1}});
  EXPECT_EQ(refused(scene).rfind("scene object ball: a clearance needs", 0), 0u);
}

TEST(Proximity, NamesAPairByItsTwoObjects) {
  Scene scene;
  scene.objects.push_back({"table", box(1, 1, 0.1), at(0, 0, -1), {}});
  const Proximity proximity(two_objects(sphere(0.1), sphere(0.1)), scene);
  char name[64];
  proximity.name_pair(0, name, sizeof(name));
  EXPECT_STREQ(name, "a/0 and b/0");
  proximity.name_pair(2, name, sizeof(name));
  EXPECT_STREQ(name, "b/0 and table");
  proximity.name_pair(2, name, 8);
  EXPECT_STREQ(name, "b/0 and");
}

}  // namespace
}  // namespace chasles::geometry
