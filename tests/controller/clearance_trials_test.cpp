// Clearance trials (controller/clearance.hpp; the target): in simulated time, random jogs,
// streams and trajectories aimed at the arm's own body and at the scene, on the Panda, the UR5 and
// the iiwa, each with its collision geometry and a scene (a table under the arm, a wall on one
// side, a post on the table, a keep-in box for the tool). The arm is the model itself integrated
// under the commanded torque, and a Judge of the test's own computes every pair's room (distance
// less stop) at every state:
//
//   every state of every trial   room ≥ 0 on every pair; no FAULT; no reflex (nothing pushes the
//                                arm, so none is ever inside a stop distance)
//   at each trial's end          the arm not closing on anything near it: at rest, or moving only
//                                tangentially
//   a trajectory through an      refused before it moves, naming the pair; one that runs is slowed
//   obstacle                     along its path and completes, or stops short naming the pair: HOLDING
//   far from everything          the scene 5 m away and the arm's pairs beyond their influence:
//                                reference and torque bit-identical to a controller without a world
//
// 100 trials by default (a deterministic prefix of the 1,000: the same trial seeds);
// CHASLES_LONG_TRIALS=1 runs all 1,000. CHASLES_TRIAL=<index> runs only that trial of each arm,
// CHASLES_TRIAL_TRACE=1 prints its every tick.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "controller/controller.hpp"
#include "controller/world.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "following.hpp"
#include "support/arm.hpp"
#include "support/contact_off.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::kMs;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The trials in all, over the three arms, and those run by default: under the sanitizers, which
// run the simulated arm 10 to 30 times slower, the first 12 (every kind on every arm).
constexpr int kAllTrials = 1000;
#ifdef CHASLES_SANITIZED
constexpr int kDefaultTrials = 12;
#else
constexpr int kDefaultTrials = 100;
#endif

bool long_trials() {
  const char* v = std::getenv("CHASLES_LONG_TRIALS");
  return v != nullptr && std::strcmp(v, "1") == 0;
}
int only_trial() {
  const char* v = std::getenv("CHASLES_TRIAL");
  return v != nullptr && *v != '\0' ? std::atoi(v) : -1;
}

// ---------------------------------------------------------------------------------------------
// The arms and their scenes.

struct ArmSpec {
  const char* name;
  const char* urdf;
  const char* tip;
  const char* srdf;                     // under tests/data/packages; "" for none
  std::vector<std::string> tool_links;  // what the keep-in box binds
  int index;                            // 0, 1, 2: its share of the trials and its seeds
};

const ArmSpec kPanda{"Panda", "panda.urdf", "panda_hand_tcp",
                     "example-robot-data/robots/panda_description/srdf/panda.srdf",
                     {"panda_hand", "panda_leftfinger", "panda_rightfinger"}, 0};
const ArmSpec kUr5{"UR5", "ur5.urdf", "tool0", "example-robot-data/robots/ur_description/srdf/ur5.srdf",
                   {"wrist_3_link", "ee_link"}, 1};
const ArmSpec kIiwa{"iiwa", "iiwa14.urdf", "iiwa_link_ee", "", {"iiwa_link_6", "iiwa_link_7"}, 2};

RobotModel load_model(const ArmSpec& spec) {
  UrdfOptions options;
  options.tip_link = spec.tip;
  return load_urdf_file(chasles::testing::data_path(spec.urdf), options);
}

// The arm's geometry as the daemon loads it: its SRDF's pairs, less those in contact at q = 0.
geometry::CollisionModel load_geometry(const ArmSpec& spec, const RobotModel& model) {
  WorldOptions options;
  options.mode = CollisionMode::kOn;
  options.urdf = chasles::testing::data_path(spec.urdf);
  options.geometry.package_dirs = {chasles::testing::data_path("packages")};
  if (*spec.srdf != '\0') options.geometry.srdf_path = chasles::testing::data_path(std::string("packages/") + spec.srdf);
  std::vector<std::string> notes;
  return load_arm_geometry(model, options, notes);
}

// The Panda on libfranka's rates, the others on the defaults, the generator's jerk within the
// torque rate as the daemon runs it (without, the torque-rate guard held back the law's torque on
// the Panda's first ticks, and the arm ran away from the reference); the contact monitor and the
// torque-semantics check off (the integrated model is exact, there is no driver), so that a
// reflex can only come from a limit or a stop distance.
Config trial_config(const ArmSpec& spec, const RobotModel& model) {
  Config config = Config::critically_damped(model.dof(), 20.0);
  if (spec.index == 0) {
    config.limits.acceleration = testing::franka_acceleration();
    config.limits.jerk = testing::franka_jerk();
  }
  chasles::testing::never_trip(config.contact, model.dof());
  config.check_torque_semantics = false;
  return config;
}

