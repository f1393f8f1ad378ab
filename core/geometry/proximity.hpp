// The distances that matter at a tick: the arm against itself, against the scene's obstacles and
// against its safety planes, with their witness points. A Proximity is built once (from the
// collision model and a scene: it allocates); a ProximityData holds a tick's results and is
// computed with no allocation.
//
// Every pair gets a stop distance (what it must never come closer than) and an influence distance
// (from where on its approach is slowed). Only pairs that may be within their influence distance
// are computed exactly: a pair whose bounding spheres are further apart than that is given the
// spheres' gap, a lower bound, and marked inexact. The closest pair is always exact.
#pragma once

#include <string>
#include <vector>

#include "core/geometry/distance.hpp"
#include "core/geometry/shape.hpp"

namespace chasles::geometry {

/// How close a pair may come (m): never below `stop`; slowed from `influence` on.
struct Clearance {
  double stop = 0.01;
  double influence = 0.10;
};

/// A keep-out volume: the table, a wall, the zone where a person stands. Fixed in the arm's base
/// frame.
struct SceneObject {
  std::string name;
  Shape shape;
  Transform T_base_object = Transform::Identity();
  Clearance clearance;
};

/// A safety plane (UR's, for the tool and the elbow; Franka's virtual walls): the bound links keep
/// to the side its normal points to.
struct SafetyPlane {
  std::string name;
  Vector3d normal = Vector3d::UnitZ();  ///< unit, in the base frame, toward the allowed side
  double offset = 0.0;                  ///< the plane is {x : normal · x = offset}, m
  /// The URDF links it binds (their collision objects); empty: every link of the arm.
  std::vector<std::string> links;
  Clearance clearance;
};

/// What surrounds the arm, in its base frame.
struct Scene {
  std::vector<SceneObject> objects;
  std::vector<SafetyPlane> planes;
};

/// A box the given links stay inside (a workspace for the tool): its six faces as planes facing
/// in, named "<name>/+x", "<name>/-x", ... Allocates.
void add_workspace_box(Scene& scene, const std::string& name, const Transform& T_base_box,
                       const Vector3d& half_extents, const std::vector<std::string>& links,
                       const Clearance& clearance);

/// Removes from `arm` the self pairs closer than `distance` (m) at the body poses `T_body` — those
/// in contact in the arm's zero configuration, as MoveIt's setup assistant disables its "default"
/// collisions: pairs whose meshes overlap where the arm was drawn overlap by design (an iiwa's
/// link 5 cylinder inside its link 7 hull), and a pair the arm starts inside could never be left.
/// Returns the pairs removed, "<object> and <object>". Allocates.
std::vector<std::string> drop_pairs_closer_than(CollisionModel& arm, const std::vector<Transform>& T_body,
                                                double distance);

/// One distance the tick watches.
struct ProximityPair {
  enum Kind { kSelf, kObject, kPlane };
  Kind kind = kSelf;
  int arm = 0;    ///< the arm's object (CollisionModel::objects); for kSelf the first of the two
  int other = 0;  ///< kSelf: the arm's second object; kObject: Scene::objects; kPlane: Scene::planes
  Clearance clearance;
};

struct ProximityOptions {
  Clearance self{0.005, 0.05};  ///< between two objects of the arm
};

/// The pairs a tick computes, built once from the arm's collision model and a scene. Immutable.
class Proximity {
 public:
  /// The self pairs of `arm` (its CollisionModel::pairs, clearance options.self), then every arm
  /// object against every scene object, then against every plane, each object only against the
  /// planes that bind its link. Throws ModelError when a plane names a link no object is on, a
  /// plane's normal is not unit length or a clearance is not 0 ≤ stop < influence.
  Proximity(CollisionModel arm, Scene scene, const ProximityOptions& options = {});

  const CollisionModel& arm() const { return arm_; }
  const Scene& scene() const { return scene_; }
  const std::vector<ProximityPair>& pairs() const { return pairs_; }
  /// "<arm object> and <other>" for pair p, into `out` (at most size − 1 characters). Allocates
  /// nothing.
  void name_pair(int p, char* out, int size) const;

  /// Each object's bounding sphere in its own frame (bounding_sphere): the arm's and the scene's.
  const std::vector<Vector3d>& arm_centres() const { return arm_centre_; }
  const std::vector<double>& arm_radii() const { return arm_radius_; }
  const std::vector<Vector3d>& scene_centres() const { return scene_centre_; }
  const std::vector<double>& scene_radii() const { return scene_radius_; }

 private:
  CollisionModel arm_;
  Scene scene_;
  std::vector<ProximityPair> pairs_;
  std::vector<Vector3d> arm_centre_, scene_centre_;
  std::vector<double> arm_radius_, scene_radius_;
};

/// One pair's distance at a tick, in the base frame.
struct PairDistance {
  /// Signed (< 0: overlapping by that depth), m. When not exact, a lower bound beyond the pair's
  /// influence distance.
  double distance = 0.0;
  Vector3d p_arm = Vector3d::Zero();    ///< the witness on the arm's object
  Vector3d p_other = Vector3d::Zero();  ///< the witness on the other (object, obstacle or plane)
  Vector3d normal = Vector3d::UnitX();  ///< unit, from the arm's object toward the other
  bool exact = false;
};

/// A tick's distances: sized for one Proximity.
struct ProximityData {
  explicit ProximityData(const Proximity& proximity);
  std::vector<Transform> T_object;    ///< the arm's objects in the base frame
  std::vector<DistanceCache> cache;   ///< per pair, where its last GJK ended
  std::vector<PairDistance> distance; ///< per pair
  int closest = -1;                   ///< the pair with the least distance (exact), −1 with no pair
  int exact = 0;                      ///< how many pairs were computed exactly
};

/// The distances at the body poses `T_body` (Data::T_body: T_body[i] the pose of body i in the
/// base frame). Allocates nothing.
void compute_distances(const Proximity& proximity, const std::vector<Transform>& T_body, ProximityData& data);

/// Pair p's distance computed exactly if compute_distances left it a bound, at the poses it used.
/// Allocates nothing.
void compute_exactly(const Proximity& proximity, ProximityData& data, int p);

/// The bounding sphere of a shape in its frame (not the least one: the centre of its box of
/// extents, and the farthest point from it).
void bounding_sphere(const Shape& shape, Vector3d& centre, double& radius);

}  // namespace chasles::geometry
