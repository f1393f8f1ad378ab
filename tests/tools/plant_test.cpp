// chasles_plant run as a real process and driven over LCM the way a controller drives it. The test
// binary runs inside its own network namespace (tools/netns.sh is its launcher, see
// CMakeLists.txt), so the multicast traffic never leaves the machine and tests running in
// parallel do not hear each other. The plant's Drake protocols are also driven in process, in
// simulated time (a plant::Simulation on a memq:// bus), their statuses read back the way the
// controller reads them (controller::StatusReader) and held against references computed here.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "lcmtypes/checked.hpp"
#include "tools/simulation/simulation.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using Clock = std::chrono::steady_clock;

constexpr char kPrefix[] = "TEST_";
constexpr double kDt = 1e-3;  // the plant's default 1000 Hz

RobotModel panda() {
  UrdfOptions options;
  options.tip_link = "panda_hand";
  return load_urdf_file(data_path("panda.urdf"), options);
}

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

// Classic RK4 on (q, q̇) with constant τ, written here independently of the plant's, for
// reference integrations at a much smaller step.
void rk4_reference(const RobotModel& model, Eigen::VectorXd& q, Eigen::VectorXd& qd, const Eigen::VectorXd& tau,
                   double h, int steps) {
  Data data(model);
  const auto qdd = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return forward_dynamics(model, data, x, v, tau);
  };
  for (int i = 0; i < steps; ++i) {
    const Eigen::VectorXd v1 = qd, a1 = qdd(q, v1);
    const Eigen::VectorXd v2 = qd + 0.5 * h * a1, a2 = qdd(q + 0.5 * h * v1, v2);
    const Eigen::VectorXd v3 = qd + 0.5 * h * a2, a3 = qdd(q + 0.5 * h * v2, v3);
    const Eigen::VectorXd v4 = qd + h * a3, a4 = qdd(q + h * v3, v4);
    q += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4);
    qd += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
  }
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

// ---- The Drake protocols, in process and in simulated time ----

using controller::Bus;
using controller::JointState;
using controller::Protocol;
using controller::StatusReader;
using controller::TorqueSemantics;
using drake::lcmt_iiwa_command;
using drake::lcmt_iiwa_status;
using drake::lcmt_panda_command;
using drake::lcmt_panda_status;
using plant::SimulationOptions;

RobotModel iiwa14() {
  UrdfOptions options;
  options.tip_link = "iiwa_link_ee";
  return load_urdf_file(data_path("iiwa14.urdf"), options);
}

Eigen::VectorXd iiwa_pose() {
  Eigen::VectorXd q(7);
  q << 0.2, 0.6, -0.3, -1.2, 0.4, 0.8, 0.1;
  return q;
}

// Each Drake protocol on its own arm: the iiwa's on Drake's iiwa 14 (rotor inertias and all), the
// Panda's on the Panda.
struct DrakeArm {
  Protocol protocol;
  RobotModel model;
  Eigen::VectorXd q0;
};
std::vector<DrakeArm> drake_arms() {
  return {{Protocol::kDrakeIiwa, iiwa14(), iiwa_pose()}, {Protocol::kDrakePanda, panda(), bent_pose()}};
}

SimulationOptions drake_options(Protocol protocol, bool lockstep,
                                std::optional<TorqueSemantics> semantics = std::nullopt,
                                const plant::EnvironmentOptions& environment = {}) {
  SimulationOptions options;
  options.protocol = protocol;
  options.lockstep = lockstep;
  options.torque_semantics = semantics;
  options.environment = environment;
  return options;
}

