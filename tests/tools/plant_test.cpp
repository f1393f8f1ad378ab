// chasles_plant run as a real process and driven over LCM the way a controller drives it. The test
// binary runs inside its own network namespace (tools/netns.sh is its launcher, see
// CMakeLists.txt), so the multicast traffic never leaves the machine and tests running in
// parallel do not hear each other. The Drake protocols driven in process, in simulated time, are
// plant_drake_test.cpp's, in the same binary; what is here needs the process: its lockstep over the
// wire, its flags, its exit, its start-up lines.
#include <gtest/gtest.h>

#include <algorithm>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <drake/lcmt_iiwa_status.hpp>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "lcmtypes/checked.hpp"
#include "support/arm.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"
#include "tests/tools/plant_reference.hpp"

namespace chasles::testing {
namespace {

using drake::lcmt_iiwa_status;
using plant_reference::iiwa_pose;
using plant_reference::kDt;
using plant_reference::panda;
using plant_reference::rk4_reference;

using Clock = std::chrono::steady_clock;

constexpr char kPrefix[] = "TEST_";

// chasles_plant with `args` (plus the test's LCM URL and channel prefix).
class PlantProcess : public ChildProcess {
 public:
  explicit PlantProcess(const std::vector<std::string>& args) : ChildProcess(command_line(args)) {}

 private:
  static std::vector<std::string> command_line(const std::vector<std::string>& args) {
    return concat({CHASLES_PLANT, "--lcm-url", kLcmUrl, "--channel-prefix", kPrefix}, args);
  }
};

// The test's end of the wire: what a controller sees and sends.
class Controller {
 public:
  // Subscribed through LCM's C interface: GCC 12 with -fsanitize=vptr miscompiles the
  // pointer-to-member call inside LCM's typed C++ subscription, and sanitized builds crash there.
  Controller() : lcm_(kLcmUrl) {
    EXPECT_TRUE(lcm_.good()) << "LCM did not start: is the test running under tools/netns.sh?";
    const std::string channel = std::string(kPrefix) + "STATE";
    lcm_subscribe(lcm_.getUnderlyingLCM(), channel.c_str(), &Controller::on_state, this);
    const std::string truth_channel = std::string(kPrefix) + "TRUTH";
    lcm_subscribe(lcm_.getUnderlyingLCM(), truth_channel.c_str(), &Controller::on_truth, this);
  }

  /// Waits for a state with seq ≥ min_seq; the latest one received, or nothing on timeout.
  std::optional<robot_state_t> wait_state(int64_t min_seq, double timeout_s = 5.0) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (!latest_ || latest_->seq < min_seq) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return std::nullopt;
      lcm_.handleTimeout(static_cast<int>(left));
    }
    return latest_;
  }

  /// Handles whatever arrives for `seconds`.
  void listen(double seconds) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return;
      lcm_.handleTimeout(static_cast<int>(left));
    }
  }

  void send(int64_t state_seq, const Eigen::VectorXd& tau) {
    joint_torque_command_t command;
    command.utime = 0;
    command.seq = ++command_seq_;
    command.state_seq = state_seq;
    command.num_joints = static_cast<int32_t>(tau.size());
    command.torque.assign(tau.data(), tau.data() + tau.size());
    lcm_.publish(std::string(kPrefix) + "COMMAND", &command);
  }

  void send_bytes(const std::vector<uint8_t>& bytes) {
    lcm_.publish(std::string(kPrefix) + "COMMAND", bytes.data(), static_cast<unsigned>(bytes.size()));
  }

  /// Every state received, in order of arrival.
  const std::vector<robot_state_t>& states() const { return states_; }
  /// Every sim_truth_t received, in order of arrival.
  const std::vector<sim_truth_t>& truths() const { return truths_; }

 private:
  static void on_state(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    auto& controller = *static_cast<Controller*>(self);
    robot_state_t state;
    const int size = static_cast<int>(rbuf->data_size);
    ASSERT_EQ(state.decode(rbuf->data, 0, size), size) << "the plant sent a malformed robot_state_t";
    controller.latest_ = state;
    controller.states_.push_back(state);
  }

  static void on_truth(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    sim_truth_t truth;
    const std::string why = messages::decode_checked(rbuf->data, rbuf->data_size, truth, 7, messages::Finite::Required);
    ASSERT_EQ(why, "") << "the plant sent a bad sim_truth_t";
    static_cast<Controller*>(self)->truths_.push_back(std::move(truth));
  }

  lcm::LCM lcm_;
  std::optional<robot_state_t> latest_;
  std::vector<robot_state_t> states_;
  std::vector<sim_truth_t> truths_;
  int64_t command_seq_ = 0;
};

