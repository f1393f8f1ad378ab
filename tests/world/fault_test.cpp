// The fault matrix in simulated time: controller and plant in one process on a memq:// bus and a
// SimulatedClock (world.hpp), every fault injected exactly, every outcome asserted exactly. The
// controller ticks as states arrive (the default) unless a row says clock-driven. The expected
// number of FAULTs is derived from what the bus carried — the arrival time of every state the
// controller could have heard, against the tick schedule those arrivals make and the stale
// limit — so a regression in the stale-state rule, in the recovery or in the plant's fault
// injection shows as a count that differs. For every fault, the whole command stream is checked
// against the safety pipeline (checks.hpp), and the plant's count of late cycles against the
// states it dropped. Each test prints its row of the fault table ("FAULT TABLE | ...").
//
// Every row runs on every wire (wires.hpp): chasles's protocol and Drake's iiwa and Panda
// protocols, each at 1 kHz and at 200 Hz. What a row injects is scaled to the wire where it is a
// time (a delay of one period, a spike of half or one and a half stale limits, a flood ten times
// the tick rate); the controller's stale limit is the daemon's default at that rate (10 ms, 15 ms
// at 200 Hz); the expected counts come from the same oracle.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/kinematics/kinematics.hpp"
#include "wires.hpp"
#include "world.hpp"
#ifdef CHASLES_FAULTS_ON_MUJOCO
#include "core/geometry/collision_model.hpp"
#include "tests/support/reference.hpp"
#include "tools/mujoco/mujoco_plant.hpp"
#endif

