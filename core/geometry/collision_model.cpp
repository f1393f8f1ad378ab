#include "core/geometry/collision_model.hpp"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <tinyxml2.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <string_view>

#include "core/lie/se3.hpp"

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

namespace chasles::geometry {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& source, const std::string& what) { throw ModelError(source + ": " + what); }

// Whitespace-separated numbers, exactly `count` of them (strtod, as the URDF loader reads numbers).
std::vector<double> read_numbers(const char* text, size_t count, const std::string& source, const std::string& where) {
  std::vector<double> values;
  const char* at = text;
  for (;;) {
    while (std::isspace(static_cast<unsigned char>(*at))) ++at;
    if (*at == '\0') break;
    char* end = nullptr;
    const double value = std::strtod(at, &end);
    if (end == at || !std::isfinite(value)) fail(source, where + ": '" + text + "' is not a list of finite numbers");
    values.push_back(value);
    at = end;
  }
  if (values.size() != count) {
    fail(source, where + ": '" + std::string(text) + "' should hold " + std::to_string(count) + " numbers");
  }
  return values;
}

Vector3d read_vector(const tinyxml2::XMLElement& e, const char* attribute, const Vector3d& absent,
                     const std::string& source, const std::string& where) {
  const char* text = e.Attribute(attribute);
  if (!text) return absent;
  const std::vector<double> v = read_numbers(text, 3, source, where + " <" + e.Name() + " " + attribute + ">");
  return Vector3d(v[0], v[1], v[2]);
}

double read_length(const tinyxml2::XMLElement& e, const char* attribute, const std::string& source,
                   const std::string& where) {
  const char* text = e.Attribute(attribute);
  const std::string what = where + " <" + e.Name() + " " + attribute + ">";
  if (!text) fail(source, what + " is missing");
  const double value = read_numbers(text, 1, source, what)[0];
  if (value <= 0.0) fail(source, what + " is " + text + ": a size must be > 0");
  return value;
}

// URDF's <origin xyz rpy>: R = Rz(yaw) Ry(pitch) Rx(roll), as urdfdom reads it; absent is identity.
Transform read_origin(const tinyxml2::XMLElement* parent, const std::string& source, const std::string& where) {
  const tinyxml2::XMLElement* origin = parent ? parent->FirstChildElement("origin") : nullptr;
  if (!origin) return Transform::Identity();
  const Vector3d xyz = read_vector(*origin, "xyz", Vector3d::Zero(), source, where);
  const Vector3d rpy = read_vector(*origin, "rpy", Vector3d::Zero(), source, where);
  const Matrix3d R = (Eigen::AngleAxisd(rpy.z(), Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vector3d::UnitY()) *
                      Eigen::AngleAxisd(rpy.x(), Vector3d::UnitX()))
                         .toRotationMatrix();
  return Transform(R, xyz);
}

// The URDF's tree as the XML gives it: each link's element and the joint above it.
struct ParentJoint {
  std::string parent;
  Transform T_parent_child;  // the joint at its zero position
};

struct UrdfTree {
  tinyxml2::XMLDocument doc;
  std::vector<const tinyxml2::XMLElement*> links;  // document order
  std::map<std::string, ParentJoint> parent_of;     // child link → its joint
  std::set<std::string> link_names;
};

void read_urdf(const std::string& path, UrdfTree& tree) {
  if (tree.doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) {
    fail(path, std::string("cannot read the URDF as XML: ") + tree.doc.ErrorStr());
  }
  const tinyxml2::XMLElement* robot = tree.doc.FirstChildElement("robot");
  if (!robot) fail(path, "no <robot> element");
  for (auto* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    const char* name = e->Attribute("name");
    if (!name) fail(path, "a <link> has no name (line " + std::to_string(e->GetLineNum()) + ")");
    tree.links.push_back(e);
    tree.link_names.insert(name);
  }
  for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const char* name = e->Attribute("name");
    const std::string where = std::string("joint '") + (name ? name : "?") + "'";
    const auto* p = e->FirstChildElement("parent");
    const auto* c = e->FirstChildElement("child");
    const char* parent = p ? p->Attribute("link") : nullptr;
    const char* child = c ? c->Attribute("link") : nullptr;
    if (!parent || !child) fail(path, where + " needs <parent link=...> and <child link=...>");
    tree.parent_of[child] = {parent, read_origin(e, path, where)};
  }
}

// The body a link rides on and its pose there: its own chain placement, or that of the nearest
// chain link up the tree composed with the joints between, each at zero.
struct Placement {
  int body = 0;
  Transform T_body_link;
};