// Lockstep: answers state k with tau(k) for `steps` steps; returns every state 0..steps in order.
template <class Torque>
std::vector<robot_state_t> drive_lockstep(Controller& controller, int steps, Torque tau) {
  std::vector<robot_state_t> trajectory;
  for (int k = 0; k <= steps; ++k) {
    const std::optional<robot_state_t> state = controller.wait_state(k);
    if (!state) {
      ADD_FAILURE() << "no state " << k << " from the plant";
      break;
    }
    EXPECT_EQ(state->seq, k) << "lockstep must step once per command";
    trajectory.push_back(*state);
    if (k < steps) controller.send(k, tau(*state));
  }
  return trajectory;
}

double energy(const RobotModel& model, Data& data, const robot_state_t& state) {
  const Eigen::VectorXd q = vector_of(state.position), qd = vector_of(state.velocity);
  return kinetic_energy(model, data, q, qd) + potential_energy(model, data, q);
}

// (a) With zero torque and no damping the arm falls. After 0.5 s (500 steps) the plant's state
// equals an RK4 integration at a 10 times smaller step (10^4 times more accurate: fourth order).
// The plant was measured 8e-9 rad and 7e-8 rad/s off, so 1e-6 rad and 1e-5 rad/s leave room for
// other machines' rounding while failing any first- or second-order integrator (semi-implicit
// Euler: 1.6e-2 rad). Total energy (about 78 J), which the plant never computes, stays within
// 1e-5 J of its start (measured: 1.7e-7 J).
TEST(plant, LockstepFallMatchesAFineIntegrationAndConservesEnergy) {
  const RobotModel model = panda();
  const Eigen::VectorXd q0 = bent_pose(), zero = Eigen::VectorXd::Zero(7);
  Controller controller;
  PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0", list(q0)});
  constexpr int kSteps = 500;
  const std::vector<robot_state_t> trajectory =
      drive_lockstep(controller, kSteps, [&](const robot_state_t&) { return zero; });
  ASSERT_EQ(trajectory.size(), static_cast<size_t>(kSteps + 1));

  Eigen::VectorXd q = q0, qd = zero;
  rk4_reference(model, q, qd, zero, kDt / 10, kSteps * 10);
  const robot_state_t& last = trajectory.back();
  EXPECT_GT(max_abs_diff(vector_of(last.position), q0), 0.1) << "the arm should have fallen";
  EXPECT_TRUE(matrices_near(vector_of(last.position), q, 1e-6));
  EXPECT_TRUE(matrices_near(vector_of(last.velocity), qd, 1e-5));
  EXPECT_TRUE(matrices_near(vector_of(last.effort), zero, 0.0));

  Data data(model);
  const double e0 = energy(model, data, trajectory.front());
  double drift = 0.0;
  for (const robot_state_t& state : trajectory) drift = std::max(drift, std::abs(energy(model, data, state) - e0));
  EXPECT_LT(drift, 1e-5) << "total energy drifted by " << drift << " J from " << e0 << " J";
  EXPECT_EQ(plant.stop(), 0) << plant.stderr_text();
}

// --armature replaces the URDF's (the Panda's has none): the arm falls as a fine integration of the
// model with that armature does, and unlike the rigid one (the rotors slow the fall measurably).
TEST(plant, ArmatureFlagGivesTheSimulatedArmItsRotors) {
  Eigen::VectorXd armature(7);
  armature << 0.6, 0.6, 0.5, 0.5, 0.2, 0.2, 0.1;
  const RobotModel model = with_armature(panda(), armature), rigid = panda();
  const Eigen::VectorXd q0 = bent_pose(), zero = Eigen::VectorXd::Zero(7);
  Controller controller;
  PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0", list(q0),
                      "--armature", list(armature)});
  constexpr int kSteps = 200;
  const std::vector<robot_state_t> trajectory =
      drive_lockstep(controller, kSteps, [&](const robot_state_t&) { return zero; });
  ASSERT_EQ(trajectory.size(), static_cast<size_t>(kSteps + 1));
  Eigen::VectorXd q = q0, qd = zero, q_rigid = q0, qd_rigid = zero;
  rk4_reference(model, q, qd, zero, kDt / 10, kSteps * 10);
  rk4_reference(rigid, q_rigid, qd_rigid, zero, kDt / 10, kSteps * 10);
  const Eigen::VectorXd last = vector_of(trajectory.back().position);
  EXPECT_TRUE(matrices_near(last, q, 1e-6));
  EXPECT_GT(max_abs_diff(last, q_rigid), 1e-3) << "the armature made no difference";
  EXPECT_EQ(plant.stop(), 0) << plant.stderr_text();
}

