// A simulator that pauses, as Drake's simulated arms paced by Python on a busy host do (10–110 ms
// every few seconds): the whole simulation stops — no step, no state, its clock standing — and
// goes on where it stopped. With --simulator the controller keeps the plant's time, so every pause
// is waited for: a programme of moves runs through pause after pause with no FAULT, no reflex, no
// abandoned move, and no phantom force in free motion. Without it the same pauses are stale states
// (the rule a real arm keeps), still without a phantom force; and a simulator silent past the
// stale limit FAULTs.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "wires.hpp"
#include "world.hpp"

namespace chasles::faults {
namespace {

using controller::DaemonOptions;
using controller::Mode;
using controller::Protocol;
using Eigen::VectorXd;

// Pauses of 10 to 100 ms every 2 s of simulated time, and the effort reported with a torque
// sensor's noise (0.05 N·m), so that the estimated force is a measurement, not an identity.
plant::SimulationOptions pausing(const Wire& wire, uint64_t seed) {
  plant::SimulationOptions p = plant_on(wire);
  p.stalls = {10.0, 100.0, 2.0, seed};
  p.faults.effort_noise = {0.05, seed};
  return p;
}

DaemonOptions simulator_on(const Wire& wire) {
  DaemonOptions o = controller_on(wire, 1'000'000'000);
  o.simulator = true;
  return o;
}

// How long the programme runs, s of simulated time: CHASLES_SIMULATOR_SECONDS for a soak (600 for
// the ten minutes), else 30.
double programme_seconds() {
  const char* text = std::getenv("CHASLES_SIMULATOR_SECONDS");
  return text != nullptr ? std::atof(text) : 30.0;
}

class Simulator : public ::testing::TestWithParam<Wire> {};

struct Programme {
  int moves = 0;
  int64_t pauses = 0, faults = 0, reflexes = 0;
  double worst_off = 0.0, peak_tip_force = 0.0;
};

// Moves back and forth under --simulator, each 1.5 s and 0.5 s of hold, for `seconds` of the plant's
// time; pausing or not.
Programme run_programme(const Wire& wire, bool pauses, double seconds) {
  World world(panda(), wire.protocol);
  plant::SimulationOptions plant = pausing(wire, 3);
  if (!pauses) plant.stalls = {};
  world.start_plant(bent_pose(), plant);
  world.add_controller(simulator_on(wire), wire.period_ns() / 2);
  Programme p;
  EXPECT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  for (double t = 0.0; t < seconds; t += 2.0, ++p.moves) {
    const VectorXd goal = p.moves % 2 == 0 ? goal_a() : bent_pose();
    world.send_joint_target(goal, 1.5);
    // Two seconds of the plant's time: the pauses in between are the controller's wait.
    const int64_t steps = world.plant()->steps() + std::llround(2.0 * wire.rate_hz);
    EXPECT_TRUE(world.run_until([&] { return world.plant()->steps() >= steps; }, 3.0));
    p.worst_off = std::max(p.worst_off, (world.plant()->plant().q() - goal).cwiseAbs().maxCoeff());
  }
  const controller::Controller& c = world.controller().controller();
  p.pauses = world.plant_stalls();
  p.faults = c.faults();
  p.reflexes = c.reflexes();
  p.peak_tip_force = c.peak_tip_force();
  EXPECT_EQ(c.mode(), Mode::kHolding) << c.fault_reason();
  return p;
}

// The run with pauses is the run without them, in the plant's time: every goal reached, no FAULT,
// no reflex, and the estimated tip force's peak (the effort noise's, in free motion) the same —
// the pauses add no phantom force.
TEST_P(Simulator, PausesAreWaitedForWithNoFaultReflexOrPhantomForce) {
  const Wire wire = GetParam();
  const double seconds = programme_seconds();
  const Programme paused = run_programme(wire, true, seconds), steady = run_programme(wire, false, seconds);
  std::printf("[ simulator ] %s at %g Hz: %d moves over %.0f s with %lld pauses of 10-100 ms; worst distance from "
              "a goal %.2e rad, peak tip force %.2f N (%.2f N without the pauses), %lld faults, %lld reflexes\n",
              controller::to_string(wire.protocol), wire.rate_hz, paused.moves, seconds,
              static_cast<long long>(paused.pauses), paused.worst_off, paused.peak_tip_force, steady.peak_tip_force,
              static_cast<long long>(paused.faults), static_cast<long long>(paused.reflexes));
  EXPECT_GE(paused.pauses, static_cast<int64_t>(seconds / 2.0) - 1);
  EXPECT_EQ(paused.faults, 0);
  EXPECT_EQ(paused.reflexes, 0);
  EXPECT_LT(paused.worst_off, 1e-3);
  // The same to 0.01 N: a target taken a tick apart in the two runs is all that differs.
  EXPECT_NEAR(paused.peak_tip_force, steady.peak_tip_force, 0.01);
}

// The same pauses without --simulator are what a real arm's would be: stale states, FAULTs.
TEST_P(Simulator, WithoutTheFlagThePausesAreStaleStates) {
  const Wire wire = GetParam();
  World world(panda(), wire.protocol);
  world.start_plant(bent_pose(), pausing(wire, 3));
  world.add_controller(controller_on(wire), wire.period_ns() / 2);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  world.run_until([&] { return world.plant_stalls() >= 3; }, 10.0);
  world.run_for(0.2);
  EXPECT_EQ(world.controller().controller().faults(), 3);
  EXPECT_NE(std::string(world.controller().controller().fault_reason()).find("no fresh robot state"), std::string::npos);
  // Held again after each, with no phantom force from the gap (the effort noise's floor, 1.1 N on
  // the Panda at 1 kHz, 2.4 N at 200 Hz): the observer steps by the states' time.
  EXPECT_EQ(world.controller().controller().mode(), Mode::kHolding);
  EXPECT_EQ(world.controller().controller().reflexes(), 0);
  EXPECT_LE(world.controller().controller().peak_tip_force(), 2.5);
}

// A simulator that stops for good is still found out, after the stale limit (1 s by default with
// --simulator) in this host's time.
TEST_P(Simulator, ASimulatorSilentPastTheStaleLimitFaults) {
  const Wire wire = GetParam();
  World world(panda(), wire.protocol);
  world.start_plant(bent_pose(), plant_on(wire));
  world.add_controller(simulator_on(wire), wire.period_ns() / 2);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  world.kill_plant();
  const int64_t killed = world.now();
  ASSERT_TRUE(world.run_until([&] { return world.controller().controller().mode() == Mode::kFault; }, 2.0));
  const double after = 1e-9 * static_cast<double>(world.now() - killed);
  EXPECT_GT(after, 1.0);
  EXPECT_LT(after, 1.0 + 2.0 * wire.period());
  EXPECT_NE(std::string(world.controller().controller().fault_reason()).find("(limit 1000.0 ms)"), std::string::npos)
      << world.controller().controller().fault_reason();
}

INSTANTIATE_TEST_SUITE_P(Wires, Simulator,
                         ::testing::Values(Wire{Protocol::kChasles, 1000.0}, Wire{Protocol::kDrakeIiwa, 200.0},
                                           Wire{Protocol::kDrakePanda, 1000.0}),
                         wire_name);

}  // namespace
}  // namespace chasles::faults
