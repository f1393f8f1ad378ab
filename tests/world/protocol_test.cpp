// The whole loop under each protocol the controller speaks with an arm's driver (protocol.hpp) and
// at the rates those drivers stream: chasles's own, Drake's iiwa (FRI's 200 Hz) and Drake's Panda
// (libfranka's 1 kHz), each also at the other rate. The plant speaks the protocol with its driver's
// semantics (gravity added to an overlay torque, Drake's signs, no sequence numbers); the checks
// are the ones the 1 kHz chasles loop is held to: the safety pipeline on every command (as the
// whole torque the arm gets), the move, the external torque against the plant's truth, the reflex,
// and the refusal of a malformed or wrongly sized status. The fault table (fault_test) runs on the
// same wires, and so does the compliance suite (compliance_test).
#include <gtest/gtest.h>

#include <algorithm>
#include <chasles/robot_state_t.hpp>
#include <cmath>
#include <cstdio>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <limits>
#include <string>

#include "core/kinematics/kinematics.hpp"
#include "wires.hpp"
#include "world.hpp"
#include "support/contact_off.hpp"

namespace chasles::faults {
namespace {

using controller::DaemonOptions;
using controller::Mode;
using controller::Protocol;
using Eigen::VectorXd;

class Protocols : public ::testing::TestWithParam<Wire> {
 protected:
  double period() const { return GetParam().period(); }
  int64_t period_ns() const { return GetParam().period_ns(); }
  DaemonOptions controller_options() const { return controller_on(GetParam()); }
  plant::SimulationOptions plant_options() const { return plant_on(GetParam()); }
  // A plant holding at the bent pose and one controller, ticking half a period after its steps.
  void start(World& world, const plant::SimulationOptions& plant, const DaemonOptions& options) {
    world.start_plant(bent_pose(), plant);
    world.add_controller(options, period_ns() / 2);
    ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  }
};

TEST_P(Protocols, AMoveReachesItsGoalAndEveryCommandKeepsTheSafetyPipeline) {
  World world(panda(), GetParam().protocol);
  start(world, plant_options(), controller_options());
  world.send_joint_target(goal_a(), 1.5);
  world.run_for(2.0);
  const double off = (world.plant()->plant().q() - goal_a()).cwiseAbs().maxCoeff();
  const Recorder& bus = world.recorder();
  const CommandReport c = check_commands(panda(), bus.commands(), bus.statuses(), 0.05, period());
  const StatusReport s = summarise(bus.statuses());
  std::printf("[ protocol ] %s at %g Hz: %lld commands, goal reached within %.2e rad, torque %.0f %% of effort, rate "
              "%.0f %% of its limit; %s\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, static_cast<long long>(c.commands), off,
              100 * c.max_effort_ratio, 100 * c.max_rate_ratio, s.modes.c_str());
  EXPECT_LT(off, 1e-3);
  EXPECT_GE(c.commands, static_cast<int64_t>(2.0 * GetParam().rate_hz));
  EXPECT_EQ(c.non_finite, 0) << c.first_violation;
  EXPECT_EQ(c.effort_violations, 0) << c.first_violation;
  EXPECT_EQ(c.rate_violations, 0) << c.first_violation;
  EXPECT_EQ(c.seq_gaps, 0);
  EXPECT_EQ(s.fault_transitions, 0);
  EXPECT_EQ(s.modes, "HOLDING>RUNNING>HOLDING");  // the first state comes before the first status
  EXPECT_EQ(world.plant()->rejected_commands(), 0);
}

// The external torque the controller estimates from the driver's states, against what the plant
// applied: within the bounds of the 1 kHz chasles loop (contact_loop_test), whatever the rate —
// the observer steps by the states' own intervals.
TEST_P(Protocols, APushIsEstimatedWithinTheOneKilohertzBounds) {
  World world(panda(), GetParam().protocol);
  plant::SimulationOptions plant = plant_options();
  plant::Push push;
  push.start = 0.2, push.duration = 5.0, push.ramp = 0.05;
  push.wrench << 0, 0, 0, 12.0, -16.0, 0.0;  // 20 N in the base's x-y plane
  plant.environment.pushes = {push};
  DaemonOptions o = controller_options();
  testing::never_trip(o.control.contact, 7);  // the estimate alone is under test
  start(world, plant, o);
  world.run_for(1.2);
  const auto& estimate = world.controller().controller().contact();
  const plant::Truth& truth = world.plant()->truth();
  ASSERT_TRUE(truth.contact);
  const double force = (estimate.wrench_base.tail<3>() - truth.tip_wrench_ext.tail<3>()).norm();
  double spare = kInf;
  for (int i = 0; i < 7; ++i) {
    const double bound = 0.01 * std::abs(truth.tau_ext(i)) + 0.05;
    spare = std::min(spare, bound - std::abs(estimate.tau_ext(i) - truth.tau_ext(i)));
  }
  std::printf("[ protocol ] %s at %g Hz: |F̂ − F| %.2e N; τ̂ within 1 %% + 0.05 N·m with %.3f N·m to spare\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, force, spare);
  EXPECT_LE(force, 0.2);
  EXPECT_GE(spare, 0.0);
}

// A push that ramps to 30 N in 5 ms: REFLEX within 10 ms of its start, plus one status period at
// the slower rate (the observer hears of it a status later).
TEST_P(Protocols, ACollisionStartsTheReflex) {
  World world(panda(), GetParam().protocol);
  plant::SimulationOptions plant = plant_options();
  plant::Push push;
  push.start = 0.3, push.duration = 1.0, push.ramp = 0.005;
  push.wrench << 0, 0, 0, 0.0, 0.0, -30.0;
  plant.environment.pushes = {push};
  start(world, plant, controller_options());
  world.run_for(0.29 - 1e-9 * static_cast<double>(world.now()));
  ASSERT_EQ(world.controller().controller().mode(), Mode::kHolding);
  ASSERT_TRUE(world.run_until([&] { return world.controller().controller().mode() == Mode::kReflex; }, 0.1));
  const double latency_ms = 1e3 * (static_cast<double>(world.plant()->steps()) * period() - push.start);
  std::printf("[ protocol ] %s at %g Hz: REFLEX %.1f ms after the push began\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, latency_ms);
  EXPECT_LE(latency_ms, 10.0 + 1e3 * period());
}

// The table pressed under Cartesian impedance (compliance_test's wall, at the demo's press): the
// spring of 1000 N/m and the table's 10⁴ N/m in series press with k K / (k + K) · 1 cm.
TEST_P(Protocols, TheTableIsPressedWithTheSeriesSpringOfTheCommandedStiffness) {
  const RobotModel& model = panda();
  Data data(model);
  VectorXd q0(7);
  q0 << 0.18, 0.6, 0.18, -0.6698, 0.18, 0.6, 0.18;
  const Transform T0 = forward_kinematics(model, data, q0);
  plant::Wall wall;
  wall.normal = Vector3d::UnitZ();
  wall.point = T0.translation() - 0.005 * wall.normal;  // 5 mm below the tip
  World world(model, GetParam().protocol);
  plant::SimulationOptions plant = plant_options();
  plant.environment.walls = {wall};
  world.start_plant(q0, plant);
  world.add_controller(controller_options(), period_ns() / 2);
  world.run_for(0.1);
  const double k = 1000.0;
  world.recorder().publish("MODE", cartesian_mode(k));
  world.run_for(0.2);
  Transform goal = T0;
  goal.translation() = wall.point - 0.01 * wall.normal;
  world.recorder().publish("TARGET", cartesian_target(goal, 1.0));
  world.run_for(6.0);
  const controller::Controller& c = world.controller().controller();
  ASSERT_EQ(c.rejected_targets(), 0) << c.last_rejection();
  const plant::Truth& truth = world.plant()->truth();
  ASSERT_TRUE(truth.contact);
  const double expected = k * wall.stiffness / (k + wall.stiffness) * 0.01;
  const double force = truth.tip_wrench_ext.tail<3>().dot(wall.normal);
  std::printf("[ protocol ] %s at %g Hz: the table pressed with %.4f N, the series spring %.4f N (%+.3f %%)\n",
              controller::to_string(GetParam().protocol), GetParam().rate_hz, force, expected,
              100.0 * (force - expected) / expected);
  EXPECT_NEAR(force, expected, 0.02 * expected);
  EXPECT_LT(world.plant()->plant().qd().norm(), 1e-3) << "not at rest";
  EXPECT_EQ(c.faults(), 0);
  EXPECT_EQ(c.reflexes(), 0) << c.reflex_reason();
}

// A status of another arm (6 joints) or a damaged one (the arm's, cut short): refused and counted,
// never taken; with nothing else coming (the plant gone), the stale rule FAULTs as with chasles's
// own states.
TEST_P(Protocols, AWronglySizedOrMalformedStatusIsRefusedCountedAndFaults) {
  World world(panda(), GetParam().protocol);
  start(world, plant_options(), controller_options());
  const std::string channel = controller::default_channels(GetParam().protocol).status;
  world.kill_plant();
  // Another arm's status as it is; the arm's own, cut short by a byte.
  const auto publish = [&world](const std::string& on, const auto& message, int n) {
    if (n == 7) {
      world.recorder().publish_truncated(on, message, 1);
    } else {
      world.recorder().publish_on(on, message);
    }
  };
  const int64_t rejected_before = world.controller().summary(1.0).rejected_messages;
  for (int k = 0; k < 20; ++k) {
    const int64_t utime = 10'000'000 + 1000 * k;
    switch (GetParam().protocol) {
      case Protocol::kChasles: {
        robot_state_t m;
        const int n = k % 2 == 0 ? 6 : 7;
        m.utime = utime, m.seq = 100'000 + k, m.num_joints = n;
        m.position.assign(n, 0.1), m.velocity.assign(n, 0.0), m.effort.assign(n, 0.0);
        publish(channel, m, n);
        break;
      }
      case Protocol::kDrakeIiwa: {
        drake::lcmt_iiwa_status m;
        const int n = k % 2 == 0 ? 6 : 7;
        m.utime = utime, m.num_joints = n;
        for (auto* v : {&m.joint_position_measured, &m.joint_velocity_estimated, &m.joint_position_commanded,
                        &m.joint_position_ipo, &m.joint_torque_measured, &m.joint_torque_commanded,
                        &m.joint_torque_external}) {
          v->assign(size_t(n), 0.1);
        }
        publish(channel, m, n);
        break;
      }
      case Protocol::kDrakePanda: {
        drake::lcmt_panda_status m;
        const int n = k % 2 == 0 ? 6 : 7;
        m.utime = utime, m.num_joints = n;
        for (auto* v : {&m.joint_position, &m.joint_position_desired, &m.joint_velocity, &m.joint_velocity_desired,
                        &m.joint_acceleration_desired, &m.joint_torque, &m.joint_torque_desired,
                        &m.joint_torque_external}) {
          v->assign(size_t(n), 0.1);
        }
        m.control_command_success_rate = 1.0, m.robot_mode = 2, m.robot_utime = utime, m.control_mode = 4;
        publish(channel, m, n);
        break;
      }
    }
    world.run_for(period());
  }
  world.run_for(0.05);
  EXPECT_EQ(world.controller().summary(1.0).rejected_messages - rejected_before, 20);
  EXPECT_EQ(world.controller().controller().mode(), Mode::kFault);
  EXPECT_NE(std::string(world.controller().controller().fault_reason()).find("no fresh robot state"), std::string::npos)
      << world.controller().controller().fault_reason();
}

INSTANTIATE_TEST_SUITE_P(Wires, Protocols, ::testing::ValuesIn(wires_to_run()), wire_name);

// A controller sending the other torque than its driver expects — the whole torque to a driver
// that adds gravity compensation, or τ − g(q) to one that adds none — stops commanding for good
// within a quarter of a second of holding (one window of semantics_check.hpp), its FAULT naming the flag
// that fixes it; sent the right one (every other test here), it never does.
struct Mismatch {
  Wire wire;
  controller::TorqueSemantics plant, controller;
};

class Semantics : public ::testing::TestWithParam<Mismatch> {};

TEST_P(Semantics, AMismatchStopsTheControllerNamingTheFlag) {
  const Mismatch m = GetParam();
  World world(panda(), m.wire.protocol);
  plant::SimulationOptions plant = plant_on(m.wire);
  plant.torque_semantics = m.plant;
  DaemonOptions options = controller_on(m.wire);
  options.torque_semantics = m.controller;
  world.start_plant(bent_pose(), plant);
  world.add_controller(options, m.wire.period_ns() / 2);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  ASSERT_TRUE(world.run_until([&] { return world.controller().controller().stood_down(); }, 0.3));
  const std::string reason = world.controller().controller().fault_reason();
  const std::string fix = m.plant == controller::TorqueSemantics::kOverlay ? "run with --torque-semantics overlay"
                                                                           : "run with --torque-semantics full";
  EXPECT_NE(reason.find(fix), std::string::npos) << reason;
  // The share of g(q) the arm got beyond (or short of) the command: the driver's whole gravity.
  const std::string sign = m.plant == controller::TorqueSemantics::kOverlay ? "commanded + " : "commanded - ";
  const size_t at = reason.find(sign);
  ASSERT_NE(at, std::string::npos) << reason;
  const double percent = std::stod(reason.substr(at + sign.size()));
  EXPECT_GT(percent, 90.0) << reason;
  EXPECT_LT(percent, 110.0) << reason;
  // For good: no command follows, however long the states keep coming.
  const size_t commands = world.recorder().commands().size();
  world.run_for(0.5);
  EXPECT_EQ(world.recorder().commands().size(), commands);
  EXPECT_EQ(world.controller().controller().mode(), Mode::kFault);
}

std::vector<Mismatch> mismatches() {
  using controller::TorqueSemantics;
  const Wire iiwa{Protocol::kDrakeIiwa, 200.0}, panda{Protocol::kDrakePanda, 1000.0}, chasles{Protocol::kChasles, 1000.0};
  return {{iiwa, TorqueSemantics::kFull, TorqueSemantics::kOverlay},
          {iiwa, TorqueSemantics::kOverlay, TorqueSemantics::kFull},
          {panda, TorqueSemantics::kFull, TorqueSemantics::kOverlay},
          {panda, TorqueSemantics::kOverlay, TorqueSemantics::kFull},
          {chasles, TorqueSemantics::kOverlay, TorqueSemantics::kFull}};
}

INSTANTIATE_TEST_SUITE_P(Wires, Semantics, ::testing::ValuesIn(mismatches()),
                         [](const ::testing::TestParamInfo<Mismatch>& p) {
                           std::string name = controller::to_string(p.param.wire.protocol);
                           name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
                           return name + "_plant_" + controller::to_string(p.param.plant);
                         });

}  // namespace
}  // namespace chasles::faults
