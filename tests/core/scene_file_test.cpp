// The scene file (core/geometry/scene_file.hpp, docs/scene.md): every shape, pose, plane and
// workspace box against the numbers written in the file, worked out here by hand; a Panda mesh
// against its STL's own vertices; the writer's file read back to the same scene; and every refusal
// with its exact message.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <dirent.h>
#include <fstream>
#include <functional>
#include <unistd.h>
#include <set>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/scene_file.hpp"
#include "support/scenes.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::geometry {
namespace {

using testing::data_path;

const std::string kPackages = data_path("packages");
const std::string kLink7 = "example-robot-data/robots/panda_description/meshes/collision/link7.stl";

using testing::read_binary_stl;

// The what() of the ArgumentError `f` throws.
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ArgumentError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("(not an ArgumentError: ") + e.what() + ")";
  }
  return "(no error)";
}

// What reading `text` as a scene file says, the file's path taken off the front.
std::string refusal(const std::string& text) {
  const testing::TempFile file("bad_scene.json", text);
  std::string what = error_of([&] { read_scene_file(file.path); });
  if (what.rfind(file.path + ": ", 0) == 0) return what.substr(file.path.size() + 2);
  return "(does not start with the file) " + what;
}

// One object of the given shape and nothing else, as a file.
std::string one_object(const std::string& object) { return R"({"version": 1, "objects": [)" + object + "]}"; }
std::string one_plane(const std::string& plane) { return R"({"version": 1, "planes": [)" + plane + "]}"; }

const std::string kEveryShape = R"({
  "version": 1,
  "objects": [
    {"name": "table", "shape": {"box": {"size": [1.2, 0.8, 0.05]}},
     "pose": {"xyz": [0.5, 0, -0.025]}, "clearance": {"stop": 0.02, "influence": 0.15}},
    {"name": "lamp", "shape": {"sphere": {"radius": 0.1}}, "pose": {"xyz": [0.3, 0.4, 0.9]}},
    {"name": "post", "shape": {"cylinder": {"radius": 0.05, "length": 1.5}},
     "pose": {"xyz": [-0.4, 0, 0.75], "rpy": [0, 0, 1.5707963267948966]}},
    {"name": "rail", "shape": {"capsule": {"radius": 0.02, "length": 0.5}},
     "pose": {"xyz": [0, -0.5, 0.3], "quaternion": [0.5, 0.5, 0.5, 0.5]}},
    {"name": "link7", "shape": {"mesh": {"file": "package://)" + kLink7 + R"(", "scale": [2, 2, 2]}}},
    {"name": "bin", "shape": {"convex": {"vertices": [[0, 0, 0], [0.2, 0, 0], [0, 0.3, 0], [0.2, 0.3, 0],
                                                      [0, 0, 0.1], [0.2, 0, 0.1], [0, 0.3, 0.1], [0.2, 0.3, 0.1],
                                                      [0.1, 0.1, 0.05]]}},
     "pose": {"xyz": [0.6, 0.3, 0]}}
  ],
  "planes": [
    {"name": "floor", "normal": [0, 0, 1], "offset": -0.01},
    {"name": "wall", "normal": [0, -1, 0], "point": [0, 0.5, 0], "links": ["panda_hand", "panda_link7"],
     "clearance": {"stop": 0.05, "influence": 0.2}}
  ],
  "workspace": [
    {"name": "tool_box", "pose": {"xyz": [0.5, 0, 0.4]}, "size": [0.6, 0.8, 0.6], "links": ["panda_hand"]}
  ]
})";

