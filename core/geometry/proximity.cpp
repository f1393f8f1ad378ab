#include "core/geometry/proximity.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/error.hpp"

namespace chasles::geometry {
namespace {

void check_clearance(const Clearance& c, const std::string& what) {
  if (!(std::isfinite(c.stop) && std::isfinite(c.influence) && c.stop >= 0.0 && c.stop < c.influence)) {
    throw ArgumentError(what + ": a clearance needs 0 ≤ stop < influence (m), not stop " + std::to_string(c.stop) +
                        ", influence " + std::to_string(c.influence));
  }
}

// The distance from an object to the forbidden side of a plane: how far its lowest point along
// the normal stands above the plane.
PairDistance plane_distance(const Shape& shape, const Transform& T, const SafetyPlane& plane, DistanceCache& cache) {
  const Vector3d& n = plane.normal;
  PairDistance d;
  d.p_arm = T * support_of_core(shape, -(T.linear().transpose() * n), cache.vertex_a) - margin_of(shape) * n;
  d.distance = n.dot(d.p_arm) - plane.offset;
  d.p_other = d.p_arm - d.distance * n;
  d.normal = -n;
  d.exact = true;
  return d;
}

PairDistance exact_distance(const Shape& a, const Transform& T_a, const Shape& b, const Transform& T_b,
                            DistanceCache& cache) {
  const Distance d = signed_distance(a, T_a, b, T_b, cache);
  return {d.distance, d.p_a, d.p_b, d.normal, true};
}

// The gap between two bounding spheres: a lower bound on the distance of what they hold.
PairDistance sphere_gap(const Vector3d& c_a, double r_a, const Vector3d& c_b, double r_b) {
  PairDistance d;
  const Vector3d between = c_b - c_a;
  const double length = between.norm();
  d.normal = length > 0.0 ? Vector3d(between / length) : Vector3d(Vector3d::UnitX());
  d.distance = length - r_a - r_b;
  d.p_arm = c_a + r_a * d.normal;
  d.p_other = c_b - r_b * d.normal;
  d.exact = false;
  return d;
}

// A lower bound on the distance from a ball (centre c, radius r, in the base frame) to a scene
// object: the distance from c to it, less r. For a box and a cylinder that distance is exact and
// cheap, where the object's own bounding sphere would be as large as a table or a wall and cull
// nothing; other shapes fall back to their bounding sphere.
PairDistance ball_to_object(const Vector3d& c, double r, const Shape& b, const Transform& T_b,
                            const Vector3d& b_centre, double b_radius) {
  const Vector3d q = T_b.linear().transpose() * (c - T_b.translation());
  Vector3d nearest;
  switch (b.kind) {
    case ShapeKind::kBox:
      nearest = q.cwiseMax(-b.half_extents).cwiseMin(b.half_extents);
      break;
    case ShapeKind::kCylinder: {
      const double radial = std::hypot(q.x(), q.y());
      const double scale = radial > b.radius ? b.radius / radial : 1.0;
      nearest = Vector3d(q.x() * scale, q.y() * scale, std::clamp(q.z(), -b.half_length, b.half_length));
      break;
    }
    default:
      return sphere_gap(c, r, T_b * b_centre, b_radius);
  }
  PairDistance d;
  const Vector3d between = T_b.linear() * (nearest - q);
  const double length = between.norm();
  d.normal = length > 0.0 ? Vector3d(between / length) : Vector3d(Vector3d::UnitX());
  d.distance = length - r;
  d.p_arm = c + r * d.normal;
  d.p_other = c + between;
  d.exact = false;
  return d;
}

}  // namespace

void bounding_sphere(const Shape& shape, Vector3d& centre, double& radius) {
  centre.setZero();
  switch (shape.kind) {
    case ShapeKind::kSphere:
      radius = shape.radius;
      return;
    case ShapeKind::kBox:
      radius = shape.half_extents.norm();
      return;
    case ShapeKind::kCylinder:
      radius = std::hypot(shape.radius, shape.half_length);
      return;
    case ShapeKind::kCapsule:
      radius = shape.radius + shape.half_length;
      return;
    case ShapeKind::kConvex:
      break;
  }
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Vector3d& v : shape.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  centre = 0.5 * (lo + hi);
  radius = 0.0;
  for (const Vector3d& v : shape.vertices) radius = std::max(radius, (v - centre).norm());
}

void add_workspace_box(Scene& scene, const std::string& name, const Transform& T_base_box,
                       const Vector3d& half_extents, const std::vector<std::string>& links,
                       const Clearance& clearance) {
  static const char* const kFaces[3][2] = {{"+x", "-x"}, {"+y", "-y"}, {"+z", "-z"}};
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const double sign = side == 0 ? 1.0 : -1.0;
      const Vector3d outward = sign * T_base_box.linear().col(axis);
      const Vector3d face = T_base_box * Vector3d(sign * half_extents[axis] * Vector3d::Unit(axis));
      // The allowed side is the inside: the normal points in, from the face toward the centre.
      scene.planes.push_back({name + "/" + kFaces[axis][side], -outward, -outward.dot(face), links, clearance});
    }
  }
}

