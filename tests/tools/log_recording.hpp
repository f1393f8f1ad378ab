// What both log test files do: record messages sent over LCM with the real lcm-logger (Recording),
// frame the log's events independently of the code under test, run `chasles`, and the seeded
// messages they send. log_test.cpp checks `chasles log export` against what was sent and on damaged
// copies; log_plot_test.cpp checks `chasles log plot`. In a namespace of their own, which each file
// brings into its anonymous namespace: panda() here is the command line's --urdf and --tip, not
// support/arm.hpp's model, and the two must not meet at link time.
#pragma once

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

namespace chasles::testing::log_recording {

inline constexpr char kTip[] = "panda_hand";
inline const std::vector<std::string> kPandaJoints = {"panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4",
                                               "panda_joint5", "panda_joint6", "panda_joint7"};

// A big-endian event of the LCM log format, parsed here independently of the code under test.
struct RawEvent {
  uint64_t offset;
  std::string channel;
  uint64_t size;  ///< header + channel + data
};

inline uint64_t be(const std::string& bytes, size_t at, int count) {
  uint64_t value = 0;
  for (int i = 0; i < count; ++i) value = (value << 8) | uint8_t(bytes[at + size_t(i)]);
  return value;
}

inline std::vector<RawEvent> raw_events(const std::string& log) {
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

inline RunResult chasles(const std::vector<std::string>& args) {
  return run_to_completion(concat({CHASLES_CLI}, args));
}

// Seeded, distinct values (no two alike), so a swapped column or row cannot pass.
inline robot_state_t state_message(int k) {
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

inline controller_status_t status_message(int k) {
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

inline arm_target_t target_message(int k) {
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

inline std::vector<std::string> panda() { return {"--urdf", data_path("panda.urdf"), "--tip", kTip}; }

inline void expect_error(const RunResult& r, const std::string& needle) {
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(r.err.rfind("chasles: ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
}

}  // namespace chasles::testing::log_recording
