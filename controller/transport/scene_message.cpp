#include "controller/transport/scene_message.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include "controller/transport/wire.hpp"
#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/scene_file.hpp"
#include "core/model/model.hpp"
#include "lcmtypes/checked.hpp"

namespace chasles::controller {
namespace {

using geometry::Clearance;
using geometry::Scene;
using geometry::ShapeKind;

// The contract's caps are the scene rules' (core/geometry/scene_file.hpp): one set of limits.
static_assert(scene_t::MAX_NAME_LENGTH == int(geometry::kMaxSceneNameLength), "the name caps must agree");
static_assert(scene_t::MAX_LINK_NAME_LENGTH == int(geometry::kMaxLinkNameLength), "the link name caps must agree");

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", x);
  return text;
}

std::string numbers(const std::vector<double>& v) {
  std::string out = "(";
  for (size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + number(v[i]);
  return out + ")";
}

bool finite(const std::vector<double>& v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

// ---- The arrays agree with their counts (a message decoded from bytes always does; one built by
// hand may not) ----

template <typename T>
std::string sized(const std::vector<T>& v, int32_t count, const char* name, const char* count_name) {
  if (count < 0) return std::string(count_name) + " " + std::to_string(count) + " is negative";
  if (v.size() != size_t(count)) {
    return std::string(name) + " holds " + std::to_string(v.size()) + " entries for " + count_name + " " +
           std::to_string(count);
  }
  return {};
}

std::string sized(const std::vector<std::vector<double>>& rows, int32_t count, size_t columns, const char* name,
                  const char* count_name) {
  if (std::string why = sized(rows, count, name, count_name); !why.empty()) return why;
  for (const auto& row : rows) {
    if (row.size() != columns) {
      return std::string(name) + " has a row of " + std::to_string(row.size()) + ", not " + std::to_string(columns);
    }
  }
  return {};
}

std::string structure_problem(const scene_t& m) {
  const std::string checks[] = {
      sized(m.object_name, m.num_objects, "object_name", "num_objects"),
      sized(m.object_kind, m.num_objects, "object_kind", "num_objects"),
      sized(m.object_size, m.num_objects, 3, "object_size", "num_objects"),
      sized(m.object_position, m.num_objects, 3, "object_position", "num_objects"),
      sized(m.object_quaternion, m.num_objects, 4, "object_quaternion", "num_objects"),
      sized(m.object_clearance, m.num_objects, 2, "object_clearance", "num_objects"),
      sized(m.object_num_vertices, m.num_objects, "object_num_vertices", "num_objects"),
      sized(m.vertices, m.num_vertices, 3, "vertices", "num_vertices"),
      sized(m.plane_name, m.num_planes, "plane_name", "num_planes"),
      sized(m.plane_normal, m.num_planes, 3, "plane_normal", "num_planes"),
      sized(m.plane_offset, m.num_planes, "plane_offset", "num_planes"),
      sized(m.plane_num_links, m.num_planes, "plane_num_links", "num_planes"),
      sized(m.plane_clearance, m.num_planes, 2, "plane_clearance", "num_planes"),
      sized(m.plane_links, m.num_plane_links, "plane_links", "num_plane_links"),
      sized(m.box_name, m.num_boxes, "box_name", "num_boxes"),
      sized(m.box_position, m.num_boxes, 3, "box_position", "num_boxes"),
      sized(m.box_quaternion, m.num_boxes, 4, "box_quaternion", "num_boxes"),
      sized(m.box_size, m.num_boxes, 3, "box_size", "num_boxes"),
      sized(m.box_num_links, m.num_boxes, "box_num_links", "num_boxes"),
      sized(m.box_clearance, m.num_boxes, 2, "box_clearance", "num_boxes"),
      sized(m.box_links, m.num_box_links, "box_links", "num_box_links"),
  };
  for (const std::string& why : checks) {
    if (!why.empty()) return why;
  }
  return {};
}

// ---- The caps, and the per-entry counts adding up to their totals ----

std::string cap_problem(int32_t count, int32_t cap, const char* what, const char* cap_name) {
  if (count > cap) {
    return std::to_string(count) + " " + what + ", more than " + cap_name + " (" + std::to_string(cap) + ")";
  }
  return {};
}

// Each entry's share of a concatenated array: 0 to `cap` each, adding up to `total`.
std::string shares_problem(const std::vector<int32_t>& shares, int32_t cap, int32_t total, const char* share_name,
                           const char* cap_name, const char* total_name) {
  int64_t sum = 0;
  for (size_t k = 0; k < shares.size(); ++k) {
    if (shares[k] < 0 || shares[k] > cap) {
      return std::string(share_name) + "[" + std::to_string(k) + "] " + std::to_string(shares[k]) + " is not within 0 to " +
             cap_name + " (" + std::to_string(cap) + ")";
    }
    sum += shares[k];
  }
  if (sum != total) {
    return std::string(share_name) + " add up to " + std::to_string(sum) + ", not " + total_name + " " +
           std::to_string(total);
  }
  return {};
}

std::string counts_problem(const scene_t& m) {
  const std::string checks[] = {
      cap_problem(m.num_objects, scene_t::MAX_OBJECTS, "objects", "MAX_OBJECTS"),
      cap_problem(m.num_vertices, scene_t::MAX_VERTICES, "vertices", "MAX_VERTICES"),
      cap_problem(m.num_planes, scene_t::MAX_PLANES, "planes", "MAX_PLANES"),
      cap_problem(m.num_boxes, scene_t::MAX_BOXES, "boxes", "MAX_BOXES"),
      shares_problem(m.object_num_vertices, scene_t::MAX_HULL_VERTICES, m.num_vertices, "object_num_vertices",
                     "MAX_HULL_VERTICES", "num_vertices"),
      shares_problem(m.plane_num_links, scene_t::MAX_LINKS, m.num_plane_links, "plane_num_links", "MAX_LINKS",
                     "num_plane_links"),
      shares_problem(m.box_num_links, scene_t::MAX_LINKS, m.num_box_links, "box_num_links", "MAX_LINKS",
                     "num_box_links"),
  };
  for (const std::string& why : checks) {
    if (!why.empty()) return why;
  }
  return {};
}

// ---- One entry at a time ----

// "object 3": the entry's name joins its label once it has passed the rule for names.
std::string named(const std::string& label, const std::string& name) { return label + " '" + name + "'"; }

std::string pose_problem(const std::vector<double>& position, const std::vector<double>& wxyz, const char* position_name,
                         const char* quaternion_name, Transform& T) {
  if (!finite(position)) return std::string(position_name) + " " + numbers(position) + " is not finite";
  T.translation() = Vector3d(position[0], position[1], position[2]);
  if (std::string why = geometry::rotation_of_quaternion(Eigen::Vector4d(wxyz[0], wxyz[1], wxyz[2], wxyz[3]), T.linear());
      !why.empty()) {
    return std::string(quaternion_name) + " " + numbers(wxyz) + " " + why;
  }
  return {};
}

std::string clearance_of(const std::vector<double>& stop_influence, const char* name, Clearance& c) {
  c = {stop_influence[0], stop_influence[1]};
  if (std::string why = geometry::clearance_problem(c); !why.empty()) return std::string(name) + ": " + why;
  return {};
}

std::string links_of(const std::vector<std::string>& all, size_t& next, int32_t count, const char* name,
                     std::vector<std::string>& links) {
  links.assign(all.begin() + long(next), all.begin() + long(next) + count);
  for (size_t i = 0; i < links.size(); ++i) {
    if (std::string why = geometry::name_problem(links[i], geometry::kMaxLinkNameLength); !why.empty()) {
      return std::string(name) + "[" + std::to_string(next + i) + "] " + why;
    }
  }
  next += size_t(count);
  return {};
}

// The sizes a kind uses (object_size's first entries), each > 0; the rest must be 0, so that a
// sender who filled the wrong ones hears so.
int sizes_used(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::kSphere: return 1;
    case ShapeKind::kBox: return 3;
    case ShapeKind::kCylinder:
    case ShapeKind::kCapsule: return 2;
    case ShapeKind::kConvex: return 0;
  }
  return 0;
}

const char* kind_name(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::kSphere: return "SPHERE";
    case ShapeKind::kBox: return "BOX";
    case ShapeKind::kCylinder: return "CYLINDER";
    case ShapeKind::kCapsule: return "CAPSULE";
    case ShapeKind::kConvex: return "CONVEX";
  }
  return "?";
}

std::string kinds_known() {
  std::string out;
  for (const auto& pair : WireTable<ShapeKind>::kPairs) {
    out += (out.empty() ? "" : ", ") + std::string(kind_name(pair.value)) + " " + std::to_string(pair.wire);
  }
  return out;
}

std::string object_problem(const scene_t& m, int k, size_t& next_vertex, geometry::SceneObject& object) {
  const size_t i = size_t(k);
  std::string label = "object " + std::to_string(k);
  if (std::string why = geometry::name_problem(m.object_name[i]); !why.empty()) return label + ": object_name " + why;
  object.name = m.object_name[i];
  label = named(label, object.name);
  ShapeKind kind{};
  if (!from_wire(m.object_kind[i], kind)) {
    return label + ": object_kind " + std::to_string(m.object_kind[i]) + " is none of " + kinds_known();
  }
  const std::vector<double>& size = m.object_size[i];
  if (!finite(size)) return label + ": object_size " + numbers(size) + " is not finite";
  const int used = sizes_used(kind);
  for (int s = 0; s < 3; ++s) {
    const double x = size[size_t(s)];
    const char* why = s >= used ? (x == 0.0 ? nullptr : "unused")
                      : x <= 0.0 ? "a size must be > 0 (m)"
                      : x < geometry::kMinSceneSize || x > geometry::kMaxSceneExtent ? "a size must be within 1e-06 and 1000 m"
                                                                                    : nullptr;
    if (why) {
      return label + ": object_size[" + std::to_string(s) + "] is " + number(x) + "; " +
             (s >= used ? std::string("a ") + kind_name(kind) + " uses " + std::to_string(used) + " sizes, the rest must be 0"
                        : std::string(why));
    }
  }
  const int32_t vertex_count = m.object_num_vertices[i];
  if ((kind == ShapeKind::kConvex) != (vertex_count > 0) || (vertex_count > 0 && vertex_count < 4)) {
    return label + ": object_num_vertices " + std::to_string(vertex_count) +
           (kind == ShapeKind::kConvex ? ": a CONVEX object needs 4 or more" : ": only a CONVEX object has vertices");
  }
  if (std::string why = pose_problem(m.object_position[i], m.object_quaternion[i], "object_position",
                                     "object_quaternion", object.T_base_object);
      !why.empty()) {
    return label + ": " + why;
  }
  if (std::string why = clearance_of(m.object_clearance[i], "object_clearance", object.clearance); !why.empty()) {
    return label + ": " + why;
  }
  geometry::Shape& shape = object.shape;
  shape.kind = kind;
  switch (kind) {
    case ShapeKind::kSphere:
      shape.radius = size[0];
      break;
    case ShapeKind::kBox:
      shape.half_extents = Vector3d(size[0], size[1], size[2]) / 2.0;
      break;
    case ShapeKind::kCylinder:
    case ShapeKind::kCapsule:
      shape.radius = size[0];
      shape.half_length = size[1] / 2.0;
      break;
    case ShapeKind::kConvex: {
      std::vector<Vector3d> points;
      points.reserve(size_t(vertex_count));
      for (int32_t v = 0; v < vertex_count; ++v) {
        const std::vector<double>& p = m.vertices[next_vertex + size_t(v)];
        if (!finite(p)) return label + ": vertices[" + std::to_string(next_vertex + size_t(v)) + "] is not finite";
        points.emplace_back(p[0], p[1], p[2]);
      }
      next_vertex += size_t(vertex_count);
      try {
        shape = geometry::convex_hull(points, label);
      } catch (const ModelError& e) {
        return e.what();
      }
      break;
    }
  }
  return {};
}

std::string plane_problem(const scene_t& m, int k, size_t& next_link, geometry::SafetyPlane& plane) {
  const size_t i = size_t(k);
  std::string label = "plane " + std::to_string(k);
  if (std::string why = geometry::name_problem(m.plane_name[i]); !why.empty()) return label + ": plane_name " + why;
  plane.name = m.plane_name[i];
  label = named(label, plane.name);
  const std::vector<double>& n = m.plane_normal[i];
  if (!finite(n)) return label + ": plane_normal " + numbers(n) + " is not finite";
  const Vector3d normal(n[0], n[1], n[2]);
  if (std::abs(normal.norm() - 1.0) > geometry::kNormalLengthTolerance) {
    return label + ": plane_normal " + numbers(n) + " has length " + number(normal.norm()) + ", not 1";
  }
  plane.normal = normal.normalized();
  if (!std::isfinite(m.plane_offset[i])) return label + ": plane_offset is not finite";
  plane.offset = m.plane_offset[i];
  if (std::string why = links_of(m.plane_links, next_link, m.plane_num_links[i], "plane_links", plane.links);
      !why.empty()) {
    return label + ": " + why;
  }
  if (std::string why = clearance_of(m.plane_clearance[i], "plane_clearance", plane.clearance); !why.empty()) {
    return label + ": " + why;
  }
  return {};
}

std::string box_problem(const scene_t& m, int k, size_t& next_link, geometry::WorkspaceBox& box) {
  const size_t i = size_t(k);
  std::string label = "box " + std::to_string(k);
  if (std::string why = geometry::name_problem(m.box_name[i]); !why.empty()) return label + ": box_name " + why;
  box.name = m.box_name[i];
  label = named(label, box.name);
  if (std::string why = pose_problem(m.box_position[i], m.box_quaternion[i], "box_position", "box_quaternion",
                                     box.T_base_box);
      !why.empty()) {
    return label + ": " + why;
  }
  const std::vector<double>& size = m.box_size[i];
  for (int s = 0; s < 3; ++s) {
    const double x = size[size_t(s)];
    if (!(std::isfinite(x) && x > 0.0)) {
      return label + ": box_size[" + std::to_string(s) + "] is " + number(x) + "; a size must be > 0 (m)";
    }
    if (x < geometry::kMinSceneSize || x > geometry::kMaxSceneExtent) {
      return label + ": box_size[" + std::to_string(s) + "] is " + number(x) + "; a size must be within 1e-06 and 1000 m";
    }
  }
  box.half_extents = Vector3d(size[0], size[1], size[2]) / 2.0;
  if (std::string why = links_of(m.box_links, next_link, m.box_num_links[i], "box_links", box.links); !why.empty()) {
    return label + ": " + why;
  }
  if (std::string why = clearance_of(m.box_clearance[i], "box_clearance", box.clearance); !why.empty()) {
    return label + ": " + why;
  }
  return {};
}

std::string build(const scene_t& m, Scene& scene) {
  if (m.version != scene_t::VERSION) {
    return "version " + std::to_string(m.version) + "; this receiver reads version " + std::to_string(scene_t::VERSION);
  }
  if (std::string why = structure_problem(m); !why.empty()) return why;
  if (std::string why = counts_problem(m); !why.empty()) return why;
  std::map<std::string, std::string> names;  // name → the entry that took it
  // "" for a name not yet taken, else who took it.
  const auto take = [&names](const std::string& name, const std::string& entry) -> std::string {
    const auto [it, fresh] = names.emplace(name, entry);
    return fresh ? "" : it->second;
  };
  size_t next_vertex = 0;
  for (int k = 0; k < m.num_objects; ++k) {
    geometry::SceneObject object;
    if (std::string why = object_problem(m, k, next_vertex, object); !why.empty()) return why;
    const std::string label = named("object " + std::to_string(k), object.name);
    if (std::string taker = take(object.name, label); !taker.empty()) return label + ": the name is taken by " + taker;
    scene.objects.push_back(std::move(object));
  }
  size_t next_link = 0;
  for (int k = 0; k < m.num_planes; ++k) {
    geometry::SafetyPlane plane;
    if (std::string why = plane_problem(m, k, next_link, plane); !why.empty()) return why;
    const std::string label = named("plane " + std::to_string(k), plane.name);
    if (std::string taker = take(plane.name, label); !taker.empty()) return label + ": the name is taken by " + taker;
    scene.planes.push_back(std::move(plane));
  }
  next_link = 0;
  for (int k = 0; k < m.num_boxes; ++k) {
    geometry::WorkspaceBox box;
    if (std::string why = box_problem(m, k, next_link, box); !why.empty()) return why;
    const std::string label = named("box " + std::to_string(k), box.name);
    if (std::string taker = take(box.name, label); !taker.empty()) return label + ": the name is taken by " + taker;
    const size_t first = scene.planes.size();
    geometry::add_workspace_box(scene, box.name, box.T_base_box, box.half_extents, box.links, box.clearance);
    for (size_t p = first; p < scene.planes.size(); ++p) {
      const std::string& face = scene.planes[p].name;
      if (std::string taker = take(face, label + "'s face"); !taker.empty()) {
        return label + ": its face's name '" + face + "' is taken by " + taker;
      }
    }
  }
  // What was built from checked fields keeps every rule; this is the net under them.
  return geometry::scene_problem(scene);
}

void say(const std::string& why, char* error, size_t size) {
  if (size > 0) std::snprintf(error, size, "%s", why.c_str());
}

}  // namespace