Eigen::VectorXd as_vector(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

template <typename Message>
std::vector<uint8_t> bytes_of(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// A torque command as the protocol's driver takes it (what controller::CommandWriter sends, built
// here field by field): the utime of the status answered, no positions, n torques.
lcmt_iiwa_command iiwa_torques(int64_t utime, const Eigen::VectorXd& tau) {
  lcmt_iiwa_command command;
  command.utime = utime;
  command.num_joints = 0;
  command.num_torques = static_cast<int32_t>(tau.size());
  command.joint_torque.assign(tau.data(), tau.data() + tau.size());
  return command;
}
lcmt_panda_command panda_torques(int64_t utime, const Eigen::VectorXd& tau) {
  lcmt_panda_command command;
  command.utime = utime;
  command.num_joint_position = command.num_joint_velocity = 0;
  command.num_joint_torque = static_cast<int32_t>(tau.size());
  command.joint_torque.assign(tau.data(), tau.data() + tau.size());
  command.control_mode_expected = lcmt_panda_status::CONTROL_MODE_TORQUE;
  return command;
}

// One status heard: its bytes decoded by the checked decoder, what StatusReader made of it, and the
// plant's own state when it was sent.
struct Heard {
  lcmt_iiwa_status iiwa;
  lcmt_panda_status panda;
  int64_t utime = 0;
  std::string refusal;  // StatusReader's
  JointState state{7};
  std::vector<double> tau_ext;
  std::vector<double> q, qd, effort;  // the plant's
};

// A plant speaking a Drake protocol on its own memq:// bus, the test in the controller's seat.
class DrakeRig {
 public:
  DrakeRig(const RobotModel& model, const Eigen::VectorXd& q0, const SimulationOptions& options)
      : model_(model), protocol_(options.protocol), bus_("memq://"), reader_(options.protocol, model.dof()) {
    const controller::ProtocolChannels channels = controller::default_channels(options.protocol, options.prefix);
    command_channel_ = channels.command;
    subscription_ = bus_.subscribe(
        channels.status, [this](const uint8_t* data, size_t size) { hear(data, size); }, 1 << 14);
    simulation_ = std::make_unique<plant::Simulation>(model, options, q0, Eigen::VectorXd::Zero(model.dof()), bus_,
                                                      clock_);
    simulation_->start();
    deliver();
  }
  ~DrakeRig() {
    simulation_.reset();
    subscription_ = Bus::Subscription();
  }

  /// The utime of the latest status heard: what a command answering it carries.
  int64_t latest_utime() const { return heard_.back().utime; }

  /// Sends the bytes on the command channel and lets the plant handle them.
  void send(const std::vector<uint8_t>& bytes) {
    bus_.publish(command_channel_, bytes);
    deliver();
  }
  /// A torque command answering the status stamped `utime`.
  void send_torques(int64_t utime, const Eigen::VectorXd& tau) {
    send(protocol_ == Protocol::kDrakeIiwa ? bytes_of(iiwa_torques(utime, tau)) : bytes_of(panda_torques(utime, tau)));
  }
  /// Lockstep: answers the latest status with tau; the plant steps once. Then time moves on a period.
  void step(const Eigen::VectorXd& tau) {
    send_torques(latest_utime(), tau);
    clock_.advance_to(clock_.now_ns() + simulation_->period_ns());
    simulation_->serve_lockstep();
    deliver();
  }
  /// Real time: one step at the next period.
  void real_time_step() {
    clock_.advance_to(clock_.now_ns() + simulation_->period_ns());
    simulation_->step();
    deliver();
  }

  plant::Simulation& simulation() { return *simulation_; }
  const std::vector<Heard>& heard() const { return heard_; }

 private:
  void deliver() {
    while (bus_.handle_pending() > 0) {
    }
  }

  void hear(const uint8_t* data, size_t size) {
    Heard h;
    const int n = model_.dof();
    if (protocol_ == Protocol::kDrakeIiwa) {
      ASSERT_EQ(messages::decode_checked(data, size, h.iiwa, n, messages::Finite::Required), "");
      h.utime = h.iiwa.utime;
    } else {
      ASSERT_EQ(messages::decode_checked(data, size, h.panda, n, messages::Finite::Required), "");
      h.utime = h.panda.utime;
    }
    h.state = JointState(n);
    h.refusal = reader_.read(data, size, clock_.now_ns(), h.state);
    const Eigen::VectorXd& tau_ext = reader_.tau_ext();
    h.tau_ext.assign(tau_ext.data(), tau_ext.data() + n);
    if (simulation_) {
      const plant::Plant& plant = simulation_->plant();
      h.q.assign(plant.q().data(), plant.q().data() + n);
      h.qd.assign(plant.qd().data(), plant.qd().data() + n);
      h.effort.assign(plant.effort().data(), plant.effort().data() + n);
    }
    heard_.push_back(std::move(h));
  }

  const RobotModel& model_;
  Protocol protocol_;
  controller::SimulatedClock clock_;
  Bus bus_;
  std::string command_channel_;
  StatusReader reader_;
  Bus::Subscription subscription_;
  std::unique_ptr<plant::Simulation> simulation_;
  std::vector<Heard> heard_;
};

// A torque that varies from step to step and joint to joint, small enough that no effort limit clips it.
Eigen::VectorXd wiggle(int k, int n) {
  Eigen::VectorXd tau(n);
  for (int i = 0; i < n; ++i) tau[i] = 2.0 * std::sin(0.3 * k + 0.7 * i);
  return tau;
}

// (a) Every status decodes with the checked decoder, and StatusReader reads back exactly the plant's
// q, q̇ and applied torque, through the wire's signs. The fields chasles does not read say what the
// driver would: the iiwa's torque commanded is −(command + g), as Drake's simulated driver reports
// it (BuildSimplifiedIiwaControl negates its actuation), its commanded position the measured one,
// its interpolator position NaN until commands come; the Panda's desired torque is the command as
// sent, its mode idle then moving, its success rate 1 when every step had a command. The overlay:
// the torque applied is the command plus g(q) of the bare arm, computed here.
TEST(plant, DrakeStatusesReadBackThePlantsStateExactly) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    Data data(arm.model);
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, true));
    constexpr int kSteps = 60;
    for (int k = 0; k < kSteps; ++k) rig.step(wiggle(k, n));
    const std::vector<Heard>& heard = rig.heard();
    ASSERT_EQ(heard.size(), size_t{kSteps + 1});
    const double nan_count_at_start =
        arm.protocol == Protocol::kDrakeIiwa
            ? double(std::count_if(heard[0].iiwa.joint_position_ipo.begin(), heard[0].iiwa.joint_position_ipo.end(),
                                   [](double x) { return std::isnan(x); }))
            : 7.0;
    EXPECT_EQ(nan_count_at_start, 7.0) << "the iiwa's ipo is NaN before any command";
    for (int k = 0; k <= kSteps; ++k) {
      SCOPED_TRACE("status " + std::to_string(k));
      const Heard& h = heard[size_t(k)];
      ASSERT_EQ(h.refusal, "");
      EXPECT_EQ(h.state.seq, k);
      EXPECT_EQ(h.utime - heard[0].utime, 1000 * k) << "1 ms steps, in µs";
      EXPECT_EQ(h.state.utime, h.utime);
      EXPECT_TRUE(matrices_near(h.state.q, as_vector(h.q), 0.0));
      EXPECT_TRUE(matrices_near(h.state.qd, as_vector(h.qd), 0.0));
      EXPECT_TRUE(matrices_near(h.state.effort, as_vector(h.effort), 0.0));
      EXPECT_TRUE(matrices_near(as_vector(h.tau_ext), Eigen::VectorXd::Zero(n), 0.0)) << "nothing pushes";
      // The command answering the previous status, and the driver's gravity at that status's q.
      const Eigen::VectorXd command = k > 0 ? wiggle(k - 1, n) : Eigen::VectorXd::Zero(n);
      const Eigen::VectorXd applied =
          k > 0 ? Eigen::VectorXd(command + gravity_torques(arm.model, data, heard[size_t(k - 1)].state.q))
                : Eigen::VectorXd::Zero(n);
      EXPECT_TRUE(matrices_near(h.state.effort, applied, 1e-12));
      if (arm.protocol == Protocol::kDrakeIiwa) {
        EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_torque_commanded), -applied, 1e-12));
        EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_commanded), h.state.q, 0.0));
        if (k > 0) {
          EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_ipo), h.state.q, 0.0));
        }
      } else {
        EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_torque_desired), command, 0.0));
        EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_position_desired), h.state.q, 0.0));
        EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_velocity_desired), Eigen::VectorXd::Zero(n), 0.0));
        EXPECT_EQ(h.panda.robot_mode, k > 0 ? lcmt_panda_status::kMove : lcmt_panda_status::kIdle);
        EXPECT_EQ(h.panda.control_mode, k > 0 ? lcmt_panda_status::CONTROL_MODE_TORQUE : 0);
        EXPECT_EQ(h.panda.control_command_success_rate, k > 0 ? 1.0 : 0.0);
        EXPECT_EQ(h.panda.robot_utime, 1000 * k);
      }
    }
  }
}

