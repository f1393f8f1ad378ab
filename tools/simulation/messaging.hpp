// The plant's side of the wire: commands in, states out, through the injected faults, and the
// truth out beside them, untouched by the faults. Every class preallocates every buffer on
// construction; receiving a valid command, encoding and publishing allocate nothing afterwards (a
// refusal builds its reason). Commands and states are in one of the protocols the controller
// speaks (controller/transport/protocol.hpp): chasles's own, or Drake's iiwa or Panda driver's, with
// the signs and control modes of the conventions table (controller/transport/conventions.hpp) that
// the controller's side decodes by.
#pragma once

#include <Eigen/Core>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <cstdint>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/lie/types.hpp"
#include "core/simulation/physics.hpp"

namespace chasles::plant {

using controller::Bus;
using controller::Clock;
using controller::conventions;
using controller::factor;
using controller::Protocol;
using controller::ProtocolConventions;

/// The utime of every state the plant sends: the plant's clock at its first state plus seq periods,
/// µs. Drake's commands carry no seq, only the utime of the status they answer (what chasles's
/// CommandWriter and drake-franka-driver's clients send): this gives the seq back.
class StateTimes {
 public:
  /// `latest_seq`: the plant's newest state, read on the caller's thread.
  StateTimes(double dt, const int64_t* latest_seq) : dt_(dt), latest_seq_(latest_seq) {}
  void start(int64_t start_utime) { start_utime_ = start_utime; }
  int64_t utime(int64_t seq) const;
  /// The seq of the state sent stamped exactly `utime` (up to the newest); −1 when none was.
  int64_t seq(int64_t utime) const;

 private:
  double dt_;
  const int64_t* latest_seq_;
  int64_t start_utime_ = 0;
};

/// The latest command as the plant applies it, whichever protocol brought it.
struct Command {
  int64_t state_seq = -1;       ///< the state it answers (Drake's: the state stamped with its utime)
  Eigen::VectorXd torque;       ///< N·m or N, one per joint, as received (before any gravity the driver adds)
  Eigen::VectorXd position;     ///< rad or m: the positions it carried (Drake's), when has_position
  bool has_position = false;
  explicit Command(int n = 0) : torque(Eigen::VectorXd::Zero(n)), position(Eigen::VectorXd::Zero(n)) {}
  /// Exchanges the contents, buffers and all: allocates nothing.
  void swap(Command& other) {
    std::swap(state_seq, other.state_seq);
    torque.swap(other.torque);
    position.swap(other.position);
    std::swap(has_position, other.has_position);
  }
};

/// Keeps the latest valid command for an n-joint arm: a joint_torque_command_t (chasles), a
/// lcmt_iiwa_command or a lcmt_panda_command. Every message passes its checked decoder
/// (lcmtypes/checked.hpp: fingerprint, counts, exact size, encoding, finite numbers) and what the
/// driver's torque mode needs (iiwa: num_torques = n; Panda: num_joint_torque = n and
/// CONTROL_MODE_TORQUE in control_mode_expected), and one that fails is counted and reported on
/// stderr (at most once a second), never kept. Fed by whoever subscribes it to the command channel.
class CommandInbox {
 public:
  /// `clock` stamps each command's arrival. Drake's protocols need `times` (kept by reference) to
  /// tell which state a command answers.
  CommandInbox(const Clock& clock, const std::string& channel, int num_joints, Protocol protocol = Protocol::kChasles,
               const StateTimes* times = nullptr);
  CommandInbox(const CommandInbox&) = delete;
  CommandInbox& operator=(const CommandInbox&) = delete;

  bool any() const { return received_ > 0; }
  /// A valid command arrived since the last take().
  bool fresh() const { return fresh_; }
  /// The latest valid command; clears fresh().
  const Command& take() {
    fresh_ = false;
    return latest_;
  }
  const Command& latest() const { return latest_; }
  /// The clock's time when the latest valid command arrived, ns.
  int64_t latest_arrival_ns() const { return arrival_ns_; }
  int64_t rejected() const { return rejected_; }
  /// Valid commands refused because they answer a state too old (or one never sent; for Drake's, a
  /// utime no state sent carries).
  int64_t stale() const { return stale_; }

