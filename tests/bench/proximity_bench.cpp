// chasles_coal_bench: the distances a control tick watches, chasles::geometry against Pinocchio +
// coal (pinocchio::computeDistances), on the same shapes, the same pairs and the same
// configurations, in one run.
//
// The target: the Panda's self pairs plus a 6-object scene, p99 ≤ 20 µs per tick on a
// moving path, at most 0.3 of Pinocchio + coal's time, and no allocation in the tick. This binary
// prints, for two sequences of configurations, per-call times (p50, p99, max in µs, one
// steady_clock reading either side of each call) of
//   - chasles culled: forward_kinematics (every body pose) + compute_distances (the object poses,
//     bounding-sphere culling of pairs beyond their influence distance, the closest exact), as the
//     tick calls it;
//   - chasles exact: forward_kinematics + every object pose + signed_distance on every pair, each
//     with its warm-start cache: the like-for-like with coal, which computes every pair;
//   - Pinocchio + coal: updateGeometryPlacements(model, data, geom, gdata, q) (forwardKinematics
//     and every object pose) + computeDistances(geom, gdata), which is exactly what
//     computeDistances(model, data, geom, gdata, q) does, split in two calls so that the pose
//     update and the distances can also be read apart; coal at Pinocchio's defaults (its GJK and
//     EPA tolerances 1e-6, no warm start: GeometryData's DistanceRequest(true)).
// Each total includes the pose update; the "distances" column is the same call less it (a third
// steady_clock reading between the two). The three are called on each configuration, in an order
// that rotates from one configuration to the next, so that the machine's load hits all three.
//
// The sequences: "moving", 20,000 configurations 1 ms apart on a smooth path (a sum of sinusoids
// about the Panda's ready pose, within the joint limits) that stays clear of the scene and of
// itself (checked here, all pairs exact; the seed is the first of a fixed list whose path is
// clear), and "random", 20,000 independent uniform configurations within the limits, with
// penetrations (self and scene).
//
// On the way it checks that both libraries compute the same: every pair's distance from chasles
// exact and from coal, and chasles culled's exact pairs against coal, within 1e-5 m (the largest
// difference and the count beyond are printed; beyond 1 mm it stops with an error), and that every
// culled pair's bound is below coal's distance. And it counts each computation's heap allocations
// over the timed calls (malloc, and operator new through it, interposed as
// tests/support/allocation_counter.cpp does).
//
// `chasles_coal_bench --breakdown` times nothing side by side: it takes compute_distances apart on
// both sequences (each exact pair timed alone, by class and the ten costliest, the same pairs at
// coal's tolerance, whether the slowest calls are slow again when repeated) and times one support
// point of the largest mesh hull, cold, warm and by a scan: where the tick's time goes.
//
// The models, both from the same files. chasles: load_urdf_file (tip panda_hand) and
// load_collision_model (the URDF's <collision> elements, meshes as their qhull hulls, the pairs
// the SRDF leaves). Pinocchio: its Model built from chasles's RobotModel as chasles_pinocchio_bench
// builds it (one joint per movable joint, its URDF origin as placement, the specialised
// JointModelRZ), and its GeometryModel from chasles's CollisionModel: one GeometryObject per
// object, on its body's joint at the object's placement, as coal::Box, Sphere, Cylinder, Capsule
// or, for a mesh, coal::ConvexBase::convexHull(vertices, true, "Qt"), the hull
// tools/reference/coal_distances.py builds from the mesh with BVHModel::buildConvexHull(true,
// "Qt"); here qhull gets the mesh's hull vertices, which gives the same hull. Pinocchio's
// buildGeomFromUrdf is not used: it lives in the wheel's compiled libpinocchio_parsers, linked
// against the wheel's urdfdom 6 and assimp 6, which define the same symbols as Debian's urdfdom 3
// and assimp 5 that chasles links, in the same process. What buildGeomFromUrdf + the SRDF's
// removeCollisionPairs + buildConvexHull give instead is checked against their record in
// tests/data/collision/panda.json (written by that script from pip Pinocchio): the same objects by
// name and kind, the same number of hull vertices per mesh, the same 44 pairs. The object poses of
// both are compared at the first configuration.
#include <pinocchio/algorithm/geometry.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/collision/distance.hpp>
#include <pinocchio/config.hpp>
#include <pinocchio/multibody.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <coal/config.hh>
#include <coal/shape/geometric_shapes.h>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry/collision_model.hpp"
#include "core/geometry/distance.hpp"
#include "core/geometry/proximity.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"


namespace {

using namespace chasles;
using namespace chasles::geometry;
using Clock = std::chrono::steady_clock;

constexpr int kConfigurations = 20000;  // per sequence
constexpr int kWarmUp = 500;            // untimed calls of each before a sequence
constexpr double kAgree = 1e-5;         // m: chasles and coal on one pair
constexpr double kGross = 1e-3;         // m: beyond this the run stops: not the same computation
constexpr double kPeriod = 1e-3;        // s: the moving path's step (1 kHz)

const std::string kData = CHASLES_BENCH_DATA;

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "chasles_coal_bench: %s\n", message.c_str());
  std::exit(1);
}

