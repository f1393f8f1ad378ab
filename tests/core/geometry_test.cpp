// The collision model read from the arms' files, checked against what the files say, read here
// by hand: the URDFs' numbers, the meshes' raw vertices (binary STL, OBJ's "v" lines), the SRDFs'
// disabled pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include "core/geometry/collision_model.hpp"
#include "core/model/urdf.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::geometry {
namespace {

using testing::data_path;

const std::string kPackages = data_path("packages");
const std::string kPandaSrdf = kPackages + "/example-robot-data/robots/panda_description/srdf/panda.srdf";
const std::string kUr5Srdf = kPackages + "/example-robot-data/robots/ur_description/srdf/ur5.srdf";

RobotModel load(const std::string& urdf, const std::string& tip) {
  UrdfOptions options;
  options.tip_link = tip;
  return load_urdf_file(data_path(urdf), options);
}

CollisionModel load_panda(const std::string& srdf = kPandaSrdf) {
  return load_collision_model(data_path("panda.urdf"), load("panda.urdf", "panda_hand"), {{kPackages}, srdf});
}

std::vector<std::string> names(const CollisionModel& m) {
  std::vector<std::string> out;
  for (const auto& o : m.objects) out.push_back(o.name);
  return out;
}

const CollisionObject& object(const CollisionModel& m, const std::string& name) {
  for (const auto& o : m.objects) {
    if (o.name == name) return o;
  }
  throw std::runtime_error("no object " + name);
}

Transform translation(double x, double y, double z) { return Transform(Matrix3d::Identity(), Vector3d(x, y, z)); }

Transform rotation_x(double a) {
  Matrix3d R;
  R << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return Transform(R, Vector3d::Zero());
}

Transform rotation_z(double a) {
  Matrix3d R;
  R << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return Transform(R, Vector3d::Zero());
}

void expect_near(const Transform& actual, const Transform& expected, double tolerance) {
  EXPECT_LE((actual.linear() - expected.linear()).cwiseAbs().maxCoeff(), tolerance);
  EXPECT_LE((actual.translation() - expected.translation()).cwiseAbs().maxCoeff(), tolerance);
}

using testing::read_binary_stl;

std::vector<Vector3d> read_obj(const std::string& path) {
  std::istringstream text(testing::read_file(path));
  std::vector<Vector3d> out;
  for (std::string line; std::getline(text, line);) {
    if (line.rfind("v ", 0) != 0) continue;
    std::istringstream v(line.substr(2));
    double x, y, z;
    v >> x >> y >> z;
    out.emplace_back(x, y, z);
  }
  return out;
}

// The hull's faces, found from the shape's vertices and neighbour lists alone: every triangle of
// mutually neighbouring vertices whose plane has all the hull's vertices on one side.
struct Plane {
  Vector3d normal;  // unit, outward
  double offset;    // normal · x ≤ offset inside
};

std::vector<Plane> supporting_planes(const Shape& hull, std::vector<bool>& on_a_face) {
  std::vector<Plane> planes;
  const auto& V = hull.vertices;
  on_a_face.assign(V.size(), false);
  for (size_t a = 0; a < V.size(); ++a) {
    for (int b : hull.neighbours[a]) {
      for (int c : hull.neighbours[a]) {
        const auto& nb = hull.neighbours[static_cast<size_t>(b)];
        if (b <= static_cast<int>(a) || c <= b || std::find(nb.begin(), nb.end(), c) == nb.end()) continue;
        Vector3d n = (V[static_cast<size_t>(b)] - V[a]).cross(V[static_cast<size_t>(c)] - V[a]);
        if (n.norm() < 1e-15) continue;
        n.normalize();
        double lowest = 0.0, highest = 0.0;
        for (const Vector3d& x : V) {
          lowest = std::min(lowest, n.dot(x - V[a]));
          highest = std::max(highest, n.dot(x - V[a]));
        }
        if (highest > 1e-10 && lowest < -1e-10) continue;  // cuts through the hull: not a face
        if (highest > 1e-10) n = -n;
        planes.push_back({n, n.dot(V[a])});
        on_a_face[a] = on_a_face[static_cast<size_t>(b)] = on_a_face[static_cast<size_t>(c)] = true;
      }
    }
  }
  return planes;
}

// `hull` is the convex hull of `mesh`: its vertices are mesh vertices, the mesh lies inside every
// face it has, and the two reach equally far in every direction tried.
void expect_hull_of(const Shape& hull, const std::vector<Vector3d>& mesh, double tolerance, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(hull.kind, ShapeKind::kConvex);
  ASSERT_GE(hull.vertices.size(), 4u);
  ASSERT_EQ(hull.neighbours.size(), hull.vertices.size());
  for (const Vector3d& v : hull.vertices) {
    double nearest = INFINITY;
    for (const Vector3d& m : mesh) nearest = std::min(nearest, (m - v).norm());
    EXPECT_LE(nearest, tolerance) << "a hull vertex is no mesh vertex";
  }
  size_t edge_ends = 0;
  for (size_t a = 0; a < hull.neighbours.size(); ++a) {
    const auto& n = hull.neighbours[a];
    EXPECT_EQ(std::set<int>(n.begin(), n.end()).size(), n.size()) << "a neighbour twice";
    for (int b : n) {
      ASSERT_TRUE(b >= 0 && b < static_cast<int>(hull.vertices.size()));
      EXPECT_NE(b, static_cast<int>(a));
      const auto& back = hull.neighbours[static_cast<size_t>(b)];
      EXPECT_NE(std::find(back.begin(), back.end(), static_cast<int>(a)), back.end()) << "neighbours not symmetric";
    }
    edge_ends += n.size();
  }
  // A closed surface of triangles (qhull's 'Qt'): Euler's V − E + F = 2 with 3F = 2E.
  EXPECT_EQ(edge_ends / 2, 3 * hull.vertices.size() - 6);
  std::vector<bool> on_a_face;
  const std::vector<Plane> planes = supporting_planes(hull, on_a_face);
  EXPECT_EQ(std::count(on_a_face.begin(), on_a_face.end(), false), 0) << "a hull vertex on no face";
  double outside = 0.0;
  for (const Plane& p : planes) {
    for (const Vector3d& m : mesh) outside = std::max(outside, p.normal.dot(m) - p.offset);
  }
  EXPECT_LE(outside, tolerance) << "a mesh vertex outside a hull face";
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  for (int k = 0; k < 200; ++k) {
    const Vector3d d(normal(rng), normal(rng), normal(rng));
    double mesh_reach = -INFINITY, hull_reach = -INFINITY;
    for (const Vector3d& m : mesh) mesh_reach = std::max(mesh_reach, d.dot(m));
    for (const Vector3d& v : hull.vertices) hull_reach = std::max(hull_reach, d.dot(v));
    EXPECT_NEAR(hull_reach, mesh_reach, tolerance * d.norm());
  }
}

// The SRDF's pairs of link names, read with a regular expression rather than an XML parser.
std::set<std::pair<std::string, std::string>> disabled_in(const std::string& srdf) {
  const std::string text = testing::read_file(srdf);
  const std::regex pair("<disable_collisions\\s+link1=\"([^\"]+)\"\\s+link2=\"([^\"]+)\"");
  std::set<std::pair<std::string, std::string>> out;
  for (std::sregex_iterator it(text.begin(), text.end(), pair), end; it != end; ++it) {
    out.emplace((*it)[1], (*it)[2]);
    out.emplace((*it)[2], (*it)[1]);
  }
  return out;
}

// Every tool's package dirs: its own first, then $ROS_PACKAGE_PATH's folders in order, empty ones
// skipped; and a package found only through the environment loads.
TEST(CollisionModel, PackageDirsAreTheGivenThenRosPackagePaths) {
  const char* saved = std::getenv("ROS_PACKAGE_PATH");
  const std::string before = saved != nullptr ? saved : "";
  ::unsetenv("ROS_PACKAGE_PATH");
  EXPECT_EQ(with_ros_package_path({"/given"}), (std::vector<std::string>{"/given"}));
  ::setenv("ROS_PACKAGE_PATH", ":/a::/b/c:", 1);
  EXPECT_EQ(with_ros_package_path({"/given"}), (std::vector<std::string>{"/given", "/a", "/b/c"}));
  ::setenv("ROS_PACKAGE_PATH", ("/nonexistent:" + kPackages).c_str(), 1);
  const RobotModel panda = load("panda.urdf", "panda_hand");
  EXPECT_FALSE(load_collision_model(data_path("panda.urdf"), panda, {with_ros_package_path({}), ""}).objects.empty());
  if (saved != nullptr) ::setenv("ROS_PACKAGE_PATH", before.c_str(), 1);
  else ::unsetenv("ROS_PACKAGE_PATH");
}

TEST(CollisionModel, PandaObjectsInDocumentOrder) {
  const CollisionModel panda = load_panda();
  std::vector<std::string> expected;
  for (int i = 0; i <= 7; ++i) expected.push_back("panda_link" + std::to_string(i) + "/0");
  expected.push_back("panda_hand/0");
  for (const char* finger : {"panda_leftfinger", "panda_rightfinger"}) {
    for (int k = 0; k < 4; ++k) expected.push_back(std::string(finger) + "/" + std::to_string(k));
  }
  EXPECT_EQ(names(panda), expected);
  for (int i = 0; i <= 7; ++i) {
    const auto& o = panda.objects[static_cast<size_t>(i)];
    EXPECT_EQ(o.body, i) << o.name;
    EXPECT_EQ(o.link, "panda_link" + std::to_string(i));
    EXPECT_EQ(o.shape.kind, ShapeKind::kConvex);
  }
  for (size_t i = 8; i < 17; ++i) EXPECT_EQ(panda.objects[i].body, 7) << panda.objects[i].name;
}

TEST(CollisionModel, PandaFingersRideOnTheLastBodyAtTheUrdfsTransforms) {
  const CollisionModel panda = load_panda();
  // panda_joint8 (0 0 0.107), panda_hand_joint (rpy 0 0 −π/4), panda_finger_joint1 at 0
  // (0 0 0.0584), then each <collision>'s origin, as the URDF writes them.
  const Transform T_7_hand = translation(0, 0, 0.107) * rotation_z(-0.7853981633974483);
  const Transform T_7_finger = T_7_hand * translation(0, 0, 0.0584);
  expect_near(object(panda, "panda_hand/0").T_body_object, T_7_hand, 1e-15);
  expect_near(object(panda, "panda_leftfinger/0").T_body_object, T_7_finger * translation(0, 18.5e-3, 11e-3), 1e-15);
  expect_near(object(panda, "panda_leftfinger/2").T_body_object,
              T_7_finger * translation(0, 15.9e-3, 28.35e-3) * rotation_x(0.5235987755982988), 1e-15);
  expect_near(object(panda, "panda_rightfinger/2").T_body_object,
              T_7_finger * translation(0, -15.9e-3, 28.35e-3) * rotation_x(-0.5235987755982988), 1e-15);
  const Shape& box = object(panda, "panda_leftfinger/2").shape;
  EXPECT_EQ(box.kind, ShapeKind::kBox);
  EXPECT_EQ(box.half_extents, Vector3d(17.5e-3 / 2, 7e-3 / 2, 23.5e-3 / 2));
  EXPECT_EQ(object(panda, "panda_rightfinger/3").shape.half_extents, Vector3d(17.5e-3 / 2, 15.2e-3 / 2, 18.5e-3 / 2));
}

TEST(CollisionModel, PandaHullsAreThoseOfTheStlFiles) {
  const CollisionModel panda = load_panda();
  const std::string dir = kPackages + "/example-robot-data/robots/panda_description/meshes/collision/";
  for (int i = 0; i <= 7; ++i) {
    const std::string file = dir + "link" + std::to_string(i) + ".stl";
    expect_hull_of(panda.objects[static_cast<size_t>(i)].shape, read_binary_stl(file), 1e-9, file);
  }
  expect_hull_of(object(panda, "panda_hand/0").shape, read_binary_stl(dir + "hand.stl"), 1e-9, "hand.stl");
}

TEST(CollisionModel, PandaPairsAreTheSrdfsComplement) {
  const CollisionModel panda = load_panda();
  const auto disabled = disabled_in(kPandaSrdf);
  EXPECT_EQ(disabled.size(), 2u * 35u);
  // Every pair of objects on different bodies whose links the SRDF does not disable: counted from
  // the SRDF above, and by hand (136 pairs of 17 objects, 12 inside a finger, 80 disabled = 44).
  size_t expected = 0;
  for (size_t i = 0; i < panda.objects.size(); ++i) {
    for (size_t j = i + 1; j < panda.objects.size(); ++j) {
      const auto &a = panda.objects[i], &b = panda.objects[j];
      if (a.link != b.link && !disabled.count({a.link, b.link})) ++expected;
    }
  }
  EXPECT_EQ(expected, 44u);
  EXPECT_EQ(panda.pairs.size(), 44u);
  for (const auto& [i, j] : panda.pairs) {
    ASSERT_LT(i, j);
    const auto &a = panda.objects[static_cast<size_t>(i)], &b = panda.objects[static_cast<size_t>(j)];
    EXPECT_FALSE(disabled.count({a.link, b.link})) << a.name << " " << b.name;
    EXPECT_NE(a.body, b.body);
  }
  const std::set<std::pair<int, int>> pairs(panda.pairs.begin(), panda.pairs.end());
  EXPECT_EQ(pairs.size(), panda.pairs.size());
  // Two the SRDF leaves: the base against the hand, link 2 against a finger's tip.
  EXPECT_TRUE(pairs.count({0, 8}));
  EXPECT_TRUE(pairs.count({2, 12}));
}

TEST(CollisionModel, Ur5MeshesEeLinkAndPairs) {
  const RobotModel model = load("ur5.urdf", "tool0");
  const CollisionModel ur5 = load_collision_model(data_path("ur5.urdf"), model, {{kPackages}, kUr5Srdf});
  EXPECT_EQ(names(ur5), (std::vector<std::string>{"base_link/0", "shoulder_link/0", "upper_arm_link/0", "forearm_link/0",
                                                  "wrist_1_link/0", "wrist_2_link/0", "wrist_3_link/0", "ee_link/0"}));
  const std::vector<int> bodies{0, 1, 2, 3, 4, 5, 6, 6};
  for (size_t i = 0; i < 8; ++i) EXPECT_EQ(ur5.objects[i].body, bodies[i]) << ur5.objects[i].name;
  // ee_fixed_joint (0 0.0823 0, yaw 1.57079632679 as written), then the box's origin (−0.01 0 0).
  const CollisionObject& ee = object(ur5, "ee_link/0");
  expect_near(ee.T_body_object, translation(0, 0.0823, 0) * rotation_z(1.57079632679) * translation(-0.01, 0, 0), 1e-15);
  EXPECT_EQ(ee.shape.kind, ShapeKind::kBox);
  EXPECT_EQ(ee.shape.half_extents, Vector3d::Constant(0.005));
  // The (0 0 0.28) beside upper_arm_link's mesh is its <inertial>'s origin; the <collision> has none.
  expect_near(object(ur5, "upper_arm_link/0").T_body_object, Transform::Identity(), 0.0);
  const std::string dir = kPackages + "/example-robot-data/robots/ur_description/meshes/ur5/collision/";
  const char* files[] = {"base", "shoulder", "upperarm", "forearm", "wrist1", "wrist2", "wrist3"};
  for (size_t i = 0; i < 7; ++i) {
    expect_hull_of(ur5.objects[i].shape, read_binary_stl(dir + files[i] + ".stl"), 1e-9, files[i]);
  }
  // 28 pairs of 8 objects, less wrist_3_link with ee_link (one body) and the SRDF's 10 (ee_link is
  // in none of them): 17.
  EXPECT_EQ(ur5.pairs.size(), 17u);
  const auto disabled = disabled_in(kUr5Srdf);
  EXPECT_EQ(disabled.size(), 20u);
  for (const auto& [i, j] : ur5.pairs) {
    EXPECT_FALSE(disabled.count({ur5.objects[static_cast<size_t>(i)].link, ur5.objects[static_cast<size_t>(j)].link}));
  }
}

TEST(CollisionModel, IiwaPrimitivesObjMeshesAndAdjacencyPairs) {
  const RobotModel model = load("iiwa14.urdf", "iiwa_link_ee");
  const CollisionModel iiwa = load_collision_model(data_path("iiwa14.urdf"), model, {{kPackages}, ""});
  std::vector<std::string> expected;
  for (int i = 0; i <= 7; ++i) expected.push_back("iiwa_link_" + std::to_string(i) + "/0");
  // link_0's <self_collision_checking> capsule is no <collision>.
  EXPECT_EQ(names(iiwa), expected);
  for (int i = 0; i <= 7; ++i) EXPECT_EQ(iiwa.objects[static_cast<size_t>(i)].body, i);
  // The URDF's cylinders: (length, radius) per link 0..5.
  const double cylinders[][2] = {{0.17, 0.139}, {0.29, 0.101}, {0.29, 0.101}, {0.29, 0.092}, {0.25, 0.092}, {0.29, 0.07}};
  for (size_t i = 0; i < 6; ++i) {
    const Shape& s = iiwa.objects[i].shape;
    EXPECT_EQ(s.kind, ShapeKind::kCylinder);
    EXPECT_EQ(s.half_length, cylinders[i][0] / 2);
    EXPECT_EQ(s.radius, cylinders[i][1]);
  }
  expect_near(iiwa.objects[0].T_body_object, translation(-0.015, 0, 0.07), 0.0);
  const std::string dir = kPackages + "/drake_models/iiwa_description/meshes/iiwa14/collision/";
  // The OBJ's decimal text read here as double, by assimp as float: 1e-7 m apart at most.
  expect_hull_of(iiwa.objects[6].shape, read_obj(dir + "link_6.obj"), 1e-7, "link_6.obj");
  expect_hull_of(iiwa.objects[7].shape, read_obj(dir + "link_7.obj"), 1e-7, "link_7.obj");
  // No SRDF: 28 pairs less the 7 of neighbouring bodies.
  EXPECT_EQ(iiwa.pairs.size(), 21u);
  for (const auto& [i, j] : iiwa.pairs) EXPECT_GE(j - i, 2);
}

TEST(CollisionModel, WithoutSrdfThePandaDropsSameAndNeighbouringBodies) {
  const CollisionModel panda = load_panda("");
  // Bodies: link0 → 0, link i → i, hand and the 8 finger boxes → 7. Pairs of 17 = 136, less
  // C(10, 2) = 45 on body 7, less neighbours: link i with link i+1 for i = 0..5 (6), link6 with the
  // 10 objects on body 7 (10): 75.
  EXPECT_EQ(panda.pairs.size(), 75u);
}

// A unit cube written as ASCII STL beside a URDF that names it relatively, and the same by file://.
std::string cube_stl() {
  std::string s = "solid cube\n";
  const int faces[12][3][3] = {
      {{0, 0, 0}, {1, 1, 0}, {1, 0, 0}}, {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}},
      {{0, 0, 1}, {1, 1, 1}, {0, 1, 1}}, {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}}, {{0, 0, 0}, {1, 0, 1}, {0, 0, 1}},
      {{0, 1, 0}, {1, 1, 1}, {1, 1, 0}}, {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}}, {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}},
      {{0, 0, 0}, {0, 1, 1}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}}, {{1, 0, 0}, {1, 1, 1}, {1, 0, 1}}};
  for (const auto& f : faces) {
    s += " facet normal 0 0 0\n  outer loop\n";
    for (const auto& v : f) {
      s += "   vertex " + std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]) + "\n";
    }
    s += "  endloop\n endfacet\n";
  }
  return s + "endsolid cube\n";
}

