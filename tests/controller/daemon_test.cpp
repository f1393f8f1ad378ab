// chasles_controller and chasles_plant run as real processes and talk over real LCM (UDP
// multicast), inside a network namespace of this test binary's own (tools/netns.sh launches it),
// while the test plays operator and monitor on the same bus.
#include <gtest/gtest.h>
#include <lcm/lcm.h>
#include <unistd.h>

#include <algorithm>
#include <chasles/arm_target_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "controller/controller.hpp"
#include "controller/transport/lcm_io.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/lcm_wire.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::bent_pose;
using testing::joint_target;
using testing::list;
using testing::vector_of;
using testing::ChildProcess;
using testing::concat;
using testing::kLcmUrl;
using testing::temp_path;
using testing::data_path;
using testing::panda;  // to kTip

constexpr char kTip[] = "panda_hand_tcp";

std::vector<std::string> plant_args(std::vector<std::string> extra) {
  return concat({CHASLES_PLANT, "--robot", data_path("panda.urdf"), "--tip", kTip, "--lcm-url", kLcmUrl}, extra);
}

// Tests that are not about stale states run with --stale-ms 100: a test machine stalls plant or
// controller now and then (an ASan build on CI, 10.5 ms), and what they judge is tracking, holding
// and rejection. The stale rule is judged by the kill test below (at 10 ms), the fault tests and,
// tick by tick, controller_test.
std::vector<std::string> controller_args(std::vector<std::string> extra) {
  if (std::find(extra.begin(), extra.end(), "--stale-ms") == extra.end()) {
    extra.insert(extra.begin(), {"--stale-ms", "100"});
  }
  return concat({CHASLES_CONTROLLER, "--robot", data_path("panda.urdf"), "--tip", kTip, "--lcm-url", kLcmUrl}, extra);
}

// The test's seat on the bus: hears states, commands and status reports, sends targets and
// arbitrary bytes. Subscribed through LCM's C interface (see plant_test.cpp for why).
class Seat {
 public:
  Seat() : lcm_(lcm_create(kLcmUrl)) {
    if (lcm_ == nullptr) throw std::runtime_error("LCM did not start: run the test under tools/netns.sh");
    lcm_subscribe(lcm_, "CHASLES_STATE", &Seat::on<robot_state_t, &Seat::keep_state>, this);
    lcm_subscribe(lcm_, "CHASLES_STATUS", &Seat::on<controller_status_t, &Seat::keep_status>, this);
    lcm_subscribe(lcm_, "CHASLES_COMMAND", &Seat::on<joint_torque_command_t, &Seat::keep_command>, this);
  }
  ~Seat() { lcm_destroy(lcm_); }

  // Handles messages until `done` holds or `seconds` pass; whether `done` held.
  bool until(const std::function<bool()>& done, double seconds) {
    const int64_t deadline = monotonic_ns() + static_cast<int64_t>(seconds * 1e9);
    while (!done()) {
      const int64_t left_ms = (deadline - monotonic_ns()) / 1'000'000;
      if (left_ms <= 0) return false;
      lcm_handle_timeout(lcm_, static_cast<int>(std::min<int64_t>(left_ms, 50)));
    }
    return true;
  }
  void listen(double seconds) { until([] { return false; }, seconds); }

  bool status_is(int8_t mode) const { return status.has_value() && status->state == mode; }
  // The latest state within `tolerance` of q (rad), and moving slower than `speed` (rad/s).
  bool state_near(const Eigen::VectorXd& q, double tolerance, double speed = INFINITY) const {
    return state.has_value() && (vector_of(state->position) - q).cwiseAbs().maxCoeff() < tolerance &&
           vector_of(state->velocity).cwiseAbs().maxCoeff() < speed;
  }

  void send_target(const arm_target_t& target) { send("CHASLES_TARGET", target); }

  template <typename Message>
  void send(const char* channel, const Message& message) {
    std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
    message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    lcm_publish(lcm_, channel, bytes.data(), static_cast<unsigned>(bytes.size()));
  }

  std::optional<robot_state_t> state;
  int64_t state_arrival_ns = 0;
  std::optional<controller_status_t> status;
  std::vector<controller_status_t> statuses;
  std::vector<joint_torque_command_t> commands;