geometry::Shape box(const Vector3d& half_extents) {
  geometry::Shape s;
  s.kind = geometry::ShapeKind::kBox;
  s.half_extents = half_extents;
  return s;
}

Transform at(double x, double y, double z) {
  Transform T = Transform::Identity();
  T.translation() = Vector3d(x, y, z);
  return T;
}

// The lowest point of the base and the first link (which turns about the vertical through the
// base, so its lowest point does not move): what stands on the table.
double standing_floor(const RobotModel& model, const geometry::CollisionModel& geometry) {
  geometry::Scene probe;
  geometry::SafetyPlane plane{"probe", Vector3d::UnitZ(), -10.0, {}, {0.0, 0.1}};
  for (const auto& o : geometry.objects) {
    if (o.body <= 1) plane.links.push_back(o.link);
  }
  probe.planes.push_back(plane);
  const geometry::Proximity proximity(geometry, probe);
  geometry::ProximityData distances(proximity);
  Data data(model);
  forward_kinematics(model, data, VectorXd::Zero(model.dof()));
  geometry::compute_distances(proximity, data.T_body, distances);
  double floor = kInf;
  for (size_t p = 0; p < proximity.pairs().size(); ++p) {
    if (proximity.pairs()[p].kind == geometry::ProximityPair::kPlane) floor = std::min(floor, distances.distance[p].distance - 10.0);
  }
  return floor;
}

// The scene, `away` m further from the arm than where the trials meet it: a table (a slab whose top
// is 5 cm under what stands on it), a wall at y = 0.4 m, a post on the table in front of the arm,
// and a keep-in box for the tool.
geometry::Scene trial_scene(const ArmSpec& spec, double floor, double away) {
  geometry::Scene scene;
  const geometry::Clearance clearance{0.01, 0.10};
  scene.objects.push_back({"table", box({1.5, 1.5, 0.05}), at(0.0, 0.0, floor - 0.05 - 0.05 - away), clearance});
  scene.objects.push_back({"post", box({0.06, 0.06, 0.25}), at(0.45 + away, -0.30, floor + 0.25), clearance});
  scene.planes.push_back({"wall", -Vector3d::UnitY(), -(0.40 + away), {}, clearance});
  geometry::add_workspace_box(scene, "workspace", at(0.0, 0.0, 0.55), Vector3d(0.85, 0.85, 0.85) + Vector3d::Constant(away),
                              spec.tool_links, clearance);
  return scene;
}

// ---------------------------------------------------------------------------------------------
// The Judge: every pair's room at a configuration, apart from the controller's numbers.

struct Judge {
  enum Which { kAll, kSelf, kScene };
  Judge(const RobotModel& model_, const geometry::Proximity& proximity_)
      : model(model_), proximity(proximity_), distances(proximity_), data(model_) {}
  void at(const VectorXd& q) {
    forward_kinematics(model, data, q);
    geometry::compute_distances(proximity, data.T_body, distances);
  }
  /// The least distance less stop over the pairs `which`, at the q last given to at().
  double room(Which which = kAll, int* pair = nullptr) const {
    double least = kInf;
    for (size_t p = 0; p < proximity.pairs().size(); ++p) {
      const bool self = proximity.pairs()[p].kind == geometry::ProximityPair::kSelf;
      if ((which == kSelf && !self) || (which == kScene && self)) continue;
      const double room = distances.distance[p].distance - proximity.pairs()[p].clearance.stop;
      if (room < least) {
        least = room;
        if (pair != nullptr) *pair = static_cast<int>(p);
      }
    }
    return least;
  }
  double room_at(const VectorXd& q, Which which = kAll, int* pair = nullptr) {
    at(q);
    return room(which, pair);
  }
  /// The least distance less influence over every pair at q but those never 1 cm beyond it in
  /// 2,000 random configurations (the UR5's ee_link beside its wrist): > 0, beyond every influence.
  double beyond_influence(const VectorXd& q) {
    if (always_near.empty()) {
      always_near.assign(proximity.pairs().size(), true);
      std::mt19937 random(7);
      for (int k = 0; k < 2000; ++k) {
        VectorXd draw(model.dof());
        for (int i = 0; i < model.dof(); ++i) {
          const double lower = std::max(model.joint(i).limits.lower, -M_PI), upper = std::min(model.joint(i).limits.upper, M_PI);
          draw(i) = std::uniform_real_distribution<double>(lower, upper)(random);
        }
        at(draw);
        for (size_t p = 0; p < proximity.pairs().size(); ++p) {
          if (distances.distance[p].distance > proximity.pairs()[p].clearance.influence + 0.01) always_near[p] = false;
        }
      }
    }
    at(q);
    double least = kInf;
    for (size_t p = 0; p < proximity.pairs().size(); ++p) {
      if (always_near[p]) continue;
      least = std::min(least, distances.distance[p].distance - proximity.pairs()[p].clearance.influence);
    }
    return least;
  }
  std::string name(int pair) const {
    char out[128];
    proximity.name_pair(pair, out, sizeof(out));
    return out;
  }
  const RobotModel& model;
  const geometry::Proximity& proximity;
  geometry::ProximityData distances;
  Data data;
  std::vector<bool> always_near;
};

