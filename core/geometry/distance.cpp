#include "core/geometry/distance.hpp"

#include <array>
#include <cmath>
#include <limits>

namespace chasles::geometry {
namespace {

constexpr int kMaxGjkIterations = 128;
constexpr int kMaxEpaIterations = 128;
constexpr int kMaxEpaVertices = kMaxEpaIterations + 4;
constexpr int kMaxEpaFaces = 2 * kMaxEpaVertices;
// Below this, a length is a point's: the Minkowski difference touches the origin there.
constexpr double kTiny = 1e-14;

double sign_of(double x) { return x < 0.0 ? -1.0 : 1.0; }

// A point of the Minkowski difference of the two cores, w = a − b, with the support points of each
// core that made it (all in a's frame), so that a witness is the same combination of the a's and
// of the b's as the closest point is of the w's.
struct Vertex {
  Vector3d w, a, b;
};

// The two shapes in a's frame: b's pose there is x ↦ R x + p.
struct Pair {
  const Shape& a;
  const Shape& b;
  Matrix3d R;
  Vector3d p;
  int& vertex_a;
  int& vertex_b;

  // The support point of the difference along d.
  Vertex support(const Vector3d& d) const {
    Vertex v;
    v.a = support_of_core(a, d, vertex_a);
    v.b = R * support_of_core(b, -(R.transpose() * d), vertex_b) + p;
    v.w = v.a - v.b;
    return v;
  }
};

// GJK's simplex: up to four vertices and the barycentric weights of its point nearest the origin.
struct Simplex {
  std::array<Vertex, 4> v;
  std::array<double, 4> lambda{};
  int n = 0;

  void keep(std::initializer_list<int> which, std::initializer_list<double> weights) {
    std::array<Vertex, 4> kept;
    int k = 0;
    auto weight = weights.begin();
    for (int i : which) {
      kept[k] = v[i];
      lambda[k] = *weight++;
      ++k;
    }
    for (int i = 0; i < k; ++i) v[i] = kept[i];
    n = k;
  }
  Vector3d point() const {
    Vector3d x = Vector3d::Zero();
    for (int i = 0; i < n; ++i) x += lambda[i] * v[i].w;
    return x;
  }
  void witnesses(Vector3d& a, Vector3d& b) const {
    a.setZero();
    b.setZero();
    for (int i = 0; i < n; ++i) {
      a += lambda[i] * v[i].a;
      b += lambda[i] * v[i].b;
    }
  }
};

// The point of segment v[i]v[j] nearest the origin; the simplex reduced to what it needs.
void nearest_on_segment(Simplex& s, int i, int j) {
  const Vector3d& a = s.v[i].w;
  const Vector3d ab = s.v[j].w - a;
  const double t = -a.dot(ab);
  const double length2 = ab.squaredNorm();
  if (t <= 0.0 || length2 <= kTiny * kTiny) {
    s.keep({i}, {1.0});
  } else if (t >= length2) {
    s.keep({j}, {1.0});
  } else {
    const double u = t / length2;
    s.keep({i, j}, {1.0 - u, u});
  }
}

// The point of triangle v[i]v[j]v[k] nearest the origin, by its Voronoi regions (Ericson,
// Real-Time Collision Detection, 5.1.5).
void nearest_on_triangle(Simplex& s, int i, int j, int k) {
  const Vector3d &a = s.v[i].w, &b = s.v[j].w, &c = s.v[k].w;
  const Vector3d ab = b - a, ac = c - a;
  const double d1 = -ab.dot(a), d2 = -ac.dot(a);
  if (d1 <= 0.0 && d2 <= 0.0) return s.keep({i}, {1.0});
  const double d3 = -ab.dot(b), d4 = -ac.dot(b);
  if (d3 >= 0.0 && d4 <= d3) return s.keep({j}, {1.0});
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double t = d1 / (d1 - d3);
    return s.keep({i, j}, {1.0 - t, t});
  }
  const double d5 = -ab.dot(c), d6 = -ac.dot(c);
  if (d6 >= 0.0 && d5 <= d6) return s.keep({k}, {1.0});
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double t = d2 / (d2 - d6);
    return s.keep({i, k}, {1.0 - t, t});
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return s.keep({j, k}, {1.0 - t, t});
  }
  const double total = va + vb + vc;
  if (std::abs(total) <= kTiny * kTiny) return nearest_on_segment(s, i, j);  // a sliver
  const double v = vb / total, w = vc / total;
  s.keep({i, j, k}, {1.0 - v - w, v, w});
}

// Whether the origin and vertex d lie on opposite sides of the plane through a, b, c.
bool origin_outside(const Vector3d& a, const Vector3d& b, const Vector3d& c, const Vector3d& d) {
  const Vector3d normal = (b - a).cross(c - a);
  const double origin_side = -normal.dot(a), d_side = normal.dot(d - a);
  return origin_side * d_side < 0.0 || std::abs(d_side) <= kTiny * kTiny;
}