// --- the scene --------------------------------------------------------------------------------------

Transform pose(const Vector3d& p, const Matrix3d& R = Matrix3d::Identity()) {
  Transform T = Transform::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

Shape box(double x, double y, double z) {
  Shape s;
  s.kind = ShapeKind::kBox;
  s.half_extents = Vector3d(x, y, z);
  return s;
}

// Points on an ellipsoid with semi-axes (a, b, c), from a fixed seed: a hull like a part on the
// table.
std::vector<Vector3d> ellipsoid_points(double a, double b, double c, int n) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  std::vector<Vector3d> points;
  for (int k = 0; k < n; ++k) {
    Vector3d u(normal(rng), normal(rng), normal(rng));
    u.normalize();
    points.emplace_back(a * u.x(), b * u.y(), c * u.z());
  }
  return points;
}

// Six obstacles around a Panda on a table (the base frame: z up, x forward), some of them within
// 10 cm of the arm on the moving path: the table top, a wall behind, a ball and a post either side
// of the workspace, a bar overhead in front, and a part on the table (a convex hull).
Scene make_scene() {
  Scene scene;
  const Clearance clearance{0.01, 0.10};  // stop, influence (m)
  scene.objects.push_back({"table", box(0.6, 0.8, 0.02), pose({0.3, 0.0, -0.025}), clearance});
  scene.objects.push_back({"wall", box(0.02, 0.8, 0.6), pose({-0.45, 0.0, 0.5}), clearance});
  Shape sphere;
  sphere.kind = ShapeKind::kSphere;
  sphere.radius = 0.08;
  scene.objects.push_back({"ball", sphere, pose({0.45, 0.45, 0.35}), clearance});
  Shape cylinder;
  cylinder.kind = ShapeKind::kCylinder;
  cylinder.radius = 0.04;
  cylinder.half_length = 0.3;
  scene.objects.push_back({"post", cylinder, pose({0.45, -0.45, 0.3}), clearance});
  Shape capsule;
  capsule.kind = ShapeKind::kCapsule;
  capsule.radius = 0.03;
  capsule.half_length = 0.25;
  // Horizontal, along y.
  scene.objects.push_back(
      {"bar", capsule, pose({0.75, 0.0, 0.75}, Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()).toRotationMatrix()),
       clearance});
  scene.objects.push_back(
      {"part", convex_hull(ellipsoid_points(0.08, 0.05, 0.04, 40), "the part"), pose({0.6, 0.0, 0.045}), clearance});
  return scene;
}

// --- Pinocchio's side -----------------------------------------------------------------------------

pinocchio::SE3 to_se3(const Transform& T) { return pinocchio::SE3(T.linear(), T.translation()); }

// The joint model Pinocchio's URDF parser would pick (as in pinocchio_bench.cpp).
pinocchio::JointModel joint_model(const Joint& joint) {
  const Vector3d& a = joint.axis;
  const bool prismatic = joint.type == JointType::Prismatic;
  for (int k = 0; k < 3; ++k) {
    if (a == Vector3d::Unit(k)) {
      if (prismatic) {
        if (k == 0) return pinocchio::JointModelPX();
        if (k == 1) return pinocchio::JointModelPY();
        return pinocchio::JointModelPZ();
      }
      if (k == 0) return pinocchio::JointModelRX();
      if (k == 1) return pinocchio::JointModelRY();
      return pinocchio::JointModelRZ();
    }
  }
  if (prismatic) return pinocchio::JointModelPrismaticUnaligned(a);
  return pinocchio::JointModelRevoluteUnaligned(a);
}

// coal's shape for one of ours. A hull is qhull's ("Qt", triangles kept), as the reference
// script's buildConvexHull(True, "Qt").
std::shared_ptr<coal::CollisionGeometry> coal_shape(const Shape& s) {
  switch (s.kind) {
    case ShapeKind::kSphere:
      return std::make_shared<coal::Sphere>(s.radius);
    case ShapeKind::kBox:
      return std::make_shared<coal::Box>(2.0 * s.half_extents);
    case ShapeKind::kCylinder:
      return std::make_shared<coal::Cylinder>(s.radius, 2.0 * s.half_length);
    case ShapeKind::kCapsule:
      return std::make_shared<coal::Capsule>(s.radius, 2.0 * s.half_length);
    case ShapeKind::kConvex:
      break;
  }
  auto points = std::make_shared<std::vector<coal::Vec3s>>(s.vertices.begin(), s.vertices.end());
  return std::shared_ptr<coal::CollisionGeometry>(
      coal::ConvexBase::convexHull(points, static_cast<unsigned>(points->size()), true, "Qt"));
}

struct Pin {
  pinocchio::Model model;
  std::unique_ptr<pinocchio::Data> data;
  pinocchio::GeometryModel geom;
  std::unique_ptr<pinocchio::GeometryData> gdata;
};

