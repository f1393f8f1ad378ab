// The controller, unchanged, on MuJoCo's plant: the whole loop in simulated time (tests/world's
// World: one memq:// bus, every message lcm-gen encoded), over chasles's protocol and Drake's iiwa
// and Panda drivers' at their rates. What holds on chasles's own plant is held here against an
// engine that is not chasles's: a move reaches its goal with the safety pipeline on every command,
// a press on the elbow and one on the hand are estimated from the states alone within the bounds
// the 1 kHz loop keeps on chasles's plant, the table is pressed with the commanded spring, and the
// truth on the wire names every contact and explains the external torque through chasles's
// Jacobian.
#include <gtest/gtest.h>

#include <chasles/contact_estimate_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "core/geometry/collision_model.hpp"
#include "core/geometry/distance.hpp"
#include "core/kinematics/kinematics.hpp"
#include "lcmtypes/checked.hpp"
#include "tests/support/contact_off.hpp"
#include "tests/support/reference.hpp"
#include "tools/mujoco/mujoco_plant.hpp"
#include "wires.hpp"
#include "world.hpp"

namespace chasles::faults {
namespace {

using controller::DaemonOptions;
using controller::Protocol;
using Eigen::VectorXd;

const geometry::CollisionModel& panda_geometry() {
  static const geometry::CollisionModel geometry = geometry::load_collision_model(
      chasles::testing::data_path("panda.urdf"), panda(), {{chasles::testing::data_path("packages")}, ""});
  return geometry;
}

// The pose the elbow is pressed at (tests/mujoco/mujoco_plant_test's): link 4 open to a push along +y.
VectorXd elbow_pose() {
  VectorXd q(7);
  q << 0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8;
  return q;
}

// The latest truth heard on PREFIX TRUTH, through the checked decoder.
class TruthListener {
 public:
  explicit TruthListener(World& world)
      : subscription_(world.bus().subscribe("CHASLES_TRUTH", [this](const uint8_t* data, size_t size) {
          sim_truth_t m;
          if (messages::decode_checked(data, size, m, 7, messages::Finite::Required).empty()) latest = m;
        })) {}
  std::optional<sim_truth_t> latest;

 private:
  controller::Bus::Subscription subscription_;
};

class OnMujoco : public ::testing::TestWithParam<Wire> {
 protected:
  // MuJoCo's Panda at q0, with `scene`, at the wire's rate; the engine is kept a pointer to.
  plant::Simulation& start_plant(World& world, const VectorXd& q0, const plant::MujocoScene& scene = {}) {
    auto engine = std::make_unique<plant::MujocoPlant>(panda(), chasles::testing::data_path("panda.urdf"),
                                                       panda_geometry(), scene, q0, VectorXd::Constant(7, 0.5),
                                                       GetParam().period());
    engine_ = engine.get();
    return world.start_plant(std::move(engine), plant_on(GetParam()));
  }
  void start(World& world, const VectorXd& q0, const DaemonOptions& options, const plant::MujocoScene& scene = {}) {
    start_with(world, q0, options, scene);
  }

 public:
  void start_with(World& world, const VectorXd& q0, const DaemonOptions& options, const plant::MujocoScene& scene) {
    start_plant(world, q0, scene);
    world.add_controller(options, GetParam().period_ns() / 2);
    ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  }