// The point of the tetrahedron nearest the origin, false when the origin is inside it (Ericson
// 5.1.6): the nearest of the faces the origin is outside of.
bool nearest_on_tetrahedron(Simplex& s) {
  static constexpr int kFaces[4][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 3, 2, 0}};
  double best = std::numeric_limits<double>::infinity();
  Simplex nearest;
  bool outside = false;
  for (const auto& f : kFaces) {
    if (!origin_outside(s.v[f[0]].w, s.v[f[1]].w, s.v[f[2]].w, s.v[f[3]].w)) continue;
    outside = true;
    Simplex face = s;
    nearest_on_triangle(face, f[0], f[1], f[2]);
    const double d2 = face.point().squaredNorm();
    if (d2 < best) best = d2, nearest = face;
  }
  if (outside) s = nearest;
  return outside;
}

// Reduces the simplex to the smallest face holding its point nearest the origin; false when the
// origin is inside it (a full tetrahedron).
bool reduce(Simplex& s) {
  switch (s.n) {
    case 1:
      s.lambda[0] = 1.0;
      return true;
    case 2:
      nearest_on_segment(s, 0, 1);
      return true;
    case 3:
      nearest_on_triangle(s, 0, 1, 2);
      return true;
    default:
      return nearest_on_tetrahedron(s);
  }
}

struct Face {
  std::array<int, 3> v;
  Vector3d normal;  // outward, unit
  double distance;  // of its plane from the origin
  bool alive;
};

// EPA's polytope: grows toward the surface of the difference from a tetrahedron around the origin.
class Polytope {
 public:
  int vertices = 0, faces = 0;
  std::array<Vertex, kMaxEpaVertices> vertex;
  std::array<Face, kMaxEpaFaces> face;

  bool add_face(int i, int j, int k) {
    if (faces == kMaxEpaFaces) return false;
    Face& f = face[faces++];
    f.v = {i, j, k};
    const Vector3d n = (vertex[j].w - vertex[i].w).cross(vertex[k].w - vertex[i].w);
    const double length = n.norm();
    f.alive = true;
    if (length <= kTiny * kTiny) {  // a sliver: never the nearest, still part of the surface
      f.normal = Vector3d::UnitX();
      f.distance = std::numeric_limits<double>::infinity();
      return true;
    }
    f.normal = n / length;
    f.distance = f.normal.dot(vertex[i].w);
    return true;
  }

  // Replaces the faces w sees with a fan from w to their horizon; false when out of room. The
  // faces seen are found by walking from `seen`, one w certainly sees, across shared edges: on
  // nearly coplanar faces (a box's) a test of each face alone can find two patches, and their
  // fans would not close.
  bool expand(int w, int seen) {
    std::array<int, kMaxEpaFaces> stack;
    std::array<std::array<int, 2>, kMaxEpaFaces + 2> horizon;
    int n_stack = 0, n_horizon = 0;
    face[seen].alive = false;
    stack[n_stack++] = seen;
    while (n_stack > 0) {
      const Face& f = face[stack[--n_stack]];
      for (int e = 0; e < 3; ++e) {
        const int from = f.v[e], to = f.v[(e + 1) % 3];
        const int g = across(to, from);
        if (g < 0) continue;  // already taken into the hole
        if (face[g].normal.dot(vertex[w].w - vertex[face[g].v[0]].w) > 0.0) {
          face[g].alive = false;
          stack[n_stack++] = g;
        } else {
          if (n_horizon == static_cast<int>(horizon.size())) return false;
          horizon[n_horizon++] = {from, to};
        }
      }
    }
    compact();
    for (int k = 0; k < n_horizon; ++k) {
      if (!add_face(horizon[k][0], horizon[k][1], w)) return false;
    }
    return true;
  }

  int nearest() const {
    int best = -1;
    for (int f = 0; f < faces; ++f) {
      if (face[f].alive && (best < 0 || face[f].distance < face[best].distance)) best = f;
    }
    return best;
  }

 private:
  // The live face with the directed edge from → to; −1 when none.
  int across(int from, int to) const {
    for (int f = 0; f < faces; ++f) {
      if (!face[f].alive) continue;
      const auto& v = face[f].v;
      for (int e = 0; e < 3; ++e) {
        if (v[e] == from && v[(e + 1) % 3] == to) return f;
      }
    }
    return -1;
  }

  void compact() {
    int kept = 0;
    for (int f = 0; f < faces; ++f) {
      if (face[f].alive) face[kept++] = face[f];
    }
    faces = kept;
  }
};