std::vector<std::string> drop_pairs_closer_than(CollisionModel& arm, const std::vector<Transform>& T_body,
                                                double distance) {
  std::vector<std::string> dropped;
  std::vector<std::pair<int, int>> kept;
  for (const auto& [a, b] : arm.pairs) {
    const CollisionObject &A = arm.objects[static_cast<size_t>(a)], &B = arm.objects[static_cast<size_t>(b)];
    DistanceCache cache;
    const double d = signed_distance(A.shape, T_body[static_cast<size_t>(A.body)] * A.T_body_object, B.shape,
                                     T_body[static_cast<size_t>(B.body)] * B.T_body_object, cache)
                         .distance;
    if (d < distance) {
      dropped.push_back(A.name + " and " + B.name);
    } else {
      kept.emplace_back(a, b);
    }
  }
  arm.pairs = std::move(kept);
  return dropped;
}

Proximity::Proximity(CollisionModel arm, Scene scene, const ProximityOptions& options)
    : arm_(std::move(arm)), scene_(std::move(scene)) {
  check_clearance(options.self, "the arm against itself");
  for (const auto& [a, b] : arm_.pairs) pairs_.push_back({ProximityPair::kSelf, a, b, options.self});
  const int objects = static_cast<int>(arm_.objects.size());
  for (int k = 0; k < static_cast<int>(scene_.objects.size()); ++k) {
    check_clearance(scene_.objects[k].clearance, "scene object " + scene_.objects[k].name);
    for (int a = 0; a < objects; ++a) pairs_.push_back({ProximityPair::kObject, a, k, scene_.objects[k].clearance});
  }
  for (int k = 0; k < static_cast<int>(scene_.planes.size()); ++k) {
    const SafetyPlane& plane = scene_.planes[k];
    check_clearance(plane.clearance, "plane " + plane.name);
    if (!plane.normal.allFinite() || std::abs(plane.normal.norm() - 1.0) > 1e-9 || !std::isfinite(plane.offset)) {
      throw ArgumentError("plane " + plane.name + ": its normal must be a unit vector and its offset finite");
    }
    for (const std::string& link : plane.links) {
      if (std::none_of(arm_.objects.begin(), arm_.objects.end(), [&](const auto& o) { return o.link == link; })) {
        throw ArgumentError("plane " + plane.name + ": no collision object is on link " + link);
      }
    }
    for (int a = 0; a < objects; ++a) {
      const auto& links = plane.links;
      if (links.empty() || std::find(links.begin(), links.end(), arm_.objects[a].link) != links.end()) {
        pairs_.push_back({ProximityPair::kPlane, a, k, plane.clearance});
      }
    }
  }
  arm_centre_.resize(arm_.objects.size());
  arm_radius_.resize(arm_.objects.size());
  for (size_t k = 0; k < arm_.objects.size(); ++k) bounding_sphere(arm_.objects[k].shape, arm_centre_[k], arm_radius_[k]);
  scene_centre_.resize(scene_.objects.size());
  scene_radius_.resize(scene_.objects.size());
  for (size_t k = 0; k < scene_.objects.size(); ++k) {
    bounding_sphere(scene_.objects[k].shape, scene_centre_[k], scene_radius_[k]);
  }
}

