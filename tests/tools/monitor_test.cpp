// chasles monitor against the real controller and plant over LCM, in a network namespace of this
// test binary's own (tools/netns.sh launches it). The test listens to the same status messages as
// the monitor and checks that the screen shows their values; then it checks what the monitor says
// when there is no controller, when the controller goes away, and when junk arrives.
#include <gtest/gtest.h>
#include <lcm/lcm.h>
#include <unistd.h>

#include <chasles/controller_status_t.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"
#include "support/bus_listener.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using Clock = std::chrono::steady_clock;
constexpr char kTip[] = "panda_hand";
constexpr char kBentPose[] = "0.1,0.5,-0.2,-1.2,0.3,1.0,0.7";

std::vector<std::string> model() { return {"--robot", data_path("panda.urdf"), "--tip", kTip, "--lcm-url", kLcmUrl}; }

// The latest controller_status_t, heard by the test itself.

RunResult monitor(const std::vector<std::string>& args) {
  return run_to_completion(concat({CHASLES_CLI, "monitor", "--lcm-url", kLcmUrl}, args));
}

// The number the regular expression's first group captures in the frame.
double field(const std::string& frame, const std::string& pattern) {
  std::smatch match;
  if (!std::regex_search(frame, match, std::regex(pattern))) {
    ADD_FAILURE() << "no match for " << pattern << " in:\n" << frame;
    return NAN;
  }
  return std::stod(match[1].str());
}

TEST(monitor, OnceShowsTheLiveControllersValues) {
  StatusListener bus(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", kBentPose, "--damping", "0.5"}, model()));
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5", "--stale-ms", "100"}, model()));
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0)) << controller.stderr_text();

  const RunResult r = monitor({"--once", "--seconds", "1.5", "--urdf", data_path("panda.urdf"), "--tip", kTip});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string& frame = r.out;
  EXPECT_EQ(frame.find('\x1b'), std::string::npos) << "--once prints plain text";
  EXPECT_NE(frame.find("controller  HOLDING"), std::string::npos) << frame;
  bus.wait_for(controller_status_t::HOLDING, 0.2);
  ASSERT_TRUE(bus.latest.has_value());
  const controller_status_t& s = *bus.latest;

  // Holding still: the joint values the test hears are the ones on screen, joint by joint.
  const char* names[] = {"panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4",
                         "panda_joint5", "panda_joint6", "panda_joint7"};
  for (int j = 0; j < 7; ++j) {
    const std::string row =
        std::string("\n") + names[j] + " +(-?[0-9.]+) +(-?[0-9.]+) +(-?[0-9.]+) +(-?[0-9.]+) +(-?[0-9.]+) +([0-9.]+) %";
    std::smatch match;
    ASSERT_TRUE(std::regex_search(frame, match, std::regex(row))) << names[j] << " in:\n" << frame;
    EXPECT_NEAR(std::stod(match[1].str()), s.q[size_t(j)], 2e-4) << names[j];
    EXPECT_NEAR(std::stod(match[2].str()), s.q_desired[size_t(j)], 2e-4) << names[j];
    EXPECT_NEAR(std::stod(match[4].str()), s.torque[size_t(j)], 0.02 + 0.01 * std::abs(s.torque[size_t(j)])) << names[j];
    EXPECT_NEAR(std::stod(match[5].str()), s.tau_ext[size_t(j)], 0.02 + 0.01 * std::abs(s.tau_ext[size_t(j)])) << names[j];
  }
  // The plant's damping is the controller's: nothing external, no contact.
  EXPECT_NE(frame.find("contact     none; external wrench at the tip (base-aligned)"), std::string::npos) << frame;
  // The Panda's effort limits are 87 N·m for joints 1-4: the last column is |τ| as a share of it.
  std::smatch match;
  ASSERT_TRUE(std::regex_search(frame, match, std::regex("\npanda_joint2 .* ([0-9.]+) %")));
  EXPECT_NEAR(std::stod(match[1].str()), 100.0 * std::abs(s.torque[1]) / 87.0, 0.2);

  EXPECT_NEAR(field(frame, "p_sb \\((-?[0-9.]+),"), s.tip_position[0], 2e-4);
  EXPECT_NEAR(field(frame, "R_sb as \\(w, x, y, z\\) \\((-?[0-9.]+),"), s.tip_quaternion[0], 2e-4);
  // The controller ticks at 1 kHz and the plant sends 1 kHz; a loaded machine may stretch either.
  EXPECT_NEAR(field(frame, "loop +([0-9.]+) Hz"), 1000.0, 300.0);
  EXPECT_NEAR(field(frame, "plant states ([0-9.]+) Hz"), 1000.0, 300.0);
  EXPECT_NEAR(field(frame, "commands ([0-9.]+) Hz"), 1000.0, 300.0);
  EXPECT_NEAR(field(frame, "status ([0-9.]+) Hz"), 100.0, 40.0);
  EXPECT_GE(field(frame, "Hz, ([0-9]+) ticks"), 1000.0);
  EXPECT_EQ(field(frame, "faults ([0-9]+)"), double(s.faults));
  EXPECT_EQ(field(frame, "rejected messages ([0-9]+)"), double(s.rejected_messages));
  EXPECT_NE(frame.find("IK          no Cartesian goal solved yet"), std::string::npos) << frame;
  EXPECT_EQ(frame.find("trajectory  "), std::string::npos) << "no trajectory has been sent:\n" << frame;
  for (const char* row : {"wake-up jitter", "compute \\(state to command\\)", "latency \\(arrival to sent\\)"}) {
    EXPECT_TRUE(std::regex_search(frame, std::regex(std::string(row) + " +[0-9.]+ +[0-9.]+ +[0-9.]+\n"))) << row;
  }
}

