// chasles target, run as a real process, heard by a subscriber in this process. The test binary
// runs inside its own network namespace (tools/netns.sh is its launcher, see CMakeLists.txt), so
// the multicast never leaves the machine. A refused target must exit 1 with one "chasles: ..."
// line and send nothing at all.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chasles/arm_target_t.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/bus_listener.hpp"
#include "lcmtypes/checked.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;

constexpr char kPrefix[] = "TEST_";

using Result = testing::RunResult;

// Runs `chasles target ARGS`, without the caller's LCM_DEFAULT_URL; `env` entries ("NAME=value")
// are added to the child's environment.
Result run_target(const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
  return testing::run_to_completion(concat({CHASLES_CLI, "target"}, args), "/dev/null",
                                    concat({"LCM_DEFAULT_URL"}, env));
}

// Every arm_target_t on `channel`, decoded as sent (a malformed one fails the test).
class Listener {
 public:
  explicit Listener(const std::string& channel) : ear_(kLcmUrl, channel) {}

  /// Everything that arrives within `seconds`; returns early once `count` targets are in.
  const std::vector<arm_target_t>& listen(double seconds, size_t count = SIZE_MAX) {
    const auto& heard = ear_.listen(seconds, count);
    for (size_t k = targets_.size(); k < heard.size(); ++k) {
      arm_target_t target;
      const int size = static_cast<int>(heard[k].size());
      EXPECT_EQ(target.decode(heard[k].data(), 0, size), size) << "chasles target sent a malformed arm_target_t";
      targets_.push_back(target);
    }
    return targets_;
  }

 private:
  testing::BusListener ear_;
  std::vector<arm_target_t> targets_;
};

int64_t now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::vector<std::string> panda_args() { return {"--robot", data_path("panda.urdf"), "--tip", "panda_hand"}; }

const std::vector<std::string> kWire = {"--lcm-url", kLcmUrl, "--channel-prefix", kPrefix};

// A successful send: exit 0, nothing on stderr, one JSON line on stdout.
json sent_json(const Result& r) {
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  return json::parse(r.out);
}

TEST(target, HoldIsSent) {
  Listener listener("TEST_TARGET");
  const int64_t before = now_us();
  const json out = sent_json(run_target(concat({"--hold"}, kWire)));
  const auto& received = listener.listen(2.0, 1);
  ASSERT_EQ(received.size(), 1u);
  const arm_target_t& target = received[0];
  EXPECT_EQ(target.mode, arm_target_t::HOLD);
  EXPECT_EQ(target.num_joints, 0);
  EXPECT_TRUE(target.joint_position.empty());
  EXPECT_EQ(target.duration, 0.0);
  EXPECT_GE(target.utime, before);
  EXPECT_LE(target.utime, now_us());
  EXPECT_EQ(out["channel"], "TEST_TARGET");
  EXPECT_EQ(out["mode"], "HOLD");
  EXPECT_EQ(out["utime"], target.utime);
}

TEST(target, JointGoalIsSentExactly) {
  Listener listener("TEST_TARGET");
  // Within the Panda's limits; joint 4 near its upper limit -0.0698, joint 7 exactly at its lower.
  const std::vector<double> q = {0.1, -0.3, 0.25, -0.07, -0.1, 1.7, -2.8973};
  const json out = sent_json(run_target(
      concat(concat(panda_args(), kWire), {"--joint", "0.1,-0.3,0.25,-0.07,-0.1,1.7,-2.8973", "--duration", "2.5"})));
  const auto& received = listener.listen(2.0, 1);
  ASSERT_EQ(received.size(), 1u);
  const arm_target_t& target = received[0];
  EXPECT_EQ(target.mode, arm_target_t::JOINT);
  EXPECT_EQ(target.num_joints, 7);
  EXPECT_EQ(target.joint_position, q);  // exactly: parsed once, sent as doubles
  EXPECT_EQ(target.duration, 2.5);
  EXPECT_EQ(out["mode"], "JOINT");
  EXPECT_EQ(out["joint_position"].get<std::vector<double>>(), q);
  EXPECT_EQ(out["joint_names"][3], "panda_joint4");
  EXPECT_EQ(out["duration"], 2.5);
  EXPECT_EQ(out["utime"], target.utime);
}