// (b) The torque semantics: under overlay a zero command holds the arm where it is (the plant adds
// g(q), as the driver does), the effort read back is g(q0); under full the same zero command lets it
// fall, as a fine RK4 integration of the model with zero torque does (the tolerances of
// LockstepFallMatchesAFineIntegrationAndConservesEnergy).
TEST(plant, DrakeOverlayAddsGravityAndFullDoesNot) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    Data data(arm.model);
    constexpr int kSteps = 500;

    DrakeRig held(arm.model, arm.q0, drake_options(arm.protocol, true, TorqueSemantics::kOverlay));
    for (int k = 0; k < kSteps; ++k) held.step(zero);
    ASSERT_EQ(held.heard().size(), size_t{kSteps + 1});
    double drift = 0.0;
    for (const Heard& h : held.heard()) drift = std::max(drift, max_abs_diff(h.state.q, arm.q0));
    EXPECT_LT(drift, 1e-6);
    EXPECT_TRUE(matrices_near(held.heard().back().state.effort, gravity_torques(arm.model, data, arm.q0), 1e-9));

    DrakeRig fell(arm.model, arm.q0, drake_options(arm.protocol, true, TorqueSemantics::kFull));
    for (int k = 0; k < kSteps; ++k) fell.step(zero);
    ASSERT_EQ(fell.heard().size(), size_t{kSteps + 1});
    Eigen::VectorXd q = arm.q0, qd = zero;
    rk4_reference(arm.model, q, qd, zero, kDt / 10, kSteps * 10);
    const JointState& last = fell.heard().back().state;
    EXPECT_GT(max_abs_diff(last.q, arm.q0), 0.05) << "the arm should have fallen";
    EXPECT_TRUE(matrices_near(last.q, q, 1e-6));
    EXPECT_TRUE(matrices_near(last.qd, qd, 1e-5));
    EXPECT_TRUE(matrices_near(last.effort, zero, 0.0));
  }
}