TEST(SceneFile, EveryShapeIsWhatTheFileSays) {
  const testing::TempFile file("every_shape.json", kEveryShape);
  const Scene scene = read_scene_file(file.path, {{kPackages}});
  ASSERT_EQ(scene.objects.size(), 6u);

  const SceneObject& table = scene.objects[0];
  EXPECT_EQ(table.name, "table");
  EXPECT_EQ(table.shape.kind, ShapeKind::kBox);
  EXPECT_EQ(table.shape.half_extents, Vector3d(0.6, 0.4, 0.025));  // half the file's full lengths
  EXPECT_EQ(table.T_base_object.translation(), Vector3d(0.5, 0, -0.025));
  EXPECT_EQ(table.T_base_object.linear(), Matrix3d::Identity());
  EXPECT_EQ(table.clearance.stop, 0.02);
  EXPECT_EQ(table.clearance.influence, 0.15);

  const SceneObject& lamp = scene.objects[1];
  EXPECT_EQ(lamp.shape.kind, ShapeKind::kSphere);
  EXPECT_EQ(lamp.shape.radius, 0.1);
  EXPECT_EQ(lamp.clearance.stop, Clearance{}.stop);  // the default when the file gives none
  EXPECT_EQ(lamp.clearance.influence, Clearance{}.influence);

  const SceneObject& post = scene.objects[2];
  EXPECT_EQ(post.shape.kind, ShapeKind::kCylinder);
  EXPECT_EQ(post.shape.radius, 0.05);
  EXPECT_EQ(post.shape.half_length, 0.75);
  Matrix3d Rz90;  // yaw π/2: x → y, y → −x
  Rz90 << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_LE((post.T_base_object.linear() - Rz90).cwiseAbs().maxCoeff(), 1e-15);

  const SceneObject& rail = scene.objects[3];
  EXPECT_EQ(rail.shape.kind, ShapeKind::kCapsule);
  EXPECT_EQ(rail.shape.radius, 0.02);
  EXPECT_EQ(rail.shape.half_length, 0.25);
  Matrix3d R120;  // (½, ½, ½, ½): 120° about (1, 1, 1), x → y → z → x
  R120 << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  EXPECT_LE((rail.T_base_object.linear() - R120).cwiseAbs().maxCoeff(), 1e-16);

  // The mesh: its hull's vertices are the STL's own, scaled by 2, and reach as far as they do.
  const SceneObject& link7 = scene.objects[4];
  ASSERT_EQ(link7.shape.kind, ShapeKind::kConvex);
  const std::vector<Vector3d> stl = read_binary_stl(kPackages + "/" + kLink7);
  ASSERT_GT(stl.size(), 100u);
  ASSERT_GE(link7.shape.vertices.size(), 4u);
  EXPECT_EQ(link7.shape.neighbours.size(), link7.shape.vertices.size());
  for (const Vector3d& v : link7.shape.vertices) {
    double nearest = INFINITY;
    for (const Vector3d& p : stl) nearest = std::min(nearest, (2.0 * p - v).norm());
    EXPECT_EQ(nearest, 0.0) << v.transpose();
  }
  for (int axis = 0; axis < 3; ++axis) {
    double lo = INFINITY, hi = -INFINITY, hull_lo = INFINITY, hull_hi = -INFINITY;
    for (const Vector3d& p : stl) lo = std::min(lo, 2.0 * p(axis)), hi = std::max(hi, 2.0 * p(axis));
    for (const Vector3d& v : link7.shape.vertices) hull_lo = std::min(hull_lo, v(axis)), hull_hi = std::max(hull_hi, v(axis));
    EXPECT_EQ(hull_lo, lo) << axis;
    EXPECT_EQ(hull_hi, hi) << axis;
  }

  // The convex points: the 8 corners, the point inside dropped.
  const SceneObject& bin = scene.objects[5];
  ASSERT_EQ(bin.shape.kind, ShapeKind::kConvex);
  std::set<std::vector<double>> corners;
  for (const Vector3d& v : bin.shape.vertices) corners.insert({v.x(), v.y(), v.z()});
  std::set<std::vector<double>> expected;
  for (double x : {0.0, 0.2}) {
    for (double y : {0.0, 0.3}) {
      for (double z : {0.0, 0.1}) expected.insert({x, y, z});
    }
  }
  EXPECT_EQ(corners, expected);

  // Planes: as given, the point form's offset n · p; then the box's six faces, facing in.
  ASSERT_EQ(scene.planes.size(), 2u + 6u);
  EXPECT_EQ(scene.planes[0].name, "floor");
  EXPECT_EQ(scene.planes[0].normal, Vector3d(0, 0, 1));
  EXPECT_EQ(scene.planes[0].offset, -0.01);
  EXPECT_TRUE(scene.planes[0].links.empty());
  EXPECT_EQ(scene.planes[1].name, "wall");
  EXPECT_EQ(scene.planes[1].normal, Vector3d(0, -1, 0));
  EXPECT_EQ(scene.planes[1].offset, -0.5);
  EXPECT_EQ(scene.planes[1].links, (std::vector<std::string>{"panda_hand", "panda_link7"}));
  EXPECT_EQ(scene.planes[1].clearance.stop, 0.05);
  EXPECT_EQ(scene.planes[1].clearance.influence, 0.2);
  // Centre (0.5, 0, 0.4), half extents (0.3, 0.4, 0.3): x in [0.2, 0.8], y in [−0.4, 0.4], z in
  // [0.1, 0.7]; each face {n · x = offset} with n pointing in.
  struct Face {
    const char* name;
    Vector3d normal;
    double offset;
  };
  const Face faces[6] = {{"tool_box/+x", {-1, 0, 0}, -0.8}, {"tool_box/-x", {1, 0, 0}, 0.2},
                         {"tool_box/+y", {0, -1, 0}, -0.4}, {"tool_box/-y", {0, 1, 0}, -0.4},
                         {"tool_box/+z", {0, 0, -1}, -0.7}, {"tool_box/-z", {0, 0, 1}, 0.1}};
  for (int k = 0; k < 6; ++k) {
    const SafetyPlane& p = scene.planes[2 + size_t(k)];
    EXPECT_EQ(p.name, faces[k].name);
    EXPECT_EQ(p.normal, faces[k].normal) << p.name;
    EXPECT_NEAR(p.offset, faces[k].offset, 1e-15) << p.name;
    EXPECT_EQ(p.links, std::vector<std::string>{"panda_hand"});
  }
  EXPECT_EQ(scene_problem(scene), "");
}