void Proximity::name_pair(int p, char* out, int size) const {
  const ProximityPair& pair = pairs_[static_cast<size_t>(p)];
  const std::string& other = pair.kind == ProximityPair::kSelf     ? arm_.objects[pair.other].name
                             : pair.kind == ProximityPair::kObject ? scene_.objects[pair.other].name
                                                                   : scene_.planes[pair.other].name;
  std::snprintf(out, static_cast<size_t>(size), "%s and %s", arm_.objects[pair.arm].name.c_str(), other.c_str());
}

ProximityData::ProximityData(const Proximity& proximity)
    : T_object(proximity.arm().objects.size()),
      cache(proximity.pairs().size()),
      distance(proximity.pairs().size()) {}

// Pair p's distance at the object poses in `data`: exact, or the bound alone when `cull` and the
// bound puts it beyond its influence.
static PairDistance pair_distance(const Proximity& proximity, ProximityData& data, size_t p, bool cull) {
  const auto& objects = proximity.arm().objects;
  const auto& pairs = proximity.pairs();
  const auto& scene = proximity.scene();
    const ProximityPair& pair = pairs[p];
  const CollisionObject& a = objects[static_cast<size_t>(pair.arm)];
  const Transform& T_a = data.T_object[static_cast<size_t>(pair.arm)];
  if (pair.kind == ProximityPair::kPlane) {
    return plane_distance(a.shape, T_a, scene.planes[static_cast<size_t>(pair.other)], data.cache[p]);
  }
  const bool self = pair.kind == ProximityPair::kSelf;
  const size_t o = static_cast<size_t>(pair.other);
  const Shape& b = self ? objects[o].shape : scene.objects[o].shape;
  const Transform& T_b = self ? data.T_object[o] : scene.objects[o].T_base_object;
  if (cull && !self) {
    const PairDistance bound = ball_to_object(T_a * proximity.arm_centres()[static_cast<size_t>(pair.arm)],
                                              proximity.arm_radii()[static_cast<size_t>(pair.arm)], b, T_b,
                                              proximity.scene_centres()[o], proximity.scene_radii()[o]);
    if (bound.distance > pair.clearance.influence) return bound;
  } else if (cull) {
    const PairDistance bound = sphere_gap(
        T_a * proximity.arm_centres()[static_cast<size_t>(pair.arm)], proximity.arm_radii()[static_cast<size_t>(pair.arm)],
        T_b * (self ? proximity.arm_centres()[o] : proximity.scene_centres()[o]),
        self ? proximity.arm_radii()[o] : proximity.scene_radii()[o]);
    if (bound.distance > pair.clearance.influence) return bound;
  }
  return exact_distance(a.shape, T_a, b, T_b, data.cache[p]);
}

void compute_distances(const Proximity& proximity, const std::vector<Transform>& T_body, ProximityData& data) {
  const auto& objects = proximity.arm().objects;
  for (size_t k = 0; k < objects.size(); ++k) {
    data.T_object[k] = T_body[static_cast<size_t>(objects[k].body)] * objects[k].T_body_object;
  }
  const auto& pairs = proximity.pairs();
  data.exact = 0;
  data.closest = -1;
  for (size_t p = 0; p < pairs.size(); ++p) {
    data.distance[p] = pair_distance(proximity, data, p, true);
    data.exact += data.distance[p].exact ? 1 : 0;
  }
  // The closest pair exact: a bound that is least may hide a pair further than another's exact.
  for (;;) {
    double least = std::numeric_limits<double>::infinity();
    for (size_t p = 0; p < pairs.size(); ++p) {
      if (data.distance[p].distance < least) least = data.distance[p].distance, data.closest = static_cast<int>(p);
    }
    if (data.closest < 0 || data.distance[static_cast<size_t>(data.closest)].exact) return;
    data.distance[static_cast<size_t>(data.closest)] = pair_distance(proximity, data, static_cast<size_t>(data.closest), false);
    ++data.exact;
  }
}

void compute_exactly(const Proximity& proximity, ProximityData& data, int p) {
  PairDistance& d = data.distance[static_cast<size_t>(p)];
  if (d.exact) return;
  d = pair_distance(proximity, data, static_cast<size_t>(p), false);
  ++data.exact;
}

}  // namespace chasles::geometry