 private:
  template <typename Message, void (Seat::*kKeep)(const Message&)>
  static void on(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    Message message;
    if (message.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;  // the test's own junk
    (static_cast<Seat*>(self)->*kKeep)(message);
  }
  void keep_state(const robot_state_t& m) {
    if (m.num_joints != 7 || !std::isfinite(m.velocity[2])) return;  // junk the test sent itself
    state = m;
    state_arrival_ns = monotonic_ns();
  }
  void keep_status(const controller_status_t& m) {
    status = m;
    statuses.push_back(m);
  }
  void keep_command(const joint_torque_command_t& m) { commands.push_back(m); }

  lcm_t* lcm_;
};


nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// Lockstep (deterministic) plant: a JOINT move of the Panda ends within 1e-3 rad of its goal, at
// rest; SIGTERM then stops the controller cleanly with its summary written.
TEST(daemon, LockstepJointMoveReachesTheTargetAndSettles) {
  Seat bus;
  const std::string summary = temp_path("summary.json");
  ChildProcess plant(plant_args({"--lockstep", "--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({"--tick", "clock", "--summary", summary}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();

  VectorXd goal = bent_pose();
  goal(0) += 0.4;
  goal(1) -= 0.3;
  goal(3) += 0.3;
  goal(5) += 0.2;
  bus.send_target(joint_target(goal, 1.0));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::RUNNING); }, 2.0)) << controller.stderr_text();
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();
  // Settled: the arm at rest at its goal, waited for (the loop's own tail, a few hundred ms).
  bus.until([&] { return bus.state_near(goal, 1e-3, 1e-3); }, 5.0);
  ASSERT_TRUE(bus.state.has_value());
  const VectorXd q = vector_of(bus.state->position), qd = vector_of(bus.state->velocity);
  EXPECT_LT((q - goal).cwiseAbs().maxCoeff(), 1e-3) << "q " << q.transpose();
  EXPECT_LT(qd.cwiseAbs().maxCoeff(), 1e-3) << "qd " << qd.transpose();

  EXPECT_EQ(controller.stop(SIGTERM), 0) << controller.stderr_text();
  const nlohmann::json s = read_json(summary);
  for (const char* key : {"ticks", "rate_hz", "overruns", "jitter_us", "compute_us", "latency_us", "tracking_error",
                          "stale_states", "rejected_messages", "faults"}) {
    EXPECT_TRUE(s.contains(key)) << key;
  }
  // The 1 s move alone spans 1000 periods of the clock; a period the loop missed (a loaded
  // machine) is counted as an overrun rather than ticked, so the two together cover it.
  EXPECT_GE(s["ticks"].get<int64_t>() + s["overruns"].get<int64_t>(), 1000);
  EXPECT_EQ(s["faults"].get<int64_t>(), 0) << controller.stderr_text();
  EXPECT_LT(s["tracking_error"]["max"].get<double>(), 0.05);
  std::remove(summary.c_str());
}

// Real time, state-driven, both ways of reading the wire: each process on its own socket
// (--receive direct, the default) and through LCM's receive thread (--receive lcm). Either way a
// JOINT move ends within 2 mrad of its goal, the commands answer the states in order, and the
// controller's summary shows no FAULT (at --stale-ms 100, as the other tests here).
class RealTime : public ::testing::TestWithParam<const char*> {};

TEST_P(RealTime, AJointMoveReachesItsGoalAndEveryCommandAnswersAState) {
  Seat bus;
  const std::string summary = temp_path(std::string("summary_") + GetParam() + ".json");
  ChildProcess plant(plant_args({"--receive", GetParam(), "--damping", "0.5", "--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({"--receive", GetParam(), "--damping", "0.5", "--summary", summary}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();
  VectorXd goal = bent_pose();
  goal(0) += 0.3, goal(1) -= 0.2, goal(3) += 0.2;
  bus.send_target(joint_target(goal, 1.0));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::RUNNING); }, 2.0)) << controller.stderr_text();
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 4.0)) << controller.stderr_text();
  // At the goal, and commands enough heard to judge their order (over 1000, below).
  bus.until([&] { return bus.state_near(goal, 2e-3) && bus.commands.size() > 1100; }, 5.0);
  ASSERT_TRUE(bus.state.has_value());
  EXPECT_LT((vector_of(bus.state->position) - goal).cwiseAbs().maxCoeff(), 2e-3);
  EXPECT_EQ(controller.stop(SIGTERM), 0) << controller.stderr_text();
  const nlohmann::json s = read_json(summary);
  EXPECT_EQ(s["faults"].get<int64_t>(), 0) << controller.stderr_text();
  EXPECT_EQ(s["tick"].get<std::string>(), "state");
  // State-driven: the commands answer the states in the order they came, none a state not yet sent.
  ASSERT_GT(bus.commands.size(), 1000u);
  for (size_t k = 0; k < bus.commands.size(); ++k) {
    const int64_t answered = bus.commands[k].state_seq;
    EXPECT_GE(answered, 0);
    EXPECT_LE(answered, bus.state->seq);
    if (k > 0) {
      EXPECT_GE(answered, bus.commands[k - 1].state_seq) << "command " << k;
    }
  }
  std::remove(summary.c_str());
}