// ---------------------------------------------------------------------------------------------
// One arm: its model, geometry, scene and world, and the simulation of a trial.

enum Kind { kJog, kStream, kTrajectory };
const char* kKindNames[] = {"jog", "stream", "trajectory"};

struct Tally {
  int trials = 0, slowed = 0, failed = 0, refused = 0, cut = 0, completed = 0;
  int64_t states = 0;
};

struct Figures {
  Tally kind[3];
  double least_room = kInf;
  std::string least_pair;
  int below = 0;  // states below a stop distance
  int64_t faults = 0, reflexes = 0;
  double worst_closing = -kInf;
  std::vector<std::string> failures;  // a line per trial with a state below a stop distance, a reflex or a fault  // the largest closing speed at a trial's end beyond what its room allows, m/s
};

class ArmTrials {
 public:
  explicit ArmTrials(const ArmSpec& spec)
      : spec_(spec),
        model_(load_model(spec)),
        geometry_(load_geometry(spec, model_)),
        config_(trial_config(spec, model_)),
        floor_(standing_floor(model_, geometry_)),
        world_(make_world(model_, geometry_, trial_scene(spec, floor_, 0.0), {})),
        far_world_(make_world(model_, geometry_, trial_scene(spec, floor_, 5.0), {})),
        judge_(model_, world_->proximity),
        far_judge_(model_, far_world_->proximity),
        limits_(model_, config_.limits),
        lower_(model_.dof()),
        upper_(model_.dof()),
        state_(model_.dof()),
        data_(model_) {
    // Configurations are drawn within the limits less 0.1 rad, and within ±π.
    for (int i = 0; i < model_.dof(); ++i) {
      lower_(i) = std::max(limits_.lower(i) + 0.1, -M_PI);
      upper_(i) = std::min(limits_.upper(i) - 0.1, M_PI);
    }
    for (size_t p = 0; p < world_->proximity.pairs().size(); ++p) pair_names_.insert(judge_.name(static_cast<int>(p)));
    judge_.at(VectorXd::Zero(dof()));
    for (size_t p = 0; p < proximity().pairs().size(); ++p) {
      const double room = judge_.distances.distance[p].distance - proximity().pairs()[p].clearance.stop;
      const bool self = proximity().pairs()[p].kind == geometry::ProximityPair::kSelf;
      start_room_.push_back(self ? std::min(0.03, room - 0.005) : 0.03);
      if (start_room_.back() < 0.03) narrow_.push_back(judge_.name(static_cast<int>(p)));
    }
  }

  int dof() const { return model_.dof(); }
  const geometry::Proximity& proximity() const { return world_->proximity; }

  /// A random configuration within the draw's bounds.
  VectorXd draw(std::mt19937& random) const {
    VectorXd q(dof());
    for (int i = 0; i < dof(); ++i) q(i) = std::uniform_real_distribution<double>(lower_(i), upper_(i))(random);
    return q;
  }
  /// A random configuration with at least 3 cm of room on every pair (on a pair that never has
  /// that much, its room at q = 0 less 5 mm: the UR5's ee_link beside its wrist_2_link).
  VectorXd draw_clear(std::mt19937& random) {
    for (;;) {
      VectorXd q = draw(random);
      if (clear(q)) return q;
    }
  }
  bool clear(const VectorXd& q) {
    judge_.at(q);
    for (size_t p = 0; p < start_room_.size(); ++p) {
      if (judge_.distances.distance[p].distance - proximity().pairs()[p].clearance.stop < start_room_[p]) return false;
    }
    return true;
  }
  /// A random configuration `depth` inside the stop distance of a pair of `which` (the arm's own,
  /// the scene's), and clear of the other kind.
  VectorXd draw_colliding(std::mt19937& random, Judge::Which which) {
    for (int attempt = 0;; ++attempt) {
      VectorXd q = draw(random);
      judge_.at(q);
      // The other kind clear too, if that is found within 2,000 draws.
      if (judge_.room(which) < -0.02 && (attempt > 2000 || judge_.room(which == Judge::kSelf ? Judge::kScene : Judge::kSelf) > 0.0)) return q;
    }
  }