// A trajectory file, sent as a joint_trajectory_t on PREFIX TRAJECTORY: the joints named by the
// URDF when the file names none, the tolerances per joint from one number, every value exact.
TEST(target, TrajectoryFileIsSentAsAJointTrajectory) {
  testing::BusListener ear(kLcmUrl, "TEST_TRAJECTORY");
  const std::string file = ::testing::TempDir() + "trajectory_" + std::to_string(::getpid()) + ".json";
  {
    std::ofstream out(file);
    out << R"({"id": 12, "points": [
      {"time_from_start": 0.5, "positions": [0.1, -0.3, 0.25, -0.5, -0.1, 1.7, 0.0], "velocities": [0, 0, 0.1, 0, 0, 0, 0]},
      {"time_from_start": 1.25, "positions": [0.2, -0.3, 0.25, -0.6, -0.1, 1.7, 0.1], "velocities": [0, 0, 0, 0, 0, 0, 0]}],
      "path_tolerance": 0.05, "goal_tolerance": [0.001, 0.001, 0.001, 0.001, 0.001, 0.001, 0.002],
      "goal_time_tolerance": 0.5, "time_scaling": true})";
  }
  const json out = sent_json(run_target(concat(concat(panda_args(), kWire), {"--trajectory", file})));
  const auto& heard = ear.listen(2.0, 1);
  ASSERT_EQ(heard.size(), 1u);
  joint_trajectory_t t;
  ASSERT_EQ(messages::decode_checked(heard[0].data(), heard[0].size(), t, 7, messages::Finite::Required), "");
  EXPECT_EQ(t.id, 12);
  EXPECT_EQ(t.joint_names[0], "panda_joint1");
  EXPECT_EQ(t.joint_names[6], "panda_joint7");
  EXPECT_EQ(t.time_from_start, (std::vector<double>{0.5, 1.25}));
  EXPECT_EQ(t.positions[1], (std::vector<double>{0.2, -0.3, 0.25, -0.6, -0.1, 1.7, 0.1}));
  EXPECT_EQ(t.num_velocities, 2);
  EXPECT_EQ(t.velocities[0][2], 0.1);
  EXPECT_EQ(t.num_accelerations, 0);
  EXPECT_EQ(t.path_tolerance, std::vector<double>(7, 0.05));
  EXPECT_EQ(t.goal_tolerance[6], 0.002);
  EXPECT_EQ(t.goal_time_tolerance, 0.5);
  EXPECT_TRUE(t.time_scaling);
  EXPECT_EQ(out["channel"], "TEST_TRAJECTORY");
  EXPECT_EQ(out["points"], 2);
  EXPECT_EQ(out["duration"], 1.25);
  EXPECT_EQ(out["utime"], t.utime);

  // Refused before anything is sent: times that do not increase, a waypoint outside the limits.
  for (const auto& [points, words] :
       {std::pair{R"([{"time_from_start": 1, "positions": [0,0,0,-1,0,1,0]}, {"time_from_start": 1, "positions": [0,0,0,-1,0,1,0]}])",
                  "waypoint 1: time_from_start 1 s is not after 1 s"},
        std::pair{R"([{"time_from_start": 1, "positions": [0,0,0,0.5,0,1,0]}])",
                  "waypoint 0: joint panda_joint4 = 0.5 is outside its limits"},
        std::pair{R"([{"time_from_start": 1, "positions": [0,0,0,-1,0,1]}])",
                  "\"positions\" must be a number or a list of 7 numbers"}}) {
    std::ofstream(file) << "{\"points\": " << points << "}";
    const Result r = run_target(concat(concat(panda_args(), kWire), {"--trajectory", file}));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
  }
  EXPECT_TRUE(ear.listen(0.2).size() == 1u) << "nothing more was sent";
  std::remove(file.c_str());
}

TEST(target, PoseIsSentWithTheQuaternionNormalised) {
  Listener listener("TEST_TARGET");
  const json out =
      sent_json(run_target(concat(kWire, {"--pose", "0.4,-0.1,0.5,0.7071,0,0.7071,0", "--duration", "3"})));
  const auto& received = listener.listen(2.0, 1);
  ASSERT_EQ(received.size(), 1u);
  const arm_target_t& target = received[0];
  EXPECT_EQ(target.mode, arm_target_t::CARTESIAN);
  EXPECT_EQ(target.num_joints, 0);
  EXPECT_EQ(target.tip_position[0], 0.4);
  EXPECT_EQ(target.tip_position[1], -0.1);
  EXPECT_EQ(target.tip_position[2], 0.5);
  const double norm = std::sqrt(
      target.tip_quaternion[0] * target.tip_quaternion[0] + target.tip_quaternion[1] * target.tip_quaternion[1] +
      target.tip_quaternion[2] * target.tip_quaternion[2] + target.tip_quaternion[3] * target.tip_quaternion[3]);
  EXPECT_NEAR(norm, 1.0, 1e-15);
  EXPECT_NEAR(target.tip_quaternion[0], std::sqrt(0.5), 1e-15);
  EXPECT_EQ(target.tip_quaternion[0], target.tip_quaternion[2]);
  EXPECT_EQ(target.tip_quaternion[1], 0.0);
  EXPECT_EQ(target.tip_quaternion[3], 0.0);
  EXPECT_EQ(target.duration, 3.0);
  EXPECT_EQ(out["mode"], "CARTESIAN");
  EXPECT_EQ(out["tip_quaternion"][0].get<double>(), target.tip_quaternion[0]);
  EXPECT_NEAR(out["quaternion_input_norm"].get<double>(), 0.7071 * std::sqrt(2.0), 1e-15);
}