// (c) Commands the driver would not take are refused and counted, never applied: the lockstep plant
// does not step on them. The iiwa's: no torques (a position command: the driver runs in torque
// mode), 3 joints, a NaN, a Panda command on its channel. The Panda's: a position or no control
// mode expected, no torques, 6 joints, a chasles command on its channel. A valid command whose utime
// no status carries (one more µs, a state not sent yet) is stale, and so, in lockstep, is one that
// answers an older status. The next valid command steps the arm from where it was.
TEST(plant, DrakeCommandsTheDriverWouldRefuseAreRefusedAndCounted) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    Data data(arm.model);
    const Eigen::VectorXd g = gravity_torques(arm.model, data, arm.q0);
    const Eigen::VectorXd tau = Eigen::VectorXd::Constant(n, 3.0);
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, true));
    const int64_t u0 = rig.latest_utime();
    int refused = 0;
    if (arm.protocol == Protocol::kDrakeIiwa) {
      lcmt_iiwa_command positions = iiwa_torques(u0, Eigen::VectorXd());
      positions.num_joints = n;
      positions.joint_position.assign(size_t(n), 0.1);
      rig.send(bytes_of(positions));
      rig.send(bytes_of(iiwa_torques(u0, Eigen::VectorXd::Constant(3, 1.0))));
      Eigen::VectorXd bad = tau;
      bad[4] = std::numeric_limits<double>::quiet_NaN();
      rig.send(bytes_of(iiwa_torques(u0, bad)));
      rig.send(bytes_of(panda_torques(u0, tau)));
      refused = 4;
    } else {
      lcmt_panda_command command = panda_torques(u0, tau);
      command.control_mode_expected = lcmt_panda_status::CONTROL_MODE_POSITION;
      rig.send(bytes_of(command));
      command.control_mode_expected = 0;
      rig.send(bytes_of(command));
      lcmt_panda_command positions = panda_torques(u0, Eigen::VectorXd());
      positions.num_joint_position = n;
      positions.joint_position.assign(size_t(n), 0.1);
      rig.send(bytes_of(positions));
      rig.send(bytes_of(panda_torques(u0, Eigen::VectorXd::Constant(6, 1.0))));
      joint_torque_command_t chasles_command;
      chasles_command.utime = u0;
      chasles_command.seq = chasles_command.state_seq = 0;
      chasles_command.num_joints = n;
      chasles_command.torque.assign(size_t(n), 0.0);
      rig.send(bytes_of(chasles_command));
      refused = 5;
    }
    rig.send_torques(u0 + 1, tau);
    rig.send_torques(u0 + 1000, tau);
    EXPECT_EQ(rig.simulation().steps(), 0) << "the plant stepped on a command it should have refused";
    EXPECT_EQ(rig.simulation().rejected_commands(), refused);
    EXPECT_EQ(rig.simulation().stale_commands(), 2);
    ASSERT_EQ(rig.heard().size(), 1u);

    rig.send_torques(u0, tau);
    ASSERT_EQ(rig.simulation().steps(), 1);
    ASSERT_EQ(rig.heard().size(), 2u);
    EXPECT_TRUE(matrices_near(rig.heard().back().state.effort, tau + g, 1e-12));
    rig.send_torques(u0, tau);  // answers status 0 again: stale in lockstep
    EXPECT_EQ(rig.simulation().steps(), 1);
    EXPECT_EQ(rig.simulation().stale_commands(), 3);
    EXPECT_EQ(rig.simulation().rejected_commands(), refused);
  }
}

