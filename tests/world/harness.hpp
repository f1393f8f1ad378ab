// The real-process harness: the test's seat on an arm's bus over UDP multicast, for the tests that
// run chasles_plant and chasles_controller as processes (the two-host test). A background thread
// records every command (decoded, with the state it answers as the test heard it), every status
// report and the latest state, for checks.hpp to judge.
#pragma once

#include <lcm/lcm.h>

#include <Eigen/Core>
#include <atomic>
#include <chasles/arm_target_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/model/model.hpp"
#include "checks.hpp"
#include "support/arm.hpp"

namespace chasles::faults {

class Seat {
 public:
  /// Joins `url` and listens to PREFIX STATE, COMMAND and STATUS.
  explicit Seat(const std::string& url, const std::string& prefix = "CHASLES_");
  ~Seat();
  Seat(const Seat&) = delete;
  Seat& operator=(const Seat&) = delete;

  /// Polls `done` (under the bus's lock) until it holds or `seconds` pass; whether it held.
  bool until(const std::function<bool(const Seat&)>& done, double seconds) const;
  void listen(double seconds) const;
  bool status_is(int8_t mode) const;  ///< call from until() (the lock is held) or after
  /// Waits for a status in `mode`.
  bool wait_for(int8_t mode, double seconds) const;

  /// Publishes raw bytes or a message on PREFIX + channel (e.g. "TARGET"). Commands sent this
  /// way are remembered, so check_commands() judges only the controller's.
  void publish(const std::string& channel, const std::vector<uint8_t>& bytes);
  template <typename Message>
  void publish(const std::string& channel, const Message& message) {
    std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
    message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    publish(channel, bytes);
  }
  void publish_command(const joint_torque_command_t& command);

  // Copies, taken under the lock.
  std::vector<HeardCommand> commands() const;
  std::vector<HeardStatus> statuses() const;
  std::optional<controller_status_t> status() const;
  std::optional<robot_state_t> state() const;
  int64_t state_count() const;
  /// Forgets the commands heard so far (e.g. to see whether any come after a point).
  void clear_commands();

  // Read inside until() only (the lock is held there).
  const std::optional<controller_status_t>& status_locked() const { return status_; }
  const std::optional<robot_state_t>& state_locked() const { return state_; }
  size_t commands_locked() const { return commands_.size(); }

 private:
  static void on_state(const lcm_recv_buf_t* rbuf, const char*, void* self);
  static void on_command(const lcm_recv_buf_t* rbuf, const char*, void* self);
  static void on_status(const lcm_recv_buf_t* rbuf, const char*, void* self);

  std::string prefix_;
  lcm_t* rx_;
  lcm_t* tx_;
  mutable std::mutex mutex_;
  std::atomic<bool> done_{false};
  int64_t index_ = 0;
  struct Heard {
    int64_t seq = -1, arrival_ns = 0;
    Eigen::VectorXd q;
  };
  std::vector<Heard> positions_;  // the states heard, a ring by seq
  std::optional<robot_state_t> state_;
  int64_t state_count_ = 0;
  std::optional<controller_status_t> status_;
  std::vector<HeardStatus> statuses_;
  std::vector<HeardCommand> commands_;
  std::set<std::pair<int64_t, int64_t>> own_commands_;  // (seq, utime) of commands the test sent
  std::thread thread_;
};

}  // namespace chasles::faults