 protected:
  DaemonOptions estimating() const {
    DaemonOptions o = controller_on(GetParam());
    testing::never_trip(o.control.contact, 7);  // the estimate alone is under test
    return o;
  }
  const plant::MujocoPlant* engine_ = nullptr;
};

TEST_P(OnMujoco, AMoveReachesItsGoalAndEveryCommandKeepsTheSafetyPipeline) {
  World world(panda(), GetParam().protocol);
  start(world, bent_pose(), controller_on(GetParam()));
  world.send_joint_target(goal_a(), 1.5);
  world.run_for(2.0);
  const double off = (world.plant()->plant().q() - goal_a()).cwiseAbs().maxCoeff();
  const Recorder& bus = world.recorder();
  const CommandReport c = check_commands(panda(), bus.commands(), bus.statuses(), 0.05, GetParam().period());
  const StatusReport s = summarise(bus.statuses());
  std::printf("[ mujoco ] %s at %g Hz: goal reached within %.2e rad, torque %.0f %% of effort; %s\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, off, 100 * c.max_effort_ratio,
              s.modes.c_str());
  EXPECT_LT(off, 1e-3);
  EXPECT_EQ(c.non_finite, 0) << c.first_violation;
  EXPECT_EQ(c.effort_violations, 0) << c.first_violation;
  EXPECT_EQ(c.rate_violations, 0) << c.first_violation;
  EXPECT_EQ(s.fault_transitions, 0);
  EXPECT_EQ(s.modes, "HOLDING>RUNNING>HOLDING");
  EXPECT_EQ(world.plant()->rejected_commands(), 0);
}

// 20 N on the elbow, held: the controller's τ̂ against MuJoCo's Σ Jᵀf within 1 % + 0.05 N·m per
// joint (the 1 kHz loop's bound on chasles's plant); the truth on the wire says where it pushes,
// and chasles's own space Jacobian at its contacts gives its τ_ext.
TEST_P(OnMujoco, APressOnTheElbowIsEstimatedAndItsTruthIsOnTheWire) {
  World world(panda(), GetParam().protocol);
  TruthListener truth(world);
  plant::MujocoScene scene;
  scene.presses = {{"panda_link4", Vector3d::Zero(), Vector3d::UnitY(), 20.0, 0.2, 5.0, 0.05}};
  start(world, elbow_pose(), estimating(), scene);
  world.run_for(1.5);
  ASSERT_EQ(engine_->presses_skipped(), 0);
  const auto& estimate = world.controller().controller().contact();
  const plant::Truth& true_now = world.plant()->truth();
  double spare = kInf;
  for (int i = 0; i < 7; ++i) {
    const double bound = 0.01 * std::abs(true_now.tau_ext(i)) + 0.05;
    spare = std::min(spare, bound - std::abs(estimate.tau_ext(i) - true_now.tau_ext(i)));
  }
  std::printf("[ mujoco ] %s at %g Hz: the elbow's 20 N (|τ_ext| %.2f N·m), |τ̂ − τ_ext| %.1e N·m, within "
              "1 %% + 0.05 N·m with %.3f N·m to spare\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, true_now.tau_ext.norm(),
              (estimate.tau_ext - true_now.tau_ext).cwiseAbs().maxCoeff(), spare);
  EXPECT_GE(spare, 0.0);

  ASSERT_TRUE(truth.latest.has_value());
  const sim_truth_t& m = *truth.latest;
  ASSERT_GT(m.num_contacts, 0);
  EXPECT_TRUE(m.contact);
  Data data(panda());
  VectorXd q(7);
  q = world.plant()->plant().q();  // the truth and the state of the same step: the latest of both
  const Matrix6Xd& J_s = space_jacobian(panda(), data, q);
  VectorXd tau = VectorXd::Zero(7);
  Vector3d total = Vector3d::Zero();
  for (int k = 0; k < m.num_contacts; ++k) {
    EXPECT_EQ(m.contact_link[size_t(k)], "panda_link4");
    EXPECT_EQ(m.contact_other[size_t(k)], "pusher");
    const Vector3d p(m.contact_point[size_t(k)].data()), f(m.contact_force[size_t(k)].data());
    EXPECT_NEAR(Vector3d(m.contact_normal[size_t(k)].data()).norm(), 1.0, 1e-12);
    Vector6d wrench;
    wrench << p.cross(f), f;
    tau.head(4) += J_s.leftCols(4).transpose() * wrench;  // link 4 rides on body 4
    total += f;
  }
  EXPECT_LT((total - 20.0 * Vector3d::UnitY()).norm(), 0.02) << total.transpose();
  EXPECT_LT((Eigen::Map<const VectorXd>(m.tau_ext.data(), 7) - tau).norm(), 1e-6 * (1.0 + tau.norm()));
  for (double w : m.tip_wrench_ext) EXPECT_EQ(w, 0.0);  // nothing on the hand
}

// The estimates heard on PREFIX CONTACT, through the checked decoder, with the plant's step at
// which each arrived.
class ContactListener {
 public:
  explicit ContactListener(World& world)
      : subscription_(world.bus().subscribe("CHASLES_CONTACT", [this, &world](const uint8_t* data, size_t size) {
          contact_estimate_t m;
          ASSERT_EQ(messages::decode_checked(data, size, m, messages::kAnyArm, messages::Finite::Required), "");
          heard.push_back({m, world.plant()->steps()});
        })) {}
  struct Heard {
    contact_estimate_t message;
    int64_t step;
  };
  std::vector<Heard> heard;