TEST(monitor, NoControllerIsSaidNotShownAsNumbers) {
  const RunResult r = monitor({"--once", "--seconds", "0.6", "--prefix", "NOBODY_"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.out.find("no controller on NOBODY_STATUS for 0.6 s"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("joint "), std::string::npos) << r.out;
  EXPECT_EQ(r.err.rfind("chasles: no controller on NOBODY_STATUS for 0.6 s", 0), 0u) << r.err;
}

// The trajectory line as the monitor prints it for `s` (its format, spelt out again here).
std::string trajectory_line(const controller_status_t& s, const char* outcome, const char* share) {
  char line[256];
  std::snprintf(line, sizeof(line), "\ntrajectory  %lld %s, %.3f of %.3f s (%s), waypoint %d, time scale %.3f\n",
                static_cast<long long>(s.trajectory_id), outcome, s.trajectory_elapsed, s.trajectory_duration, share,
                s.trajectory_waypoint, s.trajectory_time_scale);
  return line;
}

// A status with known trajectory fields, published by the test while `monitor --once` listens (it
// has its SIGINT handler once it is subscribed) and until it exits, so the one it prints is fresh:
// the trajectory's line shows them exactly, the controller's message about it on the line after,
// none when there is no message; the share is capped at 100 % past the end.
TEST(monitor, ATrajectorysProgressIsShownExactly) {
  struct Case {
    int64_t id;
    int8_t outcome;
    double elapsed, duration, scale;
    int32_t waypoint;
    std::string message, expected;
  };
  const std::string slowed = "slowed 1.425x to fit the limits";
  const Case cases[] = {
      {42, controller_status_t::TRAJECTORY_ACTIVE, 1.0, 3.0, 1.425, 7, slowed,
       "\ntrajectory  42 ACTIVE, 1.000 of 3.000 s (33.3 %), waypoint 7, time scale 1.425\n            " + slowed + "\n"},
      {9, controller_status_t::TRAJECTORY_SUCCEEDED, 2.5631, 2.5, 1.0, 12, "",
       "\ntrajectory  9 SUCCEEDED, 2.563 of 2.500 s (100.0 %), waypoint 12, time scale 1.000\ncontact     "},
      {5, controller_status_t::TRAJECTORY_REJECTED, 0.0, 0.0, 1.0, 0,
       "waypoint 2, joint panda_joint4: velocity peaks at 3.1 rad/s, over its limit 2.175; fits in 5.72 s instead of "
       "4.00 s (allow time scaling, or send it slower)",
       "\ntrajectory  5 REJECTED, 0.000 of 0.000 s (-), waypoint 0, time scale 1.000\n"
       "            waypoint 2, joint panda_joint4: velocity peaks at 3.1 rad/s, over its limit 2.175; fits in 5.72 s "
       "instead of 4.00 s (allow time scaling, or send it slower)\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.expected);
    StatusListener bus(kLcmUrl);
    ChildProcess monitor({CHASLES_CLI, "monitor", "--lcm-url", kLcmUrl, "--once", "--seconds", "1"});
    ASSERT_TRUE(monitor.catches(SIGINT, 10.0)) << monitor.stderr_text();
    controller_status_t status{};
    status.state = controller_status_t::RUNNING;
    status.num_joints = 2;
    for (auto* joints : {&status.q, &status.q_desired, &status.tracking_error, &status.torque, &status.tau_ext,
                         &status.generator_velocity_limit, &status.generator_acceleration_limit,
                         &status.generator_jerk_limit}) {
      joints->assign(2, 0.0);
    }
    status.tip_quaternion[0] = 1.0;
    status.trajectory_id = c.id;
    status.trajectory_outcome = c.outcome;
    status.trajectory_elapsed = c.elapsed;
    status.trajectory_duration = c.duration;
    status.trajectory_time_scale = c.scale;
    status.trajectory_waypoint = c.waypoint;
    status.trajectory_message = c.message;
    std::vector<uint8_t> bytes(size_t(status.getEncodedSize()));
    ASSERT_EQ(status.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (monitor.running() && Clock::now() < deadline) {  // the controller's 100 Hz
      bus.publish("CHASLES_STATUS", bytes);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_EQ(monitor.wait(), 0) << monitor.stderr_text();
    const std::string out = monitor.stdout_text();
    EXPECT_NE(out.find("controller  RUNNING"), std::string::npos) << out;
    EXPECT_NE(out.find(c.expected), std::string::npos) << out;
    EXPECT_EQ(out.find("ignored "), std::string::npos) << out;
  }
}

// End to end: `chasles target --trajectory` sends three waypoints to the live controller, which
// runs them to SUCCEEDED; the monitor's line then holds the status's frozen figures, to the digit.
TEST(monitor, ATrajectorySentWithTheCliIsFollowedToItsEnd) {
  StatusListener bus(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", kBentPose, "--damping", "0.5"}, model()));
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5", "--stale-ms", "100"}, model()));
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0)) << controller.stderr_text();
  const TempFile file("monitor_test_trajectory.json",
                      R"({"id": 31, "points": [
                           {"time_from_start": 0.3, "positions": [0.15, 0.5, -0.2, -1.2, 0.3, 1.0, 0.7]},
                           {"time_from_start": 0.6, "positions": [0.2, 0.45, -0.2, -1.2, 0.3, 1.05, 0.7]},
                           {"time_from_start": 0.9, "positions": [0.2, 0.4, -0.2, -1.25, 0.3, 1.1, 0.7]}],
                         "path_tolerance": 0.05, "goal_tolerance": 0.005, "goal_time_tolerance": 1.0,
                         "time_scaling": true})");
  const RunResult sent = run_to_completion(
      concat({CHASLES_CLI, "target", "--trajectory", file.path, "--lcm-url", kLcmUrl},
             {"--robot", data_path("panda.urdf"), "--tip", kTip}));
  ASSERT_EQ(sent.exit_code, 0) << sent.err;
  ASSERT_TRUE(bus.wait_until(
      [](const controller_status_t& s) {
        return s.trajectory_id == 31 && s.trajectory_outcome == controller_status_t::TRAJECTORY_SUCCEEDED;
      },
      10.0))
      << controller.stderr_text();
  const controller_status_t done = *bus.latest;

  const RunResult r = monitor({"--once", "--seconds", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(trajectory_line(done, "SUCCEEDED", "100.0 %")), std::string::npos)
      << trajectory_line(done, "SUCCEEDED", "100.0 %") << "in:\n" << r.out;
  EXPECT_EQ(done.trajectory_waypoint, 3);
  EXPECT_GE(done.trajectory_time_scale, 1.0);
  EXPECT_NEAR(done.trajectory_duration, 0.9 * done.trajectory_time_scale, 1e-9);
}

// End to end: `chasles jog` sends joint 1 at 0.2 rad/s for half a second, then a stop, to the live
// controller; the arm turns forward and holds, the status counts every command it sent, and
// the monitor's stream line says so.
TEST(monitor, AJogSentWithTheCliMovesTheArmAndIsCounted) {
  StatusListener bus(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", kBentPose, "--damping", "0.5"}, model()));
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5", "--stale-ms", "100"}, model()));
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0)) << controller.stderr_text();
  const double q1_before = bus.latest->q[0];
  const RunResult sent = run_to_completion({CHASLES_CLI, "jog", "--joint-velocity", "0.2,0,0,0,0,0,0", "--seconds",
                                            "0.5", "--rate", "50", "--lcm-url", kLcmUrl});
  ASSERT_EQ(sent.exit_code, 0) << sent.err;
  EXPECT_NE(sent.out.find("\"sent\":26}"), std::string::npos) << sent.out;  // 25 at 50 Hz, then the stop
  ASSERT_TRUE(bus.wait_until([](const controller_status_t& s) { return s.jogs == 26 && !s.jogging; }, 10.0))
      << controller.stderr_text();
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0));
  const controller_status_t done = *bus.latest;
  EXPECT_EQ(done.jogs_dropped, 0);
  EXPECT_EQ(done.jog_limited_by, controller_status_t::JOG_NONE);
  // Forward, by no more than 0.2 rad/s for the 0.5 s of commands and, if a loaded machine held the
  // stop back, the 100 ms timeout; how far exactly is judged in simulated time (trajectory_test).
  EXPECT_GT(done.q[0] - q1_before, 0.0);
  EXPECT_LT(done.q[0] - q1_before, 0.2 * (0.5 + 0.1));
  const RunResult r = monitor({"--once", "--seconds", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("stream      none; 0 setpoints (0 dropped), 26 jog commands (0 dropped)\n"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("speed 100 % of the asked, cut by nothing"), std::string::npos) << r.out;
}

// End to end: `chasles stream` plays 31 joint setpoints at 30 Hz (joint 7 turning 0.1 rad) to the
// live controller, which follows them and holds at the last; a file with a fault is refused whole.
TEST(monitor, AStreamPlayedWithTheCliIsFollowedAndCounted) {
  StatusListener bus(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", kBentPose, "--damping", "0.5"}, model()));
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5", "--stale-ms", "100"}, model()));
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0)) << controller.stderr_text();
  std::string points;
  for (int k = 0; k <= 30; ++k) {
    const double t = k / 30.0, s = std::min(t, 1.0);
    char point[200];
    std::snprintf(point, sizeof(point), "%s{\"t\": %.6f, \"position\": [0.1, 0.5, -0.2, -1.2, 0.3, 1.0, %.6f], "
                  "\"velocity\": [0, 0, 0, 0, 0, 0, %.6f]}", k == 0 ? "" : ",", t, 0.7 + 0.1 * s, k < 30 ? 0.1 : 0.0);
    points += point;
  }
  const TempFile file("monitor_test_stream.json", "{\"kind\": \"joint\", \"points\": [" + points + "]}");
  const RunResult sent = run_to_completion({CHASLES_CLI, "stream", file.path, "--lcm-url", kLcmUrl});
  ASSERT_EQ(sent.exit_code, 0) << sent.err;
  EXPECT_NE(sent.out.find("\"sent\":31"), std::string::npos) << sent.out;
  ASSERT_TRUE(bus.wait_until([](const controller_status_t& s) { return s.setpoints == 31 && !s.streaming; }, 10.0))
      << controller.stderr_text();
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0));
  EXPECT_NEAR(bus.latest->q_desired[6], 0.8, 1e-9) << "held at the last setpoint";
  EXPECT_EQ(bus.latest->setpoints_dropped, 0);

  const TempFile bad("monitor_test_stream_bad.json",
                     R"({"kind": "tip", "points": [{"t": 0, "position": [0.4, 0, 0.5], "quaternion": [0.9, 0, 0, 0]}]})");
  const RunResult refused = run_to_completion({CHASLES_CLI, "stream", bad.path, "--lcm-url", kLcmUrl});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("points[0]: the quaternion is not of unit norm"), std::string::npos) << refused.err;
}

