// The path check before moving (core/geometry/path_check.hpp) against an independent brute force:
// 10^4 + 1 evenly spaced configurations, every pair's signed distance computed by the distance
// engine itself (no bounding spheres, no culling, no Proximity), on the Panda, the iiwa and the
// UR5 with scene boxes and a table; and the IK's preference for collision-free answers.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/collision_model.hpp"
#include "core/geometry/distance.hpp"
#include "core/geometry/path_check.hpp"
#include "core/geometry/proximity.hpp"
#include "core/ik/ik.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "core/motion/quintic.hpp"
#include "support/reference.hpp"

namespace chasles::geometry {
namespace {

using testing::data_path;

const std::string kPackages = data_path("packages");

struct Arm {
  RobotModel model;
  CollisionModel collision;
};

Arm load_arm(const std::string& urdf, const std::string& tip, const std::string& srdf) {
  UrdfOptions options;
  options.tip_link = tip;
  RobotModel model = load_urdf_file(data_path(urdf), options);
  CollisionModel collision =
      load_collision_model(data_path(urdf), model, {{kPackages}, srdf.empty() ? "" : kPackages + "/" + srdf});
  return {std::move(model), std::move(collision)};
}

const Arm& panda() {
  static const Arm arm =
      load_arm("panda.urdf", "panda_hand", "example-robot-data/robots/panda_description/srdf/panda.srdf");
  return arm;
}

SceneObject box(const std::string& name, const Vector3d& centre, const Vector3d& half_extents,
                const Clearance& clearance = {0.01, 0.10}) {
  SceneObject object;
  object.name = name;
  object.shape.kind = ShapeKind::kBox;
  object.shape.half_extents = half_extents;
  object.T_base_object = Transform(Matrix3d::Identity(), centre);
  object.clearance = clearance;
  return object;
}

// q0 + (t / T)(q1 − q0), its speed exactly |q1 − q0| / T.
JointPath straight(const Eigen::VectorXd& q0, const Eigen::VectorXd& q1, double T) {
  JointPath path;
  path.duration = T;
  path.position = [q0, q1, T](double t, Eigen::VectorXd& q) { q = q0 + (t / T) * (q1 - q0); };
  path.speed = (q1 - q0).cwiseAbs() / T;
  return path;
}

Eigen::VectorXd vec(std::initializer_list<double> values) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(values.size()));
  Eigen::Index i = 0;
  for (double x : values) v[i++] = x;
  return v;
}

std::string pair_name(const Proximity& proximity, int p) {
  if (p < 0) return "(none)";
  char buffer[256];
  proximity.name_pair(p, buffer, sizeof buffer);
  return buffer;
}