INSTANTIATE_TEST_SUITE_P(Receive, RealTime, ::testing::Values("direct", "lcm"),
                         [](const ::testing::TestParamInfo<const char*>& p) { return std::string(p.param); });

// A planner's trajectory from q0 to `goal` in `seconds`, sampled at `points` waypoints of a
// minimum-jerk move (s = 10τ³ − 15τ⁴ + 6τ⁵), with its exact velocities and accelerations when
// `derivatives`; within 10 mrad of the goal within 1 s of its end.
joint_trajectory_t planned(const VectorXd& q0, const VectorXd& goal, double seconds, int points, bool derivatives) {
  joint_trajectory_t t{};
  t.id = points;
  t.num_joints = 7;
  t.num_points = points;
  t.num_velocities = t.num_accelerations = derivatives ? points : 0;
  for (int i = 1; i <= 7; ++i) t.joint_names.push_back("panda_joint" + std::to_string(i));
  const VectorXd delta = goal - q0;
  for (int k = 1; k <= points; ++k) {
    const double tau = static_cast<double>(k) / points, time = tau * seconds;
    const double s = tau * tau * tau * (10 - 15 * tau + 6 * tau * tau);
    const double sd = 30 * tau * tau * (1 - tau) * (1 - tau) / seconds;
    const double sdd = 60 * tau * (1 - tau) * (1 - 2 * tau) / (seconds * seconds);
    t.time_from_start.push_back(time);
    std::vector<double> q(7), qd(7), qdd(7);
    for (int i = 0; i < 7; ++i) q[i] = q0(i) + s * delta(i), qd[i] = sd * delta(i), qdd[i] = sdd * delta(i);
    t.positions.push_back(q);
    if (derivatives) t.velocities.push_back(qd), t.accelerations.push_back(qdd);
  }
  t.path_tolerance.assign(7, 0.0);
  t.goal_tolerance.assign(7, 0.01);
  t.goal_time_tolerance = 1.0;
  return t;
}

// A planner's trajectory of 10 waypoints (positions only, one datagram) and of 1000 (the type's
// limit, with velocities and accelerations: 176 kB, three fragments, as chasles_calibrate excite
// writes), on both ways of reading the wire: taken, followed, and ended at its goal.
class LargeTrajectory : public ::testing::TestWithParam<std::tuple<const char*, int>> {};

