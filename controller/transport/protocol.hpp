// The protocols the controller speaks with an arm's driver, chosen at start: chasles's own
// (robot_state_t in, joint_torque_command_t out) or Drake's for the KUKA iiwa and the Franka Panda
// (lcmt_iiwa_status / lcmt_iiwa_command, lcmt_panda_status / lcmt_panda_command). A protocol is a
// checked decoder for its status, an encoder for its command and its conventions; inside, the loop
// sees one JointState and emits one torque, and nothing else knows which robot is on the wire: the
// protocols are a seam at the edge. docs/protocols.md is the field-by-field account.
//
// Drake's conventions, which the translations below apply (conventions.hpp holds them as one table,
// which the plant's side of the wire encodes the mirror image of):
//  - Torque semantics. chasles's law computes the whole joint torque τ, gravity included. Drake's
//    iiwa drivers (drake-iiwa-driver on KUKA's FRI, Drake's simulated driver in torque-only mode)
//    add their own gravity compensation g(q) to the torque commanded, and drake-franka-driver's
//    torques exclude gravity (libfranka compensates it): so chasles sends τ − g(q) there
//    (TorqueSemantics::kOverlay, those protocols' default). kFull sends τ as it is: chasles's
//    plant, or a driver told not to compensate (drake-franka-driver --remove_gravity_compensation).
//  - Signs. Drake's convention is chasles's: positive torque, positive acceleration along the
//    joint axis; an external torque is positive when it pushes the joint the positive way. The
//    iiwa's joint_torque_measured and joint_torque_commanded are negated relative to it,
//    joint_torque_external is not; the Panda's joint_torque_external (tau_ext_hat_filtered) is
//    negated, joint_torque (tau_J) is not. Commands are in Drake's convention on both.
//  - No sequence number. Neither status carries one: StatusSequence numbers them in order of
//    arrival and refuses a duplicate or stale one by its utime.
//  - Rate. The iiwa's driver streams every 5 ms (FRI's period), the Panda's every 1 ms.
#pragma once

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <drake/lcmt_iiwa_command.hpp>
#include <drake/lcmt_iiwa_status.hpp>
#include <drake/lcmt_panda_command.hpp>
#include <drake/lcmt_panda_status.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "controller/signals.hpp"
#include "controller/transport/conventions.hpp"

namespace chasles::controller {

/// "chasles", "drake-iiwa", "drake-panda": the names --protocol takes.
const char* to_string(Protocol protocol);
/// The protocol a name gives; false (and `protocol` untouched) for any other text.
bool parse_protocol(std::string_view text, Protocol& protocol);

/// "full", "overlay": the names --torque-semantics takes.
const char* to_string(TorqueSemantics semantics);
bool parse_torque_semantics(std::string_view text, TorqueSemantics& semantics);
/// The semantics the protocol's drivers expect: kFull for chasles, kOverlay for Drake's iiwa and Panda.
TorqueSemantics default_torque_semantics(Protocol protocol);

/// The status and command channels of a protocol: chasles's take the prefix (<prefix>STATE,
/// <prefix>COMMAND); Drake's are its drivers' defaults (IIWA_STATUS / IIWA_COMMAND, PANDA_STATUS /
/// PANDA_COMMAND), which the prefix does not change: override them by name.
struct ProtocolChannels {
  std::string status, command;
};
ProtocolChannels default_channels(Protocol protocol, const std::string& prefix = "CHASLES_");

/// The period the protocol's driver publishes its status at, s: 0.005 for the iiwa (200 Hz, FRI),
/// 0.001 for the Panda (libfranka's 1 kHz); 0 for chasles, whose plant's period the controller
/// learns from the states.
double nominal_status_period(Protocol protocol);

/// The stale limit when none is given, ns: 10 ms, or three periods of a slower stream (the iiwa's
/// 5 ms gives 15 ms), so that one lost status never makes a FAULT at any rate.
int64_t default_stale_ns(double period);

/// What an iiwa command carries in its position fields beside the torques. Which the driver needs
/// depends on how it runs:
///  - kNone (num_joints 0): Drake's torque-only mode (IiwaControlMode::kTorqueOnly, whose
///    simulated driver applies g(q) + the torque) and drake-iiwa-driver --torque_only (which feeds
///    FRI the measured position itself). Drake's default for torque control.
///  - kMeasured (num_joints n, the measured position of the status answered): drake-iiwa-driver's
///    default torque mode, where the torque overlays KUKA's joint impedance about the commanded
///    position, so commanding where the arm is leaves the impedance's spring at rest (its damping
///    stays); Drake's kPositionAndTorque, likewise.
enum class IiwaPositions { kNone, kMeasured };
const char* to_string(IiwaPositions positions);
bool parse_iiwa_positions(std::string_view text, IiwaPositions& positions);

/// Drake's statuses carry no sequence number: this numbers them in order of arrival and judges each
/// by its utime against the last one taken. A later utime is the next state; the same utime again
/// is a duplicate (a driver that republishes a frozen sample must not look alive); an earlier one
/// is stale (reordered, or an old log replayed onto the bus). A sender that restarted its clock (a
/// Drake simulation started again from t = 0) is recognised by kRestartRun stale statuses in a row,
/// each later than the one before, and no state taken between them: the last of them is taken and
/// the numbering starts again from 0, so the controller's observer restarts as for a chasles plant
/// that restarted its count. A replay interleaved with a live driver never makes such a run. A
/// negative utime is no time at all: drake-iiwa-driver stamps −1 until its estimate of the robot's
/// clock has settled (its first 200 statuses, 1 s), and such a status is refused without a verdict
/// on the others.
class StatusSequence {
 public:
  enum class Verdict { kNext, kDuplicate, kStale, kRestart, kUntimed };
  static constexpr int kRestartRun = 3;

