#include "core/geometry/scene_file.hpp"


#include <Eigen/Geometry>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/lie/so3.hpp"
#include "core/model/model.hpp"

namespace chasles::geometry {

// ---- The rules ----

std::string name_problem(const std::string& name, size_t max_length) {
  if (name.empty()) return "is empty";
  if (name.size() > max_length) {
    return "is " + std::to_string(name.size()) + " bytes long, more than " + std::to_string(max_length);
  }
  for (size_t i = 0; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (c < 0x20 || c == 0x7f) return "holds a control character (byte " + std::to_string(i) + ")";
  }
  return {};
}

std::string clearance_problem(const Clearance& c) {
  if (!std::isfinite(c.stop) || !std::isfinite(c.influence)) return "stop and influence must be finite";
  if (c.influence > kMaxSceneExtent) {
    return "influence " + std::to_string(c.influence) + " m is beyond " + std::to_string(int(kMaxSceneExtent)) + " m";
  }
  if (c.stop < 0.0) return "stop " + std::to_string(c.stop) + " m is negative";
  if (!(c.stop < c.influence)) {
    return "stop " + std::to_string(c.stop) + " m is not below influence " + std::to_string(c.influence) + " m";
  }
  return {};
}

std::string rotation_of_quaternion(const Eigen::Vector4d& wxyz, Matrix3d& R) {
  if (!wxyz.allFinite()) return "is not finite";
  const double norm = wxyz.norm();
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    return "(w, x, y, z) has norm " + std::to_string(norm) + ", not 1";
  }
  R = Eigen::Quaterniond(wxyz(0), wxyz(1), wxyz(2), wxyz(3)).normalized().toRotationMatrix();
  return {};
}