// (d) A push on the tip shows in the external torque each status carries, in Drake's sign: the
// iiwa's joint_torque_external as it is, the Panda's (tau_ext_hat_filtered) negated, and
// StatusReader turns both back into J_bᵀ F_b, F_b the push as the tip frame sees it, computed here
// at each status's q. The arm is held against the push (−J_bᵀ F_b on top of the driver's g).
TEST(plant, DrakeExternalTorqueIsThePushInDrakesSign) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    Data data(arm.model);
    Vector6d W;
    W << 0.4, -0.3, 0.2, 6.0, -4.0, -12.0;  // (m, f), base-aligned at the tip origin
    const auto push_on_joints = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
      const Matrix3d R_sb = forward_kinematics(arm.model, data, q).linear();
      Vector6d F_b;
      F_b << R_sb.transpose() * W.head<3>(), R_sb.transpose() * W.tail<3>();
      return body_jacobian(arm.model, data, q).transpose() * F_b;
    };
    plant::EnvironmentOptions env;
    env.pushes.push_back({0.0, 10.0, 0.0, W});
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, true, std::nullopt, env));
    constexpr int kSteps = 100;
    for (int k = 0; k < kSteps; ++k) rig.step(-push_on_joints(rig.heard().back().state.q));
    ASSERT_EQ(rig.heard().size(), size_t{kSteps + 1});
    double drift = 0.0;
    for (size_t k = 0; k <= kSteps; ++k) {
      SCOPED_TRACE("status " + std::to_string(k));
      const Heard& h = rig.heard()[k];
      const Eigen::VectorXd expected = push_on_joints(h.state.q);
      ASSERT_GT(expected.cwiseAbs().maxCoeff(), 1.0);
      const Eigen::VectorXd wire = as_vector(arm.protocol == Protocol::kDrakeIiwa ? h.iiwa.joint_torque_external
                                                                                  : h.panda.joint_torque_external);
      const Eigen::VectorXd in_drakes_sign =
          arm.protocol == Protocol::kDrakeIiwa ? expected : Eigen::VectorXd(-expected);
      EXPECT_TRUE(matrices_near(wire, in_drakes_sign, 1e-9));
      EXPECT_TRUE(matrices_near(as_vector(h.tau_ext), expected, 1e-9));
      drift = std::max(drift, max_abs_diff(h.state.q, arm.q0));
    }
    EXPECT_LT(drift, 1e-9) << "held against the push, the arm stays";
  }
}