bool decode_scene(const scene_t& message, Scene& out, char* error, size_t size) {
  try {
    Scene scene;
    if (std::string why = build(message, scene); !why.empty()) {
      say(why, error, size);
      return false;
    }
    out = std::move(scene);
    say("", error, size);
    return true;
  } catch (const std::exception& e) {  // std::bad_alloc: the scene is not taken
    say(std::string("cannot decode the scene: ") + e.what(), error, size);
  } catch (...) {
    say("cannot decode the scene", error, size);
  }
  return false;
}

bool decode_scene(const void* data, size_t bytes, Scene& out, char* error, size_t size) {
  try {
    scene_t message;
    if (std::string why = messages::decode_checked(data, bytes, message); !why.empty()) {
      say(why, error, size);
      return false;
    }
    return decode_scene(message, out, error, size);
  } catch (const std::exception& e) {
    say(std::string("cannot decode the scene: ") + e.what(), error, size);
  } catch (...) {
    say("cannot decode the scene", error, size);
  }
  return false;
}

namespace {

void put_pose(const Transform& T, std::vector<double>& position, std::vector<double>& wxyz) {
  Eigen::Quaterniond q(T.linear());
  if (q.w() < 0.0) q.coeffs() *= -1.0;  // one of the two: w ≥ 0
  position = {T.translation().x(), T.translation().y(), T.translation().z()};
  wxyz = {q.w(), q.x(), q.y(), q.z()};
}

std::vector<double> pair_of(const Clearance& c) { return {c.stop, c.influence}; }

[[noreturn]] void refuse(const std::string& why) { throw ArgumentError("cannot encode the scene: " + why); }

void check_cap(size_t count, int32_t cap, const char* what) {
  if (count > size_t(cap)) refuse(std::to_string(count) + " " + what + "; a scene_t carries " + std::to_string(cap));
}

}  // namespace

