// chasles log plot on logs that lcm-logger really recorded from the real plant and controller,
// and on logs written here event by event at the times the test chooses: the PNGs are made, of the
// size asked, with every segment's start marked and the estimated force drawn against the truth.
// Figures a person should look at are kept in the build's tests/artifacts. Apart from the export's
// tests (log_test.cpp), in the same binary, because a plot is judged by what it marks, not by
// values read back.
#include "tests/tools/log_recording.hpp"

namespace chasles::testing {
namespace {

using log_recording::be;
using log_recording::chasles;
using log_recording::expect_error;
using log_recording::kPandaJoints;
using log_recording::kTip;
using log_recording::panda;
using log_recording::raw_events;
using log_recording::RawEvent;
using log_recording::Recording;
using log_recording::target_message;

// Width and height from a PNG's IHDR chunk; 0 when the bytes are not a PNG.
std::pair<uint32_t, uint32_t> png_size(const std::string& png) {
  if (png.size() < 24 || png.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || png.compare(12, 4, "IHDR") != 0) return {0, 0};
  return {uint32_t(be(png, 16, 4)), uint32_t(be(png, 20, 4))};
}

// A controlled run recorded: the real plant and controller, one joint move, then the plots.
TEST(log, PlotsOfARecordedRun) {
  Recording recording("run.lcmlog");
  const std::string urdf = data_path("panda.urdf");
  const std::vector<std::string> model{"--robot", urdf, "--tip", kTip, "--lcm-url", kLcmUrl};
  StatusListener status(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", "0,0,0,-1.5,0,1.5,0", "--damping", "0.5"}, model));
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5"}, model));
  ASSERT_TRUE(status.wait_for(controller_status_t::HOLDING, 5.0)) << controller.stderr_text();
  arm_target_t target{};
  target.mode = arm_target_t::JOINT;
  target.num_joints = 7;
  target.joint_position = {0.3, 0.2, 0.0, -1.2, 0.0, 1.7, 0.5};
  target.tip_quaternion[0] = 1.0;
  target.duration = 0.8;
  recording.send("CHASLES_TARGET", target);
  ASSERT_TRUE(status.wait_for(controller_status_t::RUNNING, 5.0)) << controller.stderr_text();
  // The move done, and 1.5 s of ticks in all, as the plots below need.
  ASSERT_TRUE(status.wait_until([](const controller_status_t& s) {
    return s.state == controller_status_t::HOLDING && s.ticks >= 1500;
  }, 10.0)) << controller.stderr_text();
  EXPECT_EQ(controller.stop(SIGTERM), 0) << controller.stderr_text();
  EXPECT_EQ(plant.stop(SIGTERM), 0) << plant.stderr_text();
  const std::string log = recording.finish();

  const std::string dir = temp_path("plots");
  const RunResult r = chasles(concat({"log", "plot", recording.path, "--out", dir}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto answer = nlohmann::json::parse(r.out);
  EXPECT_GT(answer["status_messages"].get<int>(), 100);
  EXPECT_GT(answer["command_messages"].get<int>(), 1000);
  EXPECT_EQ(answer["targets"], 1);
  const std::vector<std::string> names = {"joint_positions.png", "tracking_error.png", "compute_time.png",
                                          "torques.png", "jitter_histogram.png"};
  ASSERT_EQ(answer["plots"].size(), names.size());
  // The figures are kept for a person to look at (they are small), under the build tree.
  const std::string artifacts = std::string(CHASLES_ARTIFACTS) + "/plots";
  ::mkdir(CHASLES_ARTIFACTS, 0777);
  ::mkdir(artifacts.c_str(), 0777);
  for (const std::string& name : names) {
    const std::string png = read_file(dir + "/" + name);
    EXPECT_EQ(png_size(png), std::make_pair(1200u, 800u)) << name;
    // A 1200x800 pngcairo image with axes but no data is about 10 kB; with curves, several times that.
    EXPECT_GT(png.size(), 20'000u) << name;
    std::ofstream(artifacts + "/" + name, std::ios::binary) << png;
    std::remove((dir + "/" + name).c_str());
  }
  EXPECT_EQ(::rmdir(dir.c_str()), 0) << "plot left files behind in " << dir;

  // Cut short, the same log still gives its plots, and says where it ends.
  const std::vector<RawEvent> events = raw_events(log);
  const RawEvent& last = events[events.size() - 2];
  const TempFile cut("cut_run.lcmlog", log.substr(0, last.offset + 5));
  const RunResult damaged = chasles(concat({"log", "plot", cut.path, "--out", dir}, panda()));
  expect_error(damaged, "byte " + std::to_string(last.offset) + ": the last 5 bytes are too few for an event header");
  expect_error(damaged, "plotted what was readable: 5 figures in " + dir);
  for (const std::string& name : names) {
    EXPECT_EQ(png_size(read_file(dir + "/" + name)), std::make_pair(1200u, 800u)) << name;
    std::remove((dir + "/" + name).c_str());
  }
  ::rmdir(dir.c_str());
}

// An LCM log written here, event by event (sync word, number, utime, channel and data lengths,
// channel, data: big-endian), at the times the test chooses.
struct LogEvent {
  int64_t utime;
  std::string channel;
  std::vector<uint8_t> data;
};

template <typename Message>
LogEvent event_of(int64_t utime, const std::string& channel, const Message& message) {
  std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return {utime, channel, bytes};
}

std::string log_bytes(const std::vector<LogEvent>& events) {
  std::string out;
  const auto put = [&out](uint64_t v, int n) {
    for (int k = n - 1; k >= 0; --k) out.push_back(char(uint8_t(v >> (8 * k))));
  };
  for (size_t i = 0; i < events.size(); ++i) {
    put(0xEDA1DA01u, 4), put(i, 8), put(uint64_t(events[i].utime), 8);
    put(events[i].channel.size(), 4), put(events[i].data.size(), 4);
    out += events[i].channel;
    out.append(events[i].data.begin(), events[i].data.end());
  }
  return out;
}

// Every way to set the arm going is marked where it starts, as a target is: a trajectory by its
// id, a stream and a jog at their first message after half a second of silence, a control mode by
// its law.
TEST(log, PlotMarksEverySegmentsStart) {
  constexpr int64_t t0 = 1'700'000'000'000'000;
  const auto at = [](double s) { return t0 + std::llround(s * 1e6); };
  std::vector<LogEvent> events;
  for (int k = 0; k <= 200; ++k) {  // 2 s of commands: something to plot
    joint_torque_command_t c{};
    c.utime = at(0.01 * k), c.seq = k, c.state_seq = k, c.num_joints = 7;
    c.torque.assign(7, 0.1 * k);
    events.push_back(event_of(at(0.01 * k), "CHASLES_COMMAND", c));
  }
  arm_target_t target = target_message(1);  // JOINT
  events.push_back(event_of(at(0.1), "CHASLES_TARGET", target));
  control_mode_t mode{};
  mode.law = control_mode_t::JOINT_IMPEDANCE;
  mode.stiffness_frame_quaternion[0] = 1.0;
  events.push_back(event_of(at(0.3), "CHASLES_MODE", mode));
  joint_trajectory_t trajectory{};
  trajectory.id = 7, trajectory.num_joints = 7, trajectory.num_points = 1;
  trajectory.joint_names = kPandaJoints;
  trajectory.time_from_start = {1.0};
  trajectory.positions = {std::vector<double>(7, 0.1)};
  trajectory.path_tolerance.assign(7, 0.0), trajectory.goal_tolerance.assign(7, 0.0);
  events.push_back(event_of(at(0.5), "CHASLES_TRAJECTORY", trajectory));
  joint_setpoint_t setpoint{};
  setpoint.num_joints = 7;
  setpoint.position.assign(7, 0.0), setpoint.velocity.assign(7, 0.0);
  for (double t : {0.8, 0.833, 0.866, 0.9, 1.6, 1.633}) events.push_back(event_of(at(t), "CHASLES_SETPOINT", setpoint));
  jog_command_t jog{};
  jog.kind = jog_command_t::TWIST;
  for (double t : {1.2, 1.22, 1.24}) events.push_back(event_of(at(t), "CHASLES_JOG", jog));
  std::stable_sort(events.begin(), events.end(), [](const LogEvent& a, const LogEvent& b) { return a.utime < b.utime; });
  const TempFile log("segments.lcmlog", log_bytes(events));
  const std::string dir = temp_path("segment_plots");
  const RunResult r = chasles(concat({"log", "plot", log.path, "--out", dir}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto marks = nlohmann::json::parse(r.out)["marks"];
  const std::vector<std::pair<double, std::string>> expected = {
      {0.1, "JOINT"}, {0.3, "joint impedance"}, {0.5, "TRAJECTORY 7"}, {0.8, "STREAM"}, {1.2, "JOG twist"}, {1.6, "STREAM"}};
  ASSERT_EQ(marks.size(), expected.size()) << marks.dump();
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_DOUBLE_EQ(marks[i]["t"].get<double>(), expected[i].first) << i;
    EXPECT_EQ(marks[i]["label"], expected[i].second) << i;
  }
  std::filesystem::remove_all(dir);
}

// A run with a push: the plant's truth is in the log, and the plot holds the controller's estimate
// against it.
TEST(log, PlotsTheEstimatedForceAgainstTheTruth) {
  Recording recording("push.lcmlog");
  const std::string urdf = data_path("panda.urdf");
  const std::vector<std::string> model{"--robot", urdf, "--tip", kTip, "--lcm-url", kLcmUrl};
  StatusListener status(kLcmUrl);
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", "0,0,0,-1.5,0,1.5,0", "--damping", "0.5", "--push",
                             "0.5,100,0.05,0,0,0,0,10,0"},
                            model));
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5"}, model));
  // Held under the 10 N push (a contact, under the collision threshold) for a second of ticks.
  ASSERT_TRUE(status.wait_until([](const controller_status_t& s) {
    return s.state == controller_status_t::HOLDING && s.contact && s.ticks >= 1500;
  }, 10.0)) << controller.stderr_text();
  EXPECT_EQ(controller.stop(SIGTERM), 0) << controller.stderr_text();
  EXPECT_EQ(plant.stop(SIGTERM), 0) << plant.stderr_text();
  recording.finish();

  const std::string dir = temp_path("push_plots");
  const RunResult r = chasles(concat({"log", "plot", recording.path, "--out", dir}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto answer = nlohmann::json::parse(r.out);
  EXPECT_GT(answer["truth_messages"].get<int>(), 1000);
  ASSERT_EQ(answer["plots"].size(), 6u);
  EXPECT_EQ(answer["plots"].back(), dir + "/external_force.png");
  const std::string png = read_file(dir + "/external_force.png");
  EXPECT_EQ(png_size(png), std::make_pair(1200u, 800u));
  EXPECT_GT(png.size(), 20'000u);
  const std::string artifacts = std::string(CHASLES_ARTIFACTS) + "/plots";
  ::mkdir(CHASLES_ARTIFACTS, 0777);
  ::mkdir(artifacts.c_str(), 0777);
  std::ofstream(artifacts + "/external_force.png", std::ios::binary) << png;
  for (const auto& path : answer["plots"]) std::remove(path.get<std::string>().c_str());
  EXPECT_EQ(::rmdir(dir.c_str()), 0) << "plot left files behind in " << dir;
}

}  // namespace
}  // namespace chasles::testing