// The nearest chain link at or above `link` and the link's pose in its frame; an empty name when
// none is (the root's pose then).
std::pair<std::string, Transform> nearest_chain_ancestor(const std::string& link, const UrdfTree& tree,
                                                         const std::map<std::string, Placement>& chain,
                                                         const std::string& source) {
  Transform T_ancestor_link = Transform::Identity();
  std::string at = link;
  for (size_t steps = 0; steps <= tree.parent_of.size(); ++steps) {
    if (chain.count(at)) return {at, T_ancestor_link};
    const auto up = tree.parent_of.find(at);
    if (up == tree.parent_of.end()) return {std::string(), T_ancestor_link};
    T_ancestor_link = up->second.T_parent_child * T_ancestor_link;
    at = up->second.parent;
  }
  fail(source, "the joints above link '" + link + "' form a cycle");
}

// Links above the chain's base link (the model's base need not be the URDF's root) are fixed with
// it, so they ride on body 0, placed through the root.
Placement place_link(const std::string& link, const UrdfTree& tree, const std::map<std::string, Placement>& chain,
                     const std::string& base_link, const std::string& source) {
  const auto [ancestor, T_ancestor_link] = nearest_chain_ancestor(link, tree, chain, source);
  if (!ancestor.empty()) {
    const Placement& p = chain.at(ancestor);
    return {p.body, p.T_body_link * T_ancestor_link};
  }
  const Transform T_root_base = nearest_chain_ancestor(base_link, tree, {}, source).second;
  return {0, chain.at(base_link).T_body_link * inverse(T_root_base) * T_ancestor_link};
}

void collect_vertices(const aiScene& scene, const aiNode& node, const aiMatrix4x4& T_file_parent, const Vector3d& scale,
                      std::vector<Vector3d>& out) {
  const aiMatrix4x4 T_file_node = T_file_parent * node.mTransformation;
  for (unsigned m = 0; m < node.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D p = T_file_node * mesh.mVertices[v];
      out.emplace_back(scale.x() * p.x, scale.y() * p.y, scale.z() * p.z);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) collect_vertices(scene, *node.mChildren[c], T_file_node, scale, out);
}

std::vector<Vector3d> read_mesh_vertices(const std::string& path, const Vector3d& scale, const std::string& what) {
  Assimp::Importer importer;
  // The file's own axes: a Collada file's up axis is the URDF author's business (the <origin>).
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_LINE | aiPrimitiveType_POINT);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType | aiProcess_FindDegenerates);
  if (!scene || !scene->mRootNode) {
    throw ModelError(what + ": cannot read mesh '" + path + "': " + importer.GetErrorString());
  }
  std::vector<Vector3d> vertices;
  collect_vertices(*scene, *scene->mRootNode, aiMatrix4x4(), scale, vertices);
  if (vertices.empty()) throw ModelError(what + ": mesh '" + path + "' holds no vertex");
  return vertices;
}

// qhull writes its diagnostics to a FILE; they go into the error message instead of stderr.
class CapturedText {
 public:
  CapturedText() : file_(open_memstream(&text_, &size_)) {}
  ~CapturedText() {
    if (file_) std::fclose(file_);
    std::free(text_);
  }
  CapturedText(const CapturedText&) = delete;
  CapturedText& operator=(const CapturedText&) = delete;
  FILE* file() const { return file_; }
  std::string first_line() {
    if (!file_) return {};
    std::fflush(file_);
    const std::string all(text_, size_);
    const size_t start = all.find_first_not_of(" \n");
    return start == std::string::npos ? std::string() : all.substr(start, all.find('\n', start) - start);
  }

 private:
  char* text_ = nullptr;
  size_t size_ = 0;
  FILE* file_;
};

// Frees qhull's memory whichever way the hull's reading ends.
struct QhullSession {
  qhT qh;
  explicit QhullSession(FILE* errors) { qh_zero(&qh, errors); }
  ~QhullSession() {
    qh_freeqhull(&qh, !qh_ALL);
    int still_long = 0, total_long = 0;
    qh_memfreeshort(&qh, &still_long, &total_long);
  }
  QhullSession(const QhullSession&) = delete;
  QhullSession& operator=(const QhullSession&) = delete;
};

}  // namespace