  // -------------------------------------------------------------------------------------------
  // A trial aimed at the arm's body or the scene.

  void trial(int index, Figures& figures) {
    const unsigned seed = 1000u * static_cast<unsigned>(spec_.index + 1) + static_cast<unsigned>(index);
    std::mt19937 random(seed);
    const Kind kind = static_cast<Kind>(index % 3);
    const Judge::Which aim = std::bernoulli_distribution(0.5)(random) ? Judge::kSelf : Judge::kScene;
    const VectorXd start = draw_clear(random);

    Controller controller(model_, config_);
    ASSERT_TRUE(controller.set_clearance_world(world_.get()));
    begin(controller, start);
    Tally& tally = figures.kind[kind];
    ++tally.trials;
    bool slowed = false;
    below_ = false;
    // Every state judged: its room on every pair; the controller's mode.
    const auto judge_state = [&] {
      ++tally.states;
      int pair = -1;
      const double room = judge_.room_at(state_.q, Judge::kAll, &pair);
      if (room < figures.least_room) figures.least_room = room, figures.least_pair = judge_.name(pair);
      if (controller.clearance().slowing >= 0) slowed = true;
      if (std::getenv("CHASLES_TRIAL_TRACE") != nullptr) {
        const VectorXd& rqd = controller.reference().qd;
        int j = 0;
        const double over = (state_.qd.cwiseAbs().array() / limits_.velocity.array()).maxCoeff(&j);
        std::printf("tick %lld room %.5f %s mode %s slowing %d kept %.3f ref|qd|/v %.3f state|qd|/v %.3f (joint %d) ref qdd %.1f\n",
                    static_cast<long long>((now_ - begun_) / kMs), room, judge_.name(pair).c_str(), to_string(controller.mode()),
                    controller.clearance().slowing, controller.clearance().kept,
                    (rqd.cwiseAbs().array() / limits_.velocity.array()).maxCoeff(), over, j, controller.reference().qdd.cwiseAbs().maxCoeff());
      }
      if (room < 0.0) {
        ++figures.below;
        if (!below_) {
          char line[256];
          std::snprintf(line, sizeof(line), "first below at tick %lld: %s, room %.3g m", static_cast<long long>((now_ - begun_) / kMs),
                        judge_.name(pair).c_str(), room);
          first_below_ = line;
        }
        below_ = true;
      }
    };

    int64_t sent = 0, refused = 0;
    if (kind == kJog) {
      // A jog held 1–2 s, its direction toward a configuration in collision: in joint space, or the
      // tip's velocity toward where that configuration puts the tip (base frame).
      const VectorXd target = draw_colliding(random, aim);
      const double hold = std::uniform_real_distribution<double>(1.0, 2.0)(random);
      Jog jog(dof());
      if (std::bernoulli_distribution(0.5)(random)) {
        jog.kind = Jog::kJointVelocity;
        const VectorXd step = target - start;
        // Reaching it in 0.6–1.2 s, at most 1 rad/s on any joint.
        const double time = std::uniform_real_distribution<double>(0.6, 1.2)(random);
        jog.joint_velocity = step / std::max(time, step.cwiseAbs().maxCoeff() / 1.0);
      } else {
        jog.kind = Jog::kTwist;
        jog.frame = Jog::kBase;
        const Vector3d from = forward_kinematics_space(model_, start).translation();
        const Vector3d to = forward_kinematics_space(model_, target).translation();
        const double speed = std::uniform_real_distribution<double>(0.1, 0.3)(random);
        Vector3d w;
        for (int i = 0; i < 3; ++i) w(i) = std::uniform_real_distribution<double>(-0.3, 0.3)(random);
        jog.twist << w, speed * (to - from).normalized();
      }
      const int64_t end = now_ + static_cast<int64_t>(hold * 1e9);
      while (now_ < end) {
        if ((now_ - begun_) % (30 * kMs) == 0) {
          jog.utime = ++utime_;
          ++sent;
          if (!controller.set_jog(jog, now_)) ++refused;
        }
        step(controller);
        judge_state();
      }
    } else if (kind == kStream) {
      // Joint setpoints at 100 Hz along the line to a configuration in collision, reached in
      // 0.8–1.5 s, then held until 2 s.
      const VectorXd target = draw_colliding(random, aim);
      const double time = std::uniform_real_distribution<double>(0.8, 1.5)(random);
      Setpoint setpoint(dof());
      for (int k = 0; k < 2000; ++k) {
        if (k % 10 == 0) {
          setpoint.utime = ++utime_;
          setpoint.q = start + std::min(1.0, k * 1e-3 / time) * (target - start);
          ++sent;
          if (!controller.set_setpoint(setpoint, now_)) ++refused;
        }
        step(controller);
        judge_state();
      }
    } else {
      // A trajectory from the start to a clear goal within ±1.2 rad per joint, along a line that
      // passes through a collision (of the kind aimed at, if one is found in 200 draws) or, in
      // every other trial, grazes one: its least room on the way within 2 cm. Four waypoints
      // along the line, timed at half the joints' speed, slowed to fit if need be. Through a
      // collision it is refused before anything moves (the spline checked against the world),
      // naming the pair; grazing one it runs, and is cut where it closes too fast on it: it ends
      // in a brake, the pair named.
      const bool through = index % 2 == 0;
      VectorXd goal(dof());
      for (int attempt = 0;; ++attempt) {
        for (int i = 0; i < dof(); ++i) {
          goal(i) = std::clamp(start(i) + std::uniform_real_distribution<double>(-1.2, 1.2)(random), lower_(i), upper_(i));
        }
        if (!clear(goal)) continue;
        double deepest = kInf;
        for (int k = 1; k < 20; ++k) deepest = std::min(deepest, judge_.room_at(start + k / 20.0 * (goal - start), attempt < 200 ? aim : Judge::kAll));
        // (A grazing line not found in 5,000 draws: one through a collision; neither in 20,000:
        // one that comes within 2 cm of something, or at last any.)
        if (attempt > 40000 || (attempt > 20000 && deepest < 0.02)) break;
        if (through || attempt > 5000 ? deepest < -0.02 : deepest >= 0.0 && deepest < 0.02) break;
      }
      motion::Waypoints w(dof());
      w.count = 4;
      w.id = seed;
      w.time_scaling = true;
      double duration = 0.0;
      for (int i = 0; i < dof(); ++i) duration = std::max(duration, std::abs(goal(i) - start(i)) / (0.5 * limits_.velocity(i)));
      duration = std::max(duration, 0.8);
      for (int k = 0; k < 4; ++k) {
        w.q.col(k) = start + (k + 1) / 4.0 * (goal - start);
        w.time(k) = (k + 1) / 4.0 * duration;
      }
      const std::string what = std::string(spec_.name) + " trajectory trial " + std::to_string(index) + " (seed " + std::to_string(seed) + ")";
      const auto names_a_pair = [&](const std::string& text, const char* prefix) {
        for (const std::string& pair : pair_names_) {
          if (text.rfind(prefix + pair + " ", 0) == 0 || text == prefix + pair) return true;
        }
        return false;
      };
      if (!controller.set_trajectory(w, now_)) {
        // Refused before anything moved, naming the pair; the arm holds where it was.
        ++tally.refused;
        const std::string rejection = controller.last_rejection();
        EXPECT_TRUE(names_a_pair(rejection, ("trajectory " + std::to_string(seed) + ": ").c_str())) << what << ": " << rejection;
        EXPECT_NE(rejection.find("would come within its stop distance"), std::string::npos) << what << ": " << rejection;
        for (int k = 0; k < 100; ++k) step(controller), judge_state();
        EXPECT_EQ(controller.mode(), Mode::kHolding) << what;
      } else {
        // Until it ended and the arm holds, 3 s at most.
        const int64_t end = now_ + 3000 * kMs;
        while (now_ < end && (controller.trajectory().outcome == TrajectoryProgress::kActive || controller.mode() == Mode::kRunning)) {
          step(controller);
          judge_state();
        }
        const TrajectoryProgress& p = controller.trajectory();
        EXPECT_EQ(controller.mode(), Mode::kHolding) << what;
        if (p.outcome == TrajectoryProgress::kSucceeded) {
          ++tally.completed;
        } else {
          // Cut: ended in a brake, the reason naming the pair.
          EXPECT_EQ(p.outcome, TrajectoryProgress::kAborted) << what << ": " << to_string(p.outcome) << " " << p.message;
          EXPECT_TRUE(names_a_pair(controller.last_rejection(), "the motion stopped short: ")) << what << ": " << controller.last_rejection();
          EXPECT_TRUE(names_a_pair(p.message, "stopped short: ")) << what << ": " << p.message;
          ++tally.cut;
        }
      }
    }
    if (failed_ = below_ || controller.faults() > 0 || controller.reflexes() > 0; failed_) {
      char line[512];
      std::snprintf(line, sizeof(line), "%s %s trial %d (seed %u, aimed at %s): %s; %lld reflexes (%s), %lld faults (%s)",
                    spec_.name, kKindNames[kind], index, seed, aim == Judge::kSelf ? "itself" : "the scene",
                    below_ ? first_below_.c_str() : "no state below a stop distance", static_cast<long long>(controller.reflexes()),
                    controller.reflex_reason(), static_cast<long long>(controller.faults()), controller.fault_reason());
      figures.failures.push_back(line);
      ++tally.failed;
    }
    // (After a reflex the stream's messages are refused: that trial is reported as failed above.)
    if (!failed_) {
      EXPECT_EQ(refused, 0) << spec_.name << " " << kKindNames[kind] << " trial " << index << ": " << controller.last_rejection();
    }
    if (slowed) ++tally.slowed;
    figures.faults += controller.faults();
    figures.reflexes += controller.reflexes();
    // At the end, nothing near is being closed on faster than its room allows: ḋ ≥ −(d − d_s)/τ
    // for every pair within its influence (by central differences along q̇), less 5 cm/s: the
    // state's velocity lags the reference's (the PD at ω = 20 rad/s), so it may still close a
    // little faster than the reference does for a few ticks after a cut (2.3 cm/s at most in the
    // 1,000 trials). At rest, or moving tangentially, along whatever it is held against.
    const double closing = worst_closing(config_.clearance);
    figures.worst_closing = std::max(figures.worst_closing, closing);
    if (!failed_) {
      EXPECT_LE(closing, 0.05) << spec_.name << " " << kKindNames[kind] << " trial " << index << " (seed " << seed
                              << "): closing on a pair at its end";
    }
  }