  /// Judges a status stamped `utime`; for kNext and kRestart, seq() is the number it was given.
  Verdict judge(int64_t utime);
  /// The number of the last status taken; −1 before any.
  int64_t seq() const { return seq_; }
  /// The utime of the last status taken.
  int64_t last_utime() const { return last_utime_; }

 private:
  bool any_ = false;
  int64_t last_utime_ = 0;
  int64_t seq_ = -1;
  int run_ = 0;  // stale statuses in a row, each later than the one before
  int64_t run_utime_ = 0;
};

// ---- Translations: pure, allocation-free once the outputs are sized ----
// A status must have passed its checked decoder for the arm's n joints (Finite::Required); `state`
// and `tau_ext` must hold n entries. Each fills the controller's state: seq (given: from
// StatusSequence), utime (the status's), arrival_ns (given), q, qd and effort, the joint torque
// measured (gravity included) in chasles's sign; and tau_ext, the external joint torque in
// chasles's sign (positive: the environment pushes the joint the positive way).

/// iiwa: q = joint_position_measured, qd = joint_velocity_estimated (the driver's filtered
/// estimate), effort = −joint_torque_measured, tau_ext = joint_torque_external.
void state_from_iiwa(const drake::lcmt_iiwa_status& status, int64_t seq, int64_t arrival_ns, JointState& state,
                     Eigen::VectorXd& tau_ext);
/// Panda: q = joint_position (q), qd = joint_velocity (dq), effort = joint_torque (tau_J),
/// tau_ext = −joint_torque_external (−tau_ext_hat_filtered).
void state_from_panda(const drake::lcmt_panda_status& status, int64_t seq, int64_t arrival_ns, JointState& state,
                      Eigen::VectorXd& tau_ext);

/// The torque the receiver is to get for the law's whole torque τ: τ under kFull, τ − g under
/// kOverlay. g is the gravity torque the receiver compensates itself: the arm's own g(q) at the
/// state answered, from chasles's model of the bare arm — without a load the driver does not know
/// of (a payload_t's load is chasles's to hold, so it stays in τ − g). Writes n values.
void torque_for_receiver(const Eigen::VectorXd& tau, const Eigen::VectorXd& g, TorqueSemantics semantics,
                         double* out);

/// An iiwa torque command: utime as given (the utime of the status answered keeps the command on
/// the driver's clock), num_torques n with torque_for_receiver(τ, g), and the positions
/// `positions` asks for (q_measured: the measured position of the status answered).
void iiwa_command(int64_t utime, const Eigen::VectorXd& tau, const Eigen::VectorXd& g, TorqueSemantics semantics,
                  IiwaPositions positions, const Eigen::VectorXd& q_measured, drake::lcmt_iiwa_command& command);

/// A Panda torque command, as drake-franka-driver's torque mode requires: no positions, no
/// velocities, n torques (torque_for_receiver(τ, g)), control_mode_expected CONTROL_MODE_TORQUE.
/// utime: the driver drops a command more than 0.1 s (--expire_sec) from its own clock (Unix time,
/// µs), so give the utime of the status answered.
void panda_command(int64_t utime, const Eigen::VectorXd& tau, const Eigen::VectorXd& g, TorqueSemantics semantics,
                   drake::lcmt_panda_command& command);

// ---- The protocol's two ends, for whoever runs the loop ----

/// One protocol's status channel → the controller's JointState: the protocol's checked decoder for
/// the arm (Finite::Required), the sequence by arrival for Drake's, the translation. Decodes into a
/// message sized once: allocates nothing after the first status.
class StatusReader {
 public:
  StatusReader(Protocol protocol, int num_joints);
  StatusReader(const StatusReader&) = delete;
  StatusReader& operator=(const StatusReader&) = delete;