Shape convex_hull(const std::vector<Vector3d>& points, const std::string& what) {
  if (points.size() < 4) throw ModelError(what + ": " + std::to_string(points.size()) + " vertices span no volume");
  std::vector<coordT> coordinates;
  coordinates.reserve(3 * points.size());
  for (const Vector3d& p : points) {
    if (!p.allFinite()) throw ModelError(what + ": a vertex is not finite");
    coordinates.insert(coordinates.end(), {p.x(), p.y(), p.z()});
  }
  CapturedText errors;
  QhullSession session(errors.file());
  qhT* qh = &session.qh;
  // 'Qt' triangulates the merged facets, so that each facet's three vertices give its edges.
  char options[] = "qhull Qt";
  const int status = qh_new_qhull(qh, 3, static_cast<int>(points.size()), coordinates.data(), False, options, nullptr,
                                  errors.file());
  if (status != 0) {
    throw ModelError(what + ": its vertices span no volume (a flat or degenerate mesh; qhull: " + errors.first_line() +
                     ")");
  }
  std::vector<int> hull_points;         // point ids of the hull's vertices, ascending
  std::set<std::pair<int, int>> edges;  // point ids (a, b), a < b
  vertexT* vertex = nullptr;
  FORALLvertices { hull_points.push_back(qh_pointid(qh, vertex->point)); }
  std::sort(hull_points.begin(), hull_points.end());
  facetT* facet = nullptr;
  FORALLfacets {
    std::vector<int> ids;
    vertexT** vertexp = nullptr;
    FOREACHvertex_(facet->vertices) { ids.push_back(qh_pointid(qh, vertex->point)); }
    if (ids.size() != 3) throw ModelError(what + ": qhull left a facet of " + std::to_string(ids.size()) + " vertices");
    for (size_t a = 0; a < 3; ++a) {
      const int p = ids[a], q = ids[(a + 1) % 3];
      edges.emplace(std::min(p, q), std::max(p, q));
    }
  }
  Shape shape;
  shape.kind = ShapeKind::kConvex;
  std::map<int, int> index;  // point id → hull vertex index
  for (int id : hull_points) {
    index[id] = static_cast<int>(shape.vertices.size());
    shape.vertices.push_back(points[static_cast<size_t>(id)]);
  }
  shape.neighbours.resize(shape.vertices.size());
  for (const auto& [p, q] : edges) {
    const int a = index.at(p), b = index.at(q);
    shape.neighbours[static_cast<size_t>(a)].push_back(b);
    shape.neighbours[static_cast<size_t>(b)].push_back(a);
  }
  return shape;
}

std::vector<std::string> with_ros_package_path(std::vector<std::string> dirs) {
  const char* path = std::getenv("ROS_PACKAGE_PATH");
  for (std::string_view rest = path != nullptr ? path : ""; !rest.empty();) {
    const size_t colon = rest.find(':');
    const std::string_view folder = rest.substr(0, colon);
    if (!folder.empty()) dirs.emplace_back(folder);
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
  }
  return dirs;
}

std::string resolve_mesh_uri(const std::string& uri, const std::string& base_dir,
                             const std::vector<std::string>& package_dirs, const std::string& what) {
  const std::string package_scheme = "package://", file_scheme = "file://";
  if (uri.rfind(package_scheme, 0) == 0) {
    const std::string rest = uri.substr(package_scheme.size());
    const std::string package = rest.substr(0, rest.find('/'));
    bool package_found = false;
    for (const auto& dir : package_dirs) {
      const fs::path candidate = fs::path(dir) / rest;
      if (fs::is_regular_file(candidate)) return candidate.string();
      package_found = package_found || fs::is_directory(fs::path(dir) / package);
    }
    if (!package_found) {
      std::string dirs;
      for (const auto& dir : package_dirs) dirs += (dirs.empty() ? "'" : ", '") + dir + "'";
      throw ModelError(what + ": mesh '" + uri + "': package '" + package + "' is in none of the package dirs (" +
                       (dirs.empty() ? "none given" : dirs) + ")");
    }
    throw ModelError(what + ": mesh '" + uri + "': no such file in package '" + package + "'");
  }
  fs::path path = uri.rfind(file_scheme, 0) == 0 ? fs::path(uri.substr(file_scheme.size())) : fs::path(uri);
  if (path.is_relative()) path = fs::path(base_dir) / path;
  if (!fs::is_regular_file(path)) throw ModelError(what + ": mesh '" + uri + "': no such file '" + path.string() + "'");
  return path.string();
}

Shape mesh_hull(const std::string& path, const Vector3d& scale, const std::string& what) {
  return convex_hull(read_mesh_vertices(path, scale, what), what + ": mesh '" + path + "'");
}