// Unit vectors to look for more of the difference along when GJK's simplex holds the origin but is
// flat: the axes, and two more.
Vector3d any_perpendicular(const Vector3d& u) {
  const Vector3d other = std::abs(u.x()) < 0.6 ? Vector3d::UnitX() : Vector3d::UnitY();
  return u.cross(other).normalized();
}

// Grows a simplex that holds the origin into a tetrahedron that does; false when the difference is
// flat (it then has no interior, and the cores touch without overlapping: depth 0).
bool grow_to_tetrahedron(const Pair& pair, Simplex& s) {
  if (s.n == 1) {
    for (int axis = 0; axis < 6; ++axis) {
      const Vertex v = pair.support((axis % 2 == 0 ? 1.0 : -1.0) * Vector3d::Unit(axis / 2));
      if ((v.w - s.v[0].w).norm() > kTiny) {
        s.v[s.n++] = v;
        break;
      }
    }
    if (s.n == 1) return false;
  }
  if (s.n == 2) {
    const Vector3d axis = (s.v[1].w - s.v[0].w).normalized();
    const Vector3d u = any_perpendicular(axis), v = axis.cross(u);
    for (int k = 0; k < 6 && s.n == 2; ++k) {
      const double angle = k * M_PI / 3.0;
      const Vertex candidate = pair.support(std::cos(angle) * u + std::sin(angle) * v);
      if ((candidate.w - s.v[0].w).cross(axis).norm() > kTiny) s.v[s.n++] = candidate;
    }
    if (s.n == 2) return false;
  }
  if (s.n == 3) {
    Vector3d normal = (s.v[1].w - s.v[0].w).cross(s.v[2].w - s.v[0].w);
    if (normal.norm() <= kTiny * kTiny) return false;
    normal.normalize();
    Vertex candidate = pair.support(normal);
    if (std::abs(normal.dot(candidate.w - s.v[0].w)) <= kTiny) candidate = pair.support(-normal);
    if (std::abs(normal.dot(candidate.w - s.v[0].w)) <= kTiny) return false;
    s.v[s.n++] = candidate;
  }
  return true;
}

// The barycentric weights of point x in triangle (a, b, c), x in its plane.
std::array<double, 3> barycentric(const Vector3d& a, const Vector3d& b, const Vector3d& c, const Vector3d& x) {
  const Vector3d v0 = b - a, v1 = c - a, v2 = x - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denominator = d00 * d11 - d01 * d01;
  if (std::abs(denominator) <= kTiny * kTiny) return {1.0, 0.0, 0.0};
  const double v = (d11 * d20 - d01 * d21) / denominator, w = (d00 * d21 - d01 * d20) / denominator;
  return {1.0 - v - w, v, w};
}

// The depth the cores overlap by, from GJK's tetrahedron around the origin; the witnesses and the
// outward normal of the difference's face nearest the origin (a − b moves along it to part them).
double penetration(const Pair& pair, const Simplex& tetrahedron, double tolerance, Vector3d& a, Vector3d& b,
                   Vector3d& normal, int& iterations) {
  Polytope polytope;
  for (int i = 0; i < 4; ++i) polytope.vertex[i] = tetrahedron.v[i];
  polytope.vertices = 4;
  // Faces wound so that their normals point away from the vertex opposite.
  const Vector3d& p0 = polytope.vertex[0].w;
  const bool flip = (polytope.vertex[1].w - p0).cross(polytope.vertex[2].w - p0).dot(polytope.vertex[3].w - p0) > 0.0;
  if (!flip) {
    polytope.add_face(0, 1, 2), polytope.add_face(0, 3, 1), polytope.add_face(0, 2, 3), polytope.add_face(1, 3, 2);
  } else {
    polytope.add_face(0, 2, 1), polytope.add_face(0, 1, 3), polytope.add_face(0, 3, 2), polytope.add_face(1, 2, 3);
  }
  int nearest = polytope.nearest();
  for (int k = 0; k < kMaxEpaIterations && polytope.vertices < kMaxEpaVertices; ++k) {
    ++iterations;
    const Face& f = polytope.face[nearest];
    const Vertex w = pair.support(f.normal);
    if (w.w.dot(f.normal) - f.distance <= tolerance) break;
    polytope.vertex[polytope.vertices] = w;
    if (!polytope.expand(polytope.vertices++, nearest)) break;
    const int next = polytope.nearest();
    if (next < 0) break;
    nearest = next;
  }
  const Face& f = polytope.face[nearest];
  const Vertex &v0 = polytope.vertex[f.v[0]], &v1 = polytope.vertex[f.v[1]], &v2 = polytope.vertex[f.v[2]];
  const auto lambda = barycentric(v0.w, v1.w, v2.w, f.distance * f.normal);
  a = lambda[0] * v0.a + lambda[1] * v1.a + lambda[2] * v2.a;
  b = lambda[0] * v0.b + lambda[1] * v1.b + lambda[2] * v2.b;
  normal = f.normal;
  return f.distance;
}

}  // namespace