TEST(SceneFile, AMeshIsFoundBesideTheFileAndScaledByOneNumber) {
  // A copy of the Panda's link 7 in the temporary folder, named relatively by a scene file there.
  const std::string stl_path = kPackages + "/" + kLink7;
  const testing::TempFile stl("link7.stl", testing::read_file(stl_path));
  const std::string stl_name = stl.path.substr(stl.path.rfind('/') + 1);
  const testing::TempFile file(
      "relative_mesh.json", one_object(R"({"name": "m", "shape": {"mesh": {"file": ")" + stl_name + R"(", "scale": 0.5}}})"));
  const Scene scene = read_scene_file(file.path);
  ASSERT_EQ(scene.objects.size(), 1u);
  const Shape expected = mesh_hull(stl_path, Vector3d::Constant(0.5), "link7");
  EXPECT_EQ(scene.objects[0].shape.vertices, expected.vertices);
  EXPECT_EQ(scene.objects[0].shape.neighbours, expected.neighbours);
}

std::vector<std::string> files_in(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (const dirent* e = ::readdir(d)) names.emplace_back(e->d_name);
    ::closedir(d);
  }
  return names;
}

TEST(SceneFile, TheWriterReadsBackToTheSameScene) {
  const testing::TempFile source("round_trip.json", kEveryShape);
  const Scene scene = read_scene_file(source.path, {{kPackages}});
  const std::string dir = ::testing::TempDir() + "chasles_scene_" + std::to_string(::getpid());
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  const std::string path = dir + "/written.json";
  write_scene_file(path, scene);
  const Scene back = read_scene_file(path);
  // Sizes, positions, hulls, planes exactly; rotations through a quaternion, and the box's faces
  // through the box recovered from them, to rounding.
  testing::expect_same(scene, back, 1e-15);
  EXPECT_EQ(back.planes[1].normal, Vector3d(0, -1, 0));
  EXPECT_EQ(back.planes[1].offset, -0.5);

  // The file: version first, the box written back as a box, the mesh as its hull.
  const std::string text = testing::read_file(path);
  EXPECT_EQ(text.rfind("{\n  \"version\": 1,\n", 0), 0u) << text.substr(0, 40);
  EXPECT_NE(text.find("\"workspace\": [\n    {\n      \"name\": \"tool_box\""), std::string::npos);
  EXPECT_EQ(text.find("tool_box/+x"), std::string::npos);
  EXPECT_NE(text.find("\"convex\""), std::string::npos);
  EXPECT_EQ(text.find("\"mesh\""), std::string::npos);

  // Written again from what was read back: the same scene once more, and nothing left beside it
  // (the temporary file was renamed over the destination).
  write_scene_file(path, back);
  testing::expect_same(scene, read_scene_file(path), 1e-15);
  EXPECT_EQ(files_in(dir).size(), 3u) << "., .. and written.json";
  std::remove(path.c_str());
  ::rmdir(dir.c_str());
}