std::string one_link_urdf(const std::string& mesh) {
  return R"(<robot name="cube"><link name="base"/><link name="box_link"><collision><geometry>)"
         R"(<mesh filename=")" +
         mesh + R"(" scale="2 3 4"/></geometry></collision></link>)"
                R"(<joint name="j" type="revolute"><parent link="base"/><child link="box_link"/><axis xyz="0 0 1"/>)"
                R"(<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>)";
}

TEST(CollisionModel, RelativeAndFileMeshesScaledCube) {
  const testing::TempFile stl("cube.stl", cube_stl());
  const std::string stl_name = stl.path.substr(stl.path.rfind('/') + 1);
  for (const std::string& uri : {stl_name, "file://" + stl.path}) {
    const testing::TempFile urdf("cube.urdf", one_link_urdf(uri));
    const RobotModel model = load_urdf_file(urdf.path);
    const CollisionModel m = load_collision_model(urdf.path, model);
    ASSERT_EQ(m.objects.size(), 1u);
    const Shape& hull = m.objects[0].shape;
    EXPECT_EQ(m.objects[0].body, 1);
    EXPECT_TRUE(m.pairs.empty());
    // The 8 corners, scaled (2, 3, 4); 12 edges and one diagonal per square face: 18.
    ASSERT_EQ(hull.vertices.size(), 8u);
    std::set<std::vector<double>> corners;
    for (const Vector3d& v : hull.vertices) corners.insert({v.x(), v.y(), v.z()});
    for (double x : {0.0, 2.0}) {
      for (double y : {0.0, 3.0}) {
        for (double z : {0.0, 4.0}) EXPECT_TRUE(corners.count({x, y, z})) << x << " " << y << " " << z;
      }
    }
    size_t ends = 0;
    for (const auto& n : hull.neighbours) ends += n.size();
    EXPECT_EQ(ends, 2u * 18u);
  }
}

