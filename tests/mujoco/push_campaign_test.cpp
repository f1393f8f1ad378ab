// The push campaign of issue [U], a long run (label long; tools/test.sh -L long): the controller,
// unchanged, on MuJoCo's plant in simulated time, its locator thread on, and MuJoCo's ball pushing
// random points of random links with 5–40 N — the Panda and the UR5, held at rest and following
// joint moves. Each push is judged against MuJoCo's own contacts: flagged as a contact when it
// reached 10 N, within 10 ms of it; the link; the point within 2 cm median and 5 cm p90; the force
// within 10 %. And ten minutes of the same moves without a push: no contact flagged at all.
//
// What a push is: a point drawn on a link's collision surface (its samples, 1 cm apart), the ball
// put just outside it on a line within 30° of the inward normal and pushed along that line with a
// constant force (MujocoPlant::press) for 300 ms, then taken away for 400 ms. A line that meets another part first is drawn again. A push the arm
// slides out of (moving, the ball stays on its line in space) is counted apart, not judged.
#include <gtest/gtest.h>

#include <chasles/contact_estimate_t.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/contact_locator.hpp"
#include "core/kinematics/kinematics.hpp"
#include "lcmtypes/checked.hpp"
#include "tests/support/arm.hpp"
#include "tests/support/reference.hpp"
#include "tools/mujoco/mujoco_plant.hpp"
#include "wires.hpp"
#include "world.hpp"