// Lockstep is deterministic, and so is the seeded sensor noise.
TEST(plant, LockstepWithSeededNoiseRepeatsExactly) {
  const Eigen::VectorXd q0 = bent_pose(), zero = Eigen::VectorXd::Zero(7);
  const auto run = [&](const std::string& seed, double noise) {
    Controller controller;
    PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0", list(q0),
                        "--seed", seed, "--noise", std::to_string(noise)});
    const auto trajectory = drive_lockstep(controller, 100, [&](const robot_state_t&) { return zero; });
    EXPECT_EQ(plant.stop(), 0) << plant.stderr_text();
    return trajectory;
  };
  const auto first = run("3", 1e-3), again = run("3", 1e-3), clean = run("3", 0.0);
  ASSERT_EQ(first.size(), 101u);
  ASSERT_EQ(again.size(), 101u);
  ASSERT_EQ(clean.size(), 101u);
  double noise_seen = 0.0;
  for (size_t k = 0; k < first.size(); ++k) {
    EXPECT_EQ(first[k].position, again[k].position) << "state " << k;
    EXPECT_EQ(first[k].velocity, clean[k].velocity) << "noise is on the sent position only";
    noise_seen = std::max(noise_seen, max_abs_diff(vector_of(first[k].position), vector_of(clean[k].position)));
  }
  EXPECT_GT(noise_seen, 1e-4);
  EXPECT_LT(noise_seen, 1e-2);
}

// Lost and late states do not stall a lockstep run: the plant sends the latest state again
// until it is answered, and the trajectory is the same as without faults.
TEST(plant, LockstepRidesOutDroppedAndDelayedStates) {
  const Eigen::VectorXd q0 = bent_pose(), zero = Eigen::VectorXd::Zero(7);
  const auto run = [&](const std::vector<std::string>& faults) {
    std::vector<std::string> args = {"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0",
                                     list(q0)};
    args.insert(args.end(), faults.begin(), faults.end());
    Controller controller;
    PlantProcess plant(args);
    const auto trajectory = drive_lockstep(controller, 40, [&](const robot_state_t&) { return zero; });
    EXPECT_EQ(plant.stop(), 0);
    return std::make_pair(trajectory, plant.stderr_text());
  };
  const auto [clean, clean_err] = run({});
  const auto [faulty, faulty_err] = run({"--seed", "5", "--drop", "0.3", "--delay-ms", "5"});
  ASSERT_EQ(clean.size(), 41u);
  ASSERT_EQ(faulty.size(), 41u);
  EXPECT_EQ(faulty.back().position, clean.back().position);
  EXPECT_EQ(faulty.back().velocity, clean.back().velocity);
  EXPECT_NE(clean_err.find("states not sent 0;"), std::string::npos) << clean_err;
  EXPECT_EQ(faulty_err.find("states not sent 0;"), std::string::npos) << faulty_err;
}

// (b) Commanding exactly the gravity torques g(q0) holds the arm at rest.
TEST(plant, GravityTorquesHoldTheArmStill) {
  const RobotModel model = panda();
  Data data(model);
  const Eigen::VectorXd q0 = bent_pose();
  const Eigen::VectorXd g = gravity_torques(model, data, q0);
  Controller controller;
  PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0", list(q0)});
  const auto trajectory = drive_lockstep(controller, 1000, [&](const robot_state_t&) { return g; });
  ASSERT_EQ(trajectory.size(), 1001u);
  double drift = 0.0;
  for (const robot_state_t& state : trajectory) drift = std::max(drift, max_abs_diff(vector_of(state.position), q0));
  EXPECT_LT(drift, 1e-6);
  EXPECT_TRUE(matrices_near(vector_of(trajectory.back().effort), g, 1e-12));
  EXPECT_EQ(plant.stop(), 0) << plant.stderr_text();
}