namespace {

bool within_extent(const Vector3d& p) { return p.allFinite() && p.cwiseAbs().maxCoeff() <= kMaxSceneExtent; }

std::string pose_problem(const Transform& T) {
  const Matrix3d& R = T.linear();
  if (!R.allFinite() || !T.translation().allFinite()) return "its pose is not finite";
  if (!within_extent(T.translation())) return "its position is beyond " + std::to_string(int(kMaxSceneExtent)) + " m";
  if ((R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-9 || R.determinant() <= 0.0) {
    return "its pose's rotation is not a rotation (R^T R = 1, det R = +1, within 1e-9)";
  }
  return {};
}

std::string shape_problem(const Shape& s) {
  // A size (a radius, a half extent) within the scene's lengths; half of a full length counts as
  // the full length does.
  const auto size_ok = [](double x, double scale) {
    return std::isfinite(x) && scale * x >= kMinSceneSize && scale * x <= kMaxSceneExtent;
  };
  const std::string range = " within 1e-06 and 1000 m";
  switch (s.kind) {
    case ShapeKind::kSphere:
      return size_ok(s.radius, 1.0) ? "" : "a sphere's radius must be" + range;
    case ShapeKind::kBox:
      return size_ok(s.half_extents.x(), 2.0) && size_ok(s.half_extents.y(), 2.0) && size_ok(s.half_extents.z(), 2.0)
                 ? ""
                 : "a box's sizes must be" + range;
    case ShapeKind::kCylinder:
    case ShapeKind::kCapsule:
      return size_ok(s.radius, 1.0) && size_ok(s.half_length, 2.0)
                 ? ""
                 : "a cylinder's or capsule's radius and length must be" + range;
    case ShapeKind::kConvex: {
      if (s.vertices.size() < 4) return "a convex shape needs at least 4 vertices";
      if (s.neighbours.size() != s.vertices.size()) return "a convex shape needs the neighbours of each vertex";
      const int n = static_cast<int>(s.vertices.size());
      for (size_t v = 0; v < s.vertices.size(); ++v) {
        if (!within_extent(s.vertices[v])) {
          return "a convex shape's vertex is not finite or beyond " + std::to_string(int(kMaxSceneExtent)) + " m";
        }
        if (s.neighbours[v].empty()) return "a convex shape's vertex has no neighbour";
        for (int w : s.neighbours[v]) {
          if (w < 0 || w >= n || w == static_cast<int>(v)) return "a convex shape's neighbour is out of range";
        }
      }
      return {};
    }
  }
  return "an unknown shape kind";
}

}  // namespace

std::string scene_problem(const Scene& scene) {
  std::map<std::string, std::string> named;  // name → what it names
  const auto unique = [&named](const std::string& name, const std::string& what) -> std::string {
    const auto [it, fresh] = named.emplace(name, what);
    return fresh ? "" : what + ": the name is taken by " + it->second;
  };
  for (const SceneObject& o : scene.objects) {
    const std::string what = "object '" + o.name + "'";
    if (std::string why = name_problem(o.name); !why.empty()) return "an object's name " + why;
    if (std::string why = unique(o.name, what); !why.empty()) return why;
    if (std::string why = shape_problem(o.shape); !why.empty()) return what + ": " + why;
    if (std::string why = pose_problem(o.T_base_object); !why.empty()) return what + ": " + why;
    if (std::string why = clearance_problem(o.clearance); !why.empty()) return what + ": clearance: " + why;
  }
  for (const SafetyPlane& p : scene.planes) {
    const std::string what = "plane '" + p.name + "'";
    if (std::string why = name_problem(p.name); !why.empty()) return "a plane's name " + why;
    if (std::string why = unique(p.name, what); !why.empty()) return why;
    if (!p.normal.allFinite() || std::abs(p.normal.norm() - 1.0) > 1e-9) {
      return what + ": its normal must be a unit vector (within 1e-9)";
    }
    if (!std::isfinite(p.offset) || std::abs(p.offset) > kMaxSceneExtent) {
      return what + ": its offset is not finite or beyond " + std::to_string(int(kMaxSceneExtent)) + " m";
    }
    for (const std::string& link : p.links) {
      if (std::string why = name_problem(link, kMaxLinkNameLength); !why.empty()) return what + ": a link name " + why;
    }
    if (std::string why = clearance_problem(p.clearance); !why.empty()) return what + ": clearance: " + why;
  }
  return {};
}

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// Where a refusal points: the file, then the entry (`objects[2] "table"`; empty at the top level).
struct Where {
  const std::string& file;
  std::string entry;