namespace {

Shape read_shape(const tinyxml2::XMLElement& collision, const GeometryOptions& options,
                 const std::string& source, const std::string& where) {
  const tinyxml2::XMLElement* geometry = collision.FirstChildElement("geometry");
  const tinyxml2::XMLElement* e = geometry ? geometry->FirstChildElement() : nullptr;
  if (!e) fail(source, where + ": <geometry> holds no shape");
  const std::string kind = e->Name();
  Shape shape;
  if (kind == "box") {
    shape.kind = ShapeKind::kBox;
    const Vector3d size = read_vector(*e, "size", Vector3d::Constant(-1.0), source, where);
    if (!(size.array() > 0.0).all()) fail(source, where + ": <box size> must hold three sizes > 0");
    shape.half_extents = size / 2.0;
  } else if (kind == "cylinder" || kind == "capsule") {
    shape.kind = kind == "cylinder" ? ShapeKind::kCylinder : ShapeKind::kCapsule;
    shape.radius = read_length(*e, "radius", source, where);
    shape.half_length = read_length(*e, "length", source, where) / 2.0;
  } else if (kind == "sphere") {
    shape.kind = ShapeKind::kSphere;
    shape.radius = read_length(*e, "radius", source, where);
  } else if (kind == "mesh") {
    const char* filename = e->Attribute("filename");
    if (!filename) fail(source, where + ": <mesh> has no filename");
    const Vector3d scale = read_vector(*e, "scale", Vector3d::Ones(), source, where);
    const std::string what = source + ": " + where;
    const std::string path =
        resolve_mesh_uri(filename, fs::path(source).parent_path().string(), options.package_dirs, what);
    shape = mesh_hull(path, scale, what);
  } else {
    fail(source, where + ": unknown shape <" + kind + ">");
  }
  return shape;
}

using LinkPairs = std::set<std::pair<std::string, std::string>>;

// The SRDF's <disable_collisions> as pairs of link names, both orders, each link checked against
// the URDF.
LinkPairs read_disabled_pairs(const std::string& srdf_path,
                                                                  const std::set<std::string>& urdf_links) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(srdf_path.c_str()) != tinyxml2::XML_SUCCESS) {
    fail(srdf_path, std::string("cannot read the SRDF as XML: ") + doc.ErrorStr());
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) fail(srdf_path, "no <robot> element: not an SRDF");
  LinkPairs disabled;
  for (auto* e = robot->FirstChildElement("disable_collisions"); e; e = e->NextSiblingElement("disable_collisions")) {
    const std::string line = " (line " + std::to_string(e->GetLineNum()) + ")";
    const char* a = e->Attribute("link1");
    const char* b = e->Attribute("link2");
    if (!a || !b) fail(srdf_path, "<disable_collisions> needs link1 and link2" + line);
    for (const char* link : {a, b}) {
      if (!urdf_links.count(link)) {
        fail(srdf_path, std::string("<disable_collisions> names link '") + link + "', which the URDF lacks" + line);
      }
    }
    disabled.emplace(a, b);
    disabled.emplace(b, a);
  }
  return disabled;
}

std::vector<std::pair<int, int>> collision_pairs(const std::vector<CollisionObject>& objects, const std::string& srdf_path,
                                                 const std::set<std::string>& urdf_links) {
  const bool have_srdf = !srdf_path.empty();
  const LinkPairs disabled = have_srdf ? read_disabled_pairs(srdf_path, urdf_links) : LinkPairs{};
  std::vector<std::pair<int, int>> pairs;
  for (size_t i = 0; i < objects.size(); ++i) {
    for (size_t j = i + 1; j < objects.size(); ++j) {
      const CollisionObject &a = objects[i], &b = objects[j];
      if (a.body == b.body) continue;
      if (have_srdf ? disabled.count({a.link, b.link}) > 0 : std::abs(a.body - b.body) == 1) continue;
      pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
    }
  }
  return pairs;
}

}  // namespace

CollisionModel load_collision_model(const std::string& urdf_path, const RobotModel& model, const GeometryOptions& options) {
  UrdfTree tree;
  read_urdf(urdf_path, tree);
  std::map<std::string, Placement> chain;
  for (const ChainLink& link : model.links()) {
    if (!tree.link_names.count(link.name)) {
      fail(urdf_path, "the model's link '" + link.name + "' is not in this URDF: the model was loaded from another");
    }
    chain[link.name] = {link.body, link.T_body_link};
  }
  CollisionModel out;
  for (const tinyxml2::XMLElement* link : tree.links) {
    const std::string name = link->Attribute("name");
    const tinyxml2::XMLElement* collision = link->FirstChildElement("collision");
    if (!collision) continue;
    const Placement placement = place_link(name, tree, chain, model.base_link(), urdf_path);
    int k = 0;
    for (; collision; collision = collision->NextSiblingElement("collision"), ++k) {
      const std::string where = "link '" + name + "': <collision> " + std::to_string(k) + " (line " +
                                std::to_string(collision->GetLineNum()) + ")";
      CollisionObject object;
      object.name = name + "/" + std::to_string(k);
      object.link = name;
      object.body = placement.body;
      object.T_body_object = placement.T_body_link * read_origin(collision, urdf_path, where);
      object.shape = read_shape(*collision, options, urdf_path, where);
      out.objects.push_back(std::move(object));
    }
  }
  out.pairs = collision_pairs(out.objects, options.srdf_path, tree.link_names);
  return out;
}

}  // namespace chasles::geometry
