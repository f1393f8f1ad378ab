// The scene over LCM (controller/transport/scene_message.hpp): a scene through encode_scene,
// lcm-gen's bytes and decode_scene comes back as it was; the sizes mean what the contract says;
// the checked decoder walks every count before trusting one; and every refusal is exact, leaves
// the scene in force untouched, and never throws.
#include <gtest/gtest.h>

#include <chasles/scene_t.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "controller/transport/scene_message.hpp"
#include "controller/transport/wire.hpp"
#include "support/scenes.hpp"
#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/scene_file.hpp"
#include "lcmtypes/checked.hpp"
#include "support/process.hpp"

namespace chasles::controller {
namespace {

using geometry::Scene;
using geometry::ShapeKind;

std::vector<uint8_t> bytes_of(const scene_t& m) {
  std::vector<uint8_t> bytes(size_t(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, int(bytes.size())), int(bytes.size()));
  return bytes;
}

Transform pose(double x, double y, double z, double yaw) {
  Matrix3d R;
  R << std::cos(yaw), -std::sin(yaw), 0, std::sin(yaw), std::cos(yaw), 0, 0, 0, 1;
  return Transform(R, Vector3d(x, y, z));
}

// One object of every kind, two planes, a workspace box.
Scene every_kind() {
  Scene s;
  geometry::Shape box;
  box.kind = ShapeKind::kBox;
  box.half_extents = Vector3d(0.6, 0.4, 0.025);
  s.objects.push_back({"table", box, pose(0.5, 0, -0.025, 0), {0.02, 0.15}});
  geometry::Shape sphere;
  sphere.radius = 0.1;
  s.objects.push_back({"lamp", sphere, pose(0.3, 0.4, 0.9, 0.3), {}});
  geometry::Shape cylinder;
  cylinder.kind = ShapeKind::kCylinder;
  cylinder.radius = 0.05;
  cylinder.half_length = 0.75;
  s.objects.push_back({"post", cylinder, pose(-0.4, 0, 0.75, 1.0), {}});
  geometry::Shape capsule = cylinder;
  capsule.kind = ShapeKind::kCapsule;
  capsule.radius = 0.02;
  s.objects.push_back({"rail", capsule, pose(0, -0.5, 0.3, -2.0), {0.0, 0.05}});
  std::vector<Vector3d> points;
  for (double x : {0.0, 0.2}) {
    for (double y : {0.0, 0.3}) {
      for (double z : {0.0, 0.1}) points.emplace_back(x, y, z);
    }
  }
  points.emplace_back(0.1, 0.1, 0.05);  // inside
  s.objects.push_back({"bin", geometry::convex_hull(points, "bin"), pose(0.6, 0.3, 0, 0.7), {}});
  s.planes.push_back({"floor", Vector3d::UnitZ(), -0.01, {}, {}});
  s.planes.push_back({"wall", Vector3d(0, -0.6, 0.8), -0.5, {"panda_hand", "panda_link7"}, {0.05, 0.2}});
  geometry::add_workspace_box(s, "tool_box", pose(0.5, 0, 0.4, 0.4), Vector3d(0.3, 0.4, 0.3), {"panda_hand"},
                              {0.01, 0.05});
  return s;
}


TEST(SceneMessage, AScenePassesThroughLcmBytesUnchanged) {
  const Scene scene = every_kind();
  const scene_t message = encode_scene(scene, 1'790'000'000'000'000);
  EXPECT_EQ(message.version, scene_t::VERSION);
  EXPECT_EQ(message.utime, 1'790'000'000'000'000);
  EXPECT_EQ(message.num_objects, 5);
  EXPECT_EQ(message.num_vertices, 8);  // the hull's: the point inside was dropped
  EXPECT_EQ(message.num_planes, 2);    // the box goes as a box
  EXPECT_EQ(message.num_boxes, 1);
  EXPECT_EQ(message.box_name, std::vector<std::string>{"tool_box"});
  const std::vector<uint8_t> bytes = bytes_of(message);
  Scene back;
  char error[256] = "untouched";
  ASSERT_TRUE(decode_scene(bytes.data(), bytes.size(), back, error, sizeof error)) << error;
  EXPECT_STREQ(error, "");
  // Sizes, positions, hulls and the plain planes to the bit; what went through a quaternion (every
  // rotation, the box's faces) to rounding.
  chasles::testing::expect_same(scene, back, 1e-15);
  EXPECT_EQ(back.planes[1].normal, Vector3d(0, -0.6, 0.8));
  EXPECT_EQ(back.planes[1].offset, -0.5);
  // And the scene decoded goes round again to itself (its rotations settle: a quaternion of a
  // rotation matrix of a quaternion is the quaternion to rounding).
  const std::vector<uint8_t> again = bytes_of(encode_scene(back, message.utime));
  EXPECT_EQ(again.size(), bytes.size());
  Scene twice;
  ASSERT_TRUE(decode_scene(again.data(), again.size(), twice, error, sizeof error)) << error;
  chasles::testing::expect_same(back, twice, 1e-15);
  // An empty scene is a scene: it clears the one in force.
  const std::vector<uint8_t> empty = bytes_of(encode_scene(Scene{}));
  ASSERT_TRUE(decode_scene(empty.data(), empty.size(), back, error, sizeof error)) << error;
  EXPECT_TRUE(back.objects.empty() && back.planes.empty());
}

// A message of one object of `kind` with `size`, at the origin, as a sender builds it.
scene_t one_object(int8_t kind, std::vector<double> size) {
  scene_t m;
  m.version = scene_t::VERSION;
  m.utime = 1;
  m.num_objects = 1;
  m.object_name = {"thing"};
  m.object_kind = {kind};
  m.object_size = {size};
  m.object_position = {{0.1, 0.2, 0.3}};
  m.object_quaternion = {{1, 0, 0, 0}};
  m.object_clearance = {{0.01, 0.1}};
  m.object_num_vertices = {0};
  m.num_vertices = 0;
  m.num_planes = 0;
  m.num_plane_links = 0;
  m.num_boxes = 0;
  m.num_box_links = 0;
  return m;
}

scene_t one_box(std::vector<double> size, std::vector<std::string> links) {
  scene_t m = one_object(scene_t::SPHERE, {0.1, 0, 0});
  m.num_boxes = 1;
  m.box_name = {"ws"};
  m.box_position = {{0.5, 0, 0.4}};
  m.box_quaternion = {{1, 0, 0, 0}};
  m.box_size = {size};
  m.box_num_links = {int32_t(links.size())};
  m.box_clearance = {{0.01, 0.05}};
  m.num_box_links = int32_t(links.size());
  m.box_links = links;
  return m;
}

Scene decoded(const scene_t& m) {
  Scene scene;
  char error[256] = "";
  EXPECT_TRUE(decode_scene(m, scene, error, sizeof error)) << error;
  return scene;
}

TEST(SceneMessage, SizesMeanWhatTheContractSays) {
  Scene s = decoded(one_object(scene_t::BOX, {0.4, 0.6, 0.02}));
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].name, "thing");
  EXPECT_EQ(s.objects[0].shape.kind, ShapeKind::kBox);
  EXPECT_EQ(s.objects[0].shape.half_extents, Vector3d(0.2, 0.3, 0.01));  // full edge lengths on the wire
  EXPECT_EQ(s.objects[0].T_base_object.translation(), Vector3d(0.1, 0.2, 0.3));
  EXPECT_EQ(s.objects[0].T_base_object.linear(), Matrix3d::Identity());
  EXPECT_EQ(s.objects[0].clearance.stop, 0.01);
  EXPECT_EQ(s.objects[0].clearance.influence, 0.1);
  s = decoded(one_object(scene_t::SPHERE, {0.25, 0, 0}));
  EXPECT_EQ(s.objects[0].shape.kind, ShapeKind::kSphere);
  EXPECT_EQ(s.objects[0].shape.radius, 0.25);
  s = decoded(one_object(scene_t::CYLINDER, {0.05, 1.0, 0}));
  EXPECT_EQ(s.objects[0].shape.kind, ShapeKind::kCylinder);
  EXPECT_EQ(s.objects[0].shape.radius, 0.05);
  EXPECT_EQ(s.objects[0].shape.half_length, 0.5);  // end to end on the wire
  s = decoded(one_object(scene_t::CAPSULE, {0.02, 0.3, 0}));
  EXPECT_EQ(s.objects[0].shape.kind, ShapeKind::kCapsule);
  EXPECT_EQ(s.objects[0].shape.half_length, 0.15);
  // A quaternion within 1e-3 of unit norm is normalised: 90° about z.
  scene_t turned = one_object(scene_t::SPHERE, {0.25, 0, 0});
  turned.object_quaternion = {{0.7071, 0, 0, 0.7071}};
  s = decoded(turned);
  Matrix3d Rz90;
  Rz90 << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_LE((s.objects[0].T_base_object.linear() - Rz90).cwiseAbs().maxCoeff(), 1e-15);

  // A box of centre (0.5, 0, 0.4), size (0.6, 0.8, 0.6): its faces x = 0.8, 0.2, y = ±0.4, z = 0.7, 0.1,
  // each {n · x = offset} with n pointing in, after the planes.
  s = decoded(one_box({0.6, 0.8, 0.6}, {"panda_hand"}));
  ASSERT_EQ(s.planes.size(), 6u);
  struct Face {
    const char* name;
    Vector3d normal;
    double offset;
  };
  const Face faces[6] = {{"ws/+x", {-1, 0, 0}, -0.8}, {"ws/-x", {1, 0, 0}, 0.2}, {"ws/+y", {0, -1, 0}, -0.4},
                         {"ws/-y", {0, 1, 0}, -0.4},  {"ws/+z", {0, 0, -1}, -0.7}, {"ws/-z", {0, 0, 1}, 0.1}};
  for (int k = 0; k < 6; ++k) {
    const auto& p = s.planes[size_t(k)];
    EXPECT_EQ(p.name, faces[k].name);
    EXPECT_EQ(p.normal, faces[k].normal) << p.name;
    EXPECT_NEAR(p.offset, faces[k].offset, 1e-15) << p.name;
    EXPECT_EQ(p.links, std::vector<std::string>{"panda_hand"});
    EXPECT_EQ(p.clearance.stop, 0.01);
    EXPECT_EQ(p.clearance.influence, 0.05);
  }
}

// What decode_scene says of `m`, and that it left the scene in force alone.
std::string refusal(const scene_t& m) {
  Scene scene = every_kind();
  char error[256] = "";
  if (decode_scene(m, scene, error, sizeof error)) return "(taken)";
  EXPECT_EQ(scene.objects.size(), 5u) << "the scene in force is untouched";
  EXPECT_EQ(scene.planes.size(), 8u) << "the scene in force is untouched";
  return error;
}

TEST(SceneMessage, EveryRefusalSaysWhichEntryAndField) {
  scene_t m = one_object(scene_t::BOX, {1, 1, 1});
  m.version = 2;
  EXPECT_EQ(refusal(m), "version 2; this receiver reads version 1");

  m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_position[0][1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(refusal(m), "object 0 'thing': object_position (0.1, nan, 0.3) is not finite");
  m = one_object(scene_t::BOX, {1, std::numeric_limits<double>::infinity(), 1});
  EXPECT_EQ(refusal(m), "object 0 'thing': object_size (1, inf, 1) is not finite");
  m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_clearance[0][0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(refusal(m), "object 0 'thing': object_clearance: stop and influence must be finite");

  EXPECT_EQ(refusal(one_object(scene_t::BOX, {1, 0, 1})), "object 0 'thing': object_size[1] is 0; a size must be > 0 (m)");
  EXPECT_EQ(refusal(one_object(scene_t::BOX, {1, 1e300, 1})),
            "object 0 'thing': object_size[1] is 1e+300; a size must be within 1e-06 and 1000 m");
  m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_position[0][0] = -1e300;
  EXPECT_EQ(refusal(m), "object 'thing': its position is beyond 1000 m");
  EXPECT_EQ(refusal(one_object(scene_t::SPHERE, {0, 0, 0})),
            "object 0 'thing': object_size[0] is 0; a size must be > 0 (m)");
  EXPECT_EQ(refusal(one_object(scene_t::SPHERE, {0.1, 0.2, 0})),
            "object 0 'thing': object_size[1] is 0.2; a SPHERE uses 1 sizes, the rest must be 0");
  EXPECT_EQ(refusal(one_object(7, {1, 1, 1})),
            "object 0 'thing': object_kind 7 is none of SPHERE 0, BOX 1, CYLINDER 2, CAPSULE 3, CONVEX 4");

  m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_quaternion = {{1, 0, 0, 0.1}};
  EXPECT_EQ(refusal(m), "object 0 'thing': object_quaternion (1, 0, 0, 0.1) (w, x, y, z) has norm 1.004988, not 1");
  m.object_quaternion = {{0, 0, 0, 0}};
  EXPECT_EQ(refusal(m), "object 0 'thing': object_quaternion (0, 0, 0, 0) (w, x, y, z) has norm 0.000000, not 1");

  m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_name = {""};
  EXPECT_EQ(refusal(m), "object 0: object_name is empty");
  m.object_name = {std::string("a\nb")};
  EXPECT_EQ(refusal(m), "object 0: object_name holds a control character (byte 1)");

  // Duplicate names: two objects, an object and a plane, a plane and a box's face.
  m = one_object(scene_t::BOX, {1, 1, 1});
  m.num_objects = 2;
  for (auto* v : {&m.object_size, &m.object_position, &m.object_quaternion, &m.object_clearance}) v->push_back(v->front());
  m.object_name.push_back("thing");
  m.object_kind.push_back(scene_t::BOX);
  m.object_num_vertices.push_back(0);
  EXPECT_EQ(refusal(m), "object 1 'thing': the name is taken by object 0 'thing'");
  m = one_box({1, 1, 1}, {});
  m.num_planes = 1;
  m.plane_name = {"ws/-z"};
  m.plane_normal = {{0, 0, 1}};
  m.plane_offset = {0};
  m.plane_num_links = {0};
  m.plane_clearance = {{0.01, 0.1}};
  EXPECT_EQ(refusal(m), "box 0 'ws': its face's name 'ws/-z' is taken by plane 0 'ws/-z'");
  m.plane_name = {"ws"};
  EXPECT_EQ(refusal(m), "box 0 'ws': the name is taken by plane 0 'ws'");

  // Hulls: a flat one, one of too many vertices, vertices on a kind that has none.
  m = one_object(scene_t::CONVEX, {0, 0, 0});
  m.object_num_vertices = {4};
  m.num_vertices = 4;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  const std::string flat = refusal(m);
  EXPECT_EQ(flat.rfind("object 0 'thing': its vertices span no volume (a flat or degenerate mesh; qhull: ", 0), 0u) << flat;
  m.object_num_vertices = {scene_t::MAX_HULL_VERTICES + 1};
  m.num_vertices = scene_t::MAX_HULL_VERTICES + 1;
  m.vertices.assign(size_t(m.num_vertices), {0, 0, 0});
  EXPECT_EQ(refusal(m), "object_num_vertices[0] 1025 is not within 0 to MAX_HULL_VERTICES (1024)");
  m = one_object(scene_t::CONVEX, {0, 0, 0});
  m.object_num_vertices = {3};
  m.num_vertices = 3;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_EQ(refusal(m), "object 0 'thing': object_num_vertices 3: a CONVEX object needs 4 or more");
  m.object_kind = {scene_t::SPHERE};
  m.object_size = {{0.1, 0, 0}};
  EXPECT_EQ(refusal(m), "object 0 'thing': object_num_vertices 3: only a CONVEX object has vertices");
  m.object_num_vertices = {2};
  EXPECT_EQ(refusal(m), "object_num_vertices add up to 2, not num_vertices 3");

  // Caps.
  m = one_object(scene_t::BOX, {1, 1, 1});
  m.num_objects = scene_t::MAX_OBJECTS + 1;
  EXPECT_EQ(refusal(m), "object_name holds 1 entries for num_objects 65");
  for (int k = 1; k < m.num_objects; ++k) {
    m.object_name.push_back("thing " + std::to_string(k));
    m.object_kind.push_back(scene_t::BOX);
    m.object_num_vertices.push_back(0);
    for (auto* v : {&m.object_size, &m.object_position, &m.object_quaternion, &m.object_clearance}) {
      v->push_back(v->front());
    }
  }
  EXPECT_EQ(refusal(m), "65 objects, more than MAX_OBJECTS (64)");

  // Planes and boxes.
  m = one_box({1, 1, 1}, {});
  m.num_planes = 1;
  m.plane_name = {"wall"};
  m.plane_normal = {{0, 0, 2}};
  m.plane_offset = {0.5};
  m.plane_num_links = {0};
  m.plane_clearance = {{0.01, 0.1}};
  EXPECT_EQ(refusal(m), "plane 0 'wall': plane_normal (0, 0, 2) has length 2, not 1");
  m.plane_normal = {{0, 0, 0}};
  EXPECT_EQ(refusal(m), "plane 0 'wall': plane_normal (0, 0, 0) has length 0, not 1");
  m.plane_normal = {{0, 0, 1}};
  m.plane_num_links = {1};
  m.num_plane_links = 1;
  m.plane_links = {""};
  EXPECT_EQ(refusal(m), "plane 0 'wall': plane_links[0] is empty");
  m.plane_links = {"panda_hand"};
  m.plane_clearance = {{0.1, 0.1}};
  EXPECT_EQ(refusal(m), "plane 0 'wall': plane_clearance: stop 0.100000 m is not below influence 0.100000 m");
  EXPECT_EQ(refusal(one_box({1, -1, 1}, {})), "box 0 'ws': box_size[1] is -1; a size must be > 0 (m)");
  m = one_box({1, 1, 1}, {"a", "b"});
  m.box_num_links = {1};
  EXPECT_EQ(refusal(m), "box_num_links add up to 1, not num_box_links 2");
}

TEST(SceneMessage, AMessageBuiltByHandWithArraysAgainstItsCountsIsRefused) {
  scene_t m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_size = {{1, 1}};  // lcm-gen's encoder would read past this row
  EXPECT_EQ(refusal(m), "object_size has a row of 2, not 3");
  m = one_object(scene_t::BOX, {1, 1, 1});
  m.num_vertices = -1;
  EXPECT_EQ(refusal(m), "num_vertices -1 is negative");
  m = one_object(scene_t::BOX, {1, 1, 1});
  m.object_kind.clear();
  EXPECT_EQ(refusal(m), "object_kind holds 0 entries for num_objects 1");
}

TEST(SceneMessage, TheCheckedDecoderWalksEveryCountBeforeTrustingIt) {
  const std::vector<uint8_t> good = bytes_of(encode_scene(every_kind()));
  Scene scene;
  char error[256];
  // Every proper prefix is refused.
  for (size_t length = 0; length < good.size(); length += 7) {
    EXPECT_FALSE(decode_scene(good.data(), length, scene, error, sizeof error)) << length;
  }
  EXPECT_FALSE(decode_scene(good.data(), 22, scene, error, sizeof error));
  EXPECT_STREQ(error, "truncated: 22 bytes");  // num_objects itself cut
  EXPECT_FALSE(decode_scene(good.data(), 100, scene, error, sizeof error));
  EXPECT_STREQ(error, "num_objects 5 in a message of 100 bytes");  // five objects cannot fit
  // num_objects (after the fingerprint, version and utime) claiming 2^31 − 1 objects: refused from
  // the bytes there are, before anything is sized for it.
  std::vector<uint8_t> huge = good;
  for (int b = 0; b < 4; ++b) huge[20 + size_t(b)] = b == 0 ? 0x7f : 0xff;
  EXPECT_FALSE(decode_scene(huge.data(), huge.size(), scene, error, sizeof error));
  EXPECT_EQ(std::string(error), "num_objects 2147483647 in a message of " + std::to_string(good.size()) + " bytes");
  // The first object's name of length 0 (lcm-gen's decoder would throw on it).
  std::vector<uint8_t> empty_string = good;
  std::memset(empty_string.data() + 24, 0, 4);
  EXPECT_FALSE(decode_scene(empty_string.data(), empty_string.size(), scene, error, sizeof error));
  EXPECT_EQ(std::string(error),
            "a string of object_name of 0 bytes in a message of " + std::to_string(good.size()) + " bytes");
  // A byte too many, another type's fingerprint.
  std::vector<uint8_t> longer = good;
  longer.push_back(0);
  EXPECT_FALSE(decode_scene(longer.data(), longer.size(), scene, error, sizeof error));
  EXPECT_EQ(std::string(error), "of " + std::to_string(longer.size()) + " bytes; expected " + std::to_string(good.size()));
  std::vector<uint8_t> other = good;
  other[3] ^= 0x10;
  EXPECT_FALSE(decode_scene(other.data(), other.size(), scene, error, sizeof error));
  EXPECT_STREQ(error, "not a scene_t (wrong fingerprint)");
  // Finite::Required names the first array holding a NaN.
  scene_t with_nan = encode_scene(every_kind());
  with_nan.plane_offset[1] = std::numeric_limits<double>::quiet_NaN();
  const std::vector<uint8_t> nan_bytes = bytes_of(with_nan);
  scene_t m;
  EXPECT_EQ(messages::decode_checked(nan_bytes.data(), nan_bytes.size(), m, messages::kAnyArm, messages::Finite::Required),
            "with non-finite plane_offset");
  EXPECT_EQ(messages::decode_checked(nan_bytes.data(), nan_bytes.size(), m), "");
  EXPECT_FALSE(decode_scene(nan_bytes.data(), nan_bytes.size(), scene, error, sizeof error));
  EXPECT_STREQ(error, "plane 1 'wall': plane_offset is not finite");
}

TEST(SceneMessage, TheErrorIsCutToTheBufferAndNeverOverrun) {
  scene_t m = one_object(scene_t::BOX, {1, 1, 1});
  m.version = 2;
  Scene scene;
  char error[12];
  std::memset(error, 'x', sizeof error);
  EXPECT_FALSE(decode_scene(m, scene, error, 8));
  EXPECT_STREQ(error, "version");
  EXPECT_EQ(error[8], 'x');
  EXPECT_FALSE(decode_scene(m, scene, nullptr, 0));  // no room: nothing written
}

TEST(SceneMessage, EncodeRefusesWhatTheContractCannotCarry) {
  Scene scene = every_kind();
  scene.objects[1].shape.radius = -1.0;
  try {
    encode_scene(scene);
    ADD_FAILURE() << "no error";
  } catch (const ArgumentError& e) {
    EXPECT_STREQ(e.what(), "cannot encode the scene: object 'lamp': a sphere's radius must be within 1e-06 and 1000 m");
  }
  scene = Scene{};
  for (int k = 0; k <= scene_t::MAX_PLANES; ++k) scene.planes.push_back({"p" + std::to_string(k), Vector3d::UnitZ(), 0.0, {}, {}});
  try {
    encode_scene(scene);
    ADD_FAILURE() << "no error";
  } catch (const ArgumentError& e) {
    EXPECT_STREQ(e.what(), "cannot encode the scene: 65 planes (besides workspace boxes); a scene_t carries 64");
  }
}

// The fuzzer's scene seeds (tests/fuzz/corpus/README.md): byte '=' then the message; the first two
// are taken, the third refused for its flat bin.
TEST(SceneMessage, TheFuzzSeedsAreWhatTheReadmeSays) {
  const std::string dir = std::string(CHASLES_TEST_DATA) + "/../fuzz/corpus/messages/";
  const std::string expected[3] = {"", "", "object 1 'flat_bin': its vertices span no volume"};
  const size_t objects[3] = {3, 2, 0}, planes[3] = {1 + 6, 2, 0};
  for (int k = 0; k < 3; ++k) {
    const std::string bytes = testing::read_file(dir + "chasles_scene_" + std::to_string(k));
    ASSERT_GT(bytes.size(), 1u) << k;
    EXPECT_EQ(bytes[0], '=');
    Scene scene;
    char error[256];
    const bool taken = decode_scene(bytes.data() + 1, bytes.size() - 1, scene, error, sizeof error);
    EXPECT_EQ(taken, expected[k].empty()) << k << ": " << error;
    EXPECT_EQ(std::string(error).substr(0, expected[k].size()), expected[k]) << k;
    EXPECT_EQ(scene.objects.size(), objects[k]) << k;
    EXPECT_EQ(scene.planes.size(), planes[k]) << k;
  }
}

TEST(SceneMessage, ShapeKindsCrossTheWireByTheirTable) {
  const std::pair<ShapeKind, int8_t> expected[] = {{ShapeKind::kSphere, 0}, {ShapeKind::kBox, 1},
                                                   {ShapeKind::kCylinder, 2}, {ShapeKind::kCapsule, 3},
                                                   {ShapeKind::kConvex, 4}};
  ASSERT_EQ(int(std::size(expected)), enumerators::count<ShapeKind>());
  for (const auto& [kind, wire] : expected) {
    EXPECT_EQ(to_wire(kind), wire);
    ShapeKind back{};
    EXPECT_TRUE(from_wire(wire, back));
    EXPECT_EQ(back, kind);
  }
  ShapeKind untouched = ShapeKind::kBox;
  EXPECT_FALSE(from_wire(int8_t{5}, untouched));
  EXPECT_EQ(untouched, ShapeKind::kBox);
}

}  // namespace
}  // namespace chasles::controller