TEST(SceneFile, TheWriterRefusesABadSceneAndAPathItCannotWrite) {
  Scene scene;
  scene.objects.push_back({"a", {}, Transform::Identity(), {}});  // a sphere of radius 0
  EXPECT_EQ(error_of([&] { write_scene_file("/tmp/never.json", scene); }),
            "/tmp/never.json: cannot write the scene: object 'a': a sphere's radius must be within 1e-06 and 1000 m");
  scene.objects[0].shape.radius = 0.1;
  scene.planes.push_back({"a", Vector3d::UnitZ(), 0.0, {}, {}});
  EXPECT_EQ(error_of([&] { write_scene_file("/tmp/never.json", scene); }),
            "/tmp/never.json: cannot write the scene: plane 'a': the name is taken by object 'a'");
  scene.planes.clear();
  try {
    write_scene_file("/nonexistent-dir/scene.json", scene);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "/nonexistent-dir/scene.json: cannot create a temporary file beside it: No such file or directory");
  }
}

TEST(SceneFile, EveryRefusalNamesTheEntryAndTheField) {
  // JSON that does not parse: its line and column.
  EXPECT_EQ(refusal("{\"version\": 1,\n  \"objects\": [\n  }\n"),
            "not valid JSON: parse error at line 3, column 3: syntax error while parsing value - unexpected '}'; "
            "expected '[', '{', or a literal");
  EXPECT_EQ(refusal(R"({"version": 1e999})"),
            "cannot be read as JSON: number overflow parsing '1e999'");
  // The version.
  EXPECT_EQ(refusal(R"({"objects": []})"), "no \"version\" (this reader reads version 1)");
  EXPECT_EQ(refusal(R"({"version": 2})"), "version 2 is not one this reader knows (it reads version 1)");
  EXPECT_EQ(refusal(R"({"version": "1"})"), "version \"1\" is not one this reader knows (it reads version 1)");
  EXPECT_EQ(refusal(R"({"version": 1, "obstacles": []})"),
            "the top level: unknown key \"obstacles\" (known: version, objects, planes, workspace)");
  // Shapes.
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"cone": {"radius": 1}}})")),
            "objects[0] \"a\": unknown shape \"cone\" (box, sphere, cylinder, capsule, mesh, convex)");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"box": {"size": [1, 0, 1]}}})")),
            "objects[0] \"a\": shape.box.size[1] is 0: a size must be > 0 (m)");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"box": {"size": [1, 1]}}})")),
            "objects[0] \"a\": shape.box.size is a list of 2, expected a list of 3 numbers");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": -0.1}}})")),
            "objects[0] \"a\": shape.sphere.radius is -0.1: a size must be > 0 (m)");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"cylinder": {"radius": 0.1}}})")),
            "objects[0] \"a\": shape.cylinder: no \"length\"");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"capsule": {"radius": 0.1, "length": "long"}}})")),
            "objects[0] \"a\": shape.capsule.length is a string, expected a number");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 0.1}, "box": {}}})")),
            "objects[0] \"a\": shape must be an object with one key, the shape's kind: box, sphere, cylinder, "
            "capsule, mesh or convex");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"mesh": {"file": "x.stl", "scale": [1, -1, 1]}}})")),
            "objects[0] \"a\": shape.mesh.scale[1] is -1: a size must be > 0 (m)");
  const std::string flat = R"({"name": "flat", "shape": {"convex": {"vertices": [[0,0,0], [1,0,0], [0,1,0], [1,1,0]]}}})";
  const std::string flat_refusal = refusal(one_object(flat));
  EXPECT_EQ(flat_refusal.rfind("objects[0] \"flat\": shape.convex.vertices: its vertices span no volume", 0), 0u)
      << flat_refusal;
  EXPECT_EQ(refusal(one_object(R"({"name": "few", "shape": {"convex": {"vertices": [[0,0,0], [1,0,0], [0,1,0]]}}})")),
            "objects[0] \"few\": shape.convex.vertices: 3 vertices span no volume");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 2000}}})")),
            "objects[0] \"a\": shape.sphere.radius is 2000: a size must be within 1e-06 and 1000 m");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"box": {"size": [1, 1, 1e-7]}}})")),
            "objects[0] \"a\": shape.box.size[2] is 1e-07: a size must be within 1e-06 and 1000 m");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}}, "pose": {"xyz": [1e300, 0, 0]}})")),
            "object 'a': its position is beyond 1000 m");
  // Poses.
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}},
                                   "pose": {"quaternion": [1, 0, 0, 0.1]}})")),
            "objects[0] \"a\": pose.quaternion (w, x, y, z) has norm 1.004988, not 1");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}},
                                   "pose": {"rpy": [0, 0, 0], "quaternion": [1, 0, 0, 0]}})")),
            "objects[0] \"a\": pose: give rpy or quaternion, not both");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}}, "pose": {"xyz": [0, 0, null]}})")),
            "objects[0] \"a\": pose.xyz[2] is null, expected a number");
  // Clearances.
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}},
                                   "clearance": {"stop": 0.01, "influance": 0.1}})")),
            "objects[0] \"a\": clearance: unknown key \"influance\" (known: stop, influence)");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}},
                                   "clearance": {"stop": 0.2, "influence": 0.1}})")),
            "objects[0] \"a\": clearance: stop 0.200000 m is not below influence 0.100000 m");
  EXPECT_EQ(refusal(one_object(R"({"name": "a", "shape": {"sphere": {"radius": 1}}, "clearance": {"stop": -0.01}})")),
            "objects[0] \"a\": clearance: stop -0.010000 m is negative");
  // Names.
  EXPECT_EQ(refusal(one_object(R"({"name": "", "shape": {"sphere": {"radius": 1}}})")),
            "objects[0]: name \"\" is empty");
  EXPECT_EQ(refusal(one_object(R"({"name": "a\tb", "shape": {"sphere": {"radius": 1}}})")),
            "objects[0]: name \"a\\tb\" holds a control character (byte 1)");
  EXPECT_EQ(refusal(one_object(R"({"name": ")" + std::string(65, 'x') + R"(", "shape": {"sphere": {"radius": 1}}})")),
            "objects[0]: name \"" + std::string(65, 'x') + "\" is 65 bytes long, more than 64");
  EXPECT_EQ(refusal(one_object(R"({"shape": {"sphere": {"radius": 1}}})")), "objects[0]: no \"name\"");
  EXPECT_EQ(refusal(R"({"version": 1, "objects": [{"name": "a", "shape": {"sphere": {"radius": 1}}}],
                        "planes": [{"name": "a", "normal": [0, 0, 1], "offset": 0}]})"),
            "planes[0] \"a\": the name \"a\" is given twice (also objects[0] \"a\")");
  EXPECT_EQ(refusal(R"({"version": 1, "planes": [{"name": "ws/+x", "normal": [0, 0, 1], "offset": 0}],
                        "workspace": [{"name": "ws", "size": [1, 1, 1]}]})"),
            "workspace[0] \"ws\": the name \"ws/+x\" is given twice (also planes[0] \"ws/+x\")");
  // Planes.
  EXPECT_EQ(refusal(one_plane(R"({"name": "p", "normal": [0, 0, 0], "offset": 0})")),
            "planes[0] \"p\": normal [0,0,0] has length 0, not 1: give the unit vector toward the allowed side");
  EXPECT_EQ(refusal(one_plane(R"({"name": "p", "normal": [0, 0, 2], "offset": 0.5})")),
            "planes[0] \"p\": normal [0,0,2] has length 2, not 1: give the unit vector toward the allowed side "
            "([0, 0, 1])");
  EXPECT_EQ(refusal(one_plane(R"({"name": "p", "normal": [0, 0, 1]})")),
            "planes[0] \"p\": no \"offset\" or \"point\": where is the plane?");
  EXPECT_EQ(refusal(one_plane(R"({"name": "p", "normal": [0, 0, 1], "offset": 0, "point": [0, 0, 0]})")),
            "planes[0] \"p\": give offset or point, not both");
  EXPECT_EQ(refusal(one_plane(R"({"name": "p", "normal": [0, 0, 1], "offset": 0, "links": ["hand", ""]})")),
            "planes[0] \"p\": links[1] \"\" is empty");
  // Workspace boxes.
  EXPECT_EQ(refusal(R"({"version": 1, "workspace": [{"name": "ws", "size": [1, 1, 0]}]})"),
            "workspace[0] \"ws\": size[2] is 0: a size must be > 0 (m)");
  // Files.
  const std::string missing = "/nonexistent/scene.json";
  EXPECT_EQ(error_of([&] { read_scene_file(missing); }),
            missing + ": cannot open the scene file: No such file or directory");
  const testing::TempFile mesh_missing("mesh_missing.json", one_object(R"({"name": "m", "shape": {"mesh": {"file": "nope.stl"}}})"));
  const std::string dir = mesh_missing.path.substr(0, mesh_missing.path.rfind('/'));
  EXPECT_EQ(error_of([&] { read_scene_file(mesh_missing.path); }),
            mesh_missing.path + ": objects[0] \"m\": shape.mesh: mesh 'nope.stl': no such file '" + dir + "/nope.stl'");
  const testing::TempFile package_missing(
      "package_missing.json", one_object(R"({"name": "m", "shape": {"mesh": {"file": "package://nowhere/a.stl"}}})"));
  EXPECT_EQ(error_of([&] { read_scene_file(package_missing.path, {{kPackages}}); }),
            package_missing.path + ": objects[0] \"m\": shape.mesh: mesh 'package://nowhere/a.stl': package 'nowhere' "
                                   "is in none of the package dirs ('" + kPackages + "')");
}

TEST(SceneFile, TheRulesSpeakForThemselves) {
  EXPECT_EQ(name_problem("table"), "");
  EXPECT_EQ(name_problem(""), "is empty");
  EXPECT_EQ(name_problem(std::string("a\0b", 3)), "holds a control character (byte 1)");
  EXPECT_EQ(name_problem(std::string(64, 'x')), "");
  EXPECT_EQ(name_problem(std::string(65, 'x')), "is 65 bytes long, more than 64");
  EXPECT_EQ(clearance_problem({0.0, 0.1}), "");
  EXPECT_EQ(clearance_problem({0.1, 0.1}), "stop 0.100000 m is not below influence 0.100000 m");
  EXPECT_EQ(clearance_problem({0.0, NAN}), "stop and influence must be finite");
  Matrix3d R = Matrix3d::Zero();
  EXPECT_EQ(rotation_of_quaternion(Eigen::Vector4d(2, 0, 0, 0), R), "(w, x, y, z) has norm 2.000000, not 1");
  EXPECT_EQ(R, Matrix3d::Zero()) << "untouched on a refusal";
  EXPECT_EQ(rotation_of_quaternion(Eigen::Vector4d(1.0005, 0, 0, 0), R), "");
  EXPECT_EQ(R, Matrix3d::Identity());
}

}  // namespace
}  // namespace chasles::geometry