  /// One message that arrived at arrival_ns (the receiving clock's time): an empty string and
  /// `state` (sized n) filled, or why it was refused ("not a lcmt_iiwa_status (wrong
  /// fingerprint)", "a duplicate: utime 5000 again", ...), `state` untouched.
  std::string read(const void* data, size_t size, int64_t arrival_ns, JointState& state);
  /// The external joint torque of the last status read (chasles's sign); zero for chasles's own
  /// protocol, whose state carries none.
  const Eigen::VectorXd& tau_ext() const { return tau_ext_; }
  /// Statuses refused as duplicates, stale or untimed, and sender restarts recognised (Drake's
  /// protocols).
  int64_t duplicates() const { return duplicates_; }
  int64_t untimed() const { return untimed_; }
  int64_t stale() const { return stale_; }
  int64_t restarts() const { return restarts_; }

 private:
  Protocol protocol_;
  int num_joints_;
  robot_state_t chasles_;
  drake::lcmt_iiwa_status iiwa_;
  drake::lcmt_panda_status panda_;
  StatusSequence sequence_;
  Eigen::VectorXd tau_ext_;
  int64_t duplicates_ = 0, stale_ = 0, restarts_ = 0, untimed_ = 0;
};

/// The controller's torque → one protocol's command bytes, into a buffer sized once: allocates
/// nothing per command.
class CommandWriter {
 public:
  CommandWriter(Protocol protocol, int num_joints, TorqueSemantics semantics,
                IiwaPositions iiwa_positions = IiwaPositions::kNone);

  /// Encodes the command for the law's whole torque τ at `state` (the state answered: its utime,
  /// seq and q), g = g(q) at that state (ignored under kFull). chasles's protocol stamps utime and
  /// seq as given; Drake's have no seq and stamp the state's utime, on the driver's clock.
  void write(int64_t utime, int64_t seq, const JointState& state, const Eigen::VectorXd& tau,
             const Eigen::VectorXd& g);
  const std::vector<uint8_t>& bytes() const { return bytes_; }
  TorqueSemantics semantics() const { return semantics_; }

 private:
  Protocol protocol_;
  TorqueSemantics semantics_;
  IiwaPositions iiwa_positions_;
  joint_torque_command_t chasles_;
  drake::lcmt_iiwa_command iiwa_;
  drake::lcmt_panda_command panda_;
  std::vector<uint8_t> bytes_;
};

/// Drake's commands have no seq, so chasles's CommandWatch (lcm_io.hpp), which knows its own
/// commands by seq and utime, cannot tell them from another sender's. This knows them by their
/// bytes: the loop records a digest of each command before sending it; whoever hears the command
/// channel asks whether a message is one of the last kWindow sent and not yet heard — our own
/// multicast comes back once, so a second copy (a replay) and anything else is foreign. Two
/// commands of identical bytes are two records, each heard once. Lock-free: the loop stores, the
/// bus thread compares and exchanges.
class SentDigests {
 public:
  SentDigests();
  /// The loop: the command about to be sent. Allocates nothing.
  void record(const std::vector<uint8_t>& bytes);
  /// Any thread: whether these bytes are a command recorded and not yet taken; takes it.
  bool take(const void* data, size_t size);

  /// About 1 s of the iiwa's commands, 0.25 s of the Panda's: far longer than multicast takes.
  static constexpr size_t kWindow = 256;
  /// FNV-1a over the bytes, never 0 (0 marks an empty slot).
  static uint64_t digest(const void* data, size_t size);

 private:
  std::array<std::atomic<uint64_t>, kWindow> slots_;
  std::atomic<uint64_t> next_{0};
};

/// Listens on a Drake command channel for commands this process did not send, as CommandWatch
/// does on chasles's: true for a foreign message, counted.
class DigestCommandWatch {
 public:
  explicit DigestCommandWatch(SentDigests& sent) : sent_(sent) {}
  bool receive(const void* data, size_t size);
  int64_t foreign() const { return foreign_.load(std::memory_order_acquire); }
  /// The utime of the first foreign command, read from its bytes (both of Drake's commands begin
  /// with it: the status it answers, on the driver's clock); −1 before one, or when it was too
  /// short to hold one. What an operator needs to find the other sender's messages in a log.
  int64_t first_utime() const { return first_utime_.load(std::memory_order_relaxed); }

 private:
  SentDigests& sent_;
  std::atomic<int64_t> foreign_{0};
  std::atomic<int64_t> first_utime_{-1};
};

}  // namespace chasles::controller