// Pinocchio's models of the arm and the scene, with one collision pair per pair of `proximity`, in
// its order (pair p of both is the same two objects).
void build_pinocchio(const RobotModel& model, const Proximity& proximity, Pin& pin) {
  pinocchio::JointIndex parent = 0;  // the universe
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    parent = pin.model.addJoint(parent, joint_model(joint), to_se3(joint.T_parent_joint), joint.name);
  }
  const auto& objects = proximity.arm().objects;
  // chasles's body i is Pinocchio's joint i (body 0, the base, the universe), its frame the joint's.
  for (const CollisionObject& o : objects) {
    pin.geom.addGeometryObject(pinocchio::GeometryObject(o.name, static_cast<pinocchio::JointIndex>(o.body),
                                                         to_se3(o.T_body_object), coal_shape(o.shape)));
  }
  const auto& scene = proximity.scene().objects;
  for (const SceneObject& o : scene) {
    pin.geom.addGeometryObject(pinocchio::GeometryObject(o.name, 0, to_se3(o.T_base_object), coal_shape(o.shape)));
  }
  for (const ProximityPair& p : proximity.pairs()) {
    const auto other = p.kind == ProximityPair::kSelf ? p.other : static_cast<int>(objects.size()) + p.other;
    pin.geom.addCollisionPair(pinocchio::CollisionPair(static_cast<pinocchio::GeomIndex>(p.arm),
                                                       static_cast<pinocchio::GeomIndex>(other)));
  }
  pin.data = std::make_unique<pinocchio::Data>(pin.model);
  pin.gdata = std::make_unique<pinocchio::GeometryData>(pin.geom);  // after the shapes: its functors hold them
}

// The record of what pip Pinocchio's buildGeomFromUrdf + removeCollisionPairs + buildConvexHull made
// of the Panda (tests/data/collision/panda.json): the same objects, hulls and pairs as here.
void check_against_record(const CollisionModel& arm, const pinocchio::GeometryModel& geom) {
  std::ifstream file(kData + "/collision/panda.json");
  std::stringstream text;
  text << file.rdbuf();
  const nlohmann::json record = nlohmann::json::parse(text.str());
  const auto& objects = record["objects"];
  if (objects.size() != arm.objects.size()) fail("not the recorded number of objects");
  static const char* const kKinds[] = {"sphere", "box", "cylinder", "capsule", "convex"};
  for (size_t k = 0; k < objects.size(); ++k) {
    const CollisionObject& o = arm.objects[k];
    if (objects[k]["name"] != o.name || objects[k]["type"] != kKinds[static_cast<int>(o.shape.kind)]) {
      fail("object " + o.name + " is not the recorded " + objects[k]["name"].get<std::string>());
    }
    if (o.shape.kind != ShapeKind::kConvex) continue;
    const auto* hull = dynamic_cast<const coal::ConvexBase*>(geom.geometryObjects[k].geometry.get());
    const unsigned recorded = objects[k]["hull_vertices"];
    if (!hull || hull->num_points != recorded || o.shape.vertices.size() != recorded) {
      fail(o.name + ": a hull of " + std::to_string(hull ? hull->num_points : 0) + " (coal) and " +
           std::to_string(o.shape.vertices.size()) + " (chasles) vertices; the record has " + std::to_string(recorded));
    }
  }
  std::set<std::pair<int, int>> recorded, ours(arm.pairs.begin(), arm.pairs.end());
  for (const auto& p : record["pairs"]) recorded.insert(std::minmax(p[0].get<int>(), p[1].get<int>()));
  if (recorded != ours) fail("not the recorded pairs");
}

// --- the three computations, each one real call ---------------------------------------------------

// Every pair exact, as compute_distances computes its exact ones: the like-for-like with coal.
struct ExactData {
  explicit ExactData(const Proximity& proximity)
      : T_object(proximity.arm().objects.size()), cache(proximity.pairs().size()), distance(proximity.pairs().size()) {}
  std::vector<Transform> T_object;
  std::vector<DistanceCache> cache;
  std::vector<double> distance;
};

__attribute__((noinline)) void chasles_poses(const RobotModel& model, Data& data, const Eigen::VectorXd& q) {
  forward_kinematics(model, data, q);
}

__attribute__((noinline)) void chasles_culled(const Proximity& proximity, const Data& data, ProximityData& out) {
  compute_distances(proximity, data.T_body, out);
}

__attribute__((noinline)) void chasles_exact(const Proximity& proximity, const Data& data, ExactData& out) {
  const auto& objects = proximity.arm().objects;
  for (size_t k = 0; k < objects.size(); ++k) {
    out.T_object[k] = data.T_body[static_cast<size_t>(objects[k].body)] * objects[k].T_body_object;
  }
  const auto& scene = proximity.scene().objects;
  const auto& pairs = proximity.pairs();
  for (size_t p = 0; p < pairs.size(); ++p) {
    const ProximityPair& pair = pairs[p];
    const size_t a = static_cast<size_t>(pair.arm), o = static_cast<size_t>(pair.other);
    const bool self = pair.kind == ProximityPair::kSelf;
    out.distance[p] = signed_distance(objects[a].shape, out.T_object[a], self ? objects[o].shape : scene[o].shape,
                                      self ? out.T_object[o] : scene[o].T_base_object, out.cache[p])
                          .distance;
  }
}