// Live, to a pipe: a frame a second. The controller stops after the first frames: the later ones
// say for how long there has been no status and what it last was, with no joint table.
TEST(monitor, AControllerThatStopsIsReportedGone) {
  StatusListener bus(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", kBentPose}, model()));
  auto controller = std::make_unique<ChildProcess>(concat({CHASLES_CONTROLLER}, model()));
  ASSERT_TRUE(bus.wait_for(controller_status_t::HOLDING, 5.0)) << controller->stderr_text();
  // The controller stops once the monitor has printed a frame of it.
  ChildProcess watcher({CHASLES_CLI, "monitor", "--lcm-url", kLcmUrl, "--seconds", "3.2"});
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (watcher.stdout_text().find("controller  HOLDING") == std::string::npos && watcher.running() &&
         Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  controller->stop(SIGTERM);
  RunResult r;
  r.exit_code = watcher.wait();
  r.out = watcher.stdout_text();
  r.err = watcher.stderr_text();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << "no escape codes to a pipe";
  const size_t first_gone = r.out.find("no controller on CHASLES_STATUS for ");
  ASSERT_NE(first_gone, std::string::npos) << r.out;
  EXPECT_NE(r.out.find("controller  HOLDING"), std::string::npos) << r.out;
  EXPECT_LT(r.out.find("controller  HOLDING"), first_gone);
  const std::string last_frame = r.out.substr(r.out.rfind("chasles monitor"));
  EXPECT_NE(last_frame.find("(it was HOLDING, "), std::string::npos) << last_frame;
  EXPECT_EQ(last_frame.find("panda_joint"), std::string::npos) << last_frame;
  EXPECT_EQ(last_frame.find("j0 "), std::string::npos) << last_frame;
  EXPECT_NEAR(field(last_frame, "commands ([0-9.]+) Hz"), 0.0, 1e-9) << "the controller is gone";
}

// Malformed status messages are counted and the last reason shown, never decoded into numbers.
// The junk goes out once the monitor is listening: it subscribes before it installs its SIGINT
// handler, which /proc shows.
TEST(monitor, JunkIsCountedNotShown) {
  StatusListener bus(kLcmUrl);
  ChildProcess monitor({CHASLES_CLI, "monitor", "--lcm-url", kLcmUrl, "--seconds", "1.5"});
  ASSERT_TRUE(monitor.catches(SIGINT, 10.0)) << monitor.stderr_text();
  bus.publish("CHASLES_STATUS", {1, 2, 3});
  controller_status_t status{};
  status.num_joints = 0;
  std::vector<uint8_t> bytes(size_t(status.getEncodedSize()));
  status.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  bytes[8 + 8 + 1 + 3] = 0;  // the string's length with its NUL, 1 -> 0: lcm-gen's decoder would throw
  bus.publish("CHASLES_STATUS", bytes);
  ASSERT_EQ(monitor.wait(), 0) << monitor.stderr_text();
  const std::string out = monitor.stdout_text();
  EXPECT_NE(out.find("ignored 2 malformed status messages (last: CHASLES_STATUS: message string of 0 bytes"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("controller  "), std::string::npos) << out;
}

// SIGINT (Ctrl-C) ends a live monitor with exit status 0, once it has its handler.
TEST(monitor, SigintEndsItCleanly) {
  ChildProcess process({CHASLES_CLI, "monitor", "--lcm-url", kLcmUrl});
  ASSERT_TRUE(process.catches(SIGINT, 10.0)) << process.stderr_text();
  EXPECT_EQ(process.stop(SIGINT), 0) << process.stderr_text();
}

}  // namespace
}  // namespace chasles::testing
