// Compliance in the whole loop in simulated time (world.hpp): the laws of [L] against the plant,
// with the plant's truth (its wall, its push, its hidden payload) as the reference, on every wire
// (wires.hpp: chasles's and Drake's protocols, 1 kHz and 200 Hz). Every law and
// payload reaches the controller as an lcm-gen encoded control_mode_t or payload_t on the bus.
//   - stiffness: pressing on a wall 1 cm behind its surface, the steady force is the series spring
//     of the commanded stiffness and the wall's, within 2 %, and the tip does not drift sideways
//   - damping: a 5 mm step of the Cartesian target does not overshoot by more than 5 % for ζ = 1
//   - free drive: the arm yields to a push and comes to rest where it is left
//   - payload at run time: the hold error and the external torque drop once it is given
//   - switching: every switch between the four laws mid-motion stays within the rate limit
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/payload_t.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/kinematics/kinematics.hpp"
#include "wires.hpp"
#include "world.hpp"

namespace chasles::faults {
namespace {

using Eigen::VectorXd;
using controller::DaemonOptions;
using controller::Law;
using controller::Mode;

class Compliance : public ::testing::TestWithParam<Wire> {};

// Contact is expected here: no threshold starts a reflex.
void no_reflex(DaemonOptions& o, int n) {
  auto& c = o.control.contact;
  c.collision_torque = VectorXd::Constant(n, kInf);
  c.contact_torque = VectorXd::Constant(n, kInf);
  c.contact_force = c.collision_force = c.contact_moment = c.collision_moment = kInf;
}

// Five Panda configurations away from singularities and joint limits.
std::vector<VectorXd> configurations() {
  std::vector<VectorXd> qs;
  for (int k = 0; k < 5; ++k) {
    VectorXd q(7);
    q << 0.1, 0.5, -0.2, -1.9, 0.1, 2.0, 0.3;
    for (int i = 0; i < 7; ++i) q(i) += 0.2 * std::sin(1.3 * k + 0.7 * i) * (k > 0);
    qs.push_back(q);
  }
  return qs;
}

Vector3d tip_position(const RobotModel& model, World& world) {
  Data data(model);
  return forward_kinematics(model, data, world.plant()->plant().q()).translation();
}

// A wall under the tip, the Cartesian target 1 cm behind its surface: the spring of stiffness k
// and the wall's K in series press with F = k K / (k + K) · 1 cm. Two poses: a bent arm, and the
// demo's press (tools/demo.sh's second pose), where the nullspace settles slowest (about 1 s).
TEST_P(Compliance, TheWallIsPressedWithTheSeriesSpringOfTheCommandedStiffness) {
  const RobotModel& model = panda();
  Data data(model);
  VectorXd demo_press(7);
  demo_press << 0.18, 0.6, 0.18, -0.6698, 0.18, 0.6, 0.18;
  for (const VectorXd& q0 : {configurations()[0], demo_press}) {
    const Transform T0 = forward_kinematics(model, data, q0);
    for (const double k : {500.0, 1000.0, 2000.0}) {
      plant::Wall wall;
      wall.normal = Vector3d::UnitZ();
      wall.point = T0.translation() - 0.005 * wall.normal;  // 5 mm below the tip
      World world(panda(), GetParam().protocol);
      plant::SimulationOptions plant = plant_on(GetParam());
      plant.environment.walls = {wall};
      world.start_plant(q0, plant);
      // The default thresholds: 16.7 N pressed on purpose is a contact, not a collision (15 N).
      world.add_controller(controller_on(GetParam()), GetParam().period_ns() / 2);
      world.run_for(0.1);
      world.recorder().publish("MODE", cartesian_mode(k));
      world.run_for(0.2);
      Transform goal = T0;
      goal.translation() = wall.point - 0.01 * wall.normal;
      world.recorder().publish("TARGET", cartesian_target(goal, 1.0));
      world.run_for(8.0);
      const controller::Controller& c = world.controller().controller();
      ASSERT_EQ(c.law().law, Law::kCartesianImpedance);
      ASSERT_EQ(c.rejected_targets(), 0) << c.last_rejection();
      const plant::Truth& truth = world.plant()->truth();
      ASSERT_TRUE(truth.contact);
      const double K = wall.stiffness, expected = k * K / (k + K) * 0.01;
      const double force = truth.tip_wrench_ext.tail<3>().dot(wall.normal);
      const Vector3d p = tip_position(model, world);
      const double drift = (p - goal.translation()).cross(wall.normal).norm();
      std::printf("[ wall ] k = %4.0f N/m: contact force %.4f N, series spring %.4f N (%+.3f %%), lateral drift %.4f mm\n",
                  k, force, expected, 100.0 * (force - expected) / expected, 1e3 * drift);
      EXPECT_NEAR(force, expected, 0.02 * expected);
      EXPECT_LE(drift, 1e-3);
      EXPECT_LT(world.plant()->plant().qd().norm(), 1e-3) << "not at rest";
      EXPECT_EQ(c.faults(), 0);
      EXPECT_EQ(c.reflexes(), 0) << c.reflex_reason();
      EXPECT_GE(c.contacts(), 1);
    }
  }
}

// What an impedance presses with on purpose raises the collision thresholds by exactly that, no
// more: holding under Cartesian impedance, a push of 30 N (twice the 15 N threshold) is a collision
// and the reflex stops the arm, as under computed torque.
TEST_P(Compliance, ACollisionUnderCartesianImpedanceStillStartsTheReflex) {
  World world(panda(), GetParam().protocol);
  plant::SimulationOptions plant = plant_on(GetParam());
  plant::Push push;
  push.start = 0.8, push.duration = 0.3, push.ramp = 0.005;
  push.wrench << 0, 0, 0, 30.0, 0, 0;
  plant.environment.pushes = {push};
  world.start_plant(configurations()[0], plant);
  world.add_controller(controller_on(GetParam()), GetParam().period_ns() / 2);
  world.run_for(0.1);
  world.recorder().publish("MODE", cartesian_mode(1000.0));
  world.run_for(0.65);
  const controller::Controller& c = world.controller().controller();
  EXPECT_EQ(c.reflexes(), 0);
  const bool tripped = world.run_until([&] { return c.mode() == Mode::kReflex; }, 0.1);
  // The plant started at the World's time 0, which the push's start counts from.
  std::printf("[ collision ] Cartesian impedance holding, 30 N push: %s after %.1f ms\n", c.reflex_reason(),
              1e-6 * static_cast<double>(world.now()) - 1e3 * push.start);
  EXPECT_TRUE(tripped);
  EXPECT_EQ(c.reflexes(), 1);
  EXPECT_EQ(c.law().law, Law::kCartesianImpedance);
}

// A 5 mm step of the Cartesian target along each base axis from five configurations: the tip gets
// there without overshooting by more than 5 % of the step, damped critically by the law's ζ = 1.
TEST_P(Compliance, AFiveMillimetreStepOfTheTargetSettlesWithoutOvershoot) {
  const RobotModel& model = panda();
  Data data(model);
  double worst_overshoot = 0.0, worst_final = 0.0;
  for (const VectorXd& q0 : configurations()) {
    for (int axis = 0; axis < 3; ++axis) {
      World world(panda(), GetParam().protocol);
      world.start_plant(q0, plant_on(GetParam()));
      DaemonOptions o = controller_on(GetParam());
      world.add_controller(o, GetParam().period_ns() / 2);
      world.run_for(0.1);
      world.recorder().publish("MODE", cartesian_mode(1000.0));
      world.run_for(0.3);
      const Transform T0 = forward_kinematics(model, data, q0);
      const Vector3d start = tip_position(model, world), direction = Vector3d::Unit(axis);
      Transform goal = T0;
      goal.translation() = start + 0.005 * direction;
      world.recorder().publish("TARGET", cartesian_target(goal, 0.0));
      double peak = -kInf;
      world.run_until(
          [&] {
            peak = std::max(peak, (tip_position(model, world) - start).dot(direction));
            return false;
          },
          1.5);
      const controller::Controller& c = world.controller().controller();
      ASSERT_EQ(c.rejected_targets(), 0) << c.last_rejection();
      const double final_error = (tip_position(model, world) - goal.translation()).norm();
      worst_overshoot = std::max(worst_overshoot, (peak - 0.005) / 0.005);
      worst_final = std::max(worst_final, final_error);
      EXPECT_LE(peak, 0.005 * 1.05) << "axis " << axis;
      EXPECT_GE(peak, 0.005 * 0.95) << "axis " << axis << ": the step was not taken";
      EXPECT_LE(final_error, 5e-5) << "axis " << axis << ": not settled";
      EXPECT_EQ(c.faults(), 0);
    }
  }
  std::printf("[ step ] 15 steps of 5 mm: worst overshoot %+.2f %% of the step, worst error after 1.5 s %.1f um\n",
              100.0 * worst_overshoot, 1e6 * worst_final);
}

// Free drive: a 10 N push for half a second moves the arm, and once it ends the arm comes to rest
// and stays there. The push is a hand guiding the arm, no collision: the thresholds are raised, as
// they must be for guiding (a 10 N push on the hand is 2 N·m on the Panda's wrist, over 15 % of
// its effort limit).
TEST_P(Compliance, FreeDriveYieldsToAPushAndStaysWhereItIsLeft) {
  const RobotModel& model = panda();
  for (const VectorXd& q0 : configurations()) {
    World world(panda(), GetParam().protocol);
    plant::SimulationOptions plant = plant_on(GetParam());
    plant::Push push;
    push.start = 0.5, push.duration = 0.5, push.ramp = 0.02;
    push.wrench << 0, 0, 0, 10.0, 0, 0;
    plant.environment.pushes = {push};
    world.start_plant(q0, plant);
    DaemonOptions o = controller_on(GetParam());
    no_reflex(o, model.dof());
    world.add_controller(o, GetParam().period_ns() / 2);
    world.run_for(0.1);
    world.recorder().publish("MODE", mode_message(Law::kFreeDrive, model.dof()));
    world.run_for(0.35);
    const Vector3d before = tip_position(model, world);
    world.run_for(0.55 + 2.0);  // past the push, then two seconds to come to rest
    const Vector3d rested = tip_position(model, world);
    world.run_for(1.0);
    const Vector3d later = tip_position(model, world);
    const controller::Controller& c = world.controller().controller();
    const double moved = (rested - before).norm(), drift = (later - rested).norm();
    std::printf("[ free drive ] moved %.1f mm by the push; then drifts %.4f mm/s\n", 1e3 * moved, 1e3 * drift);
    EXPECT_EQ(c.law().law, Law::kFreeDrive);
    EXPECT_GT(moved, 0.01) << "the push did not move the arm";
    EXPECT_LE(drift, 1e-3);
    EXPECT_EQ(c.faults(), 0);
  }
}

// A 1.5 kg payload the plant carries and the controller does not know: the arm sags under computed
// torque and the observer reads it as external torque; once told at run time, both drop.
TEST_P(Compliance, APayloadGivenAtRunTimeRemovesTheHoldErrorAndTheExternalTorque) {
  double worst_ratio = kInf, worst_residual = 0.0;
  for (const VectorXd& q0 : configurations()) {
    Payload load;
    load.mass = 1.5;
    load.centre = Vector3d(0.0, 0.02, 0.05);
    World world(panda(), GetParam().protocol);
    plant::SimulationOptions plant = plant_on(GetParam());
    plant.environment.payload = load;
    world.start_plant(q0, plant);
    world.add_controller(controller_on(GetParam()), GetParam().period_ns() / 2);
    world.run_for(2.0);
    const controller::Controller& c = world.controller().controller();
    const double error_before = c.error().cwiseAbs().maxCoeff();
    const double tau_before = c.contact().tau_ext.cwiseAbs().maxCoeff();
    payload_t message{};
    message.mass = load.mass;
    for (int i = 0; i < 3; ++i) message.centre_of_mass[i] = load.centre(i);
    world.recorder().publish("PAYLOAD", message);
    world.run_for(2.0);
    const double error_after = c.error().cwiseAbs().maxCoeff();
    const double tau_after = c.contact().tau_ext.cwiseAbs().maxCoeff();
    ASSERT_TRUE(world.recorder().status());
    EXPECT_EQ(world.recorder().status()->payload_mass, 1.5);
    worst_ratio = std::min(worst_ratio, error_before / error_after);
    worst_residual = std::max(worst_residual, tau_after);
    std::printf("[ payload ] hold error %.2e -> %.2e rad (%.0fx); |tau_ext| %.3f -> %.2e N*m\n", error_before,
                error_after, error_before / error_after, tau_before, tau_after);
    EXPECT_GE(error_before, 20.0 * error_after);
    EXPECT_GT(tau_before, 1.0);
    EXPECT_LE(tau_after, 1e-3);
    EXPECT_EQ(c.faults(), 0);
  }
  std::printf("[ payload ] 5 configurations: hold error down %.0fx at least; |tau_ext| after at most %.2e N*m\n",
              worst_ratio, worst_residual);
}

// Every ordered pair of the four laws: the first drives a joint motion (free drive is moved by a
// push instead), the second takes over halfway through. No command steps by more than the rate
// limit, nothing faults, and the target is reached under every law but free drive.
TEST_P(Compliance, EverySwitchBetweenTheFourLawsMidMotionStaysWithinTheRateLimit) {
  const RobotModel& model = panda();
  const VectorXd q0 = configurations()[0];
  VectorXd far = q0;
  far(0) += 0.4, far(1) -= 0.2, far(3) += 0.3, far(5) -= 0.3;
  World world(panda(), GetParam().protocol);
  plant::SimulationOptions plant = plant_on(GetParam());
  world.start_plant(q0, plant);
  DaemonOptions o = controller_on(GetParam());
  no_reflex(o, model.dof());  // a switch into free drive mid-motion lets the arm coast: no reflex
  world.add_controller(o, GetParam().period_ns() / 2);
  world.run_for(0.2);
  const Law laws[] = {Law::kComputedTorque, Law::kJointImpedance, Law::kCartesianImpedance, Law::kFreeDrive};
  const controller::Controller& c = world.controller().controller();
  int switches = 0;
  bool toward_far = true;
  for (Law from : laws) {
    for (Law to : laws) {
      if (from == to) continue;
      world.recorder().publish("MODE", mode_message(from, model.dof()));
      world.run_for(0.3);
      if (from != Law::kFreeDrive) {
        world.send_joint_target(toward_far ? far : q0, 1.0);
        toward_far = !toward_far;
      }
      world.run_for(0.5);
      if (from != Law::kFreeDrive) {
        ASSERT_EQ(c.mode(), Mode::kRunning) << controller::to_string(from);
      }
      world.recorder().publish("MODE", mode_message(to, model.dof()));
      world.run_for(1.0);
      ASSERT_EQ(c.law().law, to);
      ++switches;
      if (to != Law::kFreeDrive && from != Law::kFreeDrive) {
        // The motion went on under the new law and ended at its goal.
        EXPECT_EQ(c.mode(), Mode::kHolding) << controller::to_string(from) << " -> " << controller::to_string(to);
      }
    }
  }
  const CommandReport report = check_commands(model, world.recorder().commands(), world.recorder().statuses(),
                                              o.control.torque_ramp, o.control.period);
  std::printf("[ switching ] %d switches mid-motion: %lld commands, torque steps up to %.2f of the rate limit, effort "
              "up to %.2f of its limit; %lld faults, %lld modes refused\n",
              switches, static_cast<long long>(report.commands), report.max_rate_ratio, report.max_effort_ratio,
              static_cast<long long>(c.faults()), static_cast<long long>(c.rejected_modes()));
  EXPECT_EQ(switches, 12);
  EXPECT_EQ(report.rate_violations, 0) << report.first_violation;
  EXPECT_EQ(report.effort_violations, 0) << report.first_violation;
  EXPECT_EQ(report.non_finite, 0);
  EXPECT_EQ(c.faults(), 0);
  EXPECT_EQ(c.rejected_modes(), 0) << c.mode_rejection();
}

INSTANTIATE_TEST_SUITE_P(Wires, Compliance, ::testing::ValuesIn(wires_to_run()), wire_name);

}  // namespace
}  // namespace chasles::faults