  /// From now on, keep only commands whose state_seq is within `max_lag` of *latest_seq (the
  /// plant's newest state, read on this thread) and not beyond it: a command computed from an old
  /// state — a controller whose input froze, a log replayed onto the live bus — is no command.
  void require_recent(const int64_t* latest_seq, int64_t max_lag) {
    latest_seq_ = latest_seq;
    max_lag_ = max_lag;
  }

  /// Writes one stderr line about the rejections since the last report, at most once a second.
  void report_rejections(int64_t now_ns);

  /// Checks one message and keeps it if valid.
  void receive(const void* data, size_t size);

 private:
  void reject(const std::string& why);
  /// Decodes into incoming_; an empty string or why the message is refused.
  std::string decode(const void* data, size_t size);

  const Clock& clock_;
  std::string channel_;
  int num_joints_;
  Protocol protocol_;
  const StateTimes* times_;
  joint_torque_command_t chasles_;
  drake::lcmt_iiwa_command iiwa_;
  drake::lcmt_panda_command panda_;
  Command latest_, incoming_;
  bool fresh_ = false;
  int64_t arrival_ns_ = 0;
  int64_t received_ = 0;
  int64_t rejected_ = 0;
  int64_t stale_ = 0;
  const int64_t* latest_seq_ = nullptr;
  int64_t max_lag_ = 0;
  int64_t unreported_ = 0;
  int64_t last_report_ns_ = 0;
  char reason_[160] = {};
};

/// Gaussian noise on the effort a state reports — robot_state_t's effort, the iiwa's
/// joint_torque_measured, the Panda's joint_torque (tau_J) — as a joint torque sensor's: an
/// independent draw per joint for every state produced, from a generator of its own (Box–Muller on
/// std::mt19937_64's bits, the same sequence on every platform; std::normal_distribution's is not).
/// On the report only: the torque the dynamics get, the commanded torques Drake's statuses also
/// carry and the truth are exact.
struct EffortNoise {
  double sigma = 0.0;  ///< standard deviation, N·m or N; ≥ 0 (0: none)
  uint64_t seed = 0;
};

/// Throws chasles::ArgumentError "<what>: ..." when sigma is negative or not finite.
void check_effort_noise(const EffortNoise& noise, const std::string& what);

/// Pauses of a simulator paced by a busy process (Drake's, in Python): every `every_s` of simulated
/// time the simulation stops — no step, no state, its clock standing — for a time drawn uniformly
/// from [min_ms, max_ms], then goes on where it stopped.
struct Stalls {
  double min_ms = 0.0, max_ms = 0.0, every_s = 0.0;
  uint64_t seed = 0;
  bool any() const { return every_s > 0.0 && max_ms > 0.0; }
};

/// Seeded fault injection on outgoing states.
struct Faults {
  double drop = 0.0;      ///< probability that a state message is not sent
  double delay_ms = 0.0;  ///< every state message is sent this long after it is produced
  double noise = 0.0;     ///< standard deviation of gaussian noise added to the sent position, rad or m
  /// Delay spikes: every spike_every-th state opens a spike of spike_ms, during which every state
  /// is held back and all are sent together, in order, when it ends (a stalled link or driver).
  double spike_ms = 0.0;
  int64_t spike_every = 0;
  bool spikes() const { return spike_ms > 0.0 && spike_every > 0; }
  uint64_t seed = 0;  ///< of the drops and the position noise
  EffortNoise effort_noise;
};

/// What a Drake driver reports beside the measured state, for one status (see docs/protocols.md,
/// "The plant speaks them too", for each field).
struct DriverReport {
  const Eigen::VectorXd& qd;      ///< the plant's exact velocity (no driver filter)
  /// The joint torque applied over the last step (limits applied), g included; reported with the
  /// effort noise.
  const Eigen::VectorXd& effort;
  /// What the driver handed the joints, before the limits: the command (+ g under overlay), or the brake.
  const Eigen::VectorXd& torque_commanded;
  const Eigen::VectorXd& torque_desired;      ///< the command as received, without the driver's gravity
  const Eigen::VectorXd& position_commanded;  ///< the command's positions, or the measured q
  const Eigen::VectorXd& tau_ext;             ///< the external joint torque, chasles's (and Drake's) sign
  bool commanding = false;                    ///< the last step applied a command (not the brake, not the start)
  double success_rate = 0.0;                  ///< Panda: steps with a fresh command among the last 100
  int8_t robot_mode = 0;                      ///< Panda: lcmt_panda_status::kIdle, kMove or kReflex
  int8_t control_mode = 0;                    ///< Panda: CONTROL_MODE_TORQUE once commanded, else 0
  int64_t robot_utime = 0;                    ///< Panda: the robot's own clock, µs since the plant started
};

/// Encodes the protocol's status into a preallocated buffer and publishes it, dropped, delayed and
/// noisy (position and effort) as `faults` asks.
class StatePublisher {
 public:
  /// `max_in_flight`: how many delayed messages can wait at once; one more is dropped.
  StatePublisher(Bus& bus, std::string channel, int num_joints, const Faults& faults, int max_in_flight,
                 Protocol protocol = Protocol::kChasles);