std::vector<uint8_t> encode(const joint_torque_command_t& command) {
  std::vector<uint8_t> bytes(static_cast<size_t>(command.getEncodedSize()));
  command.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// (c) Malformed commands are refused, counted and reported, never applied: the lockstep plant
// does not step on them, and the next valid command steps from where the arm was.
TEST(plant, MalformedCommandsAreRejectedNotApplied) {
  const RobotModel model = panda();
  Data data(model);
  const Eigen::VectorXd q0 = bent_pose();
  const Eigen::VectorXd g = gravity_torques(model, data, q0);
  Controller controller;
  PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0", list(q0)});
  ASSERT_TRUE(controller.wait_state(0));

  controller.send(0, Eigen::VectorXd::Constant(3, 50.0));  // too few joints
  controller.send(0, Eigen::VectorXd::Constant(8, 0.0));   // too many
  Eigen::VectorXd bad = g;
  bad[2] = std::numeric_limits<double>::quiet_NaN();
  controller.send(0, bad);
  bad[2] = -std::numeric_limits<double>::infinity();
  controller.send(0, bad);

  joint_torque_command_t command;
  command.utime = command.seq = command.state_seq = 0;
  command.num_joints = 7;
  command.torque.assign(g.data(), g.data() + g.size());
  std::vector<uint8_t> bytes = encode(command);
  bytes[0] ^= 0x01;  // another type's fingerprint
  controller.send_bytes(bytes);
  // The right size with a forged joint count: the decoder must never see it (it would try to
  // allocate 2^31 doubles, or -1).
  for (const uint8_t high : {0x7f, 0xff}) {
    bytes = encode(command);
    bytes[32] = high;
    bytes[33] = bytes[34] = bytes[35] = 0xff;
    controller.send_bytes(bytes);
  }
  constexpr int kRejected = 7;

  controller.listen(0.1);  // the plant only repeats state 0
  ASSERT_TRUE(controller.wait_state(0));
  EXPECT_FALSE(controller.wait_state(1, 0.0).has_value()) << "the plant stepped on a malformed command";
  ASSERT_TRUE(plant.running()) << plant.stderr_text();

  controller.send(0, g);
  const std::optional<robot_state_t> next = controller.wait_state(1);
  ASSERT_TRUE(next);
  EXPECT_EQ(next->seq, 1);
  EXPECT_LT(max_abs_diff(vector_of(next->position), q0), 1e-6);
  EXPECT_TRUE(matrices_near(vector_of(next->effort), g, 1e-12));

  EXPECT_EQ(plant.stop(), 0);
  const std::string err = plant.stderr_text();
  // Reports are rate-limited: the first arrives at once (it may cover a few), the total at exit.
  EXPECT_NE(err.find("chasles_plant: rejected "), std::string::npos) << err;
  EXPECT_NE(err.find(" on TEST_COMMAND (last: "), std::string::npos) << err;
  EXPECT_NE(err.find("commands rejected " + std::to_string(kRejected) + ","), std::string::npos) << err;
}

// (d) Real time: when commands stop, the arm is braked to rest: after --max-late late cycles in a row
// (silence makes every cycle late; 40 here, so a test process stalled for less than 40 ms while it
// answers does not trip it), and with --max-late 0 by the 50 ms watchdog.
TEST(plant, BrakesToRestWhenCommandsStop) {
  for (const bool late_stop : {true, false}) {
    const Eigen::VectorXd q0 = bent_pose(), zero = Eigen::VectorXd::Zero(7);
    Controller controller;
    std::vector<std::string> args = {"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--q0", list(q0)};
    if (late_stop) {
      args.insert(args.end(), {"--max-late", "40", "--timeout-ms", "500"});
    } else {
      args.insert(args.end(), {"--max-late", "0", "--timeout-ms", "50"});
    }
    PlantProcess plant(args);
    std::optional<robot_state_t> state = controller.wait_state(0);
    ASSERT_TRUE(state);
    // Zero torque, answering every state, for 0.15 s: the arm falls.
    const auto release = Clock::now() + std::chrono::milliseconds(150);
    while (Clock::now() < release) {
      state = controller.wait_state(state->seq + 1, 1.0);
      ASSERT_TRUE(state);
      controller.send(state->seq, zero);
    }
    const double falling_speed = vector_of(state->velocity).cwiseAbs().maxCoeff();
    EXPECT_GT(falling_speed, 0.3) << "the arm should be falling";

    // Silence: after 40 ms (late) or the 50 ms timeout the brake takes the velocity down with a 50 ms time constant
    // (slower at first where the effort limits clamp it): 0.7 s of simulated time is ten time
    // constants and more. The plant's clock is the wall clock, and a loaded machine can starve it of
    // steps, so the test waits for rest up to 3 s rather than judging at a fixed moment.
    double final_speed = falling_speed;
    const auto give_up = Clock::now() + std::chrono::seconds(3);
    while (final_speed >= 1e-3 && Clock::now() < give_up) {
      controller.listen(0.1);
      state = controller.wait_state(0);
      ASSERT_TRUE(state);
      final_speed = vector_of(state->velocity).cwiseAbs().maxCoeff();
    }
    EXPECT_LT(final_speed, 1e-3) << "falling at " << falling_speed << " rad/s, still " << final_speed << " after 3 s";
    EXPECT_EQ(plant.stop(), 0);
    const std::string err = plant.stderr_text();
    if (late_stop) {
      EXPECT_NE(err.find("40 late cycles in a row on TEST_COMMAND (no command answered the previous state in time): "
                         "braking to rest"),
                std::string::npos)
          << err;
      EXPECT_NE(err.find(" late cycles, 1 late stops;"), std::string::npos) << "stopped after the last command: " << err;
    } else {
      EXPECT_NE(err.find("no valid command on TEST_COMMAND for 50 ms: braking to rest"), std::string::npos) << err;
      EXPECT_NE(err.find(" late cycles, 0 late stops;"), std::string::npos) << err;
    }
  }
}

// --seconds ends the run by itself; bad input and usage errors are one line and an exit code.
TEST(plant, StopsAfterSecondsAndFailsCleanly) {
  PlantProcess timed({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--seconds", "0.2"});
  EXPECT_EQ(timed.wait(), 0) << timed.stderr_text();

  const auto expect_failure = [](std::vector<std::string> args, int code, const std::string& needle) {
    PlantProcess plant(std::move(args));
    EXPECT_EQ(plant.wait(), code);
    const std::string err = plant.stderr_text();
    EXPECT_EQ(err.rfind("chasles_plant: ", 0), 0u) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_NE(err.find(needle), std::string::npos) << err;
  };
  expect_failure({"--robot", data_path("panda.urdf")}, 1, "--tip");
  expect_failure({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--q0", "0,0,0,0,0,0,0"}, 1,
                 "panda_joint4");
  expect_failure({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--damping", "1,2"}, 1, "--damping");
  expect_failure({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--armature", "1,2"}, 1,
                 "--armature has 2 values; the arm has 7 joints");
  expect_failure({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--armature", "1,1,1,1,1,1,-1"}, 1,
                 "--armature: entry 6 is negative");
  expect_failure({"--robot", data_path("panda.urdf"), "--rate", "0"}, 2, "--rate");
  expect_failure({"--robot", data_path("panda.urdf"), "--drop", "1.5"}, 2, "--drop");
  expect_failure({"--robot", data_path("panda.urdf"), "--no-such-option"}, 2, "no-such-option");
  expect_failure({"--robot", data_path("arm_massless_tip.urdf"), "--tip", "tip"}, 1,
                 "cannot simulate this chain: the mass matrix is singular: joint 'j3' moves no inertia");
}

// TRUTH over the real wire: chasles_plant publishes sim_truth_t on PREFIX TRUTH right after every
// state, with that state's seq and utime, when asked (--truth, or anything in the environment: here
// a constant push, which the truth reports exactly as given, or perturbed inertias, which its start
// line names with their seed, as it names the effort noise's), and never otherwise.
TEST(plant, PublishesTruthOnlyWhenAsked) {
  const RobotModel model = panda();
  Data data(model);
  const Eigen::VectorXd q0 = bent_pose();
  const Eigen::VectorXd g = gravity_torques(model, data, q0);
  const auto run = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0",
                                     list(q0)};
    args.insert(args.end(), extra.begin(), extra.end());
    Controller controller;
    PlantProcess plant(args);
    const auto trajectory = drive_lockstep(controller, 20, [&](const robot_state_t&) { return g; });
    controller.listen(0.05);  // the last truth follows the last state
    EXPECT_EQ(plant.stop(), 0) << plant.stderr_text();
    EXPECT_EQ(trajectory.size(), 21u);
    return std::make_tuple(controller.states(), controller.truths(), plant.stderr_text());
  };

  const auto [states, truths, err] = run({});
  EXPECT_GE(states.size(), 21u);
  EXPECT_TRUE(truths.empty()) << truths.size() << " truths sent unasked";
  EXPECT_EQ(err.find("TRUTH"), std::string::npos) << err;

  const std::vector<std::vector<std::string>> askings = {
      {"--truth"}, {"--push", "0,100,0,0.5,0,0,0,0,-10"}, {"--perturb-inertia", "0.2,7", "--effort-noise", "0.05,3"}};
  for (const std::vector<std::string>& asking : askings) {
    SCOPED_TRACE(asking.front());
    const bool push = asking.front() == "--push";
    const auto [pushed_states, pushed_truths, pushed_err] = run(asking);
    ASSERT_EQ(pushed_truths.size(), 21u);
    for (size_t k = 0; k < pushed_truths.size(); ++k) {
      const sim_truth_t& truth = pushed_truths[k];
      EXPECT_EQ(truth.seq, static_cast<int64_t>(k));
      const auto state = std::find_if(pushed_states.begin(), pushed_states.end(),
                                      [&](const robot_state_t& s) { return s.seq == truth.seq; });
      ASSERT_NE(state, pushed_states.end());
      EXPECT_EQ(truth.utime, state->utime);
      const std::vector<double> wrench(truth.tip_wrench_ext, truth.tip_wrench_ext + 6);
      const std::vector<double> expected =
          push ? std::vector<double>{0.5, 0, 0, 0, 0, -10} : std::vector<double>(6, 0.0);
      EXPECT_EQ(wrench, expected);
      EXPECT_EQ(truth.contact, push);
    }
    EXPECT_NE(pushed_err.find(", truth on TEST_TRUTH"), std::string::npos) << pushed_err;
    EXPECT_NE(pushed_err.find("; truths sent on TEST_TRUTH, not sent 0"), std::string::npos) << pushed_err;
    if (asking.front() == "--perturb-inertia") {
      EXPECT_NE(pushed_err.find("; inertias perturbed by up to +-20 % (seed 7), not the URDF's; effort reported with "
                                "noise of sigma 0.05 N*m (seed 3)\n"),
                std::string::npos)
          << pushed_err;
    }
  }
}

// The environment's specs are checked before anything starts: one line naming the option and what
// is wrong with it, exit 1.
TEST(plant, RefusesBadEnvironmentSpecs) {
  const auto expect_refusal = [](const std::vector<std::string>& spec, const std::string& needle) {
    std::vector<std::string> args = {"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--seconds", "5"};
    args.insert(args.end(), spec.begin(), spec.end());
    PlantProcess plant(args);
    EXPECT_EQ(plant.wait(), 1);
    const std::string err = plant.stderr_text();
    EXPECT_EQ(err.rfind("chasles_plant: ", 0), 0u) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_NE(err.find(needle), std::string::npos) << err;
  };
  expect_refusal({"--push", "0,1,0.1,0,0,0,0,0"}, "--push takes START,DURATION,RAMP,mx,my,mz,fx,fy,fz (9 numbers");
  expect_refusal({"--push", "0,1,0.6,0,0,0,0,0,5"}, "--push: RAMP 0.6 s is longer than half of DURATION 1 s");
  expect_refusal({"--push", "0,1,0,0,0,0,0,0,5", "--push", "0,1,0,nan,0,0,0,0,5"},
                 "--push: entry 3 ('nan') is not finite");
  expect_refusal({"--wall", "0.5,0,0.2,0,0,0"}, "--wall: the normal (0, 0, 0) has no direction");
  expect_refusal({"--wall", "0.5,0,0.2,0,0,1,1e4"}, "--wall takes PX,PY,PZ,NX,NY,NZ[,K,D] (6 or 8 numbers");
  expect_refusal({"--payload", "-2"}, "--payload: mass -2 kg is negative");
  expect_refusal({"--payload", "inf"}, "--payload: entry 0 ('inf') is not finite");
  expect_refusal({"--friction", "0.1,-0.5"}, "--friction: joint panda_joint1: Coulomb friction -0.5 N*m is negative");
  expect_refusal({"--friction", "0.1,0.5,0.2,0.3"},
                 "--friction takes VISCOUS,COULOMB[,STICTION] for every joint or one such pair or triple per joint");
  expect_refusal({"--perturb-inertia", "1"}, "--perturb-inertia: FRACTION 1 is not in [0, 1)");
  expect_refusal({"--perturb-inertia", "0.2,x"}, "--perturb-inertia: SEED 'x' is not a whole number");
  expect_refusal({"--effort-noise", "-0.1"}, "--effort-noise: SIGMA -0.1 N*m is not a standard deviation");
}

// As a process: chasles_plant --protocol drake-iiwa --rate 200 publishes lcmt_iiwa_status on
// IIWA_STATUS every 5 ms of its clock (braked, no command yet: ipo NaN), and says so.
TEST(plant, RunsAsAnIiwaProcess) {
  lcm::LCM lcm(kLcmUrl);
  ASSERT_TRUE(lcm.good());
  std::vector<lcmt_iiwa_status> statuses;
  struct Sink {
    std::vector<lcmt_iiwa_status>* statuses;
    static void on_status(const lcm_recv_buf_t* rbuf, const char*, void* self) {
      lcmt_iiwa_status status;
      ASSERT_EQ(messages::decode_checked(rbuf->data, rbuf->data_size, status, 7, messages::Finite::Required), "");
      static_cast<Sink*>(self)->statuses->push_back(status);
    }
  } sink{&statuses};
  lcm_subscribe(lcm.getUnderlyingLCM(), "IIWA_STATUS", &Sink::on_status, &sink);
  PlantProcess plant({"--robot", data_path("iiwa14.urdf"), "--tip", "iiwa_link_ee", "--q0", list(iiwa_pose()),
                      "--protocol", "drake-iiwa", "--rate", "200"});
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (statuses.size() < 20 && Clock::now() < deadline) lcm.handleTimeout(100);
  ASSERT_GE(statuses.size(), 20u) << plant.stderr_text();
  for (size_t k = 1; k < statuses.size(); ++k) EXPECT_EQ(statuses[k].utime - statuses[k - 1].utime, 5000);
  EXPECT_TRUE(std::isnan(statuses.back().joint_position_ipo[0]));
  EXPECT_EQ(plant.stop(), 0);
  const std::string err = plant.stderr_text();
  EXPECT_NE(err.find(", 200 Hz real time"), std::string::npos) << err;
  EXPECT_NE(err.find("drake-iiwa: status on IIWA_STATUS, commands on IIWA_COMMAND (torque overlay)"),
            std::string::npos)
      << err;
}

// The protocol's flags: names refused with the names allowed, exit 2.
TEST(plant, RefusesUnknownProtocolsAndSemantics) {
  for (const auto& [flag, value, needle] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"--protocol", "drake-ur", "'drake-ur' is not one of chasles, drake-iiwa, drake-panda"},
           {"--torque-semantics", "half", "'half' is not one of overlay, full"},
           {"--status-channel", "A.*", "letters, digits"}}) {
    PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", flag, value});
    EXPECT_EQ(plant.wait(), 2);
    const std::string err = plant.stderr_text();
    EXPECT_NE(err.find(needle), std::string::npos) << err;
  }
}

// chasles's own protocol takes --torque-semantics too: with overlay a zero command holds the arm, as
// g(q0) does under the default (full) in GravityTorquesHoldTheArmStill; the start-up line says so.
TEST(plant, ChaslesProtocolTakesTheOverlaySemantics) {
  const RobotModel model = panda();
  Data data(model);
  const Eigen::VectorXd q0 = bent_pose(), zero = Eigen::VectorXd::Zero(7);
  Controller controller;
  PlantProcess plant({"--robot", data_path("panda.urdf"), "--tip", "panda_hand", "--lockstep", "--q0", list(q0),
                      "--torque-semantics", "overlay"});
  const auto trajectory = drive_lockstep(controller, 200, [&](const robot_state_t&) { return zero; });
  ASSERT_EQ(trajectory.size(), 201u);
  double drift = 0.0;
  for (const robot_state_t& state : trajectory) drift = std::max(drift, max_abs_diff(vector_of(state.position), q0));
  EXPECT_LT(drift, 1e-6);
  EXPECT_TRUE(matrices_near(vector_of(trajectory.back().effort), gravity_torques(model, data, q0), 1e-9));
  EXPECT_EQ(plant.stop(), 0);
  const std::string err = plant.stderr_text();
  EXPECT_NE(err.find("chasles: status on TEST_STATE, commands on TEST_COMMAND (torque overlay)"), std::string::npos)
      << err;
}

}  // namespace
}  // namespace chasles::testing