scene_t encode_scene(const Scene& scene, int64_t utime) {
  if (std::string why = geometry::scene_problem(scene); !why.empty()) refuse(why);
  size_t first_face = 0;
  const std::vector<geometry::WorkspaceBox> boxes =
      geometry::trailing_workspace_boxes(scene, first_face, size_t(scene_t::MAX_BOXES));
  check_cap(scene.objects.size(), scene_t::MAX_OBJECTS, "objects");
  check_cap(first_face, scene_t::MAX_PLANES, "planes (besides workspace boxes)");
  check_cap(boxes.size(), scene_t::MAX_BOXES, "workspace boxes");
  scene_t m;
  m.version = scene_t::VERSION;
  m.utime = utime;
  m.num_objects = int32_t(scene.objects.size());
  m.num_vertices = 0;
  for (const geometry::SceneObject& o : scene.objects) {
    const geometry::Shape& s = o.shape;
    m.object_name.push_back(o.name);
    m.object_kind.push_back(to_wire(s.kind));
    switch (s.kind) {
      case ShapeKind::kSphere: m.object_size.push_back({s.radius, 0.0, 0.0}); break;
      case ShapeKind::kBox: m.object_size.push_back({2 * s.half_extents.x(), 2 * s.half_extents.y(), 2 * s.half_extents.z()}); break;
      case ShapeKind::kCylinder:
      case ShapeKind::kCapsule: m.object_size.push_back({s.radius, 2 * s.half_length, 0.0}); break;
      case ShapeKind::kConvex: m.object_size.push_back({0.0, 0.0, 0.0}); break;
    }
    m.object_position.emplace_back();
    m.object_quaternion.emplace_back();
    put_pose(o.T_base_object, m.object_position.back(), m.object_quaternion.back());
    m.object_clearance.push_back(pair_of(o.clearance));
    const size_t count = s.kind == ShapeKind::kConvex ? s.vertices.size() : 0;
    check_cap(count, scene_t::MAX_HULL_VERTICES, ("hull vertices in object '" + o.name + "'").c_str());
    m.object_num_vertices.push_back(int32_t(count));
    for (size_t v = 0; v < count; ++v) m.vertices.push_back({s.vertices[v].x(), s.vertices[v].y(), s.vertices[v].z()});
  }
  check_cap(m.vertices.size(), scene_t::MAX_VERTICES, "hull vertices in all");
  m.num_vertices = int32_t(m.vertices.size());
  m.num_planes = int32_t(first_face);
  for (size_t k = 0; k < first_face; ++k) {
    const geometry::SafetyPlane& p = scene.planes[k];
    check_cap(p.links.size(), scene_t::MAX_LINKS, ("links bound by plane '" + p.name + "'").c_str());
    m.plane_name.push_back(p.name);
    m.plane_normal.push_back({p.normal.x(), p.normal.y(), p.normal.z()});
    m.plane_offset.push_back(p.offset);
    m.plane_num_links.push_back(int32_t(p.links.size()));
    m.plane_clearance.push_back(pair_of(p.clearance));
    m.plane_links.insert(m.plane_links.end(), p.links.begin(), p.links.end());
  }
  m.num_plane_links = int32_t(m.plane_links.size());
  m.num_boxes = int32_t(boxes.size());
  for (const geometry::WorkspaceBox& b : boxes) {
    check_cap(b.links.size(), scene_t::MAX_LINKS, ("links bound by box '" + b.name + "'").c_str());
    m.box_name.push_back(b.name);
    m.box_position.emplace_back();
    m.box_quaternion.emplace_back();
    put_pose(b.T_base_box, m.box_position.back(), m.box_quaternion.back());
    m.box_size.push_back({2 * b.half_extents.x(), 2 * b.half_extents.y(), 2 * b.half_extents.z()});
    m.box_num_links.push_back(int32_t(b.links.size()));
    m.box_clearance.push_back(pair_of(b.clearance));
    m.box_links.insert(m.box_links.end(), b.links.begin(), b.links.end());
  }
  m.num_box_links = int32_t(m.box_links.size());
  return m;
}

}  // namespace chasles::controller