  // -------------------------------------------------------------------------------------------
  // Far from everything: with the world and without, bit for bit.

  /// Returns false when the trial came within a pair's influence (not far from everything: not
  /// counted).
  bool free_trial(int index, int& ticks) {
    const unsigned seed = 500000u + 1000u * static_cast<unsigned>(spec_.index) + static_cast<unsigned>(index);
    std::mt19937 random(seed);
    const Kind kind = static_cast<Kind>(index % 3);
    VectorXd start;
    do start = draw(random);
    while (far_judge_.beyond_influence(start) < 0.01);
    Controller with(model_, config_), without(model_, config_);
    EXPECT_TRUE(with.set_clearance_world(far_world_.get()));
    state_.q = start;
    state_.qd.setZero();
    state_.effort = chasles::testing::gravity_of(model_, start);
    begun_ = now_;
    bool far = true;
    const auto both = [&](const auto& send) {
      send(with);
      send(without);
      now_ += kMs;
      ++state_.seq;
      state_.arrival_ns = now_;
      EXPECT_TRUE(with.tick(now_, &state_));
      EXPECT_TRUE(without.tick(now_, &state_));
      EXPECT_EQ(with.reference().q, without.reference().q) << spec_.name << " free trial " << index << " tick " << ticks;
      EXPECT_EQ(with.reference().qd, without.reference().qd) << spec_.name << " free trial " << index << " tick " << ticks;
      EXPECT_EQ(with.reference().qdd, without.reference().qdd) << spec_.name << " free trial " << index << " tick " << ticks;
      EXPECT_EQ(with.torque(), without.torque()) << spec_.name << " free trial " << index << " tick " << ticks;
      EXPECT_EQ(with.mode(), without.mode());
      EXPECT_EQ(with.clearance().slowing, -1) << spec_.name << " free trial " << index << " tick " << ticks;
      integrate(with);
      if (far_judge_.beyond_influence(state_.q) <= 0.0 || far_judge_.beyond_influence(with.reference().q) <= 0.0) far = false;
      ++ticks;
    };
    both([](Controller&) {});
    EXPECT_EQ(with.mode(), Mode::kHolding) << with.reflex_reason();
    if (with.mode() != Mode::kHolding) return false;
    // A random direction (not aimed), moderate.
    VectorXd direction(dof());
    for (int i = 0; i < dof(); ++i) direction(i) = std::uniform_real_distribution<double>(-0.4, 0.4)(random);
    if (kind == kJog) {
      Jog jog(dof());
      if (std::bernoulli_distribution(0.5)(random)) {
        jog.kind = Jog::kJointVelocity;
        jog.joint_velocity = direction;
      } else {
        jog.kind = Jog::kTwist;
        jog.frame = std::bernoulli_distribution(0.5)(random) ? Jog::kBase : Jog::kTool;
        for (int i = 0; i < 6; ++i) jog.twist(i) = std::uniform_real_distribution<double>(-0.2, 0.2)(random);
      }
      for (int k = 0; k < 1000 && !::testing::Test::HasFailure(); ++k) {
        both([&](Controller& c) {
          if (k % 30 != 0) return;
          jog.utime = utime_ + 1;
          if (!c.set_jog(jog, now_) && &c == &with) ++refused_free_;
        });
        if (k % 30 == 0) ++utime_;
      }
    } else if (kind == kStream) {
      Setpoint setpoint(dof());
      for (int k = 0; k < 1000 && !::testing::Test::HasFailure(); ++k) {
        both([&](Controller& c) {
          if (k % 10 != 0) return;
          setpoint.utime = utime_ + 1;
          setpoint.q = start + std::min(1.0, k / 800.0) * direction;
          if (!c.set_setpoint(setpoint, now_) && &c == &with) ++refused_free_;
        });
        if (k % 10 == 0) ++utime_;
      }
    } else {
      motion::Waypoints w(dof());
      w.count = 3;
      w.time_scaling = true;
      for (int k = 0; k < 3; ++k) {
        w.q.col(k) = (start + (k + 1) / 3.0 * direction).cwiseMax(lower_).cwiseMin(upper_);
        w.time(k) = (k + 1) * 0.3;
      }
      both([&](Controller& c) { EXPECT_TRUE(c.set_trajectory(w, now_)) << c.last_rejection(); });
      for (int k = 0; k < 1000 && !::testing::Test::HasFailure(); ++k) both([](Controller&) {});
    }
    if (with.reflexes() > 0) {
      std::printf("[ clearance trials ] %s free trial %d (seed %u): a reflex, with and without the world alike: %s\n", spec_.name, index,
                  seed, with.reflex_reason());
      ++reflexes_free_;
    }
    return far;
  }
  int refused_free_ = 0, reflexes_free_ = 0;