namespace chasles::faults {
namespace {

using controller::DaemonOptions;
using controller::Mode;
using Eigen::VectorXd;

struct Arm {
  const char* name;
  const RobotModel& model;
  std::string urdf;
  geometry::CollisionModel geometry;
  VectorXd rest, a, b;  // where it is held, and the two poses it moves between
};

Arm panda_arm() {
  const RobotModel& model = chasles::testing::panda();
  const std::string urdf = chasles::testing::data_path("panda.urdf");
  VectorXd rest(7), a(7), b(7);
  rest << 0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8;
  a << 0.4, -0.1, 0.2, -1.9, 0.2, 1.8, 0.5;
  b << -0.4, -0.5, -0.2, -2.4, -0.2, 2.2, 1.1;
  return {"panda", model, urdf,
          geometry::load_collision_model(urdf, model, {{chasles::testing::data_path("packages")}, ""}), rest, a, b};
}

Arm ur5_arm() {
  const RobotModel& model = chasles::testing::ur5();
  const std::string urdf = chasles::testing::data_path("ur5.urdf");
  VectorXd rest(6), a(6), b(6);
  rest << 0.0, -1.2, 1.4, -1.8, -1.57, 0.0;
  a << 0.4, -1.0, 1.2, -1.6, -1.3, 0.3;
  b << -0.4, -1.4, 1.6, -2.0, -1.8, -0.3;
  return {"ur5", model, urdf,
          geometry::load_collision_model(urdf, model, {{chasles::testing::data_path("packages")}, ""}), rest, a, b};
}

// The controller as the campaign runs it: chasles's protocol at 1 kHz, the locator on, every
// contact threshold at its default and no collision (a reflex would end the moves it is judged in).
DaemonOptions campaign_options(const Arm& arm) {
  const Wire wire{controller::Protocol::kChasles, 1000.0};
  DaemonOptions o = controller_on(wire);
  const int n = arm.model.dof();
  o.control = controller::Config::critically_damped(n, 20.0);
  o.control.damping = VectorXd::Constant(n, 0.5);
  o.control.period = wire.period();
  o.control.stale_ns = wire.stale_ns();
  o.control.contact.collision_torque = VectorXd::Constant(n, kInf);
  o.control.contact.collision_force = o.control.contact.collision_moment = kInf;
  o.arm = arm.geometry;
  return o;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

struct Figures {
  int pushes = 0, strong = 0, flagged = 0, right_link = 0, slid_off = 0, false_contacts = 0;
  std::vector<double> point_error, force_error, latency_ms;
  std::vector<std::string> misses;  // "truth → found" for the wrong links
  void add(const Figures& f) {
    pushes += f.pushes, strong += f.strong, flagged += f.flagged, right_link += f.right_link;
    slid_off += f.slid_off, false_contacts += f.false_contacts;
    point_error.insert(point_error.end(), f.point_error.begin(), f.point_error.end());
    force_error.insert(force_error.end(), f.force_error.begin(), f.force_error.end());
    latency_ms.insert(latency_ms.end(), f.latency_ms.begin(), f.latency_ms.end());
    misses.insert(misses.end(), f.misses.begin(), f.misses.end());
  }
  void print(const char* what) const {
    std::printf("[ campaign ] %s: %d pushes judged (%d slid off), %d of %d at 10 N flagged; right link %d (%.1f %%); "
                "point median %.1f mm, p90 %.1f mm; force error median %.1f %%, p90 %.1f %%; latency median %.1f ms, "
                "max %.1f ms; %d false contacts\n",
                what, pushes, slid_off, flagged, strong, right_link, 100.0 * right_link / std::max(1, pushes),
                1e3 * percentile(point_error, 0.5), 1e3 * percentile(point_error, 0.9),
                100 * percentile(force_error, 0.5), 100 * percentile(force_error, 0.9), percentile(latency_ms, 0.5),
                latency_ms.empty() ? std::nan("") : *std::max_element(latency_ms.begin(), latency_ms.end()),
                false_contacts);
  }
};

// The truth of one step: the contacts' total force and their force-weighted point, the link
// pressed most.
struct Touch {
  Vector3d force = Vector3d::Zero(), point = Vector3d::Zero();
  std::string link;
};
Touch touch_of(const plant::Truth& truth) {
  Touch t;
  double weight = 0.0, most = 0.0;
  for (const plant::ArmContact& c : truth.contacts) {
    t.force += c.force;
    t.point += c.force.norm() * c.point;
    weight += c.force.norm();
    if (c.force.norm() > most) most = c.force.norm(), t.link = c.link;
  }
  if (weight > 0.0) t.point /= weight;
  return t;
}

// The moves: a to b and back, 2 s each, the next sent when the arm holds after the last (a target
// takes effect at the next tick: until it is RUNNING, the arm still holds for the last one).
struct Mover {
  Mover(World& w, const Arm& a) : world(w), arm(a) {}
  void step() {
    const Mode mode = world.controller().controller().mode();
    if (sent && mode != Mode::kRunning) return;
    sent = false;
    if (mode != Mode::kHolding) return;
    world.send_joint_target(moves % 2 == 0 ? arm.a : arm.b, 2.0);
    sent = true;
    ++moves;
  }
  World& world;
  const Arm& arm;
  bool sent = false;  // a target sent, not yet RUNNING
  int moves = 0;
};

// `pushes` pushes on `arm`, at rest or moving, drawn from `seed`.
Figures campaign(const Arm& arm, bool moving, int pushes, uint64_t seed) {
  const RobotModel& model = arm.model;
  World world(model, controller::Protocol::kChasles);
  std::vector<contact_estimate_t> heard;
  const controller::Bus::Subscription subscription =
      world.bus().subscribe("CHASLES_CONTACT", [&](const uint8_t* data, size_t size) {
        contact_estimate_t m;
        if (messages::decode_checked(data, size, m, messages::kAnyArm, messages::Finite::Required).empty()) {
          heard.push_back(m);
        }
      });
  auto engine = std::make_unique<plant::MujocoPlant>(model, arm.urdf, arm.geometry, plant::MujocoScene{}, arm.rest,
                                                     VectorXd::Constant(model.dof(), 0.5), 1e-3);
  plant::MujocoPlant& plant = *engine;
  world.start_plant(std::move(engine), plant_on(Wire{controller::Protocol::kChasles, 1000.0}));
  world.add_controller(campaign_options(arm));
  EXPECT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  const controller::Controller& c = world.controller().controller();

  Mover mover(world, arm);
  auto keep_moving = [&] {
    if (moving) mover.step();
  };

  // The objects a push may aim at: on the chain, beyond the base.
  std::vector<const geometry::CollisionObject*> targets;
  for (const geometry::CollisionObject& object : arm.geometry.objects) {
    if (object.body > 0 && std::any_of(model.links().begin(), model.links().end(),
                                       [&](const ChainLink& l) { return l.name == object.link; })) {
      targets.push_back(&object);
    }
  }
  Data data(model);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Figures f;
  int drawn = 0;
  while (f.pushes + f.slid_off < pushes && drawn < 20 * pushes) {
    ++drawn;
    const geometry::CollisionObject& object = *targets[std::uniform_int_distribution<size_t>(0, targets.size() - 1)(rng)];
    Transform T_body_link;
    for (const ChainLink& l : model.links())
      if (l.name == object.link) T_body_link = l.T_body_link;
    // A point of the object's surface, drawn from its samples, pressed within 30° of its inward
    // normal.
    std::vector<Vector3d> points, normals;
    geometry::sample_surface(object.shape, 0.01, points, normals);
    const size_t k = std::uniform_int_distribution<size_t>(0, points.size() - 1)(rng);
    const Transform T_link_object = Transform(T_body_link.linear().transpose(),
                                              -(T_body_link.linear().transpose() * T_body_link.translation())) *
                                    object.T_body_object;
    const Vector3d aim = T_link_object * points[k];
    forward_kinematics(model, data, plant.q());
    const Vector3d inward = -(data.T_body[static_cast<size_t>(object.body)].linear() *
                              (object.T_body_object.linear() * normals[k]));
    Vector3d askew = Vector3d(unit(rng), unit(rng), unit(rng));
    askew -= askew.dot(inward) * inward;
    const double tilt = std::tan(0.5236 * (0.5 + 0.5 * unit(rng)));  // up to 30°
    const Vector3d direction = (inward + tilt * (askew.norm() > 1e-9 ? askew.normalized() : Vector3d::Zero())).normalized();
    const double force = 5.0 + 35.0 * (0.5 + 0.5 * unit(rng));
    try {
      plant.press(object.link, aim, direction, force);
    } catch (const ArgumentError&) {
      continue;  // the line meets another part first: draw again
    }
    // Pressed for 300 ms: when the truth first reached 10 N, when a located contact was first
    // flagged, and the last estimate against the truth at its step.
    const size_t first_heard = heard.size();
    int64_t reached_ns = -1, flagged_ns = -1;
    double peak = 0.0;
    Touch at_last, at_end;
    contact_estimate_t last{};
    bool located = false;
    size_t seen = first_heard;
    world.run_until(
        [&] {
          keep_moving();
          at_end = touch_of(world.plant()->truth());
          peak = std::max(peak, at_end.force.norm());
          if (reached_ns < 0 && at_end.force.norm() >= 10.0) reached_ns = world.now();
          for (; seen < heard.size(); ++seen) {
            if (flagged_ns < 0 && heard[seen].contact) flagged_ns = world.now();
            if (heard[seen].state == contact_estimate_t::LOCATED) last = heard[seen], at_last = at_end, located = true;
          }
          // The controller's own flag too: a joint's or the tip's contact threshold crossed.
          if (flagged_ns < 0 && c.contact().contact) flagged_ns = world.now();
          return false;
        },
        0.3);
    plant.release();
    // Judged when the ball still pressed at the end with half its force or more; the estimate held
    // against the truth of the step it was found at.
    if (at_end.link.empty() || at_end.force.norm() < 0.5 * force) {
      ++f.slid_off;
    } else {
      ++f.pushes;
      if (peak >= 10.0) {
        ++f.strong;
        if (flagged_ns >= 0) {
          ++f.flagged;
          f.latency_ms.push_back(1e-6 * static_cast<double>(flagged_ns - reached_ns));
        } else {
          f.misses.push_back(at_end.link + ": a push of " + std::to_string(peak) + " N never flagged");
        }
      }
      if (!located) {
        f.misses.push_back(at_end.link + " → not located (|τ_ext| " +
                           std::to_string(world.plant()->truth().tau_ext.norm()) + " N·m)");
        f.point_error.push_back(kInf);
        f.force_error.push_back(kInf);
      } else {
        if (last.link == at_last.link) {
          ++f.right_link;
        } else {
          f.misses.push_back(at_last.link + " → " + last.link);
        }
        f.point_error.push_back((Vector3d(last.point) - at_last.point).norm());
        f.force_error.push_back((Vector3d(last.force) - at_last.force).norm() / at_last.force.norm());
      }
    }
    // 400 ms away: once the truth has had no contact for 50 ms (ten of the observer's lags), any
    // contact flagged is a false one.
    int64_t free_since = -1;
    size_t checked = heard.size();
    world.run_until(
        [&] {
          keep_moving();
          if (!world.plant()->truth().contacts.empty()) {
            free_since = -1;
          } else if (free_since < 0) {
            free_since = world.now();
          }
          for (; checked < heard.size(); ++checked) {
            if (free_since >= 0 && world.now() - free_since >= 50'000'000 && heard[checked].contact) ++f.false_contacts;
          }
          return false;
        },
        0.4);
  }
  EXPECT_EQ(f.pushes + f.slid_off, pushes) << "drew " << drawn << " lines for " << pushes << " pushes";
  EXPECT_EQ(c.faults(), 0);
  return f;
}

class PushCampaign : public ::testing::TestWithParam<bool> {};

// 50 pushes each: the Panda and the UR5, at rest (false) and moving (true).
TEST_P(PushCampaign, EveryPushIsFlaggedAndFoundOnItsLink) {
  const bool moving = GetParam();
  Figures all;
  uint64_t seed = moving ? 2017 : 2016;
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    const Figures f = campaign(arm, moving, 50, seed++);
    char what[64];
    std::snprintf(what, sizeof(what), "%s %s", arm.name, moving ? "moving" : "at rest");
    f.print(what);
    for (const std::string& m : f.misses) std::printf("    wrong link: %s\n", m.c_str());
    all.add(f);
  }
  all.print(moving ? "both arms moving" : "both arms at rest");
  EXPECT_EQ(all.flagged, all.strong);
  EXPECT_GE(all.right_link, 0.95 * all.pushes);
  EXPECT_LE(percentile(all.point_error, 0.5), 0.02);
  EXPECT_LE(percentile(all.point_error, 0.9), 0.05);
  EXPECT_LE(percentile(all.force_error, 0.9), 0.10);
  EXPECT_LE(percentile(all.latency_ms, 1.0), 10.0);
  EXPECT_EQ(all.false_contacts, 0);
}

// Ten minutes of the moves on each arm, nothing touching it: not one contact, by the locator or the
// thresholds.
TEST(PushCampaign, TenMinutesOfMovesWithoutAPushFlagNoContact) {
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    World world(arm.model, controller::Protocol::kChasles);
    int64_t located = 0;
    double peak_located = 0.0;
    const controller::Bus::Subscription subscription =
        world.bus().subscribe("CHASLES_CONTACT", [&](const uint8_t* data, size_t size) {
          contact_estimate_t m;
          if (messages::decode_checked(data, size, m, messages::kAnyArm, messages::Finite::Required).empty()) {
            located += m.contact;
            peak_located = std::max(peak_located, Vector3d(m.force).norm());
          }
        });
    world.start_plant(std::make_unique<plant::MujocoPlant>(arm.model, arm.urdf, arm.geometry, plant::MujocoScene{},
                                                           arm.rest, VectorXd::Constant(arm.model.dof(), 0.5), 1e-3),
                      plant_on(Wire{controller::Protocol::kChasles, 1000.0}));
    world.add_controller(campaign_options(arm));
    ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
    const controller::Controller& c = world.controller().controller();
    Mover mover(world, arm);
    double peak_tau = 0.0;
    world.run_until(
        [&] {
          mover.step();
          peak_tau = std::max(peak_tau, c.contact().tau_ext.norm());
          return false;
        },
        600.0);
    const int moves = mover.moves;
    std::printf("[ campaign ] %s: 10 min of moves, %d moves: %lld located contacts (largest located force %.2f N), "
                "%lld contacts by the thresholds, peak |τ̂| %.3f N·m\n",
                arm.name, moves, static_cast<long long>(located), peak_located, static_cast<long long>(c.contacts()),
                peak_tau);
    EXPECT_GE(moves, 250);
    EXPECT_EQ(located, 0);
    EXPECT_EQ(c.contacts(), 0);
    EXPECT_EQ(c.faults(), 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Arms, PushCampaign, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "Moving" : "AtRest"; });

}  // namespace
}  // namespace chasles::faults