 private:
  controller::Bus::Subscription subscription_;
};

// What the controller's locator says of a press, from τ̂_ext alone: heard on PREFIX CONTACT, the
// first flagged a contact, and NONE once the press has gone.
struct Found {
  contact_estimate_t last;       // the latest estimate while pressed
  Vector3d point, applied;       // MuJoCo's: the contacts' mean point and their total force
  double latency_ms = 0.0;       // from the press reaching 10 N to the first estimate flagged
  bool flagged = false, none_after = false, in_status = false;
};

Found press_and_locate(const Wire& wire, const plant::Press& press, const VectorXd& q0,
                       OnMujoco& rig, World& world) {
  ContactListener contacts(world);
  plant::MujocoScene scene;
  scene.presses = {press};
  DaemonOptions o = controller_on(wire);
  o.arm = panda_geometry();
  rig.start_with(world, q0, o, scene);
  world.run_for(press.start + 0.8 - 1e-9 * static_cast<double>(world.now()));
  Found found;
  const plant::Truth& truth = world.plant()->truth();
  found.point = found.applied = Vector3d::Zero();
  for (const plant::ArmContact& c : truth.contacts) found.point += c.point / double(truth.contacts.size()), found.applied += c.force;
  if (contacts.heard.empty()) return found;
  found.last = contacts.heard.back().message;
  for (const auto& h : contacts.heard)
    if (h.message.contact) {
      found.flagged = true;
      const double reached = press.start + press.ramp * (10.0 / press.force);
      found.latency_ms = 1e3 * (static_cast<double>(h.step) * wire.period() - reached);
      break;
    }
  // The status says the same as the latest estimate (the last status may be one estimate behind).
  const std::optional<controller_status_t>& status = world.recorder().status();
  found.in_status = status && status->contact_link == found.last.link && status->contact_located_flag == found.last.contact;
  world.run_for(press.duration);
  found.none_after = world.plant()->truth().contacts.empty() && contacts.heard.back().message.state == contact_estimate_t::NONE;
  return found;
}

// 15 N on the hand, a body whose seven joint torques fix a point and a force: the link, the point
// within 2 cm of MuJoCo's contact and the force within 10 %, flagged within 10 ms.
TEST_P(OnMujoco, APressOnTheHandIsFoundWhereItIs) {
  World world(panda(), GetParam().protocol);
  const Found f = press_and_locate(GetParam(), {"panda_hand", Vector3d::Zero(), -Vector3d::UnitY(), 15.0, 0.2, 1.0, 0.05},
                                   bent_pose(), *this, world);
  const double off = (Vector3d(f.last.point) - f.point).norm(), error = (Vector3d(f.last.force) - f.applied).norm();
  std::printf("[ mujoco ] %s at %g Hz: the hand's %.1f N found on %s, %.1f mm from MuJoCo's contact, the force within "
              "%.2f N, residual %.1e N·m, flagged %.1f ms after 10 N\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, f.applied.norm(), f.last.link.c_str(),
              1e3 * off, error, f.last.residual, f.latency_ms);
  EXPECT_EQ(f.last.state, contact_estimate_t::LOCATED);
  EXPECT_EQ(f.last.link, "panda_hand");
  EXPECT_LT(off, 0.02);
  EXPECT_LT(error, 0.1 * f.applied.norm());
  EXPECT_TRUE(f.flagged);
  EXPECT_LE(f.latency_ms, 10.0);
  EXPECT_TRUE(f.none_after);
  EXPECT_TRUE(f.in_status);
}

// 20 N on the elbow, which the per-joint thresholds alone once missed: flagged within 10 ms, with
// a force that explains τ̂_ext. Four joint torques cannot fix a point and a force (five unknowns),
// so the point is one of a family that fits as well: on the elbow's body or the one before, the
// force's size right within 10 % (docs/simulation.md).
TEST_P(OnMujoco, APressOnTheElbowIsFlaggedAndExplained) {
  World world(panda(), GetParam().protocol);
  const Found f = press_and_locate(GetParam(), {"panda_link4", Vector3d(-0.05, 0.0, 0.0), Vector3d::UnitY(), 20.0, 0.2, 1.0, 0.05},
                                   elbow_pose(), *this, world);
  std::printf("[ mujoco ] %s at %g Hz: the elbow's %.1f N found on %s (body %d), %.1f mm from MuJoCo's contact, "
              "|f̂| %.2f N, residual %.1e of %.2f N·m, flagged %.1f ms after 10 N\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, f.applied.norm(), f.last.link.c_str(),
              f.last.body, 1e3 * (Vector3d(f.last.point) - f.point).norm(), Vector3d(f.last.force).norm(), f.last.residual,
              f.last.tau_ext_norm, f.latency_ms);
  EXPECT_EQ(f.last.state, contact_estimate_t::LOCATED);
  EXPECT_GE(f.last.body, 3);
  EXPECT_LE(f.last.body, 4);
  EXPECT_NEAR(Vector3d(f.last.force).norm(), f.applied.norm(), 0.1 * f.applied.norm());
  EXPECT_LT(f.last.residual, 0.01 * f.last.tau_ext_norm);
  EXPECT_TRUE(f.flagged);
  EXPECT_LE(f.latency_ms, 10.0);
  EXPECT_TRUE(f.none_after);
  EXPECT_TRUE(f.in_status);
}

// What a push means is its link's policy (controller/contact.hpp, LinkPolicy), with the locator
// running: the press ramps to `press.force` over 50 ms from 0.2 s; returns when the controller
// entered REFLEX after the press reached `newtons` (ms; NaN: never, within 0.6 s).
double reflex_after(const plant::Press& press, const VectorXd& q0, DaemonOptions o, bool free_drive,
                    double newtons, OnMujoco& rig, World& world) {
  plant::MujocoScene scene;
  scene.presses = {press};
  o.arm = panda_geometry();
  rig.start_with(world, q0, o, scene);
  if (free_drive) world.recorder().publish("MODE", mode_message(controller::Law::kFreeDrive, 7));
  const bool tripped = world.run_until(
      [&] { return world.controller().controller().mode() == controller::Mode::kReflex; },
      press.start + 0.6 - 1e-9 * static_cast<double>(world.now()));
  if (!tripped) return std::nan("");
  return 1e3 * (1e-9 * static_cast<double>(world.now()) - (press.start + press.ramp * newtons / press.force));
}

// Holding, 20 N on the elbow: under every joint's threshold (its τ̂ is 4 N at the tip), but located
// on the forearm with 20 N, over the link's 15 N — a collision of the elbow, with its reflex, within
// 25 ms of the press reaching 15 N: the observer's lag (1/K_O = 5 ms on a ramp of 0.4 N/ms), the
// locator's period (10 ms) and at 200 Hz a state's 5 ms.
TEST_P(OnMujoco, APushOnTheElbowWhileHoldingIsACollisionOfTheElbow) {
  World world(panda(), GetParam().protocol);
  const plant::Press press{"panda_link4", Vector3d(-0.05, 0.0, 0.0), Vector3d::UnitY(), 20.0, 0.2, 1.0, 0.05};
  const double ms = reflex_after(press, elbow_pose(), controller_on(GetParam()), false, 15.0, *this, world);
  const std::string reason = world.controller().controller().reflex_reason();
  std::printf("[ mujoco ] %s at %g Hz: the elbow's 20 N while holding: REFLEX %.1f ms after 15 N: %s\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, ms, reason.c_str());
  ASSERT_FALSE(std::isnan(ms)) << "no reflex";
  EXPECT_GE(ms, 0.0);
  EXPECT_LE(ms, 25.0);
  EXPECT_NE(reason.find(" N located on panda_link"), std::string::npos) << reason;
  EXPECT_NE(reason.find("; reflex stop"), std::string::npos) << reason;
}

// Under free drive a push on a guided link is a person's: 40 N on the elbow, over joint 2's and 4's
// collision thresholds and the link's 15 N, flags a contact and moves the arm, but starts no reflex.
// The hand, made strict, is a collision under free drive too, with its own reflex.
TEST_P(OnMujoco, UnderFreeDriveAPushOnAGuidedLinkMovesTheArmAndOnAStrictOneStartsItsReflex) {
  {
    World world(panda(), GetParam().protocol);
    const plant::Press press{"panda_link4", Vector3d(-0.05, 0.0, 0.0), Vector3d::UnitY(), 40.0, 0.2, 0.3, 0.05};
    const double ms = reflex_after(press, elbow_pose(), controller_on(GetParam()), true, 15.0, *this, world);
    const VectorXd moved = world.plant()->plant().q() - elbow_pose();
    std::printf("[ mujoco ] %s at %g Hz: under free drive the elbow's 40 N moved the arm %.3f rad, %lld contacts, "
                "%lld reflexes\n",
                controller::to_string(GetParam().protocol), GetParam().rate_hz, moved.norm(),
                static_cast<long long>(world.controller().controller().contacts()),
                static_cast<long long>(world.controller().controller().reflexes()));
    EXPECT_TRUE(std::isnan(ms)) << world.controller().controller().reflex_reason();
    EXPECT_EQ(world.controller().controller().reflexes(), 0);
    EXPECT_GE(world.controller().controller().contacts(), 1);
    EXPECT_GT(moved.norm(), 0.05);
  }
  {
    World world(panda(), GetParam().protocol);
    DaemonOptions o = controller_on(GetParam());
    o.control.contact.links = {{"panda_hand", 10.0, controller::Reflex::kCompliant, false}};
    const plant::Press press{"panda_hand", Vector3d::Zero(), -Vector3d::UnitY(), 20.0, 0.2, 0.3, 0.05};
    const double ms = reflex_after(press, bent_pose(), o, true, 10.0, *this, world);
    const std::string reason = world.controller().controller().reflex_reason();
    std::printf("[ mujoco ] %s at %g Hz: under free drive the strict hand's 20 N: REFLEX %.1f ms after 10 N: %s\n",
                controller::to_string(GetParam().protocol), GetParam().rate_hz, ms, reason.c_str());
    ASSERT_FALSE(std::isnan(ms)) << "no reflex";
    EXPECT_LE(ms, 25.0);
    EXPECT_NE(reason.find("panda_hand"), std::string::npos) << reason;
    EXPECT_NE(reason.find("; reflex compliant"), std::string::npos) << reason;
  }
}

// 15 N on the hand, sideways: the tip force the controller estimates against the force MuJoCo
// applied, within 0.5 N.
TEST_P(OnMujoco, APressOnTheHandIsEstimatedWithinHalfANewton) {
  World world(panda(), GetParam().protocol);
  plant::MujocoScene scene;
  scene.presses = {{"panda_hand", Vector3d::Zero(), -Vector3d::UnitY(), 15.0, 0.2, 5.0, 0.05}};
  start(world, bent_pose(), estimating(), scene);
  world.run_for(1.5);
  ASSERT_EQ(engine_->presses_skipped(), 0);
  const plant::Truth& truth = world.plant()->truth();
  ASSERT_TRUE(truth.contact);
  const Vector3d applied = truth.tip_wrench_ext.tail<3>();
  const Vector3d estimated = world.controller().controller().contact().wrench_base.tail<3>();
  std::printf("[ mujoco ] %s at %g Hz: the hand's press %.2f N, estimated within %.3f N\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, applied.norm(),
              (estimated - applied).norm());
  EXPECT_NEAR(applied.norm(), 15.0, 0.05);
  EXPECT_LE((estimated - applied).norm(), 0.5);
}

// The lowest point of the hand's collision geometry (what rides on the last body) at q, base frame.
double lowest_point(const VectorXd& q) {
  Data data(panda());
  forward_kinematics(panda(), data, q);
  double lowest = std::numeric_limits<double>::infinity();
  for (const geometry::CollisionObject& object : panda_geometry().objects) {
    if (object.body != 7) continue;
    const Transform T = data.T_body[size_t(object.body)] * object.T_body_object;
    int vertex = 0;
    const Vector3d down = T.linear().transpose() * -Vector3d::UnitZ();
    const double z = (T * geometry::support_of_core(object.shape, down, vertex)).z() - geometry::margin_of(object.shape);
    lowest = std::min(lowest, z);
  }
  return lowest;
}

// The table (a box of the scene) 5 mm below the hand, pressed under Cartesian impedance with the
// tip's goal 1 cm into it: at rest the table's force is the commanded spring's at its deflection,
// k (z_goal − z_tip), within 2 % (MuJoCo's contact is stiff and not a known spring: the deflection
// is measured, not predicted).
TEST_P(OnMujoco, TheTableIsPressedWithTheCommandedSpring) {
  VectorXd q0(7);
  q0 << 0.18, 0.6, 0.18, -0.6698, 0.18, 0.6, 0.18;
  const double lowest = lowest_point(q0), top = lowest - 0.005;
  plant::MujocoScene scene;
  geometry::SceneObject table;
  table.name = "table";
  table.shape.kind = geometry::ShapeKind::kBox;
  // A small table under the hand alone: the elbow of this pose hangs lower than the hand.
  Data data(panda());
  Transform goal = forward_kinematics(panda(), data, q0);
  table.shape.half_extents = Vector3d(0.12, 0.12, 0.05);
  table.T_base_object.translation() = Vector3d(goal.translation().x(), goal.translation().y(), top - 0.05);
  scene.objects = {table};
  World world(panda(), GetParam().protocol);
  start_plant(world, q0, scene);
  world.add_controller(controller_on(GetParam()), GetParam().period_ns() / 2);
  world.run_for(0.1);
  const double k = 1000.0;
  world.recorder().publish("MODE", cartesian_mode(k));
  world.run_for(0.2);
  goal.translation().z() -= lowest - top + 0.01;  // the lowest point 1 cm beyond the table's top
  world.recorder().publish("TARGET", cartesian_target(goal, 1.0));
  world.run_for(6.0);
  const controller::Controller& c = world.controller().controller();
  ASSERT_EQ(c.rejected_targets(), 0) << c.last_rejection();
  const plant::Truth& truth = world.plant()->truth();
  ASSERT_TRUE(truth.contact) << summarise(world.recorder().statuses()).modes << " lowest point " << lowest << " m, goal " << goal.translation().transpose() << ", tip at "
                              << forward_kinematics(panda(), data, world.plant()->plant().q()).translation().transpose();
  Vector3d force = Vector3d::Zero();
  for (const plant::ArmContact& contact : truth.contacts) {
    EXPECT_EQ(contact.other, "table");
    force += contact.force;
  }
  const double z_tip = forward_kinematics(panda(), data, world.plant()->plant().q()).translation().z();
  const double spring = k * (z_tip - goal.translation().z());
  std::printf("[ mujoco ] %s at %g Hz: the table pressed with %.4f N, the spring at its deflection %.4f N (%+.3f %%)\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, force.z(), spring,
              100.0 * (force.z() - spring) / spring);
  EXPECT_GT(spring, 5.0);
  EXPECT_NEAR(force.z(), spring, 0.02 * spring);
  EXPECT_LT(world.plant()->plant().qd().norm(), 1e-3) << "not at rest";
  EXPECT_EQ(c.faults(), 0);
  EXPECT_EQ(c.reflexes(), 0) << c.reflex_reason();
}

// Each protocol at its driver's rate.
INSTANTIATE_TEST_SUITE_P(Wires, OnMujoco,
                         ::testing::Values(Wire{Protocol::kChasles, 1000.0}, Wire{Protocol::kDrakeIiwa, 200.0},
                                           Wire{Protocol::kDrakePanda, 1000.0}),
                         wire_name);

}  // namespace
}  // namespace chasles::faults
