// The signed distance between two convex shapes and the points that realise it: GJK (Gilbert,
// Johnson and Keerthi 1988) while they are apart, EPA (van den Bergen 2001) once they overlap, on
// the shapes' support functions. Spheres and capsules are a point and a segment swollen by their
// radius: the distance is computed between those cores and the radii subtracted, which is exact
// for any convex core (the signed distance to C ⊕ B_r is the signed distance to C less r,
// overlapping or not) and keeps the curved surfaces out of the iterations. Allocates nothing.
#pragma once

#include "core/geometry/shape.hpp"

namespace chasles::geometry {

struct Distance {
  /// > 0: the gap between the shapes; < 0: the depth they overlap by (the shortest translation
  /// that parts them); m.
  double distance = 0.0;
  /// The witness points, in the frame the poses are given in: p_a on shape a and p_b on shape b
  /// with |p_a − p_b| = |distance|; when they overlap, p_a is a's point deepest in b and p_b b's
  /// deepest in a.
  Vector3d p_a = Vector3d::Zero(), p_b = Vector3d::Zero();
  /// The unit direction from a toward b: moving b along it (or a against it) parts them faster
  /// than any other direction.
  Vector3d normal = Vector3d::UnitX();
  int iterations = 0;  ///< GJK's, plus EPA's when they overlap
};

/// Where the last call for a pair of shapes ended, so that the next, at nearby poses, starts
/// there: GJK's last search direction (in a's frame) and each convex hull's last support vertex.
struct DistanceCache {
  Vector3d direction = Vector3d::Zero();
  int vertex_a = 0, vertex_b = 0;
};

/// The support point of `shape` in its own frame: the point of it farthest along `direction`,
/// margins (a sphere's or a capsule's radius) left out. `vertex` is where a convex hull's climb
/// starts, and is left at the vertex found.
Vector3d support_of_core(const Shape& shape, const Vector3d& direction, int& vertex);

/// The radius a shape's core is swollen by: a sphere's and a capsule's; 0 for the others.
double margin_of(const Shape& shape);

/// The signed distance between shape a at pose T_a and shape b at pose T_b (both in one frame),
/// within `tolerance` m: GJK stops when its upper and lower bounds are that close, EPA when its
/// polytope's nearest face is within it of the shape's surface.
Distance signed_distance(const Shape& a, const Transform& T_a, const Shape& b, const Transform& T_b,
                         DistanceCache& cache, double tolerance = 1e-9);

}  // namespace chasles::geometry