TEST_P(LargeTrajectory, IsTakenAndFollowedToItsGoal) {
  const auto [receive, points] = GetParam();
  Seat bus;
  ChildProcess plant(plant_args({"--receive", receive, "--damping", "0.5", "--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({"--receive", receive, "--damping", "0.5"}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();
  VectorXd goal = bent_pose();
  goal(0) += 0.3, goal(1) -= 0.2, goal(3) += 0.2, goal(6) -= 0.3;
  const joint_trajectory_t trajectory = planned(bent_pose(), goal, 2.0, points, points > 10);
  ASSERT_EQ(trajectory.getEncodedSize() > 170'000, points > 10);
  bus.send("CHASLES_TRAJECTORY", trajectory);
  const auto outcome = [&] {
    return bus.status && bus.status->trajectory_id == points ? bus.status->trajectory_outcome : -1;
  };
  ASSERT_TRUE(bus.until([&] { return outcome() == controller_status_t::TRAJECTORY_ACTIVE; }, 2.0))
      << controller.stderr_text();
  ASSERT_TRUE(bus.until([&] { return outcome() == controller_status_t::TRAJECTORY_SUCCEEDED; }, 5.0))
      << controller.stderr_text() << (bus.status ? bus.status->trajectory_message : "");
  EXPECT_EQ(bus.status->trajectory_time_scale, 1.0);
  EXPECT_EQ(bus.status->trajectory_waypoint, points);
  EXPECT_EQ(bus.status->rejected_messages, 0) << controller.stderr_text();
  EXPECT_LT((vector_of(bus.state->position) - goal).cwiseAbs().maxCoeff(), 0.01);
}

INSTANTIATE_TEST_SUITE_P(Receive, LargeTrajectory,
                         ::testing::Combine(::testing::Values("direct", "lcm"), ::testing::Values(10, 1000)),
                         [](const auto& p) {
                           return std::string(std::get<0>(p.param)) + "_" + std::to_string(std::get<1>(p.param));
                         });

// A large message that loses a fragment on the way: counted in the status and said on stderr with
// its channel and size; the arm holds on, and the next whole trajectory is taken.
TEST(daemon, ATrajectoryMissingAFragmentIsCountedAndSaid) {
  Seat bus;
  ChildProcess plant(plant_args({"--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();
  VectorXd goal = bent_pose();
  goal(0) += 0.2;
  const joint_trajectory_t trajectory = planned(bent_pose(), goal, 1.0, 1000, true);
  std::vector<uint8_t> bytes(size_t(trajectory.getEncodedSize()));
  trajectory.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  auto datagrams = testing::lcm_fragments("CHASLES_TRAJECTORY", bytes, 1);
  ASSERT_EQ(datagrams.size(), 3u);
  datagrams.erase(datagrams.begin() + 1);
  testing::send_datagrams("239.255.76.67", 7667, datagrams);
  ASSERT_TRUE(bus.until([&] { return bus.status && bus.status->rejected_messages == 1; }, 3.0))
      << controller.stderr_text();
  EXPECT_EQ(bus.status->state, controller_status_t::HOLDING);
  EXPECT_EQ(bus.status->trajectory_outcome, controller_status_t::TRAJECTORY_NONE);
  ASSERT_TRUE(bus.until([&] { return controller.stderr_text().find("lost 1 message") != std::string::npos; }, 2.0));
  const std::string said = "a " + std::to_string(bytes.size()) +
                           "-byte message on CHASLES_TRAJECTORY: fragment 2 of 3 never came (1 missing)";
  EXPECT_NE(controller.stderr_text().find(said), std::string::npos) << controller.stderr_text();
  // Sent whole, the same trajectory is taken.
  bus.send("CHASLES_TRAJECTORY", trajectory);
  EXPECT_TRUE(bus.until([&] { return bus.status->trajectory_outcome == controller_status_t::TRAJECTORY_SUCCEEDED; }, 5.0))
      << controller.stderr_text();
  EXPECT_EQ(bus.status->rejected_messages, 1);
}

// The KUKA iiwa 14 of Drake's models, plant and controller as processes speaking Drake's iiwa
// protocol (lcmt_iiwa_status / lcmt_iiwa_command on IIWA_STATUS / IIWA_COMMAND, the plant adding
// g(q) to the torque as Drake's driver does) at the driver's 200 Hz, both taken from the protocol:
// a JOINT move ends within 2 mrad of its goal, without a FAULT.
TEST(daemon, AnIiwaOverDrakesProtocolMovesAt200Hz) {
  Seat bus;
  const std::string summary = temp_path("summary_iiwa.json");
  const std::vector<std::string> robot{"--robot", data_path("iiwa14.urdf"), "--tip", "iiwa_link_ee", "--lcm-url",
                                       kLcmUrl, "--protocol", "drake-iiwa", "--damping", "0.5"};
  VectorXd start(7);
  start << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3;
  std::vector<std::string> plant{CHASLES_PLANT, "--q0", list(start)};
  plant.insert(plant.end(), robot.begin(), robot.end());
  std::vector<std::string> controller{CHASLES_CONTROLLER, "--stale-ms", "100", "--summary", summary};
  controller.insert(controller.end(), robot.begin(), robot.end());
  ChildProcess plant_process(plant);
  ChildProcess controller_process(controller);
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0))
      << controller_process.stderr_text() << plant_process.stderr_text();
  VectorXd goal = start;
  goal(0) += 0.3, goal(1) -= 0.2, goal(3) += 0.2;
  bus.send_target(joint_target(goal, 1.0));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::RUNNING); }, 2.0))
      << controller_process.stderr_text();
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 4.0))
      << controller_process.stderr_text();
  ASSERT_TRUE(bus.until([&] { return (vector_of(bus.status->q) - goal).cwiseAbs().maxCoeff() < 2e-3; }, 5.0))
      << "q " << vector_of(bus.status->q).transpose();
  EXPECT_EQ(controller_process.stop(SIGTERM), 0) << controller_process.stderr_text();
  const nlohmann::json s = read_json(summary);
  EXPECT_EQ(s["faults"].get<int64_t>(), 0) << controller_process.stderr_text();
  EXPECT_EQ(s["rejected_messages"].get<int64_t>(), 0) << controller_process.stderr_text();
  // The rate and channels came from the protocol (the loop's measured rate is a figure, not a test).
  EXPECT_NE(controller_process.stderr_text().find("7 joints, 200 Hz on IIWA_STATUS -> IIWA_COMMAND (drake-iiwa)"),
            std::string::npos)
      << controller_process.stderr_text();
  std::remove(summary.c_str());
}