__attribute__((noinline)) void pin_poses(Pin& pin, const Eigen::VectorXd& q) {
  pinocchio::updateGeometryPlacements(pin.model, *pin.data, pin.geom, *pin.gdata, q);
}

__attribute__((noinline)) std::size_t pin_distances(Pin& pin) { return pinocchio::computeDistances(pin.geom, *pin.gdata); }

// --- the sequences --------------------------------------------------------------------------------

Eigen::VectorXd ready_pose() {
  Eigen::VectorXd q(7);
  q << 0.0, -M_PI / 4, 0.0, -3 * M_PI / 4, 0.0, M_PI / 2, M_PI / 4;
  return q;
}

// A smooth path 1 ms a step: each joint the ready pose plus three sinusoids (0.05–0.4 Hz), within
// 90 % of the way to its nearer limit and at most 0.9 rad from the ready pose.
std::vector<Eigen::VectorXd> sinusoid_path(const RobotModel& model, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Eigen::VectorXd centre = ready_pose();
  const int n = model.dof();
  std::vector<std::array<double, 9>> terms(static_cast<size_t>(n));  // (amplitude, ω, phase) × 3
  for (int i = 0; i < n; ++i) {
    const JointLimits& l = model.joint(i).limits;
    const double room = std::min({0.9 * (l.upper - centre(i)), 0.9 * (centre(i) - l.lower), 0.9});
    double weights[3], total = 0.0;
    for (double& w : weights) total += (w = 0.2 + unit(rng));
    for (int k = 0; k < 3; ++k) {
      terms[i][3 * k] = room * weights[k] / total;
      terms[i][3 * k + 1] = 2 * M_PI * (0.05 + 0.35 * unit(rng));
      terms[i][3 * k + 2] = 2 * M_PI * unit(rng);
    }
  }
  std::vector<Eigen::VectorXd> path(kConfigurations, centre);
  for (int c = 0; c < kConfigurations; ++c) {
    const double t = c * kPeriod;
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) path[c](i) += terms[i][3 * k] * std::sin(terms[i][3 * k + 1] * t + terms[i][3 * k + 2]);
    }
  }
  return path;
}

std::vector<Eigen::VectorXd> uniform_configurations(const RobotModel& model) {
  std::mt19937_64 rng(20261205);
  std::vector<Eigen::VectorXd> qs(kConfigurations, Eigen::VectorXd(model.dof()));
  for (auto& q : qs) {
    for (int i = 0; i < model.dof(); ++i) {
      const JointLimits& l = model.joint(i).limits;
      q(i) = std::uniform_real_distribution<double>(l.lower, l.upper)(rng);
    }
  }
  return qs;
}

// The least distance over the path of each scene object (to any arm object) and of the arm to
// itself; all pairs exact.
std::vector<double> least_distances(const RobotModel& model, const Proximity& proximity,
                                    const std::vector<Eigen::VectorXd>& path) {
  Data data(model);
  ExactData exact(proximity);
  std::vector<double> least(proximity.scene().objects.size() + 1, INFINITY);
  for (const auto& q : path) {
    forward_kinematics(model, data, q);
    chasles_exact(proximity, data, exact);
    for (size_t p = 0; p < proximity.pairs().size(); ++p) {
      const ProximityPair& pair = proximity.pairs()[p];
      double& l = pair.kind == ProximityPair::kSelf ? least.back() : least[static_cast<size_t>(pair.other)];
      l = std::min(l, exact.distance[p]);
    }
  }
  return least;
}

// --- timing ---------------------------------------------------------------------------------------

struct Timing {
  std::vector<double> total, distances;  // µs per call
  long allocations = 0;
  double exact_pairs = 0.0;  // culled: summed over the calls

  void reserve() {
    total.reserve(kConfigurations);
    distances.reserve(kConfigurations);
  }
};

double us(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::micro>(b - a).count(); }

