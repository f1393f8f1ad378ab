// chasles log export and plot on logs that lcm-logger really recorded. The test binary runs in a
// network namespace of its own (tools/netns.sh launches it), publishes known messages over LCM
// while lcm-logger records them, and checks that the export gives back exactly what was sent;
// then it damages copies of the log (cut short, overwritten, forged sizes, random bytes) and
// checks that what is readable still comes out, with an error naming the byte offset.
#include <gtest/gtest.h>
#include <lcm/lcm.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/jog_command_t.hpp>
#include <chasles/joint_setpoint_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <chasles/payload_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"
#include "support/bus_listener.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

constexpr char kTip[] = "panda_hand";
const std::vector<std::string> kPandaJoints = {"panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4",
                                               "panda_joint5", "panda_joint6", "panda_joint7"};

// A big-endian event of the LCM log format, parsed here independently of the code under test.
struct RawEvent {
  uint64_t offset;
  std::string channel;
  uint64_t size;  ///< header + channel + data
};

uint64_t be(const std::string& bytes, size_t at, int count) {
  uint64_t value = 0;
  for (int i = 0; i < count; ++i) value = (value << 8) | uint8_t(bytes[at + size_t(i)]);
  return value;
}

std::vector<RawEvent> raw_events(const std::string& log) {
  std::vector<RawEvent> events;
  for (size_t at = 0; at + 28 <= log.size();) {
    EXPECT_EQ(be(log, at, 4), 0xEDA1DA01u) << "at byte " << at;
    const uint64_t channel_length = be(log, at + 20, 4), data_length = be(log, at + 24, 4);
    events.push_back({at, log.substr(at + 28, channel_length), 28 + channel_length + data_length});
    at += 28 + channel_length + data_length;
  }
  return events;
}

// Publishes messages while lcm-logger records them.
class Recording {
 public:
  explicit Recording(const std::string& name)
      : path(temp_path(name)), lcm_(lcm_create(kLcmUrl)),
        logger_({LCM_LOGGER, std::string("--lcm-url=") + kLcmUrl, "--flush-interval=10", "--force", "--quiet", path}) {
    if (lcm_ == nullptr) throw std::runtime_error("LCM did not start: run the test under tools/netns.sh");
    // The logger is listening once something sent reaches its file.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    const uint8_t ping = 0;
    while (file_size() == 0 && std::chrono::steady_clock::now() < deadline) {
      lcm_publish(lcm_, "WARMUP", &ping, 1);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (file_size() == 0) throw std::runtime_error("lcm-logger recorded nothing: " + logger_.stderr_text());
  }
  ~Recording() {
    lcm_destroy(lcm_);
    std::remove(path.c_str());
  }

  template <typename Message>
  void send(const std::string& channel, const Message& message) {
    std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
    message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    send_bytes(channel, bytes);
  }
  void send_bytes(const std::string& channel, const std::vector<uint8_t>& bytes) {
    lcm_publish(lcm_, channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
    // LCM queues at most 30 messages per subscription: pace the burst so the logger keeps up.
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }

  /// Sends WARMUP messages with payload 1 until the logger has written one, and so everything
  /// sent before it (one sender, one receiver: LCM keeps the order; lcm-logger flushes its file
  /// when a message comes after its flush interval, hence more than one); then stops the logger
  /// (SIGINT: it closes the file), cuts the log where those end markers begin, and returns it: the
  /// log holds what the test sent, and ends with it.
  std::string finish() {
    const uint8_t end = 1;
    const std::string marker = std::string("WARMUP") + char(end);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    bool written = false;
    while (!written && std::chrono::steady_clock::now() < deadline) {
      lcm_publish(lcm_, "WARMUP", &end, 1);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      written = read_file(path).find(marker) != std::string::npos;
    }
    EXPECT_TRUE(written) << "lcm-logger did not write what was sent";
    EXPECT_EQ(logger_.stop(SIGINT), 0) << logger_.stderr_text();
    std::string log = read_file(path);
    for (const RawEvent& e : raw_events(log)) {
      if (e.channel == "WARMUP" && e.size == 28 + 6 + 1 && uint8_t(log[e.offset + 34]) == end) {
        log.resize(e.offset);
        std::ofstream(path, std::ios::binary | std::ios::trunc) << log;
        break;
      }
    }
    return log;
  }

  const std::string path;

 private:
  uint64_t file_size() const {
    struct stat info {};
    return ::stat(path.c_str(), &info) == 0 ? uint64_t(info.st_size) : 0;
  }
  lcm_t* lcm_;
  ChildProcess logger_;
};

RunResult chasles(const std::vector<std::string>& args) {
  return run_to_completion(concat({CHASLES_CLI}, args));
}

// A CSV file as rows of cells (RFC 4180 quoting).
std::vector<std::vector<std::string>> read_csv(const std::string& text) {
  std::vector<std::vector<std::string>> rows(1);
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cell += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().push_back(cell);
      cell.clear();
    } else if (c == '\n') {
      rows.back().push_back(cell);
      cell.clear();
      rows.emplace_back();
    } else {
      cell += c;
    }
  }
  if (rows.back().empty()) rows.pop_back();
  return rows;
}

