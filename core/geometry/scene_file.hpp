// The scene file: what surrounds the arm (keep-out objects, safety planes, workspace boxes) as
// JSON, read at start (chasles_controller --scene FILE) and written by tools; docs/scene.md is the
// format. The same content travels live as chasles.scene_t (lcmtypes/chasles_scene_t.lcm,
// controller/transport/scene_message.hpp), held to the same rules, which are here: whichever way a
// scene comes, it means the same thing and is refused for the same faults. Offline work: reads
// files, allocates, calls assimp and qhull.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/geometry/proximity.hpp"

namespace chasles::geometry {

/// The scene file's version this reader reads and the writer writes.
inline constexpr int kSceneFileVersion = 1;

struct SceneFileOptions {
  /// Where a mesh's `package://NAME/rest` is looked for (as GeometryOptions::package_dirs).
  std::vector<std::string> package_dirs;
};

/// Reads the scene file at `path`: its objects, then its planes, then each workspace box's six
/// faces (add_workspace_box), in file order. A mesh is the convex hull of its file (mesh_hull,
/// the URDF loader's own), found as a URDF's is (resolve_mesh_uri: relative to the scene file's
/// folder, `file://`, or `package://` in options.package_dirs).
///
/// Throws ArgumentError naming the file, the entry (`objects[2] "table"`) and the field at fault:
/// JSON that does not parse (with its line and column), an unknown or missing version, an unknown
/// key, a value of the wrong type, an unknown shape, a size ≤ 0 or not finite, a quaternion whose
/// norm is not within kQuaternionNormTolerance of 1, a plane normal whose length is not within
/// kNormalLengthTolerance of 1, a clearance not 0 ≤ stop < influence, a name that is empty, too
/// long or holds a control character, a name given twice, a mesh that cannot be found or read or
/// spans no volume, convex vertices that span none.
Scene read_scene_file(const std::string& path, const SceneFileOptions& options = {});

/// Writes `scene` to `path` as a scene file that reads back to it (numbers to the last bit but for
/// the rotations, which go through a quaternion: within 1e-15): atomically, as a temporary file in
/// the same folder renamed over `path`, so a reader never sees half a file. Objects keep their
/// shapes, a mesh as the vertices of its hull (`convex`); planes are written with their offset;
/// planes that end the scene in groups of six that add_workspace_box made (names "<box>/+x" ...
/// "<box>/-z", one box's faces) are written back as that workspace box. Throws ArgumentError when
/// the scene breaks a rule (scene_problem), or naming the path when it cannot be written.
void write_scene_file(const std::string& path, const Scene& scene);

/// A workspace box as add_workspace_box takes it: the box's centre frame in the base frame, its
/// half extents (m), the links it binds (empty: all) and the clearance kept from each face.
struct WorkspaceBox {
  std::string name;
  Transform T_base_box = Transform::Identity();
  Vector3d half_extents = Vector3d::Zero();
  std::vector<std::string> links;
  Clearance clearance;
};

/// The workspace boxes whose faces end `scene.planes`, in order: groups of six planes as
/// add_workspace_box makes them (faces "<box>/+x", "<box>/-x", ... "<box>/-z" in that order, one
/// box's normals, links and clearance, the box's own name used by no object or plane), found from
/// the last plane back. `first_face` is the index of the first plane they take (planes.size()
/// when none). What the writers (write_scene_file, encode_scene) use to give boxes back as boxes,
/// so that reading them back (planes, then boxes) keeps the order.
/// At most `max_boxes` are taken (the last ones).
std::vector<WorkspaceBox> trailing_workspace_boxes(const Scene& scene, size_t& first_face,
                                                   size_t max_boxes = size_t(-1));

// ---- The rules every scene keeps to, from a file or a message ----

/// Names of objects, planes and workspace boxes: 1 to this many bytes, no control character (so
/// that a refusal or a status prints them on one line), unique across the scene.
inline constexpr size_t kMaxSceneNameLength = 64;
/// The lengths a scene holds, m: every size at least kMinSceneSize (a micrometre: a size below is
/// a slip of units), and every size, coordinate (positions, hull vertices), plane offset and
/// clearance at most kMaxSceneExtent (a kilometre) in magnitude. What keeps every distance a tick
/// computes finite and exact enough: squares of numbers past 1e154 overflow, and a box's faces
/// must give the box back (trailing_workspace_boxes).
inline constexpr double kMinSceneSize = 1e-6;
inline constexpr double kMaxSceneExtent = 1e3;
/// The link names a plane binds: 1 to this many bytes, no control character.
inline constexpr size_t kMaxLinkNameLength = 255;
/// How far from 1 a plane normal's length may be. A normal is not normalised silently: with an
/// offset, a normal of another length would put the plane elsewhere than its author meant (n · x =
/// offset), so one further off is refused and one within this is normalised, which moves the plane
/// by at most 1 µm per metre of offset.
inline constexpr double kNormalLengthTolerance = 1e-6;

/// Why `name` cannot name an entry of a scene ("is empty", "is 70 bytes long, more than 64",
/// "holds a control character (byte 3)"), or "".
std::string name_problem(const std::string& name, size_t max_length = kMaxSceneNameLength);

/// Why `clearance` cannot be one (0 ≤ stop < influence, finite), or "".
std::string clearance_problem(const Clearance& clearance);

/// The rotation of the quaternion (w, x, y, z), normalised: "" and `R` set, or why not (not
/// finite, or a norm not within kQuaternionNormTolerance of 1), `R` untouched.
std::string rotation_of_quaternion(const Eigen::Vector4d& wxyz, Matrix3d& R);

/// Why `scene` breaks a rule, in the Scene's own terms ("object 'table': ...", "plane 'floor':
/// ..."), or "": names as above and unique across objects and planes, shapes with finite sizes
/// within kMinSceneSize and kMaxSceneExtent (a convex shape: at least four finite vertices within
/// kMaxSceneExtent, neighbours for each, within range), poses that are rigid transforms (finite,
/// within kMaxSceneExtent, R orthonormal with det +1 within 1e-9), plane normals of unit length
/// within 1e-9 (what Proximity takes) and offsets within kMaxSceneExtent, link names as above,
/// clearances (influence within kMaxSceneExtent).
/// What the readers build always passes; write_scene_file and encode_scene refuse a scene that
/// does not.
std::string scene_problem(const Scene& scene);

}  // namespace chasles::geometry
