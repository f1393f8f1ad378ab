// chasles._core's scene: a scene file (core/geometry/scene_file.hpp) and a scene_t message's bytes
// (controller/transport/scene_message.hpp) read by the C++ readers the controller runs, so that what
// the view draws is what the controller takes, and a scene the controller refuses is refused here
// for the same reason. Each returns plain Python values (lists of floats), built once per scene:
// nothing here is on a per-tick path.
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "controller/transport/scene_message.hpp"
#include "core/error.hpp"
#include "core/geometry/scene_file.hpp"

namespace chasles::python {

namespace {

nb::list to_list(const Eigen::Ref<const Eigen::VectorXd>& v) {
  nb::list out;
  for (Eigen::Index i = 0; i < v.size(); ++i) out.append(v[i]);
  return out;
}

// A transform as a 4×4 list of rows.
nb::list pose_list(const Transform& T) {
  nb::list rows;
  const Eigen::Matrix4d M = T.matrix();
  for (int r = 0; r < 4; ++r) rows.append(to_list(M.row(r).transpose()));
  return rows;
}

nb::dict scene_dict(const geometry::Scene& scene) {
  using geometry::ShapeKind;
  nb::list objects, planes, boxes;
  for (const auto& o : scene.objects) {
    nb::dict d;
    d["name"] = o.name;
    const char* kinds[] = {"sphere", "box", "cylinder", "capsule", "convex"};
    d["kind"] = kinds[static_cast<int>(o.shape.kind)];
    d["radius"] = o.shape.radius;
    d["half_length"] = o.shape.half_length;
    d["half_extents"] = to_list(o.shape.half_extents);
    nb::list vertices;
    for (const auto& v : o.shape.vertices) vertices.append(to_list(v));
    d["vertices"] = vertices;
    d["pose"] = pose_list(o.T_base_object);
    objects.append(d);
  }
  // A workspace box comes as its six faces at the end of the planes: given back as the box.
  size_t first_face = scene.planes.size();
  for (const auto& b : geometry::trailing_workspace_boxes(scene, first_face)) {
    nb::dict d;
    d["name"] = b.name;
    d["pose"] = pose_list(b.T_base_box);
    d["half_extents"] = to_list(b.half_extents);
    boxes.append(d);
  }
  for (size_t k = 0; k < first_face; ++k) {
    nb::dict d;
    d["name"] = scene.planes[k].name;
    d["normal"] = to_list(scene.planes[k].normal);
    d["offset"] = scene.planes[k].offset;
    planes.append(d);
  }
  nb::dict out;
  out["objects"] = objects;
  out["planes"] = planes;
  out["boxes"] = boxes;
  return out;
}

}  // namespace

void bind_scene(nb::module_& m) {
  m.def(
      "read_scene_file",
      [](const std::string& path, const std::vector<std::string>& package_dirs) {
        geometry::SceneFileOptions options;
        options.package_dirs = package_dirs;
        return scene_dict(geometry::read_scene_file(path, options));
      },
      nb::arg("path"), nb::arg("package_dirs") = std::vector<std::string>{},
      "The scene file at path (docs/scene.md) as the controller's --scene reads it: a dict of 'objects' "
      "(name, kind sphere/box/cylinder/capsule/convex, radius, half_length, half_extents, vertices of a "
      "convex hull, pose 4×4 in the base frame), 'planes' (name, normal, offset) and 'boxes' (the "
      "workspace boxes: name, pose, half_extents). Raises ArgumentError naming the entry and field at fault.");
  m.def(
      "decode_scene",
      [](nb::bytes data) {
        geometry::Scene scene;
        char error[512];
        if (!controller::decode_scene(data.c_str(), data.size(), scene, error, sizeof error)) {
          throw ArgumentError(error);
        }
        return scene_dict(scene);
      },
      nb::arg("data"),
      "A scene_t message's bytes (PREFIX SCENE) checked and read as the controller reads them, as the same "
      "dict as read_scene_file. Raises ArgumentError with the controller's reason for refusing it.");
}

}  // namespace chasles::python