// A Collada tetrahedron in centimetres with z up: the unit scale applies, assimp's turn to y-up
// does not (the vertices stay in the file's frame, as coal keeps them).
TEST(CollisionModel, ColladaKeepsItsAxesAndTakesItsUnit) {
  const testing::TempFile dae("tet.dae", R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="centimeter" meter="0.01"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="tet"><mesh>
    <source id="p"><float_array id="pa" count="12">0 0 0 1 0 0 0 2 0 0 0 3</float_array>
      <technique_common><accessor source="#pa" count="4" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/><p>0 2 1 0 1 3 0 3 2 1 2 3</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#tet"/></node></visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)");
  std::string urdf = one_link_urdf("file://" + dae.path);
  urdf.replace(urdf.find(R"( scale="2 3 4")"), 14, "");
  const testing::TempFile file("tet.urdf", urdf);
  const CollisionModel m = load_collision_model(file.path, load_urdf_file(file.path));
  ASSERT_EQ(m.objects.size(), 1u);
  std::set<std::vector<double>> corners;
  for (const Vector3d& v : m.objects[0].shape.vertices) corners.insert({v.x(), v.y(), v.z()});
  EXPECT_EQ(corners, (std::set<std::vector<double>>{{0, 0, 0}, {0.01f, 0, 0}, {0, 0.02f, 0}, {0, 0, 0.03f}}));
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ModelError& e) {
    return e.what();
  }
  return "(no ModelError)";
}