  const ArmSpec& spec() const { return spec_; }

 private:
  void begin(Controller& controller, const VectorXd& start) {
    state_.q = start;
    state_.qd.setZero();
    state_.effort = chasles::testing::gravity_of(model_, start);
    begun_ = now_;
    now_ += kMs;
    ++state_.seq;
    state_.arrival_ns = now_;
    ASSERT_TRUE(controller.tick(now_, &state_));
    ASSERT_EQ(controller.mode(), Mode::kHolding) << controller.reflex_reason();
  }
  void step(Controller& controller) {
    now_ += kMs;
    ++state_.seq;
    state_.arrival_ns = now_;
    controller.tick(now_, &state_);
    integrate(controller);
  }
  /// The arm: the model itself under the command, semi-implicit Euler in substeps.
  void integrate(const Controller& controller) {
    constexpr int kSubsteps = 10;
    constexpr double h = 1e-3 / kSubsteps;
    for (int s = 0; s < kSubsteps; ++s) {
      state_.qd += h * forward_dynamics(model_, data_, state_.q, state_.qd, controller.torque());
      state_.q += h * state_.qd;
    }
    state_.effort = controller.torque();
  }
  /// The largest ḋ + (d − d_s)/τ of a pair within its influence at the state (≤ 0: none closes
  /// faster than the damper allows), m/s.
  double worst_closing(const ClearanceConfig& c) {
    const double h = 1e-4;
    judge_.at(state_.q + h * state_.qd);
    const std::vector<geometry::PairDistance> plus = judge_.distances.distance;
    judge_.at(state_.q - h * state_.qd);
    const std::vector<geometry::PairDistance> minus = judge_.distances.distance;
    judge_.at(state_.q);
    double worst = -kInf;
    for (size_t p = 0; p < proximity().pairs().size(); ++p) {
      const geometry::PairDistance& d = judge_.distances.distance[p];
      if (!d.exact || d.distance >= proximity().pairs()[p].clearance.influence) continue;
      const double rate = (plus[p].distance - minus[p].distance) / (2 * h);
      const double room = std::max(0.0, d.distance - proximity().pairs()[p].clearance.stop);
      worst = std::max(worst, -rate - room / c.time_constant);
    }
    return worst;
  }