// The CSV's rows as maps from column name to cell.
std::vector<std::map<std::string, std::string>> csv_records(const std::string& path) {
  const auto rows = read_csv(read_file(path));
  std::vector<std::map<std::string, std::string>> records;
  if (rows.empty()) return records;
  for (size_t r = 1; r < rows.size(); ++r) {
    EXPECT_EQ(rows[r].size(), rows[0].size()) << "row " << r;
    std::map<std::string, std::string> record;
    for (size_t c = 0; c < rows[0].size() && c < rows[r].size(); ++c) record[rows[0][c]] = rows[r][c];
    records.push_back(std::move(record));
  }
  return records;
}

double number(const std::map<std::string, std::string>& record, const std::string& column) {
  const auto it = record.find(column);
  if (it == record.end()) {
    ADD_FAILURE() << "no column " << column;
    return NAN;
  }
  return std::strtod(it->second.c_str(), nullptr);
}

// Seeded, distinct values (no two alike), so a swapped column or row cannot pass.
robot_state_t state_message(int k) {
  robot_state_t m;
  m.utime = 1'700'000'000'000'000 + k * 1000;
  m.seq = k;
  m.num_joints = 7;
  for (int j = 0; j < 7; ++j) {
    m.position.push_back(std::sin(0.1 * k + j) * 2.0 + 1e-9 * j);
    m.velocity.push_back(std::cos(0.37 * k - j) / 3.0);
    m.effort.push_back(-87.0 + 0.123456789 * (k * 7 + j));
  }
  return m;
}

controller_status_t status_message(int k) {
  controller_status_t m;
  m.utime = 1'700'000'000'000'000 + k * 10'000;
  m.state = int8_t(k % 4);
  m.message = k % 3 == 0 ? "" : "refused \"target\", joint " + std::to_string(k) + ": over its limit";
  m.num_joints = 7;
  for (int j = 0; j < 7; ++j) {
    m.q.push_back(0.01 * k + j);
    m.q_desired.push_back(0.01 * k + j + 1e-4 * j);
    m.tracking_error.push_back(1e-4 * j - 1e-7 * k);
    m.torque.push_back(1.5 * j - 0.25 * k);
  }
  for (int i = 0; i < 3; ++i) m.tip_position[i] = 0.1 * i + 0.001 * k;
  m.tip_quaternion[0] = std::cos(0.01 * k);
  m.tip_quaternion[1] = std::sin(0.01 * k);
  m.tip_quaternion[2] = m.tip_quaternion[3] = 0.0;
  m.ik_iterations = k;
  m.ik_residual = 1e-12 * k;
  m.ik_converged = k % 2 == 0;
  m.jitter_p50_us = 10.5 + k;
  m.jitter_p99_us = 40.25 + k;
  m.jitter_max_us = 900.125 + k;
  m.compute_p50_us = 3.0 + k;
  m.compute_p99_us = 9.0 + k;
  m.compute_max_us = 20.0 + k;
  m.latency_p50_us = 120.0 + k;
  m.latency_p99_us = 400.0 + k;
  m.latency_max_us = 1200.0 + k;
  m.ticks = 1000 * k;
  m.overruns = k / 5;
  m.stale_states = k / 7;
  m.rejected_messages = k / 11;
  m.faults = k / 13;
  m.tau_ext.clear();
  for (int j = 0; j < 7; ++j) m.tau_ext.push_back(0.01 * j * k - 0.5);
  for (int j = 0; j < 7; ++j) {
    m.generator_velocity_limit.push_back(2.0 + 0.1 * j);
    m.generator_acceleration_limit.push_back(10.0 + j + 0.5 * k);
    m.generator_jerk_limit.push_back(3000.0 - 10.0 * j - k);
  }
  for (int i = 0; i < 6; ++i) m.tip_wrench_ext[i] = 0.5 * i - 0.1 * k;
  m.contact = k % 2 == 1;
  m.collision = k % 4 == 3;
  m.contacts = k / 2;
  m.reflexes = k / 4;
  return m;
}