// Without --channel-prefix and --lcm-url: CHASLES_TARGET, on $LCM_DEFAULT_URL.
TEST(target, DefaultChannelAndUrlFromTheEnvironment) {
  Listener listener("CHASLES_TARGET");
  const json out = sent_json(run_target({"--hold"}, {std::string("LCM_DEFAULT_URL=") + kLcmUrl}));
  EXPECT_EQ(out["channel"], "CHASLES_TARGET");
  EXPECT_EQ(listener.listen(2.0, 1).size(), 1u);
}

// Refused input: exit 1, one "chasles: " line naming the problem, nothing on stdout, nothing sent.
TEST(target, BadValuesAreRefusedAndNothingIsSent) {
  Listener listener("TEST_TARGET");
  const auto refused = [&](const std::vector<std::string>& args, const std::string& needle) {
    const Result r = run_target(concat(kWire, args));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
  };
  const auto joint = [](const std::string& q, const std::string& duration = "2") {
    return concat(panda_args(), {"--joint", q, "--duration", duration});
  };
  refused(joint("0,0,0,-1,0,1"), "--joint has 6 entries, expected 7");
  refused(joint("0,0,0,-1,0,1,0,0"), "--joint has 8 entries, expected 7");
  refused(joint("0,0,nan,-1,0,1,0"), "entry 2 ('nan') is not finite");
  refused(joint("0,0,0,-1,0,inf,0"), "entry 5 ('inf') is not finite");
  refused(joint("0,0,0,-1,x,1,0"), "entry 4 ('x') is not a number");
  refused(joint(""), "--joint: entry 0 ('') is not a number");
  // Zero is outside the Panda's fourth joint's range [-3.0718, -0.0698].
  refused(joint("0,0,0,0,0,1,0"), "joint panda_joint4 = 0 is outside its limits [-3.0718, -0.0698]");
  refused(joint("0,0,0,-1,0,1,2.8974"), "joint panda_joint7 = 2.8974 is outside its limits [-2.8973, 2.8973]");
  refused(joint("0,0,0,-1,0,1,0", "0"), "--duration: 0 s");
  refused(joint("0,0,0,-1,0,1,0", "-1"), "must be positive and finite");
  refused(joint("0,0,0,-1,0,1,0", "inf"), "must be positive and finite");
  refused(joint("0,0,0,-1,0,1,0", "nan"), "must be positive and finite");
  refused(joint("0,0,0,-1,0,1,0", "2s"), "--duration: '2s' is not a number");
  refused({"--robot", data_path("no_such.urdf"), "--joint", "0", "--duration", "1"}, "no_such.urdf");

  const auto pose = [](const std::string& p, const std::string& duration = "2") {
    return std::vector<std::string>{"--pose", p, "--duration", duration};
  };
  refused(pose("0.4,0,0.5,1,0,0"), "--pose has 6 entries, expected 7");
  refused(pose("0.4,nan,0.5,1,0,0,0"), "entry 1 ('nan') is not finite");
  refused(pose("0.4,0,0.5,0.5,0,0,0"), "has norm 0.5");
  refused(pose("0.4,0,0.5,0,0,0,0"), "has norm 0");
  refused(pose("0.4,0,0.5,1.002,0,0,0"), "has norm 1.002");
  refused(pose("0.4,0,0.5,1,0,0,0", "0"), "must be positive and finite");
  refused(concat(panda_args(), pose("3,0,0.5,1,0,0,0")), "beyond the arm's reach");

  EXPECT_TRUE(listener.listen(0.3).empty()) << "a refused target was sent";
}

// Combinations that make no sense are usage errors (exit 2), before anything is sent.
TEST(target, UsageErrorsExitTwo) {
  Listener listener("TEST_TARGET");
  const auto usage = [&](const std::vector<std::string>& args, const std::string& needle) {
    const Result r = run_target(concat(kWire, args));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
  };
  usage({}, "exactly one of --hold, --joint, --pose and --trajectory");
  usage({"--hold", "--pose", "0,0,0,1,0,0,0", "--duration", "1"}, "exactly one of");
  usage({"--hold", "--duration", "1"}, "--hold takes no --duration");
  usage({"--trajectory", "t.json", "--duration", "1"}, "--trajectory takes no --duration");
  usage(concat(panda_args(), {"--joint", "0,0,0,-1,0,1,0"}), "--joint needs --duration");
  usage({"--joint", "0,0,0,-1,0,1,0", "--duration", "1"}, "--joint needs --robot");
  usage({"--pose", "0,0,0,1,0,0,0"}, "--pose needs --duration");
  const Result r = run_target({"--hold", "--lcm-url", kLcmUrl, "--channel-prefix", "A.*"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--channel-prefix"), std::string::npos) << r.err;
  EXPECT_TRUE(listener.listen(0.3).empty());
}

// An LCM that cannot start is one line, with LCM's own reason, and exit 1.
TEST(target, LcmThatCannotStartIsAnError) {
  const Result r = run_target({"--hold", "--lcm-url", "nosuchprovider://x"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err.rfind("chasles: cannot start LCM on nosuchprovider://x", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("provider \"nosuchprovider\" not found"), std::string::npos) << r.err;  // LCM's reason
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
}  // namespace chasles::testing