// A CARTESIAN move, lockstep: the IK worker plans the straight-line path, the arm follows it and
// ends within 1 mm and 1 mrad of the goal pose.
TEST(daemon, LockstepCartesianMoveEndsAtTheGoalPose) {
  const RobotModel model = panda();
  Data data(model);
  VectorXd q_goal = bent_pose();
  q_goal(0) -= 0.3;
  q_goal(1) += 0.2;
  q_goal(5) -= 0.2;
  const Transform T_goal = forward_kinematics(model, data, q_goal);
  const Eigen::Quaterniond r(T_goal.linear());
  Seat bus;
  ChildProcess plant(plant_args({"--lockstep", "--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({"--tick", "clock"}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();

  arm_target_t target{};
  target.utime = realtime_us();
  target.mode = arm_target_t::CARTESIAN;
  for (int i = 0; i < 3; ++i) target.tip_position[i] = T_goal.translation()(i);
  target.tip_quaternion[0] = r.w(), target.tip_quaternion[1] = r.x();
  target.tip_quaternion[2] = r.y(), target.tip_quaternion[3] = r.z();
  target.duration = 1.0;
  bus.send_target(target);
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::RUNNING); }, 3.0)) << controller.stderr_text();
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();
  const auto tip_error = [&] {
    const Transform T = forward_kinematics(model, data, vector_of(bus.state->position));
    return std::max((T.translation() - T_goal.translation()).norm(),
                    log3(T.linear().transpose() * T_goal.linear()).norm());
  };
  bus.until([&] { return tip_error() < 1e-3; }, 5.0);
  EXPECT_TRUE(bus.status->ik_converged);
  EXPECT_GT(bus.status->ik_iterations, 0);
  const Transform T = forward_kinematics(model, data, vector_of(bus.state->position));
  EXPECT_LT((T.translation() - T_goal.translation()).norm(), 1e-3);
  EXPECT_LT(log3(T.linear().transpose() * T_goal.linear()).norm(), 1e-3);
  std::printf("Cartesian move: tip within %.2g m and %.2g rad of the goal\n", (T.translation() - T_goal.translation()).norm(),
              log3(T.linear().transpose() * T_goal.linear()).norm());
}