// Real time: a command is judged by the state its utime names. Answering every status in time is
// never late and releases the brake; answering the one before (a controller a cycle behind) is late
// every step, and 20 in a row brake the arm (the Panda then reports a reflex, and its success rate
// counts the braked steps as steps without a command). drake-franka-driver's 0.1 s expiry is the
// plant's --max-command-lag-ms.
TEST(plant, DrakeRealTimeJudgesCommandsByTheStateTheirUtimeNames) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, false));
    for (int k = 0; k < 30; ++k) {
      rig.send_torques(rig.latest_utime(), zero);
      rig.real_time_step();
    }
    plant::Simulation& simulation = rig.simulation();
    EXPECT_EQ(simulation.late_cycles(), 0);
    EXPECT_FALSE(simulation.braking());
    EXPECT_EQ(simulation.stale_commands(), 0);
    if (arm.protocol == Protocol::kDrakePanda) {
      EXPECT_EQ(rig.heard().back().panda.robot_mode, lcmt_panda_status::kMove);
      EXPECT_EQ(rig.heard().back().panda.control_command_success_rate, 1.0);
    }
    for (int k = 0; k < 25; ++k) {
      rig.send_torques(rig.heard()[rig.heard().size() - 2].utime, zero);
      rig.real_time_step();
    }
    EXPECT_EQ(simulation.late_cycles(), 25);
    EXPECT_EQ(simulation.late_stops(), 1);
    EXPECT_TRUE(simulation.braking());
    if (arm.protocol == Protocol::kDrakePanda) {
      // 55 steps since the first command (fewer than libfranka's 100), braked from the 20th late one
      // on: 49 of them applied a fresh command.
      EXPECT_EQ(rig.heard().back().panda.robot_mode, lcmt_panda_status::kReflex);
      EXPECT_DOUBLE_EQ(rig.heard().back().panda.control_command_success_rate, 49.0 / 55.0);
    }
  }
}

