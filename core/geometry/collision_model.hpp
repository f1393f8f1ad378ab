// The arm's collision geometry read from its URDF (and SRDF): every <collision> of every link as a
// convex object placed on the body of the chain that carries it, and the pairs worth a distance.
// Loading is offline work: it reads files, allocates and calls assimp and qhull.
#pragma once

#include <string>
#include <vector>

#include "core/geometry/shape.hpp"
#include "core/model/model.hpp"

namespace chasles::geometry {

struct GeometryOptions {
  /// Where `package://NAME/rest` is looked for: `<dir>/NAME/rest` in the first dir where that file
  /// exists (ROS's package path, Pinocchio's package_dirs).
  std::vector<std::string> package_dirs;
  /// An SRDF whose <disable_collisions link1 link2/> remove pairs; empty: none (see the pair rule).
  std::string srdf_path;
};

/// Reads the collision geometry of the URDF at `urdf_path`, the one `model` was loaded from.
///
/// Objects: the k-th <collision> of a link (document order, from 0) is the object "<link>/<k>".
/// Links are taken in the URDF's document order. A link on the chain rides on its body at
/// model.links()' T_body_link; a link off it (fingers, a tool link, anything hanging from the chain
/// through fixed joints or movable joints the chain does not include) is carried rigidly by the
/// nearest chain link up the tree, with every joint between at its zero position: a gripper's
/// fingers stand where q = 0 puts them, closed or open as the URDF's zero says.
///
/// Shapes: <box size> (half extents), <cylinder radius length> (axis z), <sphere radius>, Drake's
/// <capsule radius length> (length between the caps' centres), and <mesh filename scale> as the
/// convex hull of its vertices. A mesh is read with assimp (STL, OBJ, DAE, glTF, ...), every node
/// transform applied as coal does, Collada's unit scale too, but not assimp's turn of a Collada
/// file to y-up: the vertices stay in the file's frame, which the URDF places in the link frame.
/// A mesh filename is `package://NAME/rest`, `file:///absolute`, an absolute path, or a path
/// relative to the URDF's folder.
///
/// Pairs (i < j): never two objects on the same body (their distance never changes: an overlap
/// there would read as a collision for ever). With an SRDF, every other pair of objects on
/// different links except those of each <disable_collisions> pair of links. Without one, also not
/// two objects on bodies next to each other on the chain (body b and b + 1, one joint apart), whose
/// meshes usually overlap at the joint, as MoveIt's adjacency rule.
///
/// Throws ModelError naming the file and the link (or element) at fault: XML that does not parse, a
/// link of the model the URDF lacks, a shape without its sizes or with sizes ≤ 0, a mesh that
/// cannot be found, read, holds no vertex, or is flat (no volume: qhull fails), an unknown package,
/// an SRDF that is not XML or names a link the URDF lacks.
CollisionModel load_collision_model(const std::string& urdf_path, const RobotModel& model,
                                    const GeometryOptions& options = {});

/// The convex hull of `points` as a kConvex Shape: only the hull's vertices, each with its hull
/// neighbours. `what` names the points' origin in the error; throws ModelError when the points
/// span no volume (fewer than four, all on a plane, or not finite).
Shape convex_hull(const std::vector<Vector3d>& points, const std::string& what);

/// `dirs`, then the folders of $ROS_PACKAGE_PATH (colon-separated, empty ones skipped): where every
/// tool looks for `package://` meshes, so that a package found by one is found by all.
std::vector<std::string> with_ros_package_path(std::vector<std::string> dirs);

/// The file a mesh reference names, as the URDF loader resolves its <mesh filename>:
/// `package://NAME/rest` (in the first of `package_dirs` that holds it), `file:///absolute`, an
/// absolute path, or a path relative to `base_dir`. Throws ModelError, `what` first, when no such
/// file exists or the package is in none of the dirs. The scene file (scene_file.hpp) reads its
/// meshes through this and mesh_hull, so a mesh means the same thing in a URDF and in a scene.
std::string resolve_mesh_uri(const std::string& uri, const std::string& base_dir,
                             const std::vector<std::string>& package_dirs, const std::string& what);

/// The convex hull of the mesh file at `path` (any format assimp reads; node transforms and
/// Collada's unit applied, its up axis not), each vertex scaled per axis by `scale`. Throws
/// ModelError, `what` first, when the file cannot be read, holds no vertex or spans no volume.
Shape mesh_hull(const std::string& path, const Vector3d& scale, const std::string& what);

}  // namespace chasles::geometry