// HOLD under gravity: the arm stays where it was found, within 1e-3 rad over 5 s.
TEST(daemon, HoldUnderGravityDriftsLessThanAMilliradianIn5s) {
  Seat bus;
  ChildProcess plant(plant_args({"--lockstep", "--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({"--tick", "clock"}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();
  double drift = 0.0;
  const int64_t end = monotonic_ns() + 5'000'000'000;
  bus.until(
      [&] {
        if (bus.state) drift = std::max(drift, (vector_of(bus.state->position) - bent_pose()).cwiseAbs().maxCoeff());
        return monotonic_ns() > end;
      },
      10.0);
  EXPECT_LT(drift, 1e-3);
  EXPECT_GT(bus.state->seq, 3000) << "the lockstep plant should have stepped about 5000 times";
}

// Malformed states and targets on the bus are refused and counted; nothing crashes and the arm
// keeps being held.
TEST(daemon, MalformedStatesAndTargetsAreRejectedAndCounted) {
  Seat bus;
  ChildProcess plant(plant_args({"--q0", list(bent_pose())}));
  ChildProcess controller(controller_args({}));
  ASSERT_TRUE(bus.until([&] { return bus.status_is(controller_status_t::HOLDING); }, 5.0)) << controller.stderr_text();

  robot_state_t wrong_size{};
  wrong_size.num_joints = 6;
  wrong_size.position.assign(6, 0.0);
  wrong_size.velocity.assign(6, 0.0);
  wrong_size.effort.assign(6, 0.0);
  robot_state_t nan{};
  nan.num_joints = 7;
  nan.position.assign(7, 0.0);
  nan.velocity.assign(7, 0.0);
  nan.effort.assign(7, 0.0);
  nan.velocity[2] = std::nan("");
  bus.send("CHASLES_STATE", wrong_size);
  bus.send("CHASLES_STATE", nan);
  VectorXd bad = bent_pose();
  bad(4) = std::nan("");
  bus.send_target(joint_target(bad, 1.0));
  bus.send_target(joint_target(bent_pose().head(6), 1.0));
  EXPECT_TRUE(bus.until([&] { return bus.status && bus.status->rejected_messages >= 4; }, 3.0))
      << controller.stderr_text();
  // Two statuses later (20 ms at 100 Hz), nothing has stopped or faulted over the bad messages.
  const size_t heard = bus.statuses.size();
  bus.until([&] { return bus.statuses.size() >= heard + 2; }, 3.0);
  EXPECT_TRUE(controller.running());
  EXPECT_TRUE(plant.running());
  EXPECT_EQ(bus.status->state, controller_status_t::HOLDING);
  EXPECT_EQ(bus.status->faults, 0);
  const std::string log = controller.stderr_text();
  EXPECT_NE(log.find("for 6 joints"), std::string::npos) << log;
  EXPECT_NE(log.find("non-finite"), std::string::npos) << log;
}

// The plant dies: FAULT soon after stale-ms and no more commands; a plant started again elsewhere
// is held where it is, the first torque close to gravity's. That the tick faults on the first
// tick past stale-ms is controller_test's, on a simulated clock; here the bound leaves room for a
// test machine that stalls the controller for tens of milliseconds, as CI machines have.
// A chain whose M is singular loads, but the controller refuses to start on it, saying why.
TEST(daemon, RefusesAChainWithASingularMassMatrix) {
  ChildProcess controller({CHASLES_CONTROLLER, "--robot", data_path("arm_massless_tip.urdf"), "--tip", "tip",
                           "--lcm-url", kLcmUrl});
  EXPECT_EQ(controller.wait(), 1);
  const std::string err = controller.stderr_text();
  EXPECT_NE(err.find("chasles_controller: " + data_path("arm_massless_tip.urdf") +
                     ": cannot control this chain: the mass matrix is singular: joint 'j3' moves no inertia"),
            std::string::npos)
      << err;
}

// Bad input — a gain that is not a number, a config file that is not JSON or names a setting
// there is none of — stops the controller before the loop with exit 1 and one line,
// "chasles_controller: " and what is wrong (main throws chasles::Error for it, as the libraries do).
TEST(daemon, SaysWhatIsWrongWithItsInputInOneLine) {
  const testing::TempFile not_json("not_json.json", "{\"kp\": 100,\n");
  const testing::TempFile unknown("unknown_setting.json", "{\"kq\": 100}");
  const testing::TempFile policy("link_policy.json", "{\"link_policy\": [\"panda_elbow,20,stop,guided\"]}");
  // --seconds: a case that failed to fail ends all the same.
  const std::vector<std::string> panda_args = {"--robot", data_path("panda.urdf"), "--tip", "panda_hand",
                                               "--lcm-url", kLcmUrl, "--seconds", "1"};
  for (const auto& [args, said] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--kp", "100,x"}, "--kp: 'x' is not a finite number"},
           {{"--kd", "1,2"}, "--kd has 2 entries; give one or 7"},
           {{"--config", not_json.path}, "config file " + not_json.path + " is not valid JSON: "},
           {{"--config", unknown.path}, "config file " + unknown.path + ": kq: unknown setting"},
           {{"--link-policy", "panda_hand,10,halt,strict"}, "--link-policy 'panda_hand,10,halt,strict': the reflex 'halt'"},
           {{"--config", policy.path, "--collision", "off"}, "the contact policy of link 'panda_elbow': no such link on the chain"}}) {
    const testing::RunResult run =
        testing::run_to_completion(concat(concat({CHASLES_CONTROLLER}, panda_args), args));
    EXPECT_EQ(run.exit_code, 1) << said;
    EXPECT_EQ(run.err.rfind("chasles_controller: " + said, 0), 0u) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  }
}

// --armature takes one value per joint, ≥ 0; anything else is refused before the loop starts.
TEST(daemon, RefusesAnArmatureListOfTheWrongLength) {
  for (const auto& [list, needle] : std::vector<std::pair<std::string, std::string>>{
           {"1,2,3", "chasles_controller: --armature has 3 values; the arm has 7 joints"},
           {"1,1,1,1,1,1,-1", "chasles_controller: --armature: entry 6 is negative"},
           {"1,1,1,x,1,1,1", "chasles_controller: --armature: entry 3 ('x') is not a number"}}) {
    ChildProcess controller({CHASLES_CONTROLLER, "--robot", data_path("panda.urdf"), "--tip", "panda_hand",
                             "--armature", list, "--lcm-url", kLcmUrl});
    EXPECT_EQ(controller.wait(), 1) << list;
    const std::string err = controller.stderr_text();
    EXPECT_NE(err.find(needle), std::string::npos) << err;
  }
}

// --friction-from-urdf feeds forward the joints' <dynamics damping friction> (the Panda's URDF
// states damping 0.003 and friction 0 on each joint), said at start; a value that is no friction
// stops the controller before it starts, naming the file and the joint.
TEST(daemon, TakesTheJointsFrictionFromTheUrdfWhenAsked) {
  {
    ChildProcess controller({CHASLES_CONTROLLER, "--robot", data_path("panda.urdf"), "--tip", "panda_hand",
                             "--friction-from-urdf", "--lcm-url", kLcmUrl});
    ASSERT_TRUE(controller.catches(SIGTERM, 10.0)) << controller.stderr_text();
    EXPECT_EQ(controller.stop(SIGTERM), 0);
    const std::string err = controller.stderr_text();
    EXPECT_NE(err.find("chasles_controller: joint friction from " + data_path("panda.urdf") +
                       ": damping 0.003,0.003,0.003,0.003,0.003,0.003,0.003 N·m·s/rad, Coulomb 0,0,0,0,0,0,0 N·m"),
              std::string::npos)
        << err;
  }
  std::ifstream file(data_path("panda.urdf"));
  std::string xml((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const size_t third = xml.find("damping=\"0.003\"", xml.find("name=\"panda_joint3\""));
  ASSERT_NE(third, std::string::npos);
  const testing::TempFile urdf("negative_friction.urdf", xml.replace(third, 15, "damping=\"-1\""));
  ChildProcess controller({CHASLES_CONTROLLER, "--robot", urdf.path, "--tip", "panda_hand", "--friction-from-urdf",
                           "--lcm-url", kLcmUrl});
  EXPECT_EQ(controller.wait(), 1);
  const std::string err = controller.stderr_text();
  EXPECT_NE(err.find("chasles_controller: " + urdf.path +
                     ": joint 'panda_joint3': <dynamics damping=\"-1\"> is not a finite number >= 0"),
            std::string::npos)
      << err;
}

// The whole send path of a tick — control law, encoding, the send on UDP multicast — allocates
// nothing.
TEST(daemon, TickAndPublishAllocateNothing) {
  const RobotModel model = panda();
  controller::Bus bus(kLcmUrl);
  const std::string channel = "CHASLES_COMMAND";
  Controller controller(model, Config::critically_damped(7, 20.0));
  // Drake's iiwa protocol, whose torque is sent less g(q): the longest send path.
  CommandWriter encoder(Protocol::kDrakeIiwa, 7, TorqueSemantics::kOverlay, IiwaPositions::kMeasured);
  Data gravity_data(model);
  JointState state(7);
  state.q = bent_pose();
  ASSERT_TRUE(controller.tick(0, &state));
  encoder.write(0, 0, state, controller.torque(), gravity_torques(model, gravity_data, state.q));
  ASSERT_TRUE(bus.publish(channel, encoder.bytes()));  // the first send may set things up
  testing::AllocationCounter counter;
  for (int k = 1; k <= 10'000; ++k) {
    state.arrival_ns = k * 1000;
    state.q(0) += 1e-5;
    ASSERT_TRUE(controller.tick(k * 1000, &state));
    state.utime = k;
    encoder.write(k, k, state, controller.torque(), gravity_torques(model, gravity_data, state.q));
    ASSERT_TRUE(bus.publish(channel, encoder.bytes()));
  }
  EXPECT_EQ(counter.count(), 0);
}

}  // namespace
}  // namespace chasles::controller