// Receiving a valid Drake command and encoding a Drake status allocate nothing once constructed,
// the effort noise drawn.
TEST(plant, DrakeCommandsAndStatusesAllocateNothing) {
  for (const Protocol protocol : {Protocol::kDrakeIiwa, Protocol::kDrakePanda}) {
    SCOPED_TRACE(controller::to_string(protocol));
    const Eigen::VectorXd q = bent_pose(), tau = Eigen::VectorXd::Constant(7, 1.5);
    controller::SimulatedClock clock;
    const int64_t latest = 5;
    plant::StateTimes times(1e-3, &latest);
    times.start(1'000'000);
    plant::CommandInbox inbox(clock, "COMMAND", 7, protocol, &times);
    const std::vector<uint8_t> command = protocol == Protocol::kDrakeIiwa ? bytes_of(iiwa_torques(1'003'000, tau))
                                                                          : bytes_of(panda_torques(1'003'000, tau));
    Bus bus("memq://");
    plant::Faults faults;
    faults.effort_noise = {0.1, 5};
    plant::StatePublisher publisher(bus, "STATUS", 7, faults, 4, protocol);
    const plant::DriverReport report{q, tau, tau, tau, q, tau, true, 1.0, 2, 4, 1000};
    inbox.receive(command.data(), command.size());
    publisher.encode(1, 1, q, report);
    long allocations = 0;
    {
      AllocationCounter counter;
      for (int k = 0; k < 100; ++k) {
        inbox.receive(command.data(), command.size());
        publisher.encode(k, k, q, report);
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0);
    EXPECT_EQ(inbox.rejected(), 0);
    EXPECT_EQ(inbox.take().state_seq, 3) << "utime 1'003'000 is state 3's";
  }
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

// A real-time Drake plant's steps allocate nothing, in process: each command received from the bus
// (the overlay's gravity added, its utime mapped to a state), each status encoded and sent with the
// push's external torque in it, then the brake when the commands stop. What the test's own publish
// allocates (LCM's memq provider copies each message) is counted apart.
TEST(plant, DrakeRealTimeStepsAllocateNothing) {
  for (const Protocol protocol : {Protocol::kDrakeIiwa, Protocol::kDrakePanda}) {
    SCOPED_TRACE(controller::to_string(protocol));
    const RobotModel model = panda();
    Vector6d W;
    W << 0.1, 0, 0, 0, 0, -5;
    plant::EnvironmentOptions env;
    env.pushes.push_back({0.0, 10.0, 0.0, W});
    controller::SimulatedClock clock;
    Bus bus("memq://");
    plant::Simulation simulation(model, drake_options(protocol, false, std::nullopt, env), bent_pose(),
                                 Eigen::VectorXd::Zero(7), bus, clock);
    const std::string channel = controller::default_channels(protocol).command;
    lcmt_iiwa_command iiwa = iiwa_torques(0, Eigen::VectorXd::Constant(7, 0.5));
    lcmt_panda_command panda_command = panda_torques(0, Eigen::VectorXd::Constant(7, 0.5));
    std::vector<uint8_t> bytes(static_cast<size_t>(
        protocol == Protocol::kDrakeIiwa ? iiwa.getEncodedSize() : panda_command.getEncodedSize()));
    long sent_allocations = 0;
    const auto step = [&](bool command) {
      if (command) {  // answers the latest state, by its utime
        const int64_t utime = simulation.state_utime(simulation.steps());
        if (protocol == Protocol::kDrakeIiwa) {
          iiwa.utime = utime;
          iiwa.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        } else {
          panda_command.utime = utime;
          panda_command.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        }
        {
          AllocationCounter sending;  // the test's side: LCM's memq copies what is published
          bus.publish(channel, bytes);
          sent_allocations += sending.count();
        }
        while (bus.handle_pending() > 0) {
        }
      }
      clock.advance_to(clock.now_ns() + simulation.period_ns());
      simulation.step();
    };
    simulation.start();
    for (int k = 0; k < 5; ++k) step(true);
    sent_allocations = 0;
    long allocations = 0;
    {
      AllocationCounter counter;
      for (int k = 0; k < 100; ++k) step(true);
      for (int k = 0; k < 100; ++k) step(false);
      allocations = counter.count();
    }
    EXPECT_EQ(allocations - sent_allocations, 0) << sent_allocations << " in the test's own sends";
    EXPECT_EQ(simulation.steps(), 205);
    EXPECT_EQ(simulation.rejected_commands() + simulation.stale_commands(), 0);
    EXPECT_TRUE(simulation.braking()) << "silence for 100 ms: the watchdog brakes";
  }
}

// A command's positions, when it carries them (the iiwa's num_joints n: drake-iiwa-driver's default
// torque mode; a Panda command's joint_position), are reported as the commanded ones —
// joint_position_commanded and, while commanding, joint_position_ipo; joint_position_desired — and
// not applied: the torque alone moves the arm (the plant has no impedance controller).
TEST(plant, DrakeCommandPositionsAreReportedNotApplied) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    const Eigen::VectorXd p = arm.q0 + Eigen::VectorXd::Constant(n, 0.25);
    DrakeRig with(arm.model, arm.q0, drake_options(arm.protocol, true));
    DrakeRig without(arm.model, arm.q0, drake_options(arm.protocol, true));
    for (int k = 0; k < 20; ++k) {
      if (arm.protocol == Protocol::kDrakeIiwa) {
        lcmt_iiwa_command command = iiwa_torques(with.latest_utime(), zero);
        command.num_joints = n;
        command.joint_position.assign(p.data(), p.data() + n);
        with.send(bytes_of(command));
      } else {
        lcmt_panda_command command = panda_torques(with.latest_utime(), zero);
        command.num_joint_position = n;
        command.joint_position.assign(p.data(), p.data() + n);
        command.control_mode_expected |= lcmt_panda_status::CONTROL_MODE_POSITION;  // as Drake's sender marks it
        with.send(bytes_of(command));
      }
      without.step(zero);
    }
    ASSERT_EQ(with.heard().size(), 21u);
    const Heard& h = with.heard().back();
    if (arm.protocol == Protocol::kDrakeIiwa) {
      EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_commanded), p, 0.0));
      EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_ipo), p, 0.0));
    } else {
      EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_position_desired), p, 0.0));
    }
    EXPECT_TRUE(matrices_near(h.state.q, without.heard().back().state.q, 0.0)) << "the positions moved the arm";
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