double margin_of(const Shape& shape) {
  return shape.kind == ShapeKind::kSphere || shape.kind == ShapeKind::kCapsule ? shape.radius : 0.0;
}

Vector3d support_of_core(const Shape& shape, const Vector3d& d, int& vertex) {
  switch (shape.kind) {
    case ShapeKind::kSphere:
      return Vector3d::Zero();
    case ShapeKind::kCapsule:
      return Vector3d(0.0, 0.0, sign_of(d.z()) * shape.half_length);
    case ShapeKind::kBox:
      return Vector3d(sign_of(d.x()) * shape.half_extents.x(), sign_of(d.y()) * shape.half_extents.y(),
                      sign_of(d.z()) * shape.half_extents.z());
    case ShapeKind::kCylinder: {
      const double radial = std::hypot(d.x(), d.y());
      const double z = sign_of(d.z()) * shape.half_length;
      if (radial <= kTiny) return Vector3d(0.0, 0.0, z);
      return Vector3d(shape.radius * d.x() / radial, shape.radius * d.y() / radial, z);
    }
    case ShapeKind::kConvex:
      break;
  }
  const auto& v = shape.vertices;
  const int count = static_cast<int>(v.size());
  if (vertex < 0 || vertex >= count) vertex = 0;
  double best = v[static_cast<size_t>(vertex)].dot(d);
  if (shape.neighbours.empty()) {
    for (int i = 0; i < count; ++i) {
      const double value = v[static_cast<size_t>(i)].dot(d);
      if (value > best) best = value, vertex = i;
    }
  } else {
    // A vertex of a convex polytope that no neighbour beats is the farthest of all.
    for (bool moved = true; moved;) {
      moved = false;
      for (int next : shape.neighbours[static_cast<size_t>(vertex)]) {
        const double value = v[static_cast<size_t>(next)].dot(d);
        if (value > best) best = value, vertex = next, moved = true;
      }
    }
  }
  return v[static_cast<size_t>(vertex)];
}

Distance signed_distance(const Shape& shape_a, const Transform& T_a, const Shape& shape_b, const Transform& T_b,
                         DistanceCache& cache, double tolerance) {
  const Matrix3d Ra_t = T_a.linear().transpose();
  const Pair pair{shape_a, shape_b, Ra_t * T_b.linear(), Ra_t * (T_b.translation() - T_a.translation()),
                  cache.vertex_a, cache.vertex_b};
  Distance result;
  Simplex s;
  Vector3d direction = cache.direction.squaredNorm() > 0.0 ? cache.direction : Vector3d(-pair.p);
  if (direction.squaredNorm() <= kTiny * kTiny) direction = Vector3d::UnitX();
  s.v[0] = pair.support(-direction);
  s.lambda[0] = 1.0;
  s.n = 1;
  Vector3d v = s.v[0].w;
  bool overlap = false;
  for (int k = 0; k < kMaxGjkIterations; ++k) {
    ++result.iterations;
    const double v2 = v.squaredNorm();
    if (v2 <= kTiny * kTiny) {
      overlap = true;
      break;
    }
    const Vertex w = pair.support(-v);
    // |v| bounds the distance from above and v·w/|v| from below: stop when they meet.
    if (v2 - v.dot(w.w) <= tolerance * std::sqrt(v2)) break;
    bool repeated = false;
    for (int i = 0; i < s.n; ++i) repeated = repeated || (s.v[i].w - w.w).squaredNorm() <= kTiny * kTiny;
    if (repeated) break;
    s.v[s.n++] = w;
    if (!reduce(s)) {
      overlap = true;
      break;
    }
    v = s.point();
  }
  Vector3d p_a, p_b, normal;
  double core = 0.0;
  if (!overlap) {
    s.witnesses(p_a, p_b);
    core = v.norm();
    normal = -v / core;
    cache.direction = v;
  } else if (Simplex grown = s; grown.n == 4 || grow_to_tetrahedron(pair, grown)) {
    core = -penetration(pair, grown, tolerance, p_a, p_b, normal, result.iterations);
    cache.direction = -normal;
  } else {
    // A flat difference holding the origin: the cores touch and cannot overlap.
    s.witnesses(p_a, p_b);
    normal = pair.p.squaredNorm() > 0.0 ? Vector3d(pair.p.normalized()) : Vector3d(Vector3d::UnitX());
  }
  const double margin_a = margin_of(shape_a), margin_b = margin_of(shape_b);
  p_a += margin_a * normal;
  p_b -= margin_b * normal;
  result.distance = core - margin_a - margin_b;
  result.p_a = T_a * p_a;
  result.p_b = T_a * p_b;
  result.normal = T_a.linear() * normal;
  return result;
}

}  // namespace chasles::geometry