double percentile(std::vector<double> v, double fraction) {
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(fraction * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

struct Agreement {
  double exact_max = 0.0;   // chasles exact against coal, every pair
  double culled_max = 0.0;  // chasles culled's exact pairs against coal
  long beyond = 0;          // pairs (either comparison) differing by more than kAgree
  double worst_bound = -INFINITY;  // culled bound − coal's distance, at most 0 if a lower bound
  std::string worst_pair;
  double worst_ours = 0.0, worst_coal = 0.0;
  int penetrating = 0;  // pair-calls where coal reports an overlap
};

struct Result {
  std::string sequence;
  Timing culled, exact, coal;
  Agreement agreement;
  int calls = 0;
};

Result run_sequence(const std::string& name, const std::vector<Eigen::VectorXd>& qs, const RobotModel& model,
                    const Proximity& proximity, Pin& pin) {
  Result r;
  r.sequence = name;
  r.calls = static_cast<int>(qs.size());
  Data data_culled(model), data_exact(model);
  ProximityData culled(proximity);
  ExactData exact(proximity);
  for (Timing* t : {&r.culled, &r.exact, &r.coal}) t->reserve();
  const size_t pairs = proximity.pairs().size();

  auto call = [&](int which, const Eigen::VectorXd& q, bool timed) {
    Timing& t = which == 0 ? r.culled : which == 1 ? r.exact : r.coal;
    // tests/support/allocation_counter.cpp interposes glibc's allocator: every operator new and
    // Eigen allocation, in chasles or in the wheel's libcoal, is counted.
    const chasles::testing::AllocationCounter counter;
    const Clock::time_point t0 = Clock::now();
    if (which == 0) chasles_poses(model, data_culled, q);
    if (which == 1) chasles_poses(model, data_exact, q);
    if (which == 2) pin_poses(pin, q);
    const Clock::time_point t1 = Clock::now();
    if (which == 0) chasles_culled(proximity, data_culled, culled);
    if (which == 1) chasles_exact(proximity, data_exact, exact);
    if (which == 2) pin_distances(pin);
    const Clock::time_point t2 = Clock::now();
    const long allocations = counter.count();
    if (!timed) return;
    t.allocations += allocations;
    t.total.push_back(us(t0, t2));
    t.distances.push_back(us(t1, t2));
    if (which == 0) t.exact_pairs += culled.exact;
  };

  // Warm-up on the sequence's first configurations (caches, branch predictors, the page faults of
  // first touches), untimed.
  for (int c = 0; c < std::min(kWarmUp, r.calls); ++c) {
    for (int which = 0; which < 3; ++which) call(which, qs[static_cast<size_t>(c)], false);
  }
  Agreement& a = r.agreement;
  char pair_name[160];
  for (int c = 0; c < r.calls; ++c) {
    for (int k = 0; k < 3; ++k) call((c + k) % 3, qs[static_cast<size_t>(c)], true);
    for (size_t p = 0; p < pairs; ++p) {
      const double theirs = pin.gdata->distanceResults[p].min_distance;
      a.penetrating += theirs < 0.0 ? 1 : 0;
      const double e = std::abs(exact.distance[p] - theirs);
      a.exact_max = std::max(a.exact_max, e);
      a.beyond += e > kAgree ? 1 : 0;
      const PairDistance& d = culled.distance[p];
      if (d.exact) {
        const double u = std::abs(d.distance - theirs);
        a.culled_max = std::max(a.culled_max, u);
        a.beyond += u > kAgree ? 1 : 0;
      } else {
        a.worst_bound = std::max(a.worst_bound, d.distance - theirs);
      }
      if (std::max(e, d.exact ? std::abs(d.distance - theirs) : 0.0) > kGross) {
        proximity.name_pair(static_cast<int>(p), pair_name, sizeof pair_name);
        fail(name + ", configuration " + std::to_string(c) + ", " + pair_name + ": chasles " +
             std::to_string(exact.distance[p]) + " m, coal " + std::to_string(theirs) + " m");
      }
    }
  }
  return r;
}

void print_results(const std::vector<Result>& results) {
  std::printf("%-7s %-28s %8s %8s %8s %11s %11s %12s %12s\n", "path", "computation", "p50 µs", "p99 µs", "max µs",
              "dist p50", "dist p99", "exact/call", "allocations");
  for (const Result& r : results) {
    const struct {
      const char* name;
      const Timing& t;
    } rows[] = {{"chasles compute_distances", r.culled},
                {"chasles every pair exact", r.exact},
                {"Pinocchio+coal computeDist.", r.coal}};
    for (const auto& row : rows) {
      char exact[32] = "-";
      if (&row.t == &r.culled) std::snprintf(exact, sizeof exact, "%.1f", row.t.exact_pairs / r.calls);
      std::printf("%-7s %-28s %8.1f %8.1f %8.1f %11.1f %11.1f %12s %12ld\n", r.sequence.c_str(), row.name,
                  percentile(row.t.total, 0.50), percentile(row.t.total, 0.99),
                  *std::max_element(row.t.total.begin(), row.t.total.end()), percentile(row.t.distances, 0.50),
                  percentile(row.t.distances, 0.99), exact, row.t.allocations);
    }
  }
  std::printf("\nratios, chasles / Pinocchio+coal (whole call):\n");
  std::printf("%-7s %-28s %8s %8s\n", "path", "computation", "p50", "p99");
  for (const Result& r : results) {
    for (const auto& [name, t] : {std::pair<const char*, const Timing*>{"chasles compute_distances", &r.culled},
                                  {"chasles every pair exact", &r.exact}}) {
      std::printf("%-7s %-28s %8.2f %8.2f\n", r.sequence.c_str(), name,
                  percentile(t->total, 0.50) / percentile(r.coal.total, 0.50),
                  percentile(t->total, 0.99) / percentile(r.coal.total, 0.99));
    }
  }
  // The targets, on the moving path: compute_distances' p99 at most 20 µs, and at most 0.3 of
  // Pinocchio + coal's time (at p50 and at p99; the ratios judged as printed, to two decimals).
  const Result& moving = results.front();
  const double p99 = percentile(moving.culled.total, 0.99);
  const double r50 = percentile(moving.culled.total, 0.50) / percentile(moving.coal.total, 0.50);
  const double r99 = p99 / percentile(moving.coal.total, 0.99);
  std::printf("\ntargets (moving): compute_distances p99 %.1f µs <= 20: %s; ratio to Pinocchio+coal %.2f (p50), %.2f "
              "(p99) <= 0.30: %s; allocations %ld: %s\n",
              p99, p99 <= 20.0 ? "yes" : "NO", r50, r99, std::round(100.0 * std::max(r50, r99)) <= 30.0 ? "yes" : "NO",
              moving.culled.allocations, moving.culled.allocations == 0 ? "none" : "NO");
  std::printf("\nagreement with coal (m):\n");
  for (const Result& r : results) {
    const Agreement& a = r.agreement;
    std::printf("%-7s every pair exact: largest difference %.2e; compute_distances' exact pairs: %.2e; %ld beyond "
                "%.0e; culled bounds at most %.2e above coal's distance; %d pair-calls overlapping (coal)\n",
                r.sequence.c_str(), a.exact_max, a.culled_max, a.beyond, kAgree, a.worst_bound, a.penetrating);
  }
}


// --- where compute_distances' time goes (--breakdown) ---------------------------------------------

// Over a sequence, compute_distances as the tick calls it, then again pair by pair: each pair it
// computed exactly timed alone by signed_distance with a cache of its own that follows the same
// history (updated only when the pair is exact), its GJK (+ EPA) iterations counted; the
// remainder of the call (object poses, bounding spheres, the search for the closest) is the call's
// time less the pairs'. The same exact pairs also at coal's tolerance (1e-6), to show what the
// tighter one costs. Each call is made twice in a row, from the same state, so that a slow tick
// the configuration causes is told apart from one the machine caused.
void breakdown(const std::string& name, const std::vector<Eigen::VectorXd>& qs, const RobotModel& model,
               const Proximity& proximity) {
  const auto& pairs = proximity.pairs();
  const auto& objects = proximity.arm().objects;
  const auto& scene = proximity.scene().objects;
  Data data(model);
  ProximityData culled(proximity), again(proximity);
  std::vector<DistanceCache> cache(pairs.size()), loose_cache(pairs.size());
  std::vector<Transform> T_object(objects.size());
  struct PairStats {
    long calls = 0, iterations = 0, overlaps = 0;
    double ns = 0.0, loose_ns = 0.0;
    long loose_iterations = 0;
  };
  std::vector<PairStats> stats(pairs.size());
  std::vector<double> call_us, repeat_us, pairs_us, loose_us;
  std::vector<long> tick_iterations;
  // The cost of two clock readings, taken out of each pair's time.
  double clock_ns = 0.0;
  {
    const int n = 100000;
    const Clock::time_point t0 = Clock::now();
    for (int k = 0; k < n; ++k) {
      volatile auto t = Clock::now();
      (void)t;
    }
    clock_ns = 1e3 * us(t0, Clock::now()) / n;
  }
  for (const auto& q : qs) {
    forward_kinematics(model, data, q);
    again = culled;
    const Clock::time_point t0 = Clock::now();
    chasles_culled(proximity, data, culled);
    const Clock::time_point t1 = Clock::now();
    chasles_culled(proximity, data, again);  // the same call from the same state
    const Clock::time_point t2 = Clock::now();
    call_us.push_back(us(t0, t1));
    repeat_us.push_back(us(t1, t2));
    for (size_t k = 0; k < objects.size(); ++k) {
      T_object[k] = data.T_body[static_cast<size_t>(objects[k].body)] * objects[k].T_body_object;
    }
    double sum = 0.0, loose_sum = 0.0;
    long iterations = 0;
    for (size_t p = 0; p < pairs.size(); ++p) {
      if (!culled.distance[p].exact) continue;
      const ProximityPair& pair = pairs[p];
      const size_t a = static_cast<size_t>(pair.arm), o = static_cast<size_t>(pair.other);
      const bool self = pair.kind == ProximityPair::kSelf;
      const Shape& b = self ? objects[o].shape : scene[o].shape;
      const Transform& T_b = self ? T_object[o] : scene[o].T_base_object;
      const Clock::time_point s0 = Clock::now();
      const Distance d = signed_distance(objects[a].shape, T_object[a], b, T_b, cache[p]);
      const Clock::time_point s1 = Clock::now();
      const Distance loose = signed_distance(objects[a].shape, T_object[a], b, T_b, loose_cache[p], 1e-6);
      const Clock::time_point s2 = Clock::now();
      PairStats& st = stats[p];
      ++st.calls;
      st.iterations += d.iterations;
      st.overlaps += d.distance < 0.0 ? 1 : 0;
      st.ns += 1e3 * us(s0, s1) - clock_ns;
      st.loose_ns += 1e3 * us(s1, s2) - clock_ns;
      st.loose_iterations += loose.iterations;
      sum += us(s0, s1) - 1e-3 * clock_ns;
      loose_sum += us(s1, s2) - 1e-3 * clock_ns;
      iterations += d.iterations;
    }
    pairs_us.push_back(sum);
    loose_us.push_back(loose_sum);
    tick_iterations.push_back(iterations);
  }
  const double n = static_cast<double>(qs.size());
  std::printf("\n%s: compute_distances per call: p50 %.1f µs, p99 %.1f µs; the same call repeated from the same state: "
              "p50 %.1f, p99 %.1f\n",
              name.c_str(), percentile(call_us, 0.5), percentile(call_us, 0.99), percentile(repeat_us, 0.5),
              percentile(repeat_us, 0.99));
  // Whether the slow calls are slow again when repeated (the configuration) or not (the machine).
  const double slow = percentile(call_us, 0.99);
  long slow_calls = 0, slow_again = 0;
  double slow_iterations = 0.0, all_iterations = 0.0;
  for (size_t c = 0; c < call_us.size(); ++c) {
    all_iterations += static_cast<double>(tick_iterations[c]);
    if (call_us[c] < slow) continue;
    ++slow_calls;
    slow_again += repeat_us[c] >= percentile(repeat_us, 0.95) ? 1 : 0;
    slow_iterations += static_cast<double>(tick_iterations[c]);
  }
  std::printf("  the slowest 1 %% of calls (%ld): %ld of them again among the slowest 5 %% when repeated; GJK+EPA "
              "iterations per call %.0f there against %.0f on average\n",
              slow_calls, slow_again, slow_iterations / static_cast<double>(std::max(slow_calls, 1L)), all_iterations / n);
  std::printf("  the exact pairs alone, timed one by one: p50 %.1f µs, p99 %.1f µs per call; at tolerance 1e-6 instead "
              "of 1e-9: p50 %.1f, p99 %.1f\n",
              percentile(pairs_us, 0.5), percentile(pairs_us, 0.99), percentile(loose_us, 0.5),
              percentile(loose_us, 0.99));
  std::printf("  (clock readings cost %.0f ns a pair, taken out)\n", clock_ns);

  // By class: the arm against itself, against each scene object.
  std::printf("  %-22s %8s %10s %10s %10s %10s %12s %14s\n", "pairs", "count", "exact/call", "ns/exact", "iter/exact",
              "overlap %", "µs per call", "ns, iter @1e-6");
  for (int k = -1; k < static_cast<int>(scene.size()); ++k) {
    PairStats total;
    int count = 0;
    for (size_t p = 0; p < pairs.size(); ++p) {
      const bool self = pairs[p].kind == ProximityPair::kSelf;
      if ((k < 0) != self || (!self && pairs[p].other != k)) continue;
      ++count;
      total.calls += stats[p].calls, total.iterations += stats[p].iterations, total.overlaps += stats[p].overlaps;
      total.ns += stats[p].ns, total.loose_ns += stats[p].loose_ns, total.loose_iterations += stats[p].loose_iterations;
    }
    const double calls = static_cast<double>(std::max(total.calls, 1L));
    std::printf("  %-22s %8d %10.1f %10.0f %10.1f %10.1f %12.2f %8.0f %5.1f\n",
                k < 0 ? "self" : ("arm - " + scene[static_cast<size_t>(k)].name).c_str(), count,
                static_cast<double>(total.calls) / n, total.ns / calls, static_cast<double>(total.iterations) / calls,
                100.0 * static_cast<double>(total.overlaps) / calls, 1e-3 * total.ns / n, total.loose_ns / calls,
                static_cast<double>(total.loose_iterations) / calls);
  }
  std::vector<size_t> order(pairs.size());
  for (size_t p = 0; p < order.size(); ++p) order[p] = p;
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) { return stats[x].ns > stats[y].ns; });
  std::printf("  the 10 pairs that take most:\n");
  char pair_name[160];
  for (size_t r = 0; r < 10 && r < order.size(); ++r) {
    const PairStats& st = stats[order[r]];
    if (st.calls == 0) break;
    proximity.name_pair(static_cast<int>(order[r]), pair_name, sizeof pair_name);
    const double calls = static_cast<double>(st.calls);
    std::printf("    %-44s exact %5.1f %% of calls, %5.0f ns, %4.1f iterations, %5.1f %% overlapping, %.2f µs per call\n",
                pair_name, 100.0 * calls / n, st.ns / calls, static_cast<double>(st.iterations) / calls,
                100.0 * static_cast<double>(st.overlaps) / calls, 1e-3 * st.ns / n);
  }
}