TEST(CollisionModel, ErrorsNameTheFileAndTheLink) {
  const RobotModel panda = load("panda.urdf", "panda_hand");
  std::string urdf = testing::read_file(data_path("panda.urdf"));
  const std::string link3 = "meshes/collision/link3.stl";
  urdf.replace(urdf.find(link3), link3.size(), "meshes/collision/link3_missing.stl");
  const testing::TempFile missing("missing_mesh.urdf", urdf);
  std::string what = error_of([&] { load_collision_model(missing.path, panda, {{kPackages}, ""}); });
  EXPECT_NE(what.find("link3_missing.stl"), std::string::npos) << what;
  EXPECT_NE(what.find("panda_link3"), std::string::npos) << what;
  EXPECT_NE(what.find(missing.path), std::string::npos) << what;

  what = error_of([&] { load_collision_model(data_path("panda.urdf"), panda, {{"/nonexistent"}, ""}); });
  EXPECT_NE(what.find("package 'example-robot-data'"), std::string::npos) << what;
  EXPECT_NE(what.find("panda_link0"), std::string::npos) << what;

  const testing::TempFile not_xml("bad.srdf", "disable_collisions: everything\n<robot");
  what = error_of([&] { load_panda(not_xml.path); });
  EXPECT_NE(what.find(not_xml.path), std::string::npos) << what;
  EXPECT_NE(what.find("XML"), std::string::npos) << what;

  const testing::TempFile unknown("unknown.srdf",
                                  R"(<robot name="panda"><disable_collisions link1="panda_link1" )"
                                  R"(link2="panda_link99" reason="Never"/></robot>)");
  what = error_of([&] { load_panda(unknown.path); });
  EXPECT_NE(what.find("panda_link99"), std::string::npos) << what;
  EXPECT_NE(what.find(unknown.path), std::string::npos) << what;

  // A flat mesh: one square, no volume.
  const testing::TempFile flat("flat.stl",
                               "solid flat\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n"
                               "   vertex 1 1 0\n  endloop\n endfacet\n facet normal 0 0 1\n  outer loop\n"
                               "   vertex 0 0 0\n   vertex 1 1 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid flat\n");
  const testing::TempFile flat_urdf("flat.urdf", one_link_urdf("file://" + flat.path));
  what = error_of([&] { load_collision_model(flat_urdf.path, load_urdf_file(flat_urdf.path)); });
  EXPECT_NE(what.find("box_link"), std::string::npos) << what;
  EXPECT_NE(what.find(flat.path), std::string::npos) << what;
  EXPECT_NE(what.find("no volume"), std::string::npos) << what;

  // A model of another arm.
  what = error_of([&] { load_collision_model(data_path("ur5.urdf"), panda, {{kPackages}, ""}); });
  EXPECT_NE(what.find("panda_link0"), std::string::npos) << what;
}

}  // namespace
}  // namespace chasles::geometry