  /// Encodes a robot_state_t (chasles's protocol); the position and the effort get the sensor
  /// noise here, so a state sent again is the same message.
  void encode(int64_t utime, int64_t seq, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
              const Eigen::VectorXd& effort);
  /// Encodes the protocol's status (any protocol: chasles's takes utime, seq, q, qd and effort);
  /// the measured position and torque get the sensor noise.
  void encode(int64_t utime, int64_t seq, const Eigen::VectorXd& q, const DriverReport& report);
  /// Sends the last encoded state: dropped with probability faults.drop, else now or after the delay.
  void send(int64_t now_ns);
  /// Publishes the delayed states that are due; returns when the next one is due (INT64_MAX: none).
  int64_t flush(int64_t now_ns);
  /// States not delivered: dropped on purpose, lost to a full delay queue or a failed send.
  int64_t dropped() const { return dropped_; }

 private:
  struct Delayed {
    int64_t due_ns = 0;
    std::vector<uint8_t> bytes;
  };
  void publish(const std::vector<uint8_t>& bytes);
  double noisy(double q);
  /// The effort as the sensor reports it: `effort` plus this state's draw of the effort noise.
  const Eigen::VectorXd& measured(const Eigen::VectorXd& effort);
  void encode_iiwa(int64_t utime, const Eigen::VectorXd& q, const DriverReport& report);
  void encode_panda(int64_t utime, const Eigen::VectorXd& q, const DriverReport& report);

  Bus& bus_;
  std::string channel_;
  Faults faults_;
  Protocol protocol_;
  robot_state_t message_;
  drake::lcmt_iiwa_status iiwa_;
  drake::lcmt_panda_status panda_;
  std::vector<uint8_t> bytes_;
  std::vector<Delayed> queue_;  // a ring: head_ is the oldest, size_ entries
  size_t head_ = 0, size_ = 0;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  std::normal_distribution<double> gaussian_{0.0, 1.0};
  std::mt19937_64 effort_rng_;
  Eigen::VectorXd measured_effort_;
  int64_t dropped_ = 0;
  int64_t sends_ = 0;          // states handed to send(), for the spikes
  int64_t spike_end_ns_ = 0;   // the current spike holds states until then
};

/// Encodes sim_truth_t into a preallocated buffer and publishes it at once: no drop, delay or noise
/// (the truth is what happened, not what the sensors said).
class TruthPublisher {
 public:
  TruthPublisher(Bus& bus, std::string channel, int num_joints);

  /// Encodes and sends one truth, its contacts with it (at most sim_truth_t::MAX_CONTACTS, those
  /// with the largest forces); a send that fails is counted (not_sent()). Allocates nothing while
  /// the names fit the room kept for them (kNameRoom bytes).
  void publish(int64_t utime, int64_t seq, const Truth& truth);
  int64_t not_sent() const { return not_sent_; }

  static constexpr size_t kNameRoom = 64;

 private:
  Bus& bus_;
  std::string channel_;
  sim_truth_t message_;
  std::vector<uint8_t> bytes_;
  std::vector<int> order_;  // the contacts sent, by force
  int64_t not_sent_ = 0;
};

}  // namespace chasles::plant