arm_target_t target_message(int k) {
  arm_target_t m{};
  m.utime = 1'700'000'000'000'000 + k;
  m.mode = int8_t(k % 3);
  m.num_joints = m.mode == arm_target_t::JOINT ? 7 : 0;
  for (int j = 0; j < m.num_joints; ++j) m.joint_position.push_back(0.1 * j - 0.05 * k);
  for (int i = 0; i < 3; ++i) m.tip_position[i] = 0.2 * k + i;
  m.tip_quaternion[0] = 1.0;
  m.duration = 0.5 * (k + 1);
  return m;
}

std::vector<std::string> panda() { return {"--urdf", data_path("panda.urdf"), "--tip", kTip}; }

TEST(log, ExportGivesBackEveryMessageSent) {
  Recording recording("export.lcmlog");
  constexpr int kStates = 120, kStatuses = 30, kTargets = 6;
  for (int k = 0; k < kStates; ++k) {
    recording.send("CHASLES_STATE", state_message(k));
    if (k < kStatuses) recording.send("CHASLES_STATUS", status_message(k));
    if (k < kTargets) recording.send("CHASLES_TARGET", target_message(k));
  }
  recording.finish();

  // States: joint arrays by the URDF's joint names, every value exactly as sent.
  const std::string csv = temp_path("states.csv");
  RunResult r = chasles(concat({"log", "export", recording.path, "--channel", "CHASLES_STATE", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto answer = nlohmann::json::parse(r.out);
  EXPECT_EQ(answer["messages"], kStates);
  EXPECT_EQ(answer["type"], "chasles.robot_state_t");
  EXPECT_EQ(answer["columns"], 3 + 3 + 3 * 7);
  auto records = csv_records(csv);
  ASSERT_EQ(records.size(), size_t(kStates));
  double last_t = -1.0;
  for (int k = 0; k < kStates; ++k) {
    const robot_state_t sent = state_message(k);
    const auto& row = records[size_t(k)];
    EXPECT_EQ(row.at("utime"), std::to_string(sent.utime));
    EXPECT_EQ(row.at("seq"), std::to_string(k));
    EXPECT_EQ(row.at("num_joints"), "7");
    for (int j = 0; j < 7; ++j) {
      const std::string& name = kPandaJoints[size_t(j)];
      EXPECT_EQ(number(row, "position[" + name + "]"), sent.position[size_t(j)]) << "state " << k << " " << name;
      EXPECT_EQ(number(row, "velocity[" + name + "]"), sent.velocity[size_t(j)]) << "state " << k << " " << name;
      EXPECT_EQ(number(row, "effort[" + name + "]"), sent.effort[size_t(j)]) << "state " << k << " " << name;
    }
    EXPECT_GE(number(row, "log_t"), last_t);
    last_t = number(row, "log_t");
  }
  std::remove(csv.c_str());

  // Status: every field, the string with its comma and quotes intact; without a URDF the joints
  // are j0..j6.
  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_STATUS", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  records = csv_records(csv);
  ASSERT_EQ(records.size(), size_t(kStatuses));
  for (int k = 0; k < kStatuses; ++k) {
    const controller_status_t sent = status_message(k);
    const auto& row = records[size_t(k)];
    EXPECT_EQ(row.at("state"), std::to_string(int{sent.state}));
    EXPECT_EQ(row.at("message"), sent.message);
    for (int j = 0; j < 7; ++j) {
      const std::string label = "[j" + std::to_string(j) + "]";
      EXPECT_EQ(number(row, "q" + label), sent.q[size_t(j)]);
      EXPECT_EQ(number(row, "q_desired" + label), sent.q_desired[size_t(j)]);
      EXPECT_EQ(number(row, "tracking_error" + label), sent.tracking_error[size_t(j)]);
      EXPECT_EQ(number(row, "torque" + label), sent.torque[size_t(j)]);
    }
    EXPECT_EQ(number(row, "tip_position[x]"), sent.tip_position[0]);
    EXPECT_EQ(number(row, "tip_position[z]"), sent.tip_position[2]);
    EXPECT_EQ(number(row, "tip_quaternion[w]"), sent.tip_quaternion[0]);
    EXPECT_EQ(number(row, "tip_quaternion[x]"), sent.tip_quaternion[1]);
    EXPECT_EQ(number(row, "ik_iterations"), sent.ik_iterations);
    for (int j = 0; j < 7; ++j) EXPECT_EQ(number(row, "tau_ext[j" + std::to_string(j) + "]"), sent.tau_ext[size_t(j)]);
    EXPECT_EQ(number(row, "tip_wrench_ext[mx]"), sent.tip_wrench_ext[0]);
    EXPECT_EQ(number(row, "tip_wrench_ext[fz]"), sent.tip_wrench_ext[5]);
    EXPECT_EQ(row.at("contact"), sent.contact ? "1" : "0");
    EXPECT_EQ(row.at("collision"), sent.collision ? "1" : "0");
    EXPECT_EQ(number(row, "reflexes"), sent.reflexes);
    EXPECT_EQ(number(row, "ik_residual"), sent.ik_residual);
    EXPECT_EQ(row.at("ik_converged"), sent.ik_converged ? "1" : "0");
    EXPECT_EQ(number(row, "jitter_max_us"), sent.jitter_max_us);
    EXPECT_EQ(number(row, "compute_p99_us"), sent.compute_p99_us);
    EXPECT_EQ(number(row, "latency_p50_us"), sent.latency_p50_us);
    EXPECT_EQ(row.at("ticks"), std::to_string(sent.ticks));
    EXPECT_EQ(row.at("overruns"), std::to_string(sent.overruns));
    EXPECT_EQ(row.at("stale_states"), std::to_string(sent.stale_states));
    EXPECT_EQ(row.at("rejected_messages"), std::to_string(sent.rejected_messages));
    EXPECT_EQ(row.at("faults"), std::to_string(sent.faults));
  }
  std::remove(csv.c_str());

  // Targets: HOLD and CARTESIAN carry no joints, JOINT seven; the columns are the widest and the
  // cells a message does not have are empty.
  r = chasles(concat({"log", "export", recording.path, "--channel", "CHASLES_TARGET", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  records = csv_records(csv);
  ASSERT_EQ(records.size(), size_t(kTargets));
  for (int k = 0; k < kTargets; ++k) {
    const arm_target_t sent = target_message(k);
    const auto& row = records[size_t(k)];
    EXPECT_EQ(row.at("mode"), std::to_string(int{sent.mode}));
    EXPECT_EQ(number(row, "duration"), sent.duration);
    EXPECT_EQ(number(row, "tip_position[y]"), sent.tip_position[1]);
    for (int j = 0; j < 7; ++j) {
      const std::string cell = row.at("joint_position[" + kPandaJoints[size_t(j)] + "]");
      if (sent.num_joints == 0) {
        EXPECT_EQ(cell, "");
      } else {
        EXPECT_EQ(std::strtod(cell.c_str(), nullptr), sent.joint_position[size_t(j)]);
      }
    }
  }
  std::remove(csv.c_str());

  // To standard output, the CSV is the whole output.
  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_TARGET", "--out", "-"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_csv(r.out).size(), size_t(kTargets + 1));
}

// The control laws, payloads and the simulator's truth a run records export too, every field as
// sent: a Cartesian impedance with a posture, a joint impedance, a payload, two truths.
TEST(log, ExportGivesBackModesPayloadsAndTruths) {
  Recording recording("modes.lcmlog");
  control_mode_t cartesian{};
  cartesian.utime = 11;
  cartesian.law = control_mode_t::CARTESIAN_IMPEDANCE;
  cartesian.damping_ratio = 0.8;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) cartesian.cartesian_stiffness[r][c] = r == c ? 100.0 * (r + 1) : 0.5 * (r + c);
  }
  cartesian.stiffness_frame_position[2] = 0.1;
  cartesian.stiffness_frame_quaternion[0] = 1.0;
  cartesian.num_posture = 7;
  for (int i = 0; i < 7; ++i) cartesian.nullspace_posture.push_back(0.1 * i - 0.3);
  cartesian.nullspace_stiffness = 12.5;
  control_mode_t joint{};
  joint.utime = 12;
  joint.law = control_mode_t::JOINT_IMPEDANCE;
  joint.num_joints = 7;
  for (int i = 0; i < 7; ++i) joint.joint_stiffness.push_back(100.0 + i), joint.joint_damping.push_back(0.25 * i);
  joint.damping_ratio = 1.0;
  joint.stiffness_frame_quaternion[0] = 1.0;
  payload_t payload{};
  payload.utime = 13;
  payload.mass = 1.5;
  payload.centre_of_mass[0] = 0.01, payload.centre_of_mass[2] = 0.05;
  payload.inertia[0][0] = 0.002, payload.inertia[1][1] = 0.003, payload.inertia[2][2] = 0.004;
  recording.send("CHASLES_MODE", cartesian);
  recording.send("CHASLES_MODE", joint);
  recording.send("CHASLES_PAYLOAD", payload);
  for (int k = 0; k < 2; ++k) {
    sim_truth_t truth{};
    truth.utime = 20 + k;
    truth.seq = k;
    truth.num_joints = 7;
    for (int i = 0; i < 7; ++i) truth.tau_ext.push_back(0.5 * i + k);
    for (int i = 0; i < 6; ++i) truth.tip_wrench_ext[i] = i - 2.5 * k;
    truth.contact = k == 1;
    recording.send("CHASLES_TRUTH", truth);
  }
  recording.finish();

  const std::string csv = temp_path("modes.csv");
  RunResult r = chasles(concat({"log", "export", recording.path, "--channel", "CHASLES_MODE", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "chasles.control_mode_t");
  auto records = csv_records(csv);
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].at("law"), "2");
  EXPECT_EQ(number(records[0], "damping_ratio"), 0.8);
  for (int r6 = 0; r6 < 6; ++r6) {
    for (int c = 0; c < 6; ++c) {
      const std::string name = "cartesian_stiffness[" + std::to_string(r6) + "][" + std::to_string(c) + "]";
      EXPECT_EQ(number(records[0], name), cartesian.cartesian_stiffness[r6][c]) << name;
    }
  }
  EXPECT_EQ(number(records[0], "stiffness_frame_position[z]"), 0.1);
  EXPECT_EQ(number(records[0], "stiffness_frame_quaternion[w]"), 1.0);
  EXPECT_EQ(records[0].at("num_posture"), "7");
  EXPECT_EQ(number(records[0], "nullspace_stiffness"), 12.5);
  EXPECT_EQ(records[0].at("joint_stiffness[" + kPandaJoints[0] + "]"), "");  // a Cartesian law has none
  EXPECT_EQ(records[1].at("law"), "1");
  for (int j = 0; j < 7; ++j) {
    const std::string& name = kPandaJoints[size_t(j)];
    EXPECT_EQ(number(records[0], "nullspace_posture[" + name + "]"), cartesian.nullspace_posture[size_t(j)]);
    EXPECT_EQ(number(records[1], "joint_stiffness[" + name + "]"), joint.joint_stiffness[size_t(j)]);
    EXPECT_EQ(number(records[1], "joint_damping[" + name + "]"), joint.joint_damping[size_t(j)]);
  }
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_PAYLOAD", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "chasles.payload_t");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(number(records[0], "mass"), 1.5);
  EXPECT_EQ(number(records[0], "centre_of_mass[x]"), 0.01);
  EXPECT_EQ(number(records[0], "centre_of_mass[z]"), 0.05);
  EXPECT_EQ(number(records[0], "inertia[y][y]"), 0.003);
  EXPECT_EQ(number(records[0], "inertia[x][z]"), 0.0);
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "CHASLES_TRUTH", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "chasles.sim_truth_t");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(records[size_t(k)].at("seq"), std::to_string(k));
    EXPECT_EQ(number(records[size_t(k)], "tau_ext[j6]"), 0.5 * 6 + k);
    EXPECT_EQ(number(records[size_t(k)], "tip_wrench_ext[fz]"), 5 - 2.5 * k);
    EXPECT_EQ(records[size_t(k)].at("contact"), k == 1 ? "1" : "0");
  }
  std::remove(csv.c_str());
}

// An arm driven over Drake's protocols logs its driver's messages: each exports field for field,
// in the .lcm contract's order, with the joints named from the URDF.
TEST(log, ExportGivesBackDrakesIiwaAndPandaMessages) {
  Recording recording("drake.lcmlog");
  drake::lcmt_iiwa_status status{};
  status.utime = 5000;
  status.num_joints = 7;
  std::vector<double>* fields[] = {&status.joint_position_measured, &status.joint_velocity_estimated,
                                         &status.joint_position_commanded, &status.joint_position_ipo,
                                         &status.joint_torque_measured, &status.joint_torque_commanded,
                                         &status.joint_torque_external};
  for (size_t f = 0; f < 7; ++f) {
    for (int i = 0; i < 7; ++i) fields[f]->push_back(10.0 * double(f) + 0.25 * i);
  }
  drake::lcmt_iiwa_command command{};
  command.utime = 5000;
  command.num_joints = 0;
  command.num_torques = 7;
  for (int i = 0; i < 7; ++i) command.joint_torque.push_back(-1.5 * i);
  drake::lcmt_panda_command panda_command{};
  panda_command.utime = 7000;
  panda_command.num_joint_torque = 7;
  for (int i = 0; i < 7; ++i) panda_command.joint_torque.push_back(0.5 * i);
  panda_command.control_mode_expected = drake::lcmt_panda_status::CONTROL_MODE_TORQUE;
  recording.send("IIWA_STATUS", status);
  recording.send("IIWA_COMMAND", command);
  recording.send("PANDA_COMMAND", panda_command);
  recording.finish();

  const std::string csv = temp_path("drake.csv");
  RunResult r = chasles(concat({"log", "export", recording.path, "--channel", "IIWA_STATUS", "--out", csv}, panda()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "drake.lcmt_iiwa_status");
  auto records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].at("utime"), "5000");
  const char* names[] = {"joint_position_measured", "joint_velocity_estimated", "joint_position_commanded",
                         "joint_position_ipo", "joint_torque_measured", "joint_torque_commanded",
                         "joint_torque_external"};
  for (size_t f = 0; f < 7; ++f) {
    for (int i = 0; i < 7; ++i) {
      const std::string column = std::string(names[f]) + "[" + kPandaJoints[size_t(i)] + "]";
      EXPECT_EQ(number(records[0], column), 10.0 * double(f) + 0.25 * i) << column;
    }
  }
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "IIWA_COMMAND", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "drake.lcmt_iiwa_command");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].at("num_joints"), "0");
  EXPECT_EQ(records[0].at("num_torques"), "7");
  EXPECT_EQ(records[0].at("joint_position[j0]"), "");  // torque-only: no positions
  EXPECT_EQ(number(records[0], "joint_torque[j6]"), -9.0);
  std::remove(csv.c_str());

  r = chasles({"log", "export", recording.path, "--channel", "PANDA_COMMAND", "--out", csv});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["type"], "drake.lcmt_panda_command");
  records = csv_records(csv);
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].at("num_joint_torque"), "7");
  EXPECT_EQ(number(records[0], "joint_torque[j3]"), 1.5);
  EXPECT_EQ(records[0].at("control_mode_expected"), "4");
  std::remove(csv.c_str());
}

