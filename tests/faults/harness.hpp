// The fault harness: the test's seat on an arm's bus. A background thread records every command
// (decoded, with the state it answers as the test heard it), every status report and the latest
// state; check_commands() then judges the command stream against exactly what the controller's
// safety pipeline promises (controller.cpp): every torque finite and within the URDF effort
// limit, every step within effort / torque_ramp × period of the previous command — or, for the
// first command after WAITING or a FAULT, of g(q) at the state it answers, where the rate limiter
// restarts.
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

#include "chasles/core/model/model.hpp"
#include "support/arm.hpp"

namespace chasles::faults {

/// A command as heard, with what it answers.
struct HeardCommand {
  joint_torque_command_t message;
  int64_t index = 0;  ///< arrival order among everything the bus heard
  std::optional<Eigen::VectorXd> q_answered;  ///< position of the state with seq == state_seq, as last heard
  /// The test heard that state → the test heard this command, µs (−1: state not heard): the
  /// round trip through the controller, as a process beside the plant sees it.
  double round_trip_us = -1.0;
};

struct HeardStatus {
  controller_status_t message;
  int64_t index = 0;
};

class Bus {
 public:
  /// Joins `url` and listens to PREFIX STATE, COMMAND and STATUS.
  explicit Bus(const std::string& url, const std::string& prefix = "CHASLES_");
  ~Bus();
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  /// Polls `done` (under the bus's lock) until it holds or `seconds` pass; whether it held.
  bool until(const std::function<bool(const Bus&)>& done, double seconds) const;
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
  /// The longest wait between two states the test heard, and the longest run of seqs it did not
  /// hear (states the plant dropped, or the test missed): what the state stream itself explains.
  struct StateGaps {
    double max_arrival_gap_ms = 0.0;
    int64_t max_missing_run = 0;
  };
  StateGaps state_gaps() const;
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
  StateGaps gaps_;
  int64_t last_seq_ = -1, last_arrival_ns_ = 0;
  std::optional<controller_status_t> status_;
  std::vector<HeardStatus> statuses_;
  std::vector<HeardCommand> commands_;
  std::set<std::pair<int64_t, int64_t>> own_commands_;  // (seq, utime) of commands the test sent
  std::thread thread_;
};

/// What the command stream showed; every *_violations must be 0.
struct CommandReport {
  int64_t commands = 0;
  int64_t non_finite = 0, effort_violations = 0, rate_violations = 0;
  int64_t restarts_from_gravity = 0;  ///< first commands after WAITING / a FAULT, checked against g(q)
  int64_t seq_gaps = 0;               ///< commands the test did not hear (not judged)
  double max_effort_ratio = 0.0;      ///< max |τ_i| / effort_i
  double max_rate_ratio = 0.0;        ///< max |Δτ_i| / (effort_i / ramp × period), over judged steps
  double spacing_p50_us = 0.0, spacing_p99_us = 0.0;  ///< utime spacing of consecutive commands
  std::string first_violation;
};

/// Judges the controller's commands: `ramp_s` and `period_s` as configured.
CommandReport check_commands(const RobotModel& model, const std::vector<HeardCommand>& commands,
                             const std::vector<HeardStatus>& statuses, double ramp_s, double period_s);

/// What the status stream showed.
struct StatusReport {
  std::string modes;  ///< the sequence of states, repeats collapsed: "WAITING>HOLDING>RUNNING>..."
  int64_t fault_transitions = 0;
  std::vector<std::string> fault_messages;  ///< one per FAULT reported, as first reported
  double jitter_p99_median_us = 0.0;        ///< median over status windows of jitter_p99_us
  double latency_p99_median_us = 0.0;
  double jitter_max_us = 0.0;               ///< the controller's longest wake-up delay, any window
  int64_t ticks = 0, overruns = 0, stale = 0, rejected = 0, faults = 0;
};
StatusReport summarise(const std::vector<HeardStatus>& statuses);

/// Whether the FAULTs counted in `s` are ones a stall explains. Each test injects gaps in the
/// state stream no longer than `injected_ms` (dropped runs, delay spikes, or one period), well
/// under `stale_ms`, so those alone never fault; but a CI machine can stall a process for tens of
/// milliseconds. Explained: the bus itself waited near `stale_ms` for a state (the plant or the
/// network stalled), or the controller woke so late that, added to the injected gap, the state it
/// found was near the limit. Empty when every FAULT is explained (or there is none); else why not.
std::string unexplained_faults(const Bus::StateGaps& gaps, const StatusReport& s, double stale_ms, double injected_ms);

/// One line for the fault table, printed by each test.
std::string table_row(const std::string& fault, const CommandReport& c, const StatusReport& s);

/// The p-quantile of v by rank (0 for none).
double percentile(std::vector<double> v, double p);

/// The arm's model as the tests run it (the Panda to its TCP).
const RobotModel& panda();
using testing::bent_pose;
using testing::joint_target;
using testing::list;
using testing::vector_of;
joint_torque_command_t command_of(int64_t seq, int64_t utime, int64_t state_seq, const Eigen::VectorXd& tau);

}  // namespace chasles::faults
