// Fault tests: chasles_plant and chasles_controller as real processes on real LCM, inside a network
// namespace of this binary's own (tools/netns.sh), with faults injected by the plant's seeded
// options or by the test on the bus. For every fault the harness checks the controller's whole
// command stream — finite, within the effort limits, within the torque-rate limit (restarting
// from g(q) only after a FAULT) — its rate, and that the status reported what happened. Each
// test prints its row of the fault table ("FAULT TABLE | ...").
#include <gtest/gtest.h>

#include <algorithm>
#include <chasles/arm_target_t.hpp>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "chasles/controller/clock.hpp"
#include "harness.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::faults {
namespace {

using controller::monotonic_ns;
using controller::sleep_until;
using Eigen::VectorXd;
using testing::ChildProcess;
using testing::data_path;

constexpr char kLcmUrl[] = "udpm://239.255.76.67:7667?ttl=0";
constexpr double kPeriod = 1e-3;  // the controller's default rate
constexpr double kRamp = 0.05;    // its default --torque-ramp-ms
constexpr double kStaleMs = 10.0; // its default --stale-ms

std::vector<std::string> plant_args(std::vector<std::string> extra, const VectorXd& q0 = bent_pose()) {
  std::vector<std::string> argv{CHASLES_PLANT, "--robot", data_path("panda.urdf"), "--tip", "panda_hand_tcp",
                                "--lcm-url", kLcmUrl, "--q0", list(q0)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

std::vector<std::string> controller_args(std::vector<std::string> extra) {
  std::vector<std::string> argv{CHASLES_CONTROLLER, "--robot", data_path("panda.urdf"), "--tip", "panda_hand_tcp",
                                "--lcm-url", kLcmUrl};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

VectorXd goal_a() {
  VectorXd q = bent_pose();
  q(0) += 0.4, q(1) -= 0.3, q(3) += 0.3, q(5) += 0.2;
  return q;
}

// The checks every fault test ends with; prints the test's row of the fault table.
void expect_safe(const Bus& bus, const std::string& fault, const ChildProcess& controller) {
  const std::vector<HeardStatus> statuses = bus.statuses();
  const CommandReport c = check_commands(panda(), bus.commands(), statuses, kRamp, kPeriod);
  const StatusReport s = summarise(statuses);
  std::printf("%s\n", table_row(fault, c, s).c_str());
  EXPECT_GT(c.commands, 300);
  EXPECT_EQ(c.non_finite, 0) << c.first_violation;
  EXPECT_EQ(c.effort_violations, 0) << c.first_violation;
  EXPECT_EQ(c.rate_violations, 0) << c.first_violation;
  EXPECT_LE(c.seq_gaps, c.commands / 100) << "the test missed too many commands to judge the stream";
  // The first command and those after a FAULT may start from g(q) (one after a FAULT that is also
  // within the rate limit of the last command before it counts as an ordinary step).
  EXPECT_GE(c.restarts_from_gravity, 1);
  EXPECT_LE(c.restarts_from_gravity, 1 + s.faults);
  // Timing is measured by the benchmarks and the soak, and only printed here: CI machines have
  // stalled these processes for 30 ms at a time, which would fail any bound a 1 kHz loop deserves.
  // Judged is what no stall explains: the rate (command stamps a period apart at the median) and
  // that the loop did not fall behind for good, which would overrun on nearly every tick.
  EXPECT_NEAR(c.spacing_p50_us, kPeriod * 1e6, 0.1 * kPeriod * 1e6);
  EXPECT_LE(s.overruns, s.ticks / 2) << controller.stderr_text();
}

// Starts plant and controller and waits for the controller to hold the arm.
struct Rig {
  Bus bus{kLcmUrl};
  std::unique_ptr<ChildProcess> plant, controller;
  Rig(const std::vector<std::string>& plant_extra, const std::vector<std::string>& controller_extra)
      : plant(std::make_unique<ChildProcess>(plant_args(plant_extra))),
        controller(std::make_unique<ChildProcess>(controller_args(controller_extra))) {}
  bool holding() const { return bus.wait_for(controller_status_t::HOLDING, 5.0); }
  // A JOINT move to `goal` over `duration` s; whether it ends in HOLDING within tolerance. A FAULT
  // that cuts the move short leaves the arm held where it was; the target is then sent again (at
  // most twice), as an operator would. Whether that FAULT was the test's own is judged apart, by
  // expect_no_fault_of_its_own.
  ::testing::AssertionResult move(const VectorXd& goal, double duration, double tolerance) {
    VectorXd q;
    for (int attempt = 0; attempt < 3; ++attempt) {
      const int64_t faults_before = bus.status()->faults;
      bus.publish("TARGET", joint_target(goal, duration));
      if (!bus.wait_for(controller_status_t::RUNNING, 2.0)) return ::testing::AssertionFailure() << "never RUNNING";
      if (!bus.wait_for(controller_status_t::HOLDING, duration + 3.0)) {
        return ::testing::AssertionFailure() << "never HOLDING";
      }
      bus.listen(0.3);
      q = vector_of(bus.state()->position);
      if ((q - goal).cwiseAbs().maxCoeff() <= tolerance) return ::testing::AssertionSuccess();
      if (bus.status()->faults == faults_before) break;
    }
    return ::testing::AssertionFailure() << "ended at " << q.transpose() << ", goal " << goal.transpose();
  }
  // The longest the dropped states left the controller without one: the run the bus missed, plus
  // the period before the next state, ms.
  double drop_gap_ms() const { return static_cast<double>(bus.state_gaps().max_missing_run + 1) * kPeriod * 1e3; }
  // No FAULT but those a stall of the machine explains, given gaps of up to `injected_ms`.
  void expect_no_fault_of_its_own(double injected_ms, double stale_ms = kStaleMs) const {
    const std::string why = unexplained_faults(bus.state_gaps(), summarise(bus.statuses()), stale_ms, injected_ms);
    EXPECT_TRUE(why.empty()) << why << "\n" << controller->stderr_text();
  }
};

// kill -9 of the plant in the middle of a JOINT move: FAULT (no fresh state) within stale-ms, no
// command while it lasts; a plant started again is held where it is (the rate limiter restarts
// from g(q) there) and the next move completes.
TEST(faults, PlantKilledMidMotionAndRestarted) {
  Rig rig({}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  rig.bus.publish("TARGET", joint_target(goal_a(), 1.5));
  ASSERT_TRUE(rig.bus.wait_for(controller_status_t::RUNNING, 2.0));
  rig.bus.listen(0.5);
  rig.plant->stop(SIGKILL);
  ASSERT_TRUE(rig.bus.wait_for(controller_status_t::FAULT, 2.0)) << rig.controller->stderr_text();
  EXPECT_NE(rig.bus.status()->message.find("no fresh robot state"), std::string::npos) << rig.bus.status()->message;
  rig.bus.listen(0.05);
  const size_t heard = rig.bus.commands().size();
  rig.bus.listen(0.2);
  EXPECT_EQ(rig.bus.commands().size(), heard) << "commands during a FAULT";

  // The new plant starts where the old one was cut off (within the limits: it may have fallen).
  VectorXd elsewhere = vector_of(rig.bus.state()->position);
  for (int i = 0; i < 7; ++i) {
    const JointLimits& limits = panda().joint(i).limits;
    elsewhere(i) = std::clamp(elsewhere(i), limits.lower + 1e-3, limits.upper - 1e-3);
  }
  rig.plant = std::make_unique<ChildProcess>(plant_args({}, elsewhere));
  ASSERT_TRUE(rig.bus.wait_for(controller_status_t::HOLDING, 5.0))
      << rig.controller->stderr_text() << rig.plant->stderr_text();
  EXPECT_TRUE(rig.move(bent_pose(), 1.5, 2e-3));
  const controller_status_t s = *rig.bus.status();
  // At least the kill's. A machine that stalls plant or controller past stale-ms adds more, and
  // those are right too (the state was stale); the tick-level rule is in controller_test.
  EXPECT_GE(s.faults, 1);
  EXPECT_GT(s.stale_states, 0);
  expect_safe(rig.bus, "plant kill -9 mid-motion, restart", *rig.controller);
}

// 10 % of states dropped (seeded): the move completes with no FAULT.
TEST(faults, TenPercentOfStatesDropped) {
  Rig rig({"--drop", "0.1", "--seed", "11"}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  EXPECT_TRUE(rig.move(goal_a(), 1.0, 2e-3));
  // The drops alone never leave the controller without a state for stale-ms (a run of 10 has
  // p = 1e-10 per state)...
  EXPECT_LT(rig.drop_gap_ms(), kStaleMs);
  // ...so any FAULT must be a stall's.
  rig.expect_no_fault_of_its_own(rig.drop_gap_ms());
  expect_safe(rig.bus, "10 % state drop", *rig.controller);
}

// 50 % dropped: a gap of 10 states (p = 2^-10 per state) exceeds the default stale-ms of 10 and
// is a FAULT, so the arm may stop mid-motion and be held; every FAULT is reported and recovered
// from. With --stale-ms 30 (a gap of 30: p ≈ 1e-9) the move completes.
TEST(faults, FiftyPercentOfStatesDropped) {
  {
    Rig rig({"--drop", "0.5", "--seed", "5"}, {});
    ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
    rig.bus.publish("TARGET", joint_target(goal_a(), 1.0));
    rig.bus.listen(2.5);
    const StatusReport s = summarise(rig.bus.statuses());
    EXPECT_LE(s.fault_transitions, s.faults) << "every FAULT is counted in status";
    for (const auto& m : s.fault_messages) EXPECT_NE(m.find("no fresh robot state"), std::string::npos) << m;
    EXPECT_NE(rig.bus.status()->state, controller_status_t::FAULT) << "recovered";
    expect_safe(rig.bus, "50 % state drop, stale-ms 10", *rig.controller);
  }
  Rig rig({"--drop", "0.5", "--seed", "5"}, {"--stale-ms", "30"});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  EXPECT_TRUE(rig.move(goal_a(), 1.0, 3e-3));
  EXPECT_LT(rig.drop_gap_ms(), 30.0);
  rig.expect_no_fault_of_its_own(rig.drop_gap_ms(), 30.0);
  expect_safe(rig.bus, "50 % state drop, stale-ms 30", *rig.controller);
}

// 5 ms delay spikes (every 200th state holds the stream back 5 ms, then it arrives in a burst):
// below stale-ms, so no FAULT; the latest state wins, the move completes.
TEST(faults, FiveMillisecondDelaySpikes) {
  Rig rig({"--delay-spike-ms", "5", "--delay-spike-every", "200"}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  EXPECT_TRUE(rig.move(goal_a(), 1.0, 2e-3));
  rig.expect_no_fault_of_its_own(5.0 + kPeriod * 1e3);
  expect_safe(rig.bus, "5 ms delay spikes every 200 states", *rig.controller);
}

// A spike longer than stale-ms (15 ms): FAULT, reported with the state's age; the burst after it
// brings the arm back to HOLDING where it is.
TEST(faults, DelaySpikesLongerThanTheStaleLimitFault) {
  Rig rig({"--delay-spike-ms", "15", "--delay-spike-every", "1000"}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  rig.bus.listen(2.2);
  const StatusReport s = summarise(rig.bus.statuses());
  EXPECT_GE(s.faults, 1);
  // A FAULT shorter than the status thread's look (1 ms) shows in the counter only.
  EXPECT_GE(s.fault_transitions, 1);
  EXPECT_LE(s.fault_transitions, s.faults);
  ASSERT_FALSE(s.fault_messages.empty());
  EXPECT_NE(s.fault_messages[0].find("no fresh robot state"), std::string::npos) << s.fault_messages[0];
  EXPECT_TRUE(rig.bus.wait_for(controller_status_t::HOLDING, 1.0));
  expect_safe(rig.bus, "15 ms delay spikes every 1000 states", *rig.controller);
}

// Bursts of NaN (and infinite) states from another sender on the state channel while the plant
// runs: each is rejected and counted, none reaches the law; the move completes without a FAULT.
TEST(faults, BurstsOfNaNStates) {
  Rig rig({}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  const int64_t rejected_before = rig.bus.status()->rejected_messages;
  rig.bus.publish("TARGET", joint_target(goal_a(), 1.0));
  constexpr int kBursts = 5, kPerBurst = 20;
  for (int burst = 0; burst < kBursts; ++burst) {
    for (int k = 0; k < kPerBurst; ++k) {
      robot_state_t bad = *rig.bus.state();
      bad.seq += 1;
      (k % 2 == 0 ? bad.position : bad.velocity)[size_t(k % 7)] = k % 3 == 0 ? INFINITY : std::nan("");
      rig.bus.publish("STATE", bad);
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    rig.bus.listen(0.1);
  }
  ASSERT_TRUE(rig.bus.wait_for(controller_status_t::HOLDING, 3.0));
  rig.bus.listen(0.3);
  if ((vector_of(rig.bus.state()->position) - goal_a()).cwiseAbs().maxCoeff() > 2e-3 && rig.bus.status()->faults > 0) {
    EXPECT_TRUE(rig.move(goal_a(), 1.0, 2e-3)) << "after a FAULT cut the move short";
  }
  const controller_status_t s = *rig.bus.status();
  rig.expect_no_fault_of_its_own(kPeriod * 1e3);
  EXPECT_EQ(s.rejected_messages - rejected_before, kBursts * kPerBurst) << rig.controller->stderr_text();
  EXPECT_LT((vector_of(rig.bus.state()->position) - goal_a()).cwiseAbs().maxCoeff(), 2e-3);
  EXPECT_NE(rig.controller->stderr_text().find("non-finite"), std::string::npos);
  expect_safe(rig.bus, "NaN/inf state bursts (5 x 20)", *rig.controller);
}

// 10 kHz of targets for 1 s, bad ones (NaN, outside the limits, wrong joint count, zero duration,
// too fast) interleaved with good ones: the bad are refused and counted, the good followed; the
// tick keeps its timing; the last good target is reached.
TEST(faults, TargetFloodAt10kHz) {
  Rig rig({}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  const int64_t rejected_before = rig.bus.status()->rejected_messages;
  constexpr int kTargets = 10'000;
  int bad = 0;
  VectorXd good = bent_pose();
  int64_t next = monotonic_ns();
  for (int k = 0; k < kTargets; ++k) {
    VectorXd q = bent_pose();
    q(0) += 0.3 * std::sin(1e-3 * k);
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
    rig.bus.publish("TARGET", target);
    next += 100'000;
    sleep_until(next);
  }
  rig.bus.publish("TARGET", joint_target(good, 0.5));
  ASSERT_TRUE(rig.bus.until(
      [](const Bus& b) { return b.status_locked() && b.status_locked()->state == controller_status_t::HOLDING; }, 3.0));
  rig.bus.listen(0.3);
  const controller_status_t s = *rig.bus.status();
  const int64_t rejected = s.rejected_messages - rejected_before;
  std::printf("target flood: %d sent, %d bad; controller rejected %lld; message: %s\n", kTargets, bad,
              static_cast<long long>(rejected), s.message.c_str());
  // LCM may drop some of a burst in the controller's receive queue before they are judged; none
  // that it judged escapes the count. A good target may be refused too, "not taken" when a stall
  // let the loop's queue of 16 fill.
  EXPECT_GE(rejected, bad * 9 / 10);
  EXPECT_LE(rejected, kTargets);
  rig.expect_no_fault_of_its_own(kPeriod * 1e3);
  EXPECT_LT((vector_of(rig.bus.state()->position) - good).cwiseAbs().maxCoeff(), 2e-3);
  expect_safe(rig.bus, "10 kHz target flood, 5 of 6 bad", *rig.controller);
}

// A second controller on the same channels while the first commands the arm: it hears the first's
// commands before its loop starts, refuses to run (exit 1, one clear line), and the first goes on
// undisturbed.
TEST(faults, SecondControllerRefusesToStart) {
  Rig rig({}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  const testing::RunResult second = testing::run_to_completion(controller_args({"--seconds", "2"}));
  EXPECT_EQ(second.exit_code, 1) << second.err;
  EXPECT_NE(second.err.find("another controller is already commanding CHASLES_COMMAND"), std::string::npos)
      << second.err;
  EXPECT_NE(second.err.find("refusing to start"), std::string::npos) << second.err;
  rig.bus.listen(0.3);
  rig.expect_no_fault_of_its_own(kPeriod * 1e3);
  EXPECT_TRUE(rig.bus.wait_for(controller_status_t::HOLDING, 1.0)) << "a FAULT from a stall recovers to HOLDING";
  expect_safe(rig.bus, "second controller started", *rig.controller);
}

// Two controllers that both start before the plant (neither has commanded yet, so both start).
// Once the plant is up, whichever hears the other's commands reports FAULT ("another sender is
// commanding") and never commands again. Which one depends on the race: if one commands first
// and the other hears that before its own first command, only the second stands down and the
// first drives alone; if both command before hearing each other, both stand down and the plant's
// watchdog brakes the arm. Either way, afterwards at most one sender drives the arm.
TEST(faults, TwoControllersRunningAtOnceAtMostOneDrives) {
  Bus bus(kLcmUrl);
  ChildProcess first(controller_args({}));
  ChildProcess second(controller_args({}));
  bus.listen(0.3);  // both past their listening window
  ChildProcess plant(plant_args({}));
  ASSERT_TRUE(bus.until(
      [](const Bus& b) { return b.status_locked() && b.status_locked()->state == controller_status_t::FAULT; }, 5.0))
      << first.stderr_text() << second.stderr_text();
  bus.listen(0.3);
  bus.clear_commands();
  bus.listen(0.3);
  const std::string needle = "another sender is commanding CHASLES_COMMAND";
  const bool first_down = first.stderr_text().find(needle) != std::string::npos;
  const bool second_down = second.stderr_text().find(needle) != std::string::npos;
  EXPECT_TRUE(first_down || second_down);
  EXPECT_TRUE(first.running() && second.running()) << "they stay up, reporting";
  const std::vector<HeardCommand> after = bus.commands();
  if (first_down && second_down) {
    EXPECT_TRUE(after.empty()) << "a controller kept commanding";
    plant.stop(SIGTERM);
    EXPECT_NE(plant.stderr_text().find("braking to rest"), std::string::npos) << plant.stderr_text();
  } else {
    ASSERT_GT(after.size(), 100u) << "the controller that was first drives on";
    for (size_t k = 1; k < after.size(); ++k) {
      ASSERT_EQ(after[k].message.seq, after[k - 1].message.seq + 1) << "two senders interleaved";
    }
  }
  std::printf("FAULT TABLE | two controllers started together | %s | afterwards %zu commands in 0.3 s, one "
              "stream\n",
              first_down && second_down ? "both FAULT, plant brakes" : "the later one FAULT, the first drives on",
              after.size());
}

// A command stream with a stale state_seq: the first 0.3 s of the controller's commands replayed
// onto the live bus 0.5 s later (as lcm-logplayer would, by mistake, onto a live network). The
// controller hears commands it did not send: FAULT, no more commands. The real-time plant applies
// none of the replayed ones — each answers a state hundreds of steps older than its newest, over
// --max-command-lag-ms — so with its controller silent its watchdog brakes the arm to rest.
TEST(faults, ReplayedCommandsWithStaleStateSeq) {
  Rig rig({}, {});
  ASSERT_TRUE(rig.holding()) << rig.controller->stderr_text();
  rig.bus.listen(0.3);
  const std::vector<HeardCommand> recorded = rig.bus.commands();
  ASSERT_GT(recorded.size(), 100u);
  rig.bus.listen(0.5);
  const int64_t start = monotonic_ns();
  for (size_t k = 0; k < 300 && k < recorded.size(); ++k) {
    joint_torque_command_t replay = recorded[k].message;  // its seq, utime and (old) state_seq
    replay.torque.assign(7, 0.0);  // were it applied, the arm would fall: the harm is visible
    rig.bus.publish_command(replay);
    sleep_until(start + static_cast<int64_t>(k + 1) * 1'000'000);
  }
  ASSERT_TRUE(rig.bus.wait_for(controller_status_t::FAULT, 1.0)) << rig.controller->stderr_text();
  EXPECT_NE(rig.bus.status()->message.find("another sender is commanding CHASLES_COMMAND"), std::string::npos)
      << rig.bus.status()->message;
  rig.bus.clear_commands();
  rig.bus.listen(0.5);
  EXPECT_TRUE(rig.bus.commands().empty()) << "the controller kept commanding";
  const VectorXd q = vector_of(rig.bus.state()->position), qd = vector_of(rig.bus.state()->velocity);
  EXPECT_LT((q - bent_pose()).cwiseAbs().maxCoeff(), 0.05) << "the replayed zero torques were applied: " << q.transpose();
  EXPECT_LT(qd.cwiseAbs().maxCoeff(), 0.05);
  EXPECT_EQ(rig.plant->stop(SIGTERM), 0);
  const std::string plant_log = rig.plant->stderr_text();
  EXPECT_NE(plant_log.find("a command answering state"), std::string::npos) << plant_log;
  EXPECT_NE(plant_log.find("braking to rest"), std::string::npos) << plant_log;
  std::printf("FAULT TABLE | replayed commands, stale state_seq | controller: %s | plant: ignored as stale, braked; "
              "arm moved %.4f rad\n",
              rig.bus.status()->message.c_str(), (q - bent_pose()).cwiseAbs().maxCoeff());
}

}  // namespace
}  // namespace chasles::faults