// What one support point of a mesh's hull costs: climbed from a vertex far from the answer (a
// cache left stale while the pair was culled), from the last answer when the direction turns by
// about a degree (a pair exact at every tick), and found by scanning every vertex.
void support_costs(const CollisionModel& arm) {
  const CollisionObject* hull = nullptr;
  for (const auto& o : arm.objects) {
    if (o.shape.kind == ShapeKind::kConvex && (!hull || o.shape.vertices.size() > hull->shape.vertices.size())) hull = &o;
  }
  if (!hull) return;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  constexpr int n = 200000;
  std::vector<Vector3d> directions(n);
  for (auto& d : directions) d = Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
  Shape scan = hull->shape;
  scan.neighbours.clear();  // support_of_core then scans every vertex
  double sink = 0.0;
  auto time = [&](auto&& body) {
    const Clock::time_point t0 = Clock::now();
    for (int k = 0; k < n; ++k) sink += body(k);
    return 1e3 * us(t0, Clock::now()) / n;
  };
  const double cold = time([&](int k) {
    int vertex = 0;
    return support_of_core(hull->shape, directions[static_cast<size_t>(k)], vertex).x();
  });
  int last = 0;
  const Eigen::AngleAxisd turn(M_PI / 180, Vector3d(1, 2, 3).normalized());
  Vector3d d = Vector3d::UnitX();
  const double warm = time([&](int) {
    d = turn * d;
    return support_of_core(hull->shape, d, last).x();
  });
  const double all = time([&](int k) {
    int vertex = 0;
    return support_of_core(scan, directions[static_cast<size_t>(k)], vertex).x();
  });
  std::printf("\nsupport point of %s's hull (%zu vertices): climbed from vertex 0 %.0f ns, from the last answer (the "
              "direction turned by 1°) %.0f ns, scanning every vertex %.0f ns%s\n",
              hull->name.c_str(), hull->shape.vertices.size(), cold, warm, all, sink == 0.123 ? " " : "");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    UrdfOptions urdf_options;
    urdf_options.tip_link = "panda_hand";
    const std::string urdf = kData + "/panda.urdf";
    const RobotModel model = load_urdf_file(urdf, urdf_options);
    GeometryOptions options;
    options.package_dirs = {kData + "/packages"};
    options.srdf_path = kData + "/packages/example-robot-data/robots/panda_description/srdf/panda.srdf";
    const Proximity proximity(load_collision_model(urdf, model, options), make_scene());

    Pin pin;
    build_pinocchio(model, proximity, pin);
    check_against_record(proximity.arm(), pin.geom);

    // The object poses of both at one configuration.
    {
      Data data(model);
      ExactData exact(proximity);
      const Eigen::VectorXd q = ready_pose();
      forward_kinematics(model, data, q);
      chasles_exact(proximity, data, exact);
      pin_poses(pin, q);
      double worst = 0.0;
      for (size_t k = 0; k < exact.T_object.size(); ++k) {
        worst = std::max(worst, (exact.T_object[k].matrix() - pin.gdata->oMg[k].toHomogeneousMatrix()).cwiseAbs().maxCoeff());
      }
      if (worst > 1e-12) fail("the object poses differ by " + std::to_string(worst));
    }

    const auto& arm = proximity.arm();
    int self = 0;
    for (const auto& p : proximity.pairs()) self += p.kind == ProximityPair::kSelf ? 1 : 0;
    std::printf("chasles_coal_bench: Panda, %zu objects, %d self pairs + %zu objects x %zu scene objects = %zu pairs; "
                "Pinocchio %s, coal %s\n",
                arm.objects.size(), self, arm.objects.size(), proximity.scene().objects.size(),
                proximity.pairs().size(), PINOCCHIO_VERSION, COAL_VERSION);

    // The first path of the list that stays clear of the scene and of the arm itself.
    std::vector<Eigen::VectorXd> path;
    std::vector<double> least;
    unsigned seed = 0;
    for (seed = 1; seed <= 50 && path.empty(); ++seed) {
      path = sinusoid_path(model, seed);
      least = least_distances(model, proximity, path);
      if (*std::min_element(least.begin(), least.end()) <= 0.0) path.clear();
    }
    if (path.empty()) fail("no clear path among the 50 seeds");
    std::printf("moving: %d steps of 1 ms, seed %u; least distance over the path:", kConfigurations, seed - 1);
    for (size_t k = 0; k < proximity.scene().objects.size(); ++k) {
      std::printf(" %s %.3f,", proximity.scene().objects[k].name.c_str(), least[k]);
    }
    std::printf(" self %.3f m\n", least.back());
    std::printf("random: %d uniform configurations within the joint limits\n\n", kConfigurations);

    if (argc > 1 && std::string(argv[1]) == "--breakdown") {
      breakdown("moving", path, model, proximity);
      breakdown("random", uniform_configurations(model), model, proximity);
      support_costs(proximity.arm());
      return 0;
    }
    if (argc > 1) fail(std::string("unknown argument ") + argv[1] + " (--breakdown, or none)");
    std::vector<Result> results;
    results.push_back(run_sequence("moving", path, model, proximity, pin));
    results.push_back(run_sequence("random", uniform_configurations(model), model, proximity, pin));
    print_results(results);
  } catch (const std::exception& e) {
    fail(e.what());
  }
  return 0;
}
