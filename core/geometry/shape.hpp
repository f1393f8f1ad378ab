// The arm's shape and its surroundings as convex pieces: what distances are computed between.
// Every shape is convex and centred on its own frame; a mesh stands for its convex hull. Sizes in
// m. A shape is described by its support function (the point of it farthest along a direction),
// which is all GJK and EPA need (core/geometry/distance.hpp).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/lie/types.hpp"

namespace chasles::geometry {

enum class ShapeKind {
  kSphere,    ///< radius
  kBox,       ///< half_extents along x, y, z
  kCylinder,  ///< radius, half_length along z (URDF's cylinder: its axis is z, centred)
  kCapsule,   ///< radius, half_length of the segment along z (the caps' centres at ±half_length)
  kConvex,    ///< the convex hull of vertices (a mesh's, scaled)
};

struct Shape {
  ShapeKind kind = ShapeKind::kSphere;
  double radius = 0.0;
  double half_length = 0.0;
  Vector3d half_extents = Vector3d::Zero();
  /// kConvex: the hull's vertices (only those on the hull), in the shape's frame.
  std::vector<Vector3d> vertices;
  /// kConvex: for each vertex, the vertices it shares a hull edge with, so that the support
  /// point is found by climbing from the last one instead of scanning every vertex.
  std::vector<std::vector<int>> neighbours;
};

/// One convex piece of the arm, rigidly on one body of the chain.
struct CollisionObject {
  std::string name;  ///< "<link>/<k>": the k-th <collision> of that link in the URDF, from 0
  std::string link;  ///< the URDF link it belongs to (on the chain, or rigidly carried by it)
  int body = 0;      ///< the body it rides on: 0 the fixed base, i the child of joint i
  Transform T_body_object = Transform::Identity();  ///< its frame in the body's frame
  Shape shape;
};

/// The arm's collision geometry and the pairs of its objects whose distance matters (i < j).
struct CollisionModel {
  std::vector<CollisionObject> objects;
  std::vector<std::pair<int, int>> pairs;
};

}  // namespace chasles::geometry