TEST(log, ExportRefusesWhatItCannotDo) {
  Recording recording("refusals.lcmlog");
  for (int k = 0; k < 3; ++k) recording.send("CHASLES_STATE", state_message(k));
  recording.send_bytes("OTHER", {1, 2, 3, 4, 5, 6, 7, 8, 9});
  recording.finish();
  const std::string csv = temp_path("refused.csv");
  const auto refused = [&](const std::vector<std::string>& args, const std::string& needle) {
    const RunResult r = chasles(args);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
    EXPECT_FALSE(std::ifstream(csv).good()) << "a refused export wrote " << csv;
  };
  refused({"log", "export", recording.path, "--channel", "CHASLES_STATUS", "--out", csv},
          "no messages on CHASLES_STATUS (channels in the log: CHASLES_STATE 3, OTHER 1, WARMUP");
  refused({"log", "export", recording.path, "--channel", "OTHER", "--out", csv}, "are not of a type chasles reads");
  refused(concat({"log", "export", recording.path, "--channel", "CHASLES_STATE", "--out", csv},
                 {"--urdf", data_path("ur5.urdf"), "--tip", "tool0"}),
          "carry 7 joints; the URDF's chain has 6");
  refused({"log", "export", temp_path("no_such.lcmlog"), "--channel", "CHASLES_STATE", "--out", csv},
          "cannot open the log");
  const TempFile empty("empty.lcmlog", "");
  refused({"log", "export", empty.path, "--channel", "CHASLES_STATE", "--out", csv},
          "no messages on CHASLES_STATE (channels in the log: none)");
  const RunResult usage = chasles({"log", "export", recording.path, "--out", csv});
  EXPECT_EQ(usage.exit_code, 2);
  EXPECT_NE(usage.err.find("--channel is required"), std::string::npos) << usage.err;
  EXPECT_NE(usage.err.find("chasles log export --help"), std::string::npos) << usage.err;
}