  ArmSpec spec_;
  RobotModel model_;
  geometry::CollisionModel geometry_;
  Config config_;
  double floor_;
  std::shared_ptr<ClearanceWorld> world_, far_world_;
  Judge judge_, far_judge_;
  motion::MotionLimits limits_;
  VectorXd lower_, upper_;
  std::set<std::string> pair_names_;
  std::vector<double> start_room_;  // the least room a trial starts with, per pair
  bool below_ = false, failed_ = false;
  std::string first_below_;
 public:
  std::vector<std::string> narrow_;  // the pairs that start with less than 3 cm
 private:
  JointState state_;
  Data data_;
  int64_t now_ = 0, begun_ = 0, utime_ = 0;
};

// The arm's share of the trials: 334, 333, 333 of 1,000 (34, 33, 33 of 100).
int share(int total, int arm) { return total / 3 + (arm < total % 3 ? 1 : 0); }

void run_trials(const ArmSpec& spec) {
  ArmTrials arm(spec);
  const int trials = share(long_trials() ? kAllTrials : kDefaultTrials, spec.index);
  const int only = only_trial();
  Figures figures;
  const auto began = std::chrono::steady_clock::now();
  for (int i = 0; i < trials; ++i) {
    if (only >= 0 && i != only) continue;
    arm.trial(i, figures);
    if (::testing::Test::HasFatalFailure()) return;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  int64_t states = 0;
  for (const Tally& t : figures.kind) states += t.states;
  std::printf("[ clearance trials ] %s: %d objects, %zu pairs (%d self); %d trials%s in %.1f s (%lld states)\n", spec.name,
              static_cast<int>(arm.proximity().arm().objects.size()), arm.proximity().pairs().size(),
              static_cast<int>(arm.proximity().arm().pairs.size()), figures.kind[0].trials + figures.kind[1].trials + figures.kind[2].trials,
              long_trials() ? " (CHASLES_LONG_TRIALS)" : "", seconds, static_cast<long long>(states));
  for (int k = 0; k < 3; ++k) {
    const Tally& t = figures.kind[k];
    const std::string outcomes = k == kTrajectory ? ", " + std::to_string(t.refused) + " refused naming the pair, " + std::to_string(t.cut) +
                                                         " cut and braked to HOLDING, " + std::to_string(t.completed) + " completed"
                                                   : "";
    std::printf("[ clearance trials ]   %-10s %4d trials, %4d slowed, %4d failed%s\n", kKindNames[k], t.trials, t.slowed, t.failed,
                outcomes.c_str());
  }
  std::printf("[ clearance trials ]   least room %.5f m (%s); %d states below a stop distance, %lld reflexes, %lld "
              "faults; at the ends, the worst closing beyond the damper's rate %.2g m/s\n",
              figures.least_room, figures.least_pair.c_str(), figures.below, static_cast<long long>(figures.reflexes),
              static_cast<long long>(figures.faults), figures.worst_closing);
  for (const std::string& failure : figures.failures) std::printf("[ clearance trials ]   FAILED %s\n", failure.c_str());
  EXPECT_EQ(figures.below, 0);
  EXPECT_EQ(figures.faults, 0);
  EXPECT_EQ(figures.reflexes, 0);
  EXPECT_GE(figures.least_room, 0.0);
}

void run_free_trials(const ArmSpec& spec) {
  ArmTrials arm(spec);
  const int trials = long_trials() ? 30 : 6;
  int far = 0, near = 0, ticks = 0;
  for (int i = 0; far < trials && i < 10 * trials; ++i) {
    (arm.free_trial(i, ticks) ? far : near) += 1;
    if (::testing::Test::HasFailure()) return;
  }
  std::printf("[ clearance trials ] %s far from everything: %d trials (%d more came within an influence and were not "
              "counted), %d ticks bit-identical to no world\n",
              spec.name, far, near, ticks);
  EXPECT_EQ(far, trials);
}

TEST(ClearanceTrials, PandaNeverBelowAStopDistance) { run_trials(kPanda); }
TEST(ClearanceTrials, Ur5NeverBelowAStopDistance) { run_trials(kUr5); }
TEST(ClearanceTrials, IiwaNeverBelowAStopDistance) { run_trials(kIiwa); }

TEST(ClearanceTrials, PandaFarFromEverythingMovesExactlyAsWithoutAWorld) { run_free_trials(kPanda); }
TEST(ClearanceTrials, Ur5FarFromEverythingMovesExactlyAsWithoutAWorld) { run_free_trials(kUr5); }
TEST(ClearanceTrials, IiwaFarFromEverythingMovesExactlyAsWithoutAWorld) { run_free_trials(kIiwa); }

}  // namespace
}  // namespace chasles::controller