  [[noreturn]] void fail(const std::string& what) const {
    throw ArgumentError(file + ": " + (entry.empty() ? "" : entry + ": ") + what);
  }
};

std::string type_of(const Json& v) {
  switch (v.type()) {
    case Json::value_t::null: return "null";
    case Json::value_t::object: return "an object";
    case Json::value_t::array: return "a list";
    case Json::value_t::string: return "a string";
    case Json::value_t::boolean: return "a boolean";
    case Json::value_t::number_integer:
    case Json::value_t::number_unsigned:
    case Json::value_t::number_float: return "a number";
    default: return "not a value";
  }
}

// nlohmann's messages start with a tag ("[json.exception.parse_error.101] "): the rest is the news.
std::string without_tag(const std::string& message) {
  const size_t end = message.find("] ");
  return message.rfind("[json.exception.", 0) == 0 && end != std::string::npos ? message.substr(end + 2) : message;
}

// A string as JSON spells it: control characters escaped, bad UTF-8 replaced.
std::string spelt(const std::string& s) { return Json(s).dump(-1, ' ', false, Json::error_handler_t::replace); }

// `value` is an object whose keys are all among `keys`: a misspelt key ("influance") is an error,
// not a default silently taken.
void expect_keys(const Json& value, std::initializer_list<const char*> keys, const Where& at, const std::string& field) {
  const std::string prefix = field.empty() ? "" : field + " ";
  if (!value.is_object()) at.fail(prefix + "is " + type_of(value) + ", expected an object");
  for (const auto& item : value.items()) {
    bool known = false;
    std::string list;
    for (const char* key : keys) {
      known = known || item.key() == key;
      list += (list.empty() ? "" : ", ") + std::string(key);
    }
    if (!known) {
      at.fail((field.empty() ? "" : field + ": ") + "unknown key \"" + item.key() + "\" (known: " + list + ")");
    }
  }
}

const Json* find(const Json& object, const char* key) {
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

const Json& require(const Json& object, const char* key, const Where& at, const std::string& field) {
  const Json* value = find(object, key);
  if (!value) at.fail((field.empty() ? "" : field + ": ") + "no \"" + key + "\"");
  return *value;
}

double number(const Json& v, const Where& at, const std::string& field) {
  if (!v.is_number()) at.fail(field + " is " + type_of(v) + ", expected a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) at.fail(field + " is not a finite number");
  return x;
}

// A size: > 0, m.
double length(const Json& v, const Where& at, const std::string& field) {
  const double x = number(v, at, field);
  if (x <= 0.0) at.fail(field + " is " + v.dump() + ": a size must be > 0 (m)");
  if (x < kMinSceneSize || x > kMaxSceneExtent) at.fail(field + " is " + v.dump() + ": a size must be within 1e-06 and 1000 m");
  return x;
}

Vector3d vector3(const Json& v, const Where& at, const std::string& field) {
  if (!v.is_array() || v.size() != 3) {
    at.fail(field + " is " + (v.is_array() ? "a list of " + std::to_string(v.size()) : type_of(v)) +
            ", expected a list of 3 numbers");
  }
  return {number(v[0], at, field + "[0]"), number(v[1], at, field + "[1]"), number(v[2], at, field + "[2]")};
}

Vector3d sizes3(const Json& v, const Where& at, const std::string& field) {
  const Vector3d s = vector3(v, at, field);
  for (int i = 0; i < 3; ++i) length(v[static_cast<size_t>(i)], at, field + "[" + std::to_string(i) + "]");
  return s;
}

std::string text(const Json& v, const Where& at, const std::string& field) {
  if (!v.is_string()) at.fail(field + " is " + type_of(v) + ", expected a string");
  return v.get<std::string>();
}

std::string read_name(const Json& entry, const Where& at) {
  const std::string name = text(require(entry, "name", at, ""), at, "name");
  if (std::string why = name_problem(name); !why.empty()) at.fail("name " + spelt(name) + " " + why);
  return name;
}

std::vector<std::string> read_links(const Json& entry, const Where& at) {
  const Json* v = find(entry, "links");
  if (!v) return {};
  if (!v->is_array()) at.fail("links is " + type_of(*v) + ", expected a list of link names");
  std::vector<std::string> links;
  for (size_t i = 0; i < v->size(); ++i) {
    const std::string field = "links[" + std::to_string(i) + "]";
    links.push_back(text((*v)[i], at, field));
    if (std::string why = name_problem(links.back(), kMaxLinkNameLength); !why.empty()) {
      at.fail(field + " " + spelt(links.back()) + " " + why);
    }
  }
  return links;
}

Clearance read_clearance(const Json& entry, const Where& at) {
  Clearance c;
  const Json* v = find(entry, "clearance");
  if (!v) return c;
  expect_keys(*v, {"stop", "influence"}, at, "clearance");
  if (const Json* stop = find(*v, "stop")) c.stop = number(*stop, at, "clearance.stop");
  if (const Json* influence = find(*v, "influence")) c.influence = number(*influence, at, "clearance.influence");
  if (std::string why = clearance_problem(c); !why.empty()) at.fail("clearance: " + why);
  return c;
}

// {xyz, rpy} or {xyz, quaternion (w, x, y, z)}; absent parts are zero and the identity. rpy as
// URDF's <origin>: R = Rz(yaw) Ry(pitch) Rx(roll).
Transform read_pose(const Json& entry, const Where& at) {
  const Json* v = find(entry, "pose");
  if (!v) return Transform::Identity();
  expect_keys(*v, {"xyz", "rpy", "quaternion"}, at, "pose");
  Transform T;
  if (const Json* xyz = find(*v, "xyz")) T.translation() = vector3(*xyz, at, "pose.xyz");
  const Json* rpy = find(*v, "rpy");
  const Json* quaternion = find(*v, "quaternion");
  if (rpy && quaternion) at.fail("pose: give rpy or quaternion, not both");
  if (rpy) {
    const Vector3d a = vector3(*rpy, at, "pose.rpy");
    T.linear() = (Eigen::AngleAxisd(a.z(), Vector3d::UnitZ()) * Eigen::AngleAxisd(a.y(), Vector3d::UnitY()) *
                  Eigen::AngleAxisd(a.x(), Vector3d::UnitX()))
                     .toRotationMatrix();
  } else if (quaternion) {
    if (!quaternion->is_array() || quaternion->size() != 4) {
      at.fail("pose.quaternion is " +
              (quaternion->is_array() ? "a list of " + std::to_string(quaternion->size()) : type_of(*quaternion)) +
              ", expected a list of 4 numbers (w, x, y, z)");
    }
    Eigen::Vector4d wxyz;
    for (int i = 0; i < 4; ++i) {
      wxyz(i) = number((*quaternion)[static_cast<size_t>(i)], at, "pose.quaternion[" + std::to_string(i) + "]");
    }
    if (std::string why = rotation_of_quaternion(wxyz, T.linear()); !why.empty()) at.fail("pose.quaternion " + why);
  }
  return T;
}

Shape read_shape(const Json& entry, const Where& at, const std::string& dir, const SceneFileOptions& options) {
  const Json& v = require(entry, "shape", at, "");
  if (!v.is_object() || v.size() != 1) {
    at.fail("shape must be an object with one key, the shape's kind: box, sphere, cylinder, capsule, mesh or convex");
  }
  const std::string kind = v.begin().key();
  const Json& p = v.begin().value();
  const std::string field = "shape." + kind;
  Shape shape;
  if (kind == "box") {
    expect_keys(p, {"size"}, at, field);
    shape.kind = ShapeKind::kBox;
    shape.half_extents = sizes3(require(p, "size", at, field), at, field + ".size") / 2.0;
  } else if (kind == "sphere") {
    expect_keys(p, {"radius"}, at, field);
    shape.kind = ShapeKind::kSphere;
    shape.radius = length(require(p, "radius", at, field), at, field + ".radius");
  } else if (kind == "cylinder" || kind == "capsule") {
    expect_keys(p, {"radius", "length"}, at, field);
    shape.kind = kind == "cylinder" ? ShapeKind::kCylinder : ShapeKind::kCapsule;
    shape.radius = length(require(p, "radius", at, field), at, field + ".radius");
    shape.half_length = length(require(p, "length", at, field), at, field + ".length") / 2.0;
  } else if (kind == "mesh") {
    expect_keys(p, {"file", "scale"}, at, field);
    const std::string file = text(require(p, "file", at, field), at, field + ".file");
    Vector3d scale = Vector3d::Ones();
    if (const Json* s = find(p, "scale")) {
      scale = s->is_number() ? Vector3d::Constant(length(*s, at, field + ".scale")) : sizes3(*s, at, field + ".scale");
    }
    const std::string what = at.file + ": " + at.entry + ": " + field;
    try {
      shape = mesh_hull(resolve_mesh_uri(file, dir, options.package_dirs, what), scale, what);
    } catch (const ModelError& e) {
      throw ArgumentError(e.what());
    }
  } else if (kind == "convex") {
    expect_keys(p, {"vertices"}, at, field);
    const Json& list = require(p, "vertices", at, field);
    if (!list.is_array()) at.fail(field + ".vertices is " + type_of(list) + ", expected a list of [x, y, z]");
    std::vector<Vector3d> points;
    for (size_t i = 0; i < list.size(); ++i) {
      points.push_back(vector3(list[i], at, field + ".vertices[" + std::to_string(i) + "]"));
    }
    try {
      shape = convex_hull(points, at.file + ": " + at.entry + ": " + field + ".vertices");
    } catch (const ModelError& e) {
      throw ArgumentError(e.what());
    }
  } else {
    at.fail("unknown shape \"" + kind + "\" (box, sphere, cylinder, capsule, mesh, convex)");
  }
  return shape;
}

const Json& section(const Json& document, const char* key, const std::string& path) {
  static const Json kNone = Json::array();
  const Json* v = find(document, key);
  if (!v) return kNone;
  if (!v->is_array()) Where{path, ""}.fail(std::string(key) + " is " + type_of(*v) + ", expected a list");
  return *v;
}

std::string entry_label(const char* section_name, size_t i, const std::string& name = "") {
  return std::string(section_name) + "[" + std::to_string(i) + "]" + (name.empty() ? "" : " \"" + name + "\"");
}

std::string read_text(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw ArgumentError(path + ": cannot read the scene file: is a directory");
  std::ifstream file(path, std::ios::binary);
  if (!file) throw ArgumentError(path + ": cannot open the scene file: " + std::strerror(errno));
  std::ostringstream out;
  out << file.rdbuf();
  if (file.bad()) throw ArgumentError(path + ": cannot read the scene file");
  return out.str();
}

}  // namespace

Scene read_scene_file(const std::string& path, const SceneFileOptions& options) {
  Json document;
  try {
    document = Json::parse(read_text(path));
  } catch (const Json::parse_error& e) {
    throw ArgumentError(path + ": not valid JSON: " + without_tag(e.what()));
  } catch (const Json::exception& e) {  // a number beyond a double (1e999)
    throw ArgumentError(path + ": cannot be read as JSON: " + without_tag(e.what()));
  }
  const Where top{path, ""};
  expect_keys(document, {"version", "objects", "planes", "workspace"}, top, "the top level");
  const Json* version = find(document, "version");
  if (!version) top.fail("no \"version\" (this reader reads version " + std::to_string(kSceneFileVersion) + ")");
  if (!version->is_number_integer() || version->get<int64_t>() != kSceneFileVersion) {
    top.fail("version " + version->dump() + " is not one this reader knows (it reads version " +
             std::to_string(kSceneFileVersion) + ")");
  }
  const std::string dir = fs::path(path).parent_path().string();
  Scene scene;
  std::map<std::string, std::string> named;  // name → the entry that took it
  const auto take_name = [&named](const std::string& name, const std::string& label, const Where& at) {
    const auto [it, fresh] = named.emplace(name, label);
    if (!fresh) at.fail("the name \"" + name + "\" is given twice (also " + it->second + ")");
  };

  const Json& objects = section(document, "objects", path);
  for (size_t i = 0; i < objects.size(); ++i) {
    Where at{path, entry_label("objects", i)};
    const Json& e = objects[i];
    expect_keys(e, {"name", "shape", "pose", "clearance"}, at, "");
    SceneObject object;
    object.name = read_name(e, at);
    at.entry = entry_label("objects", i, object.name);
    take_name(object.name, at.entry, at);
    object.shape = read_shape(e, at, dir, options);
    object.T_base_object = read_pose(e, at);
    object.clearance = read_clearance(e, at);
    scene.objects.push_back(std::move(object));
  }

  const Json& planes = section(document, "planes", path);
  for (size_t i = 0; i < planes.size(); ++i) {
    Where at{path, entry_label("planes", i)};
    const Json& e = planes[i];
    expect_keys(e, {"name", "normal", "offset", "point", "links", "clearance"}, at, "");
    SafetyPlane plane;
    plane.name = read_name(e, at);
    at.entry = entry_label("planes", i, plane.name);
    take_name(plane.name, at.entry, at);
    const Vector3d n = vector3(require(e, "normal", at, ""), at, "normal");
    if (std::abs(n.norm() - 1.0) > kNormalLengthTolerance) {
      std::ostringstream why;
      why.precision(17);
      why << "normal " << find(e, "normal")->dump() << " has length " << n.norm() << ", not 1: give the unit vector "
          << "toward the allowed side";
      if (n.norm() > 0.0) {
        const Vector3d u = n.normalized();
        why << " ([" << u.x() << ", " << u.y() << ", " << u.z() << "])";
      }
      at.fail(why.str());
    }
    plane.normal = n.normalized();
    const Json* offset = find(e, "offset");
    const Json* point = find(e, "point");
    if (offset && point) at.fail("give offset or point, not both");
    if (!offset && !point) at.fail("no \"offset\" or \"point\": where is the plane?");
    plane.offset = offset ? number(*offset, at, "offset") : plane.normal.dot(vector3(*point, at, "point"));
    plane.links = read_links(e, at);
    plane.clearance = read_clearance(e, at);
    scene.planes.push_back(std::move(plane));
  }

  const Json& boxes = section(document, "workspace", path);
  for (size_t i = 0; i < boxes.size(); ++i) {
    Where at{path, entry_label("workspace", i)};
    const Json& e = boxes[i];
    expect_keys(e, {"name", "pose", "size", "links", "clearance"}, at, "");
    const std::string name = read_name(e, at);
    at.entry = entry_label("workspace", i, name);
    take_name(name, at.entry, at);
    const Vector3d size = sizes3(require(e, "size", at, ""), at, "size");
    const size_t first = scene.planes.size();
    add_workspace_box(scene, name, read_pose(e, at), size / 2.0, read_links(e, at), read_clearance(e, at));
    for (size_t k = first; k < scene.planes.size(); ++k) {
      take_name(scene.planes[k].name, at.entry + "'s face \"" + scene.planes[k].name + "\"", at);
    }
  }
  // What was built from checked fields keeps every rule; this is the net under them.
  if (std::string why = scene_problem(scene); !why.empty()) top.fail(why);
  return scene;
}

namespace {

using Ordered = nlohmann::ordered_json;  // keys in the order written: version first

Ordered numbers(const Vector3d& v) { return Ordered::array({v.x(), v.y(), v.z()}); }

Ordered pose_json(const Transform& T) {
  Eigen::Quaterniond q(T.linear());
  if (q.w() < 0.0) q.coeffs() *= -1.0;  // one of the two: w ≥ 0
  return {{"xyz", numbers(T.translation())}, {"quaternion", Ordered::array({q.w(), q.x(), q.y(), q.z()})}};
}

Ordered clearance_json(const Clearance& c) { return {{"stop", c.stop}, {"influence", c.influence}}; }

Ordered shape_json(const Shape& s) {
  switch (s.kind) {
    case ShapeKind::kSphere:
      return {{"sphere", {{"radius", s.radius}}}};
    case ShapeKind::kBox:
      return {{"box", {{"size", numbers(2.0 * s.half_extents)}}}};
    case ShapeKind::kCylinder:
      return {{"cylinder", {{"radius", s.radius}, {"length", 2.0 * s.half_length}}}};
    case ShapeKind::kCapsule:
      return {{"capsule", {{"radius", s.radius}, {"length", 2.0 * s.half_length}}}};
    case ShapeKind::kConvex:
      break;
  }
  Ordered vertices = Ordered::array();
  for (const Vector3d& v : s.vertices) vertices.push_back(numbers(v));
  return {{"convex", {{"vertices", vertices}}}};
}

// A workspace box recovered from the six planes add_workspace_box made of it (faces +x, −x, +y, −y,
// +z, −z in that order): the − face's normal is the box's axis, the + face's its negation, and the
// offsets give the centre and half extent along it (offset₊ = −a·c − h, offset₋ = a·c − h).
bool as_box(const std::vector<SafetyPlane>& planes, size_t at, WorkspaceBox& box) {
  static const char* const kFaces[6] = {"/+x", "/-x", "/+y", "/-y", "/+z", "/-z"};
  const SafetyPlane& first = planes[at];
  const std::string& name0 = first.name;
  if (name0.size() <= 3 || name0.compare(name0.size() - 3, 3, kFaces[0]) != 0) return false;
  box.name = name0.substr(0, name0.size() - 3);
  Matrix3d R;
  Vector3d along;
  for (int axis = 0; axis < 3; ++axis) {
    const SafetyPlane& plus = planes[at + 2 * size_t(axis)];
    const SafetyPlane& minus = planes[at + 2 * size_t(axis) + 1];
    for (const SafetyPlane* p : {&plus, &minus}) {
      const std::string face = kFaces[p == &plus ? 2 * axis : 2 * axis + 1];
      if (p->name != box.name + face || p->links != first.links || p->clearance.stop != first.clearance.stop ||
          p->clearance.influence != first.clearance.influence) {
        return false;
      }
    }
    if ((plus.normal + minus.normal).cwiseAbs().maxCoeff() > 1e-12) return false;
    R.col(axis) = minus.normal;
    box.half_extents(axis) = -(plus.offset + minus.offset) / 2.0;
    along(axis) = (minus.offset - plus.offset) / 2.0;
  }
  if ((R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-9 || R.determinant() <= 0.0 ||
      !(box.half_extents.array() > 0.0).all()) {
    return false;
  }
  box.T_base_box = Transform(R, R * along);
  box.links = first.links;
  box.clearance = first.clearance;
  return true;
}

}  // namespace

std::vector<WorkspaceBox> trailing_workspace_boxes(const Scene& scene, size_t& first_face, size_t max_boxes) {
  const auto name_is_free = [&scene](const std::string& name) {
    return std::none_of(scene.objects.begin(), scene.objects.end(), [&](const auto& o) { return o.name == name; }) &&
           std::none_of(scene.planes.begin(), scene.planes.end(), [&](const auto& p) { return p.name == name; });
  };
  std::vector<WorkspaceBox> boxes;
  first_face = scene.planes.size();
  for (WorkspaceBox box; boxes.size() < max_boxes && first_face >= 6 && as_box(scene.planes, first_face - 6, box) &&
                         name_is_free(box.name);
       first_face -= 6) {
    boxes.insert(boxes.begin(), box);
  }
  return boxes;
}

namespace {

}  // namespace

void write_scene_file(const std::string& path, const Scene& scene) {
  if (std::string why = scene_problem(scene); !why.empty()) {
    throw ArgumentError(path + ": cannot write the scene: " + why);
  }
  Ordered objects = Ordered::array();
  for (const SceneObject& o : scene.objects) {
    objects.push_back({{"name", o.name},
                       {"shape", shape_json(o.shape)},
                       {"pose", pose_json(o.T_base_object)},
                       {"clearance", clearance_json(o.clearance)}});
  }
  size_t end = 0;
  const std::vector<WorkspaceBox> boxes = trailing_workspace_boxes(scene, end);
  Ordered planes = Ordered::array();
  for (size_t k = 0; k < end; ++k) {
    const SafetyPlane& p = scene.planes[k];
    planes.push_back({{"name", p.name},
                      {"normal", numbers(p.normal)},
                      {"offset", p.offset},
                      {"links", p.links},
                      {"clearance", clearance_json(p.clearance)}});
  }
  Ordered workspace = Ordered::array();
  for (const WorkspaceBox& b : boxes) {
    workspace.push_back({{"name", b.name},
                         {"pose", pose_json(b.T_base_box)},
                         {"size", numbers(2.0 * b.half_extents)},
                         {"links", b.links},
                         {"clearance", clearance_json(b.clearance)}});
  }
  Ordered document = {{"version", kSceneFileVersion}, {"objects", objects}, {"planes", planes}, {"workspace", workspace}};
  write_file_atomically(path, document.dump(2) + "\n");
}

}  // namespace chasles::geometry