// What export makes of a damaged copy of a log: exit status, stderr, and the seq of every row.
struct DamagedExport {
  RunResult result;
  std::vector<int64_t> seqs;
};

DamagedExport export_damaged(const std::string& bytes, const std::string& name) {
  const TempFile log(name, bytes);
  const std::string csv = temp_path(name + ".csv");
  DamagedExport out;
  out.result = chasles({"log", "export", log.path, "--channel", "CHASLES_STATE", "--out", csv});
  for (const auto& row : csv_records(csv)) out.seqs.push_back(std::stoll(row.at("seq")));
  std::remove(csv.c_str());
  return out;
}

std::vector<int64_t> iota(int64_t from, int64_t to) {
  std::vector<int64_t> v;
  for (int64_t k = from; k < to; ++k) v.push_back(k);
  return v;
}

void expect_error(const RunResult& r, const std::string& needle) {
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
}

TEST(log, DamagedLogsExportWhatIsReadableAndNameTheByte) {
  Recording recording("damaged.lcmlog");
  constexpr int kStates = 40;
  for (int k = 0; k < kStates; ++k) recording.send("CHASLES_STATE", state_message(k));
  const std::string log = recording.finish();
  std::vector<RawEvent> states;
  for (const RawEvent& e : raw_events(log)) {
    if (e.channel == "CHASLES_STATE") states.push_back(e);
  }
  ASSERT_EQ(states.size(), size_t(kStates));
  ASSERT_EQ(states.back().offset + states.back().size, log.size()) << "the state messages should end the log";

  // Cut in the middle of state 30's message: states 0..29 come out, the error names where 30 starts.
  const RawEvent& s30 = states[30];
  DamagedExport d = export_damaged(log.substr(0, s30.offset + s30.size / 2), "cut_data");
  expect_error(d.result, "byte " + std::to_string(s30.offset) + ": event #");
  expect_error(d.result, "is cut short: it needs " + std::to_string(s30.size) + " bytes and the file ends " +
                             std::to_string(s30.size / 2) + " bytes after its start");
  expect_error(d.result, "exported the 30 readable messages on CHASLES_STATE");
  EXPECT_EQ(d.seqs, iota(0, 30));

  // Cut inside an event header.
  d = export_damaged(log.substr(0, s30.offset + 10), "cut_header");
  expect_error(d.result, "byte " + std::to_string(s30.offset) + ": the last 10 bytes are too few for an event header");
  EXPECT_EQ(d.seqs, iota(0, 30));

  // State 12's sync word overwritten: it is lost, the reader finds state 13 and goes on.
  std::string damaged = log;
  damaged[states[12].offset + 1] = 'X';
  d = export_damaged(damaged, "bad_sync");
  expect_error(d.result, "byte " + std::to_string(states[12].offset) + ": no event starts here (0xED58DA01 where");
  expect_error(d.result, "skipped " + std::to_string(states[12].size) + " bytes to the next event, at byte " +
                             std::to_string(states[13].offset));
  std::vector<int64_t> expected = iota(0, 12), rest = iota(13, kStates);
  expected.insert(expected.end(), rest.begin(), rest.end());
  EXPECT_EQ(d.seqs, expected);

  // A forged data length of 2 GB in state 20's header: too long for the file; state 21 is found.
  damaged = log;
  for (int i = 0; i < 4; ++i) damaged[states[20].offset + 24 + size_t(i)] = "\x7f\xff\xff\xf0"[i];
  d = export_damaged(damaged, "forged_length");
  expect_error(d.result, "byte " + std::to_string(states[20].offset) + ": event #");
  expect_error(d.result, "is cut short: it needs 2147483");
  expected = iota(0, 20);
  rest = iota(21, kStates);
  expected.insert(expected.end(), rest.begin(), rest.end());
  EXPECT_EQ(d.seqs, expected);

  // Well framed, but state 5's num_joints says -3 and state 6's 1000: skipped, each named.
  damaged = log;
  const auto set_count = [&](const RawEvent& e, uint32_t count) {
    const size_t at = e.offset + 28 + e.channel.size() + 8 + 8 + 8;  // fingerprint, utime, seq
    for (int i = 0; i < 4; ++i) damaged[at + size_t(i)] = char((count >> (24 - 8 * i)) & 0xff);
  };
  set_count(states[5], uint32_t(-3));
  set_count(states[6], 1000);
  d = export_damaged(damaged, "bad_counts");
  expect_error(d.result, "byte " + std::to_string(states[5].offset) + ": event #");
  expect_error(d.result, "is a message num_joints -3 in a message of 196 bytes; skipped");
  expect_error(d.result, "byte " + std::to_string(states[6].offset) + ": event #");
  expect_error(d.result, "num_joints 1000");
  EXPECT_EQ(d.seqs.size(), size_t(kStates - 2));

  // Random damage, seeded: never a crash or a hang, always exit 0 or 1, never more rows than sent.
  std::mt19937 rng(20240611);
  for (int trial = 0; trial < 60; ++trial) {
    damaged = log;
    const int flips = 1 + int(rng() % 8);
    for (int f = 0; f < flips; ++f) damaged[rng() % damaged.size()] = char(rng() & 0xff);
    if (trial % 3 == 0) damaged.resize(rng() % damaged.size());
    d = export_damaged(damaged, "random_" + std::to_string(trial));
    EXPECT_TRUE(d.result.exit_code == 0 || d.result.exit_code == 1) << "trial " << trial << ": " << d.result.err;
    EXPECT_LE(d.seqs.size(), size_t(kStates)) << "trial " << trial;
    if (d.result.exit_code == 1) {
      EXPECT_NE(d.result.err.find("byte "), std::string::npos) << d.result.err;
    }
  }
}

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