// Every pair's signed distance at a configuration by the distance engine itself, nothing culled
// and no Proximity computation: a plane as the half-space's slab, a box 0.5 m deep and 20 m wide
// whose top face is the plane.
class ExactDistances {
 public:
  ExactDistances(const RobotModel& model, const Proximity& proximity)
      : model_(model),
        proximity_(proximity),
        data_(model),
        T_(proximity.arm().objects.size()),
        caches_(proximity.pairs().size()),
        d_(static_cast<Eigen::Index>(proximity.pairs().size())) {
    for (const SafetyPlane& plane : proximity.scene().planes) {
      Shape slab;
      slab.kind = ShapeKind::kBox;
      slab.half_extents = Vector3d(10.0, 10.0, 0.25);
      const Vector3d z = plane.normal;
      const Vector3d x = (std::abs(z.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY()).cross(z).normalized();
      Matrix3d R;
      R << x, z.cross(x), z;
      slabs_.push_back(slab);
      T_slabs_.emplace_back(R, (plane.offset - 0.25) * z);
    }
  }

  const Eigen::VectorXd& at(const Eigen::VectorXd& q) {
    const auto& objects = proximity_.arm().objects;
    const auto& scene = proximity_.scene();
    forward_kinematics(model_, data_, q);
    for (size_t k = 0; k < objects.size(); ++k) {
      T_[k] = data_.T_body[static_cast<size_t>(objects[k].body)] * objects[k].T_body_object;
    }
    for (size_t p = 0; p < proximity_.pairs().size(); ++p) {
      const ProximityPair& pair = proximity_.pairs()[p];
      const size_t a = static_cast<size_t>(pair.arm), o = static_cast<size_t>(pair.other);
      const Shape& other = pair.kind == ProximityPair::kSelf     ? objects[o].shape
                           : pair.kind == ProximityPair::kObject ? scene.objects[o].shape
                                                                 : slabs_[o];
      const Transform& T_other = pair.kind == ProximityPair::kSelf     ? T_[o]
                                 : pair.kind == ProximityPair::kObject ? scene.objects[o].T_base_object
                                                                       : T_slabs_[o];
      d_[static_cast<Eigen::Index>(p)] = signed_distance(objects[a].shape, T_[a], other, T_other, caches_[p]).distance;
    }
    return d_;
  }

 private:
  const RobotModel& model_;
  const Proximity& proximity_;
  Data data_;
  std::vector<Shape> slabs_;
  std::vector<Transform> T_slabs_, T_;
  std::vector<DistanceCache> caches_;
  Eigen::VectorXd d_;
};

// The brute force: `intervals` + 1 evenly spaced configurations of the path, every pair's exact
// distance at each.
struct Dense {
  int first = -1;  // the first sample with a pair below its stop, −1: none
  double time = 0.0;
  int pair = -1;  // at `first`, the pair deepest below its stop
  double least_margin = std::numeric_limits<double>::infinity();
  int least_pair = -1;
  double least_time = 0.0;
};

Dense brute_force(const RobotModel& model, const Proximity& proximity, const JointPath& path, int intervals,
                  bool stop_at_first = true) {
  ExactDistances exact(model, proximity);
  Eigen::VectorXd q(model.dof());
  Dense dense;
  for (int i = 0; i <= intervals; ++i) {
    const double t = path.duration * i / intervals;
    path.position(t, q);
    const Eigen::VectorXd& d = exact.at(q);
    double deepest = 0.0;
    for (size_t p = 0; p < proximity.pairs().size(); ++p) {
      const double margin = d[static_cast<Eigen::Index>(p)] - proximity.pairs()[p].clearance.stop;
      if (margin < dense.least_margin) {
        dense.least_margin = margin;
        dense.least_pair = static_cast<int>(p);
        dense.least_time = t;
      }
      if (dense.first < 0 && margin < deepest) deepest = margin, dense.pair = static_cast<int>(p);
    }
    if (dense.first < 0 && dense.pair >= 0) {
      dense.first = i;
      dense.time = t;
      if (stop_at_first) return dense;
    }
  }
  return dense;
}

struct Checked {
  PathClearance clearance;
  double ms = 0.0;
};

Checked check(const RobotModel& model, const Proximity& proximity, const JointPath& path,
              const PathCheckOptions& options = {}) {
  Data data(model);
  ProximityData pdata(proximity);
  const auto start = std::chrono::steady_clock::now();
  Checked c{check_path(model, proximity, data, pdata, path, options), 0.0};
  c.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return c;
}

constexpr int kDense = 10000;  // the brute force's intervals
const Eigen::VectorXd kReady = vec({0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785});

// The Panda at its ready pose swept about joint 1 from −1 to 1 rad in 2 s: the hand, pointing
// down, draws an arc of radius 0.3 m at 0.48 to 0.62 m above the base.
JointPath panda_sweep(double T = 2.0) {
  Eigen::VectorXd q0 = kReady, q1 = kReady;
  q0[0] = -1.0;
  q1[0] = 1.0;
  return straight(q0, q1, T);
}

void print(const char* what, const Proximity& proximity, const Checked& c, const Dense* dense = nullptr) {
  const PathClearance& r = c.clearance;
  std::printf("%s: %s after %d samples (%d least steps, shortfall %.2g m) in %.2f ms", what,
              r.clear ? "clear" : "refused", r.samples, r.least_steps, r.shortfall, c.ms);
  if (r.pair >= 0) {
    std::printf("; %s below its stop from %.5f s (seen at %.5f s, %.4f m)", pair_name(proximity, r.pair).c_str(),
                r.time, r.time_seen, r.distance);
  }
  std::printf("; nearest its stop %s at %.4f s, %.4f m", pair_name(proximity, r.least_pair).c_str(), r.least_time,
              r.least_distance);
  if (dense != nullptr && dense->first >= 0) {
    std::printf("; the brute force: %s at %.5f s", pair_name(proximity, dense->pair).c_str(), dense->time);
  }
  std::printf("\n");
}

// The check refuses the path at the time the brute force first sees a pair below its stop, never
// later, and earlier by at most the brute force's spacing and the least step, naming that pair.
void expect_refused_as_the_brute_force_sees(const RobotModel& model, const Proximity& proximity, const JointPath& path,
                                            const std::string& pair, const char* what) {
  const Dense dense = brute_force(model, proximity, path, kDense);
  ASSERT_GT(dense.first, 0) << "the brute force sees no collision, or one at the start";
  EXPECT_EQ(pair_name(proximity, dense.pair), pair);
  const Checked c = check(model, proximity, path);
  print(what, proximity, c, &dense);
  const PathClearance& r = c.clearance;
  const double T = path.duration, resolution = PathCheckOptions{}.min_step * T;
  EXPECT_FALSE(r.clear);
  EXPECT_TRUE(r.complete);
  EXPECT_EQ(pair_name(proximity, r.pair), pair);
  EXPECT_LE(r.time, dense.time);
  EXPECT_GE(r.time, dense.time - T / kDense - resolution);
  EXPECT_GE(r.time_seen, r.time);
  EXPECT_LE(r.time_seen - r.time, resolution * (1.0 + 1e-9));
  EXPECT_EQ(r.checked_until, r.time_seen);
  EXPECT_LT(r.distance, proximity.pairs()[static_cast<size_t>(r.pair)].clearance.stop);
  // What a least step may have let through unseen before: at most w · min_step · T / 2.
  EXPECT_LE(r.shortfall, (distance_rates(model, proximity) * path.speed).maxCoeff() * resolution / 2.0);
  // What the check costs against the brute force's 10^4 + 1 configurations.
  EXPECT_LT(r.samples, 200);
}

TEST(PathCheck, PandaSweepThroughABoxIsRefusedWhereTheBruteForceFirstSeesIt) {
  const Arm& arm = panda();
  Scene scene;
  scene.objects.push_back(box("box", Vector3d(0.3, 0.0, 0.5), Vector3d(0.05, 0.05, 0.05)));
  expect_refused_as_the_brute_force_sees(arm.model, Proximity(arm.collision, scene), panda_sweep(),
                                         "panda_hand/0 and box", "Panda through a box");
}

TEST(PathCheck, PandaSweepTwoCentimetresOutsideTheStopIsClear) {
  // The same sweep over a box below the fingers: joint 1 turns about the vertical, so the fingers'
  // lowest point keeps its height and the least distance is where they pass over the box's top
  // face. The box is raised to put that distance at its stop (1 cm) + 2 cm, measured at the middle of
  // the sweep (joint 1 at 0, the fingers over the face).
  const Arm& arm = panda();
  const JointPath path = panda_sweep();
  const Vector3d half(0.05, 0.05, 0.05);
  Vector3d centre(0.3, 0.0, 0.3);
  Eigen::VectorXd middle(7);
  path.position(1.0, middle);
  CollisionModel no_self = arm.collision;
  no_self.pairs.clear();
  {
    Scene low;
    low.objects.push_back(box("box", centre, half));
    const Proximity proximity(no_self, low);
    Data data(arm.model);
    ProximityData pdata(proximity);
    centre.z() += configuration_clearance(arm.model, proximity, data, pdata, middle).distance - 0.03;
  }
  Scene scene;
  scene.objects.push_back(box("box", centre, half));
  const Proximity proximity(arm.collision, scene);
  // The whole path, every pair, at a quarter of the spacing (the least distance is flat while the
  // fingers cross the face, 0.3 s of the sweep).
  const Dense dense = brute_force(arm.model, proximity, path, kDense / 4, false);
  ASSERT_EQ(dense.first, -1);
  EXPECT_NEAR(dense.least_margin, 0.02, 1e-9) << pair_name(proximity, dense.least_pair);

  const Checked c = check(arm.model, proximity, path);
  print("Panda 2 cm outside a box's stop", proximity, c);
  const PathClearance& r = c.clearance;
  EXPECT_TRUE(r.clear);
  EXPECT_TRUE(r.complete);
  EXPECT_EQ(r.pair, -1);
  EXPECT_EQ(r.checked_until, path.duration);
  // Every step proven: none needed the least step.
  EXPECT_EQ(r.least_steps, 0);
  EXPECT_EQ(r.shortfall, 0.0);
  ASSERT_GE(r.least_pair, 0);
  EXPECT_EQ(proximity.pairs()[static_cast<size_t>(r.least_pair)].kind, ProximityPair::kObject);
  EXPECT_NEAR(r.least_distance, 0.03, 1e-9);
  EXPECT_LT(r.samples, 200);
}

TEST(PathCheck, PandaFoldingIntoItselfIsRefusedAtTheSelfPair) {
  // From the ready pose toward the shoulder folded back and the elbow bent to its limit: the hand
  // comes down onto link 1.
  const Arm& arm = panda();
  const Eigen::VectorXd folded = vec({1.269, -1.650, -0.876, -2.978, -0.214, 1.215, 2.355});
  expect_refused_as_the_brute_force_sees(arm.model, Proximity(arm.collision, Scene{}), straight(kReady, folded, 2.0),
                                         "panda_link1/0 and panda_hand/0", "Panda folding into itself");
}

TEST(PathCheck, PandaFingersFlashingThroughAThinPlateAreCaught) {
  // The sweep in 50 ms (joint 1 at 40 rad/s) through a plate 2 mm thick that only the fingers
  // reach, standing halfway between two of 8 evenly spaced samples: those see the fingers 1 cm
  // clear on either side of it, and conservative advancement does not.
  const Arm& arm = panda();
  const JointPath path = panda_sweep(0.05);
  const double angle = 0.125;  // halfway between samples 4 and 5 of 8 over [−1, 1] rad
  SceneObject plate = box("plate", Vector3d::Zero(), Vector3d(0.125, 0.001, 0.0325), {0.005, 0.05});
  plate.T_base_object = Transform(Eigen::AngleAxisd(angle, Vector3d::UnitZ()).toRotationMatrix(),
                                  Vector3d(0.325 * std::cos(angle), 0.325 * std::sin(angle), 0.4725));
  Scene scene;
  scene.objects.push_back(plate);
  const Proximity proximity(arm.collision, scene);
  EXPECT_EQ(brute_force(arm.model, proximity, path, 8).first, -1) << "8 samples see the plate";
  expect_refused_as_the_brute_force_sees(arm.model, proximity, path, "panda_rightfinger/2 and plate",
                                         "Panda's fingers through a thin plate");
}

TEST(PathCheck, IiwaWristLoweredOntoATablePlaneIsRefused) {
  // A table at 25 cm that links 5 to 7 keep 2 cm above; the shoulder lowers the wrist onto it.
  // The iiwa's self pairs are left out: without an SRDF its meshes of links 5 and 7 overlap across
  // the wrist in every pose, as the URDF ships them.
  const Arm iiwa = load_arm("iiwa14.urdf", "iiwa_link_ee", "");
  CollisionModel no_self = iiwa.collision;
  no_self.pairs.clear();
  Scene scene;
  scene.planes.push_back(
      {"table", Vector3d::UnitZ(), 0.25, {"iiwa_link_5", "iiwa_link_6", "iiwa_link_7"}, {0.02, 0.1}});
  expect_refused_as_the_brute_force_sees(
      iiwa.model, Proximity(no_self, scene),
      straight(vec({0.0, 0.5, 0.0, -1.5, 0.0, -0.5, 0.0}), vec({0.3, 1.3, 0.0, -1.2, 0.0, -0.5, 0.5}), 1.5),
      "iiwa_link_5/0 and table", "iiwa onto a table");
}

TEST(PathCheck, Ur5ElbowFoldedOntoItsUpperArmIsRefused) {
  const Arm ur5 = load_arm("ur5.urdf", "tool0", "example-robot-data/robots/ur_description/srdf/ur5.srdf");
  expect_refused_as_the_brute_force_sees(
      ur5.model, Proximity(ur5.collision, Scene{}),
      straight(vec({0.0, -1.57, 1.57, -1.57, -1.57, 0.0}), vec({0.0, -1.57, 3.1, -1.57, -1.57, 0.0}), 2.0),
      "upper_arm_link/0 and wrist_3_link/0", "UR5 folding its elbow");
}

TEST(PathCheck, ControllersQuinticGoalIsAPath) {
  // The controller's JOINT goal: the quintic from q0 at rest to q1 over T (core/motion/quintic.hpp)
  // is the path's position; its speed is bounded by its peak, 15/8 |q1 − q0| / T at T/2 (the
  // derivative of 10s³ − 15s⁴ + 6s⁵, 30 s²(1 − s)², at s = ½), or, for a quintic from a moving
  // start, by the velocity limits it was checked against (an empty JointPath::speed: the model's).
  const Arm& arm = panda();
  Scene scene;
  scene.objects.push_back(box("box", Vector3d(0.3, 0.0, 0.5), Vector3d(0.05, 0.05, 0.05)));
  const Proximity proximity(arm.collision, scene);
  Eigen::VectorXd q0 = kReady, q1 = kReady;
  q0[0] = -1.0;
  q1[0] = 1.0;
  const double T = 2.0;
  motion::QuinticTrajectory quintic(arm.model.dof());
  motion::Reference from(arm.model.dof());
  from.hold(q0);
  quintic.start(from, q1, T);

  JointPath path;
  path.duration = quintic.duration();
  path.position = [&quintic, reference = motion::Reference(arm.model.dof())](double t, Eigen::VectorXd& q) mutable {
    quintic.sample(t, reference);
    q = reference.q;
  };
  path.speed = 15.0 / 8.0 * (q1 - q0).cwiseAbs() / T;
  expect_refused_as_the_brute_force_sees(arm.model, proximity, path, "panda_hand/0 and box",
                                         "Panda's quintic through a box");

  // Bounded by the velocity limits instead: the same answer, from more samples.
  const Checked exact = check(arm.model, proximity, path);
  path.speed.resize(0);
  const Checked limits = check(arm.model, proximity, path);
  print("the same bounded by the velocity limits", proximity, limits);
  EXPECT_EQ(limits.clearance.pair, exact.clearance.pair);
  EXPECT_NEAR(limits.clearance.time, exact.clearance.time, 2 * PathCheckOptions{}.min_step * T);
  EXPECT_GT(limits.clearance.samples, exact.clearance.samples);
}

TEST(PathCheck, RunningOutOfSamplesIsNotClear) {
  const Arm& arm = panda();
  const Proximity proximity(arm.collision, Scene{});
  PathCheckOptions options;
  options.max_samples = 3;
  const PathClearance r = check(arm.model, proximity, panda_sweep(), options).clearance;
  EXPECT_FALSE(r.clear);
  EXPECT_FALSE(r.complete);
  EXPECT_EQ(r.pair, -1);
  EXPECT_EQ(r.samples, 3);
  EXPECT_GT(r.checked_until, 0.0);
  EXPECT_LT(r.checked_until, 2.0);
  // The whole sweep clears the arm itself with the default cap.
  EXPECT_TRUE(check(arm.model, proximity, panda_sweep()).clearance.clear);
}

TEST(PathCheck, OneConfigurationAndBadInput) {
  const Arm& arm = panda();
  Scene scene;
  scene.objects.push_back(box("box", Vector3d(0.3, 0.0, 0.5), Vector3d(0.05, 0.05, 0.05)));
  const Proximity proximity(arm.collision, scene);
  // A duration of 0: the one configuration, here the fold's end, the hand deep in link 1.
  JointPath folded;
  folded.position = [](double, Eigen::VectorXd& q) { q = vec({1.269, -1.650, -0.876, -2.978, -0.214, 1.215, 2.355}); };
  const PathClearance at_fold = check(arm.model, proximity, folded).clearance;
  EXPECT_FALSE(at_fold.clear);
  EXPECT_EQ(at_fold.time, 0.0);
  EXPECT_EQ(at_fold.time_seen, 0.0);
  EXPECT_EQ(at_fold.samples, 1);
  EXPECT_EQ(pair_name(proximity, at_fold.pair), "panda_link1/0 and panda_hand/0");
  JointPath still = panda_sweep();
  still.duration = 0.0;
  const PathClearance away = check(arm.model, proximity, still).clearance;
  EXPECT_TRUE(away.clear);
  EXPECT_EQ(away.samples, 1);

  auto refused = [&](JointPath path, const PathCheckOptions& options, const std::string& message) {
    try {
      check(arm.model, proximity, path, options);
      ADD_FAILURE() << "accepted, expected: " << message;
    } catch (const ArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  JointPath path = panda_sweep();
  path.position = nullptr;
  refused(path, {}, "no position function");
  path = panda_sweep();
  path.duration = -1.0;
  refused(path, {}, "duration must be finite");
  path = panda_sweep();
  path.speed.resize(3);
  refused(path, {}, "the speed bound has 3 entries");
  path = panda_sweep();
  path.speed[2] = std::nan("");
  refused(path, {}, "speed bound of joint panda_joint3");
  path = panda_sweep();
  path.position = [sweep = panda_sweep()](double t, Eigen::VectorXd& q) {
    sweep.position(t, q);
    if (t > 0.1) q[3] = std::nan("");
  };
  refused(path, {}, "not finite");
  refused(panda_sweep(), {0.0, 100}, "min_step");
  refused(panda_sweep(), {1e-4, 1}, "max_samples");
}

TEST(PathCheck, DistanceRatesBoundEveryPairsChange) {
  // The bound that makes the steps safe, against the distances themselves: at random
  // configurations of the Panda, each joint moved by 1 mrad changes no pair's exact distance by
  // more than its rate times that (and the engine's tolerance).
  const Arm& arm = panda();
  Scene scene;
  scene.objects.push_back(box("box", Vector3d(0.3, 0.0, 0.5), Vector3d(0.05, 0.05, 0.05)));
  scene.planes.push_back({"floor", Vector3d::UnitZ(), 0.0, {}, {0.01, 0.1}});
  const Proximity proximity(arm.collision, scene);
  const Eigen::MatrixXd rates = distance_rates(arm.model, proximity);
  const Eigen::Index pairs = rates.rows();
  ExactDistances exact(arm.model, proximity);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr double kStep = 1e-3;
  double tightest = 0.0;  // the largest |Δd| / (R δ) seen
  for (int sample = 0; sample < 100; ++sample) {
    Eigen::VectorXd q(7);
    for (int i = 0; i < 7; ++i) {
      const JointLimits& limits = arm.model.joint(i).limits;
      q[i] = limits.lower + u(rng) * (limits.upper - limits.lower);
    }
    const Eigen::VectorXd d0 = exact.at(q);
    for (int k = 0; k < 7; ++k) {
      Eigen::VectorXd moved = q;
      moved[k] += kStep;
      const Eigen::VectorXd& d1 = exact.at(moved);
      for (Eigen::Index p = 0; p < pairs; ++p) {
        const double change = std::abs(d1[p] - d0[p]);
        EXPECT_LE(change, rates(p, k) * kStep + 1e-8)
            << pair_name(proximity, static_cast<int>(p)) << ", joint " << k + 1;
        if (rates(p, k) > 0.0) tightest = std::max(tightest, change / (rates(p, k) * kStep));
      }
    }
  }
  std::printf("the largest change seen is %.2f of its bound\n", tightest);
}

// The IK preferring answers clear of collision: its margin, the configuration's clearance.
struct ClearIk {
  const RobotModel& model;
  const Proximity& proximity;
  Data data;
  ProximityData pdata;
  ClearIk(const RobotModel& m, const Proximity& p) : model(m), proximity(p), data(m), pdata(p) {}
  ConfigurationClearance at(const Eigen::VectorXd& q) {
    return configuration_clearance(model, proximity, data, pdata, q);
  }
  IkMargin margin() {
    return [this](const Eigen::VectorXd& q) { return at(q).margin; };
  }
};

// A target the Panda reaches from its ready pose with its elbow up behind the shoulder, and with
// the elbow elsewhere by other branches of its redundancy. The search is bounded by its restart
// cap, never its time, so that its answer is the same on every machine.
IkOptions ik_options() {
  IkOptions options;
  options.max_restarts = 40;
  options.time_budget = std::chrono::seconds(10);
  return options;
}

const Transform& ik_target() {
  static const Transform target = forward_kinematics_space(panda().model, vec({0.3, -0.3, 0.0, -2.0, 0.0, 1.8, 0.785}));
  return target;
}

TEST(IkClear, PrefersAnotherBranchWhenTheFirstAnswerHitsABox) {
  const Arm& arm = panda();
  // A box just above where the first answer puts the elbow (link 4's top at 0.78 m), far from the
  // hand at the target.
  Scene scene;
  scene.objects.push_back(box("box", Vector3d(-0.05, 0.0, 0.82), Vector3d(0.08, 0.08, 0.06)));
  const Proximity proximity(arm.collision, scene);
  ClearIk clear(arm.model, proximity);
  IkSolver solver(arm.model, ik_options());

  const IkResult plain = solver.solve(ik_target(), kReady);
  ASSERT_TRUE(plain.converged);
  const ConfigurationClearance hit = clear.at(plain.q);
  EXPECT_LT(hit.margin, 0.0);
  EXPECT_EQ(pair_name(proximity, hit.pair), "panda_link4/0 and box");

  const IkResult preferred = solver.solve(ik_target(), kReady, clear.margin());
  const ConfigurationClearance c = clear.at(preferred.q);
  std::printf("first answer: %s at %.4f m; preferred: after %d restarts (%d refused), %s at %.4f m, %.2f ms\n",
              pair_name(proximity, hit.pair).c_str(), hit.distance, preferred.restarts, preferred.refused,
              pair_name(proximity, c.pair).c_str(), c.distance, preferred.time_us / 1e3);
  EXPECT_TRUE(preferred.converged);
  EXPECT_TRUE(preferred.accepted);
  EXPECT_EQ(preferred.refused, 1);
  EXPECT_EQ(preferred.restarts, 1);
  EXPECT_GE(preferred.margin, 0.0);
  EXPECT_EQ(preferred.margin, c.margin);
  EXPECT_LE(preferred.pos_err, 1e-6);
  EXPECT_LE(preferred.rot_err, 1e-6);
  EXPECT_GT((preferred.q - plain.q).norm(), 1.0) << "another branch";

  // A margin that accepts everything changes nothing.
  const IkResult anything = solver.solve(ik_target(), kReady, [](const Eigen::VectorXd&) { return 1.0; });
  EXPECT_EQ(anything.q, plain.q);
  EXPECT_TRUE(anything.accepted);
  EXPECT_EQ(anything.refused, 0);
  EXPECT_THROW(solver.solve(ik_target(), kReady, IkMargin()), ArgumentError);
}

TEST(IkClear, NoClearAnswerIsFlaggedWithThePair) {
  // The box around the hand at the target: every answer puts the hand in it.
  const Arm& arm = panda();
  Scene scene;
  scene.objects.push_back(box("box", ik_target().translation(), Vector3d(0.08, 0.08, 0.06)));
  const Proximity proximity(arm.collision, scene);
  ClearIk clear(arm.model, proximity);
  IkSolver solver(arm.model, ik_options());
  const IkResult r = solver.solve(ik_target(), kReady, clear.margin());
  const ConfigurationClearance c = clear.at(r.q);
  std::printf("no clear answer: %d restarts, %d refused; the answer's %s at %.4f m\n", r.restarts, r.refused,
              pair_name(proximity, c.pair).c_str(), c.distance);
  EXPECT_TRUE(r.converged);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.restarts, 40);
  EXPECT_GE(r.refused, 1);
  EXPECT_LT(r.margin, 0.0);
  EXPECT_EQ(r.margin, c.margin);
  EXPECT_EQ(pair_name(proximity, c.pair), "panda_hand/0 and box");
}
}  // namespace
}  // namespace chasles::geometry