namespace chasles::faults {
namespace {

using Eigen::VectorXd;
using controller::TickSource;
constexpr double kRamp = 0.05;  // the controller's default --torque-ramp-ms

double distance(const VectorXd& a, const VectorXd& b) { return (a - b).cwiseAbs().maxCoeff(); }

// The ticks a controller with period P makes, from the arrivals of the states it heard.
// Clock-driven: every period from its first tick. State-driven: at every arrival (several at one
// instant make one tick), and when none comes, 1.5 periods after the last arrival, then every
// period (the watchdog) — as node.hpp specifies, derived here from the arrivals alone.
std::vector<int64_t> tick_times(const std::vector<int64_t>& arrivals, int64_t first_tick, int64_t last_tick,
                                TickSource tick, int64_t P) {
  std::vector<int64_t> ticks;
  if (tick == TickSource::kClock) {
    for (int64_t t = first_tick; t <= last_tick; t += P) ticks.push_back(t);
    return ticks;
  }
  int64_t deadline = first_tick;
  size_t next = 0;
  while (true) {
    const bool arrival = next < arrivals.size() && arrivals[next] <= deadline;
    const int64_t t = arrival ? arrivals[next] : deadline;
    if (t > last_tick) break;
    ticks.push_back(t);
    if (arrival) {
      while (next < arrivals.size() && arrivals[next] == t) ++next;
      deadline = t + P + P / 2;
    } else {
      deadline = t + P;
    }
  }
  return ticks;
}

// The FAULTs the stale rule must raise: at each tick the newest state the controller holds arrived
// at the last arrival at or before it; a tick that finds it older than the limit is stale, and every
// run of stale ticks after a fresh one is one FAULT.
int64_t expected_faults(const std::vector<int64_t>& arrivals, int64_t first_tick, int64_t last_tick, int64_t stale_ns,
                        TickSource tick, int64_t P) {
  int64_t faults = 0;
  bool fresh_before = false, stale_before = false;
  size_t next = 0;
  int64_t latest = -1;
  for (const int64_t t : tick_times(arrivals, first_tick, last_tick, tick, P)) {
    while (next < arrivals.size() && arrivals[next] <= t) latest = arrivals[next++];
    if (latest < 0) continue;
    const bool stale = t - latest > stale_ns;
    if (stale && !stale_before && fresh_before) ++faults;
    fresh_before = fresh_before || !stale;
    stale_before = stale;
  }
  return faults;
}

// The spacing of the commands, µs, by the same oracle: a tick sends one when the newest state it
// holds is fresh, and none while it is stale (the FAULT) or before the first.
std::vector<double> command_spacing_us(const std::vector<int64_t>& arrivals, int64_t first_tick, int64_t last_tick,
                                       int64_t stale_ns, TickSource tick, int64_t P) {
  std::vector<double> spacing;
  size_t next = 0;
  int64_t latest = -1, last_command = -1;
  for (const int64_t t : tick_times(arrivals, first_tick, last_tick, tick, P)) {
    while (next < arrivals.size() && arrivals[next] <= t) latest = arrivals[next++];
    if (latest < 0 || t - latest > stale_ns) continue;
    if (last_command >= 0) spacing.push_back(1e-3 * static_cast<double>(t - last_command));
    last_command = t;
  }
  return spacing;
}

// After a last state at 0 and nothing more, by the same oracle: the ticks that still answer it (the
// one at its arrival and the watchdog's within the stale limit) and the time of the tick that
// FAULTs (the first beyond it).
struct LastState {
  int64_t answers = 0;
  int64_t fault_at = 0;
};
LastState after_the_last_state(int64_t stale_ns, int64_t P) {
  LastState last;
  for (const int64_t t : tick_times({0}, 0, stale_ns + 2 * P, TickSource::kState, P)) {
    if (t <= stale_ns) {
      ++last.answers;
    } else {
      last.fault_at = t;
      break;
    }
  }
  return last;
}

class Faults : public ::testing::TestWithParam<Wire> {};

// The plant every row runs on: chasles's own, or with CHASLES_FAULTS_ON_MUJOCO MuJoCo's Panda
// (tests/mujoco's mujoco_fault_test: the same rows, the same oracle, on the other engine). The
// faults are the Simulation's, whatever it steps; the damping is 0.5 on every joint on both.
plant::Simulation& start_plant(World& world, const VectorXd& q0, const plant::SimulationOptions& options) {
#ifdef CHASLES_FAULTS_ON_MUJOCO
  static const geometry::CollisionModel geometry = geometry::load_collision_model(
      chasles::testing::data_path("panda.urdf"), panda(), {{chasles::testing::data_path("packages")}, ""});
  return world.start_plant(std::make_unique<plant::MujocoPlant>(panda(), chasles::testing::data_path("panda.urdf"),
                                                                geometry, plant::MujocoScene{}, q0,
                                                                VectorXd::Constant(7, 0.5), 1.0 / options.rate_hz),
                           options);
#else
  return world.start_plant(q0, options);
#endif
}

// A plant at the bent pose on the wire and one controller holding it, ticking half a period after
// the plant's steps.
struct Rig {
  Wire wire;
  World world;
  TickSource tick;
  int64_t stale_ns;
  int64_t first_tick = 0;
  explicit Rig(const Wire& w, const plant::SimulationOptions& plant, int64_t stale = 0,
               TickSource t = TickSource::kState)
      : wire(w), world(panda(), w.protocol), tick(t), stale_ns(stale > 0 ? stale : w.stale_ns()) {
    start_plant(world, bent_pose(), plant);
    world.add_controller(controller_on(wire, stale_ns, tick), P() / 2);
    first_tick = world.now() + P() + P() / 2;
  }
  explicit Rig(const Wire& w) : Rig(w, plant_on(w)) {}
  int64_t P() const { return wire.period_ns(); }
  Recorder& bus() { return world.recorder(); }
  const controller_status_t& status() { return *bus().status(); }
  bool holding() {
    return world.run_until([this] { return bus().status_is(controller_status_t::HOLDING); }, 1.0);
  }
  // A JOINT move and the settling after it; the arm's distance from the goal at the end.
  double move(const VectorXd& goal, double duration) {
    world.send_joint_target(goal, duration);
    world.run_for(duration + 0.5);
    return distance(vector_of(bus().state()->position), goal);
  }
  // The plant's late cycles the bus explains when nothing delays the states: a step is late when
  // no command answered the state of the step before, from the step after the first answer on.
  int64_t late_cycles_the_bus_explains() {
    std::set<int64_t> answered;
    for (const HeardCommand& c : bus().commands()) answered.insert(c.message.state_seq);
    if (answered.empty()) return 0;
    int64_t late = 0;
    for (int64_t s = *answered.begin() + 1; s <= world.plant()->steps(); ++s) late += answered.count(s - 1) == 0;
    return late;
  }
  int64_t fault_count_the_bus_explains() {
    return expected_faults(bus().state_arrivals(), first_tick, world.now(), stale_ns, tick, P());
  }
  std::vector<double> command_spacing_the_bus_explains() {
    return command_spacing_us(bus().state_arrivals(), first_tick, world.now(), stale_ns, tick, P());
  }
};

// The checks every fault test ends with; prints the test's row of the fault table. The commands'
// spacing is the oracle's: a period apart, and state-driven, a lost state makes one gap of 1.5
// periods (the watchdog's tick) and one of half a period (the next state's).
void expect_safe(Rig& rig, const std::string& fault) {
  const auto& statuses = rig.bus().statuses();
  const CommandReport c = check_commands(panda(), rig.bus().commands(), statuses, kRamp, rig.wire.period());
  const StatusReport s = summarise(statuses);
  const std::vector<double> spacing = rig.command_spacing_the_bus_explains();
  std::printf("%s\n", table_row(fault + " [" + controller::to_string(rig.wire.protocol) + " " +
                                    std::to_string(static_cast<int>(rig.wire.rate_hz)) + " Hz]",
                                c, s)
                          .c_str());
  EXPECT_GT(c.commands, static_cast<int64_t>(0.3 * rig.wire.rate_hz));
  EXPECT_EQ(c.non_finite, 0) << c.first_violation;
  EXPECT_EQ(c.effort_violations, 0) << c.first_violation;
  EXPECT_EQ(c.rate_violations, 0) << c.first_violation;
  EXPECT_EQ(c.seq_gaps, 0) << "a command the bus carried was not heard";
  // The first command and the first after each FAULT start from g(q), unless that is also
  // within the rate limit of the last command before it.
  EXPECT_GE(c.restarts_from_gravity, 1);
  EXPECT_LE(c.restarts_from_gravity, 1 + s.faults);
  // In simulated time no tick is late, and a state-driven tick starts the instant its state arrives.
  EXPECT_EQ(c.spacing_p50_us, percentile(spacing, 0.5));
  EXPECT_EQ(c.spacing_p99_us, percentile(spacing, 0.99));
  EXPECT_EQ(s.overruns, 0);
  if (rig.tick == TickSource::kState) {
    EXPECT_EQ(rig.world.controller().summary(1.0).latency_us.max, 0.0);
  }
}

TEST_P(Faults, FaultFreeMoveAndTheOracleAgree) {
  Rig rig(GetParam());
  ASSERT_TRUE(rig.holding());
  EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
  EXPECT_EQ(rig.status().faults, 0);
  EXPECT_EQ(rig.fault_count_the_bus_explains(), 0);
  EXPECT_EQ(rig.world.plant()->late_cycles(), 0);
  expect_safe(rig, "none");
}

// Clock-driven ticks (--tick clock), half a period after the plant's steps: the same rules hold —
// no FAULT and no late cycle without a fault, and under 50 % drops the FAULTs the bus explains.
TEST_P(Faults, ClockDrivenTicksKeepTheSameRules) {
  {
    Rig rig(GetParam(), plant_on(GetParam()), 0, TickSource::kClock);
    ASSERT_TRUE(rig.holding());
    EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
    EXPECT_EQ(rig.status().faults, 0);
    EXPECT_EQ(rig.world.plant()->late_cycles(), 0);
    expect_safe(rig, "none, clock-driven");
  }
  {
    plant::SimulationOptions plant = plant_on(GetParam());
    plant.faults.seed = 11;
    plant.faults.drop = 0.5;
    Rig rig(GetParam(), plant, 0, TickSource::kClock);
    ASSERT_TRUE(rig.holding());
    rig.world.send_joint_target(goal_a(), 1.0);
    rig.world.run_for(8.0);
    const int64_t expected = rig.fault_count_the_bus_explains();
    EXPECT_GE(expected, 1);
    EXPECT_EQ(rig.status().faults, expected);
    EXPECT_EQ(rig.world.plant()->late_cycles(), rig.late_cycles_the_bus_explains());
    expect_safe(rig, "50 % of states dropped (seed 11), clock-driven");
  }
}

// A state that reaches the controller a period late (a period of network delay): its answer
// reaches the plant after the step it was for, so every cycle is late. After --max-late (20) in a
// row the plant brakes, once, and stays braked while the lateness lasts, as Franka's FCI stops an
// arm; with --max-late 0 it counts the same late cycles and never brakes.
TEST_P(Faults, EveryCycleLateBrakesTheArmAfterMaxLate) {
  for (const int max_late : {20, 0}) {
    plant::SimulationOptions plant = plant_on(GetParam());
    plant.faults.delay_ms = 1e3 * GetParam().period();
    plant.max_late = max_late;
    Rig rig(GetParam(), plant);
    ASSERT_TRUE(rig.holding());
    rig.world.run_for(0.5);
    const plant::Simulation& p = *rig.world.plant();
    EXPECT_GT(p.late_cycles(), static_cast<int64_t>(0.4 * GetParam().rate_hz));
    EXPECT_EQ(p.late_in_a_row(), p.late_cycles()) << "no cycle was on time";
    EXPECT_EQ(p.late_stops(), max_late > 0 ? 1 : 0);
    EXPECT_EQ(p.brakes(), max_late > 0 ? 1 : 0);
    EXPECT_EQ(p.braking(), max_late > 0);
    EXPECT_EQ(rig.status().faults, 0) << "the controller is in time by its own clock: only the plant can tell";
  }
}

// kill -9 of the plant in the middle of a JOINT move: one FAULT, raised on the first tick after the
// newest state is stale-ms old, and not a command after it; a plant started again where the old one
// stopped is held there (the rate limiter restarts from g(q)) and the next move completes.
TEST_P(Faults, PlantKilledMidMotionAndRestarted) {
  Rig rig(GetParam());
  ASSERT_TRUE(rig.holding());
  rig.world.send_joint_target(goal_a(), 2.0);
  rig.world.run_for(0.5);
  ASSERT_TRUE(rig.bus().status_is(controller_status_t::RUNNING));
  const VectorXd q_at_kill = vector_of(rig.bus().state()->position);
  const int64_t last_seq = rig.bus().state()->seq;
  rig.world.kill_plant();
  ASSERT_TRUE(rig.world.run_until([&] { return rig.bus().status_is(controller_status_t::FAULT); }, 1.0));
  // The status goes out on the tick that finds the last state too old (10.5 ms after it at 1 kHz,
  // 17.5 ms at 200 Hz); the ticks before it still answer that state.
  const LastState last = after_the_last_state(rig.stale_ns, rig.P());
  EXPECT_EQ(rig.world.now() - rig.bus().state_arrivals().back(), last.fault_at);
  rig.world.run_for(0.5);
  EXPECT_EQ(rig.status().faults, 1);
  EXPECT_NE(rig.status().message.find("no fresh robot state"), std::string::npos) << rig.status().message;
  const auto& commands = rig.bus().commands();
  EXPECT_EQ(std::count_if(commands.begin(), commands.end(),
                          [&](const HeardCommand& c) { return c.message.state_seq == last_seq; }),
            last.answers);
  EXPECT_EQ(commands.back().message.state_seq, last_seq) << "a command after the FAULT";

  start_plant(rig.world, q_at_kill, plant_on(GetParam()));
  ASSERT_TRUE(rig.holding());
  EXPECT_LT(distance(vector_of(rig.bus().state()->position), q_at_kill), 1e-3) << "held where the plant restarted";
  EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
  EXPECT_EQ(rig.status().faults, 1);
  expect_safe(rig, "plant killed mid-motion, restarted");
}

// 10 % of states dropped (seed 7): the longest run of drops is short of a stale limit of ten
// periods (the 1 kHz default), so there is no FAULT at all, and the move completes. (At 200 Hz the
// default limit is three periods, which a run of three drops in a row, p = 10^-3 per state, passes;
// FiftyPercentOfStatesDropped holds that limit to its count.)
TEST_P(Faults, TenPercentOfStatesDropped) {
  plant::SimulationOptions plant = plant_on(GetParam());
  plant.faults.seed = 7;
  plant.faults.drop = 0.1;
  Rig rig(GetParam(), plant, 10 * GetParam().period_ns());
  ASSERT_TRUE(rig.holding());
  EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
  EXPECT_GT(rig.world.plant()->states_not_sent(), static_cast<int64_t>(0.1 * GetParam().rate_hz));
  EXPECT_EQ(rig.fault_count_the_bus_explains(), 0);
  EXPECT_EQ(rig.world.plant()->late_cycles(), rig.late_cycles_the_bus_explains());
  EXPECT_EQ(rig.world.plant()->late_stops(), 0);
  EXPECT_EQ(rig.status().faults, 0);
  expect_safe(rig, "10 % of states dropped (seed 7)");
}

// 50 % dropped: a run of drops as long as the stale limit (10 at 1 kHz, p = 2^-10 per state; 3 at
// 200 Hz, whose limit is three periods) leaves the controller without a state past the limit; each
// such run is exactly one FAULT, and the arm is held where it is after it. With a limit of 30
// periods none is long enough, and the move completes: across a gap of several periods the
// observer takes the torque of each step the commands in force then (docs/protocols.md, "Lost
// statuses"), where the last state's effort alone read 18 N at the tip at 200 Hz, a false collision.

TEST_P(Faults, FiftyPercentOfStatesDropped) {
  plant::SimulationOptions plant = plant_on(GetParam());
  plant.faults.seed = 11;
  plant.faults.drop = 0.5;
  {
    Rig rig(GetParam(), plant);
    ASSERT_TRUE(rig.holding());
    rig.world.send_joint_target(goal_a(), 1.0);
    rig.world.run_for(8.0);
    const int64_t expected = rig.fault_count_the_bus_explains();
    EXPECT_GE(expected, 1) << "seed 11 should give at least one run of drops past the limit in 8 s";
    EXPECT_EQ(rig.status().faults, expected);
    EXPECT_EQ(summarise(rig.bus().statuses()).fault_transitions, expected);
    EXPECT_EQ(rig.world.plant()->late_cycles(), rig.late_cycles_the_bus_explains());
    expect_safe(rig, "50 % of states dropped (seed 11), default stale limit");
  }
  {
    Rig rig(GetParam(), plant, 30 * GetParam().period_ns());
    ASSERT_TRUE(rig.holding());
    EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
    EXPECT_EQ(rig.world.controller().controller().reflexes(), 0) << rig.world.controller().controller().reflex_reason();
    EXPECT_EQ(rig.fault_count_the_bus_explains(), 0);
    EXPECT_EQ(rig.status().faults, 0);
    expect_safe(rig, "50 % of states dropped (seed 11), stale limit 30 periods");
  }
}

// Delay spikes: every 200th state opens a spike during which every state is held back, then all
// arrive together. Half the stale limit: no FAULT. One and a half: exactly one FAULT per spike, and
// the burst after each brings the arm back to HOLDING where it is.
TEST_P(Faults, DelaySpikesWithinTheStaleLimit) {
  plant::SimulationOptions plant = plant_on(GetParam());
  plant.faults.spike_ms = 0.5e-6 * static_cast<double>(GetParam().stale_ns());
  plant.faults.spike_every = 200;
  Rig rig(GetParam(), plant);
  ASSERT_TRUE(rig.holding());
  EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
  EXPECT_EQ(rig.fault_count_the_bus_explains(), 0);
  EXPECT_EQ(rig.status().faults, 0);
  expect_safe(rig, "delay spikes of half the stale limit every 200 states");
}

TEST_P(Faults, DelaySpikesLongerThanTheStaleLimitFault) {
  plant::SimulationOptions plant = plant_on(GetParam());
  plant.faults.spike_ms = 1.5e-6 * static_cast<double>(GetParam().stale_ns());
  plant.faults.spike_every = 500;
  Rig rig(GetParam(), plant);
  ASSERT_TRUE(rig.holding());
  rig.world.run_until([&] { return rig.world.plant()->steps() >= 2600; }, 20.0);  // 2601 states sent: 5 spikes
  rig.world.run_for(0.1);
  EXPECT_EQ(rig.fault_count_the_bus_explains(), 5);
  EXPECT_EQ(rig.status().faults, 5);
  EXPECT_EQ(rig.status().state, controller_status_t::HOLDING);
  char expected[96];
  std::snprintf(expected, sizeof expected, "no fresh robot state: the latest is %.1f ms old",
                1e-6 * static_cast<double>(after_the_last_state(rig.stale_ns, rig.P()).fault_at));
  EXPECT_NE(summarise(rig.bus().statuses()).fault_messages.at(0).find(expected), std::string::npos)
      << summarise(rig.bus().statuses()).fault_messages.at(0);
  expect_safe(rig, "delay spikes of 1.5 stale limits every 500 states");
}

// Bursts of NaN and infinite states from another sender on the status channel, in the protocol's
// own message: each is refused and counted, none reaches the law; the move completes without a
// FAULT.
TEST_P(Faults, BurstsOfNaNStates) {
  Rig rig(GetParam());
  ASSERT_TRUE(rig.holding());
  const int64_t rejected_before = rig.status().rejected_messages;
  rig.world.send_joint_target(goal_a(), 1.0);
  constexpr int kBursts = 5, kPerBurst = 20;
  for (int burst = 0; burst < kBursts; ++burst) {
    for (int k = 0; k < kPerBurst; ++k) {
      robot_state_t bad = *rig.bus().state();
      bad.seq += 1;
      bad.utime += 1;
      (k % 2 == 0 ? bad.position : bad.velocity)[size_t(k % 7)] = k % 3 == 0 ? INFINITY : std::nan("");
      rig.bus().publish_status(bad);
      rig.world.run_for(2e-4);
    }
    rig.world.run_for(0.1);
  }
  rig.world.run_for(1.0);
  EXPECT_LT(distance(vector_of(rig.bus().state()->position), goal_a()), 1e-3);
  EXPECT_EQ(rig.status().rejected_messages - rejected_before, kBursts * kPerBurst);
  EXPECT_EQ(rig.status().faults, 0);
  expect_safe(rig, "NaN/inf state bursts (5 x 20)");
}

// Targets at ten times the tick rate for 1 s (10 kHz on a 1 kHz loop), 5 of every 6 bad (NaN,
// outside the limits, wrong joint count, zero duration, too fast): every bad one refused and
// counted, no good one refused, the last good one reached.
TEST_P(Faults, TargetFloodAtTenTimesTheTickRate) {
  Rig rig(GetParam());
  ASSERT_TRUE(rig.holding());
  const int64_t rejected_before = rig.status().rejected_messages;
  const int targets = static_cast<int>(10 * GetParam().rate_hz);
  int bad = 0;
  VectorXd good = bent_pose();
  for (int k = 0; k < targets; ++k) {
    VectorXd q = bent_pose();
    q(0) += 0.3 * std::sin(1e-3 * k * 1000.0 / GetParam().rate_hz);
    arm_target_t target = joint_target(q, 1.0);
    switch (k % 6) {
      case 1:
        target.joint_position[2] = std::nan("");
        break;
      case 2:
        target.joint_position[3] = 3.5;  // outside the limits
        break;
      case 3:
        target.num_joints = 6, target.joint_position.resize(6);
        break;
      case 4:
        target.duration = 0.0;
        break;
      case 5:
        target.duration = 1e-3;  // far over the velocity limits
        target.joint_position[0] += 1.0;
        break;
      default:
        good = q;
        break;
    }
    bad += k % 6 != 0;
    rig.bus().publish("TARGET", target);
    rig.world.run_for(0.1 * GetParam().period());
  }
  rig.world.run_for(1.5);
  EXPECT_EQ(rig.status().rejected_messages - rejected_before, bad);
  EXPECT_EQ(rig.status().state, controller_status_t::HOLDING);
  EXPECT_LT(distance(vector_of(rig.bus().state()->position), good), 1e-3);
  EXPECT_EQ(rig.status().faults, 0);
  expect_safe(rig, "target flood at 10x the tick rate, 5 of 6 bad");
}

// A second controller on the same channels while the first commands the arm: in its listening
// window (before its loop starts) it hears the first's commands and refuses to start; the first
// goes on undisturbed.
TEST_P(Faults, SecondControllerRefusesToStart) {
  Rig rig(GetParam());
  ASSERT_TRUE(rig.holding());
  const int second = rig.world.add_controller(controller_on(GetParam()));
  rig.world.set_ticking(second, false);
  EXPECT_EQ(rig.world.controller(second).refusal(), "");
  rig.world.run_for(0.05);  // the daemon's listening window
  const std::string expected = "another controller is already commanding " + GetParam().channels().command +
                               " (heard " + std::to_string(std::llround(0.05 * GetParam().rate_hz)) +
                               " command(s) before this one sent any, ";
  EXPECT_EQ(rig.world.controller(second).refusal().rfind(expected, 0), 0u) << rig.world.controller(second).refusal();
  EXPECT_LT(rig.move(goal_a(), 1.0), 1e-3);
  EXPECT_EQ(rig.status().faults, 0);
  expect_safe(rig, "second controller refuses to start");
}

// Two controllers that both start before the plant. The first to command (the one whose ticks come
// first after the plant's first state) drives; the other hears that command before its own first
// tick, stands down — FAULT, latched — and never sends one. The move completes under the first.
// Its reason names the command it heard: by seq on chasles's protocol, by the utime of the status it
// answers on Drake's, whose commands carry no seq.
TEST_P(Faults, TwoControllersRunningAtOnceOnlyOneDrives) {
  const Wire& wire = GetParam();
  World world(panda(), wire.protocol);
  world.add_controller(controller_on(wire), wire.period_ns() / 2);
  const int second = world.add_controller(controller_on(wire), wire.period_ns() * 7 / 10);
  world.run_for(0.1);
  start_plant(world, bent_pose(), plant_on(wire));
  ASSERT_TRUE(world.run_until([&] { return world.controller(0).controller().mode() == controller::Mode::kHolding; }, 1.0));
  world.send_joint_target(goal_a(), 1.0);
  world.run_for(1.5);
  EXPECT_EQ(world.controller(0).controller().faults(), 0);
  EXPECT_EQ(world.controller(second).controller().faults(), 1);
  EXPECT_TRUE(world.controller(second).controller().stood_down());
  const std::string first_state_utime = std::to_string(world.plant()->state_utime(0));
  EXPECT_EQ(world.controller(second).controller().fault_reason(),
            wire.protocol == controller::Protocol::kChasles
                ? "another sender is commanding CHASLES_COMMAND (seq 1 answering state 0; our latest state 0): "
                  "stopped commanding"
                : "another sender is commanding " + wire.channels().command + " (a command not ours answering utime " +
                      first_state_utime + "; our latest state utime " + first_state_utime + "): stopped commanding");
  EXPECT_EQ(world.controller(second).summary(1.6).commands, 0);
  EXPECT_LT(distance(vector_of(world.recorder().state()->position), goal_a()), 1e-3);
}

// The controller's commands of its first 0.3 s replayed onto the live bus 0.5 s later (as
// lcm-logplayer would, by mistake): the controller hears commands it did not send, FAULTs once and
// sends nothing more; the plant applies none of the replayed ones — each answers a state hundreds
// of steps older than its newest, beyond its lag limit — so with its controller silent its
// watchdog brakes the arm to rest, once.
TEST_P(Faults, ReplayedCommandsWithStaleStateSeq) {
  const Wire& wire = GetParam();
  Rig rig(wire);
  ASSERT_TRUE(rig.holding());
  rig.world.run_for(0.3);
  // Each recorded command encoded again as the protocol carries it, the state it answers and all,
  // with zero torque: were it applied, the arm would fall (or, on a driver adding g, coast
  // undamped), so the harm is visible.
  controller::CommandWriter writer(wire.protocol, 7, controller::default_torque_semantics(wire.protocol));
  controller::JointState answered(7);
  const VectorXd zero = VectorXd::Zero(7);
  std::vector<std::vector<uint8_t>> recorded;
  for (const auto& c : rig.bus().commands()) {
    answered.seq = c.message.state_seq;
    answered.utime = rig.world.plant()->state_utime(c.message.state_seq);
    writer.write(c.message.utime, c.message.seq, answered, zero, zero);
    recorded.push_back(writer.bytes());
  }
  rig.world.run_for(0.5);
  const int64_t stale_before = rig.world.plant()->stale_commands();
  const int64_t index = rig.bus().index();
  for (const auto& replay : recorded) {
    rig.bus().publish_raw(wire.channels().command, replay);
    rig.world.run_for(wire.period());
  }
  rig.world.run_for(0.5);
  EXPECT_EQ(rig.status().faults, 1);
  EXPECT_EQ(rig.status().state, controller_status_t::FAULT);
  EXPECT_NE(rig.status().message.find("another sender is commanding " + wire.channels().command), std::string::npos)
      << rig.status().message;
  EXPECT_EQ(rig.bus().commands_after(index), 0) << "the controller commanded after hearing a replay";
  EXPECT_EQ(rig.world.plant()->stale_commands() - stale_before, static_cast<int64_t>(recorded.size()));
  EXPECT_TRUE(rig.world.plant()->braking());
  EXPECT_EQ(rig.world.plant()->brakes(), 1);
  EXPECT_LT(rig.world.plant()->plant().qd().cwiseAbs().maxCoeff(), 1e-3);
}

// The IK worker in simulated time: a CARTESIAN target becomes a request, Node::plan solves it with
// Ceres between two ticks, the loop follows the joint path; the plant's tip ends at the goal pose.
TEST_P(Faults, CartesianMoveEndsAtTheGoalPose) {
  Rig rig(GetParam());
  ASSERT_TRUE(rig.holding());
  Data data(panda());
  const Transform goal = forward_kinematics(panda(), data, goal_a());
  rig.bus().publish("TARGET", cartesian_target(goal, 1.5));
  rig.world.run_for(2.5);
  EXPECT_EQ(summarise(rig.bus().statuses()).modes, "HOLDING>RUNNING>HOLDING");
  EXPECT_TRUE(rig.status().ik_converged);
  const Transform reached = forward_kinematics(panda(), data, vector_of(rig.bus().state()->position));
  EXPECT_LT((reached.translation() - goal.translation()).norm(), 1e-3);
  EXPECT_LT(Eigen::AngleAxisd(reached.linear().transpose() * goal.linear()).angle(), 1e-3);
  EXPECT_EQ(rig.status().faults, 0);
  expect_safe(rig, "none (Cartesian move)");
}

INSTANTIATE_TEST_SUITE_P(Wires, Faults, ::testing::ValuesIn(wires_to_run()), wire_name);

}  // namespace
}  // namespace chasles::faults
