// The controller's side of the wire. Receivers are fed by the Bus on the thread that handles it
// and hand validated values to the real-time thread through mailboxes; the command encoder runs
// on the real-time thread and allocates nothing.
//
// Every received message is untrusted: each goes through the one checked decoder of its type
// (lcmtypes/checked.hpp), which reads the fingerprint and the count from the raw bytes before
// lcm-gen's decoder may trust them, then the exact size, then the values' finiteness.
#pragma once

#include <array>
#include <atomic>
#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/jog_command_t.hpp>
#include <chasles/joint_setpoint_t.hpp>
#include <chasles/tip_setpoint_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <chasles/payload_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "controller/law_settings.hpp"
#include "controller/signals.hpp"
#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/mailbox.hpp"
#include "controller/transport/realtime/realtime.hpp"
#include "controller/transport/wire.hpp"
#include "core/model/model.hpp"
#include "core/model/payload.hpp"
#include "core/motion/waypoints.hpp"

namespace chasles::controller {

/// Channel names: a configurable prefix, so several arms can share one network.
struct Channels {
  std::string state, command, target, status, mode, payload, trajectory, setpoint, tip_setpoint, jog, scene, contact;
  explicit Channels(const std::string& prefix = "CHASLES_")
      : state(prefix + "STATE"),
        command(prefix + "COMMAND"),
        target(prefix + "TARGET"),
        status(prefix + "STATUS"),
        mode(prefix + "MODE"),
        payload(prefix + "PAYLOAD"),
        trajectory(prefix + "TRAJECTORY"),
        setpoint(prefix + "SETPOINT"),
        tip_setpoint(prefix + "TIP_SETPOINT"),
        jog(prefix + "JOG"),
        scene(prefix + "SCENE"),
        contact(prefix + "CONTACT") {}
};

/// Counts rejected messages and keeps the latest reason, for the status report. Lock-free: with
/// state-driven ticks the real-time loop itself handles the bus.
class Rejections {
 public:
  /// The thread that handles the bus: one more message refused, and why (cut to 191 characters).
  void add(const std::string& reason);
  /// Any thread.
  int64_t count() const { return count_.load(std::memory_order_relaxed); }
  /// The reporting thread: the latest reason.
  const char* last();

 private:
  using Reason = std::array<char, 192>;
  std::atomic<int64_t> count_{0};
  Mailbox<Reason> latest_{Reason{}};
  Reason last_{};
};

/// The arm's status in its protocol (robot_state_t, or a Drake status: StatusReader) → validated
/// JointState in `mailbox`.
class StateReceiver {
 public:
  StateReceiver(int num_joints, Mailbox<JointState>& mailbox, Protocol protocol = Protocol::kChasles);
  StateReceiver(const StateReceiver&) = delete;
  StateReceiver& operator=(const StateReceiver&) = delete;

  /// Checks and decodes one message that arrived at arrival_ns (the receiving clock's time);
  /// returns an empty string or why it was refused.
  std::string receive(const void* data, size_t size, int64_t arrival_ns);

 private:
  StatusReader reader_;
  Mailbox<JointState>& mailbox_;
};

/// arm_target_t on `channel` → Target in `queue` (structure checked here; meaning — limits,
/// durations, mode — by Controller::set_target). A queue, not a mailbox: every target is judged
/// and answered, even two sent within one tick.
class TargetReceiver {
 public:
  TargetReceiver(int num_joints, SpscRing<Target>& queue);
  TargetReceiver(const TargetReceiver&) = delete;
  TargetReceiver& operator=(const TargetReceiver&) = delete;

  /// Checks, decodes and queues one message; returns an empty string or why it was refused.
  std::string receive(const void* data, size_t size);

 private:
  int num_joints_;
  arm_target_t message_;
  Target target_;
  SpscRing<Target>& queue_;
};

/// joint_setpoint_t → Setpoint in `queue` (sized, finite; ordered and clamped by
/// Controller::set_setpoint). A queue: every setpoint of a tick is judged, newest by utime wins.
class SetpointReceiver {
 public:
  SetpointReceiver(int num_joints, SpscRing<Setpoint>& queue);
  SetpointReceiver(const SetpointReceiver&) = delete;
  SetpointReceiver& operator=(const SetpointReceiver&) = delete;

  /// Checks, decodes and queues one message; returns an empty string or why it was refused.
  std::string receive(const void* data, size_t size);

 private:
  int num_joints_;
  joint_setpoint_t message_;
  Setpoint setpoint_;
  SpscRing<Setpoint>& queue_;
};

/// tip_setpoint_t → TipSetpoint in `queue` (finite; the quaternion's norm, order and meaning
/// judged by Controller::set_tip_setpoint).
class TipSetpointReceiver {
 public:
  explicit TipSetpointReceiver(SpscRing<TipSetpoint>& queue) : queue_(queue) {}
  TipSetpointReceiver(const TipSetpointReceiver&) = delete;
  TipSetpointReceiver& operator=(const TipSetpointReceiver&) = delete;

  /// Checks, decodes and queues one message; returns an empty string or why it was refused.
  std::string receive(const void* data, size_t size);

 private:
  tip_setpoint_t message_;
  TipSetpoint setpoint_;
  SpscRing<TipSetpoint>& queue_;
};

/// jog_command_t → Jog in `queue` (sized, finite; kind, frame and order judged by
/// Controller::set_jog). A twist may come without joint velocities (num_joints 0).
class JogReceiver {
 public:
  JogReceiver(int num_joints, SpscRing<Jog>& queue);
  JogReceiver(const JogReceiver&) = delete;
  JogReceiver& operator=(const JogReceiver&) = delete;

  /// Checks, decodes and queues one message; returns an empty string or why it was refused.
  std::string receive(const void* data, size_t size);

 private:
  int num_joints_;
  jog_command_t message_;
  Jog jog_;
  SpscRing<Jog>& queue_;
};

/// joint_trajectory_t → Waypoints in `queue`, in the arm's joint order. Structure is checked here
/// (counts, every joint named once, finite values); meaning — times, limits, tolerances — by
/// Controller::set_trajectory. Decoding up to 1000 waypoints may allocate on the receiving thread
/// (lcm-gen's rows); what reaches the loop does not.
class TrajectoryReceiver {
 public:
  TrajectoryReceiver(const RobotModel& model, SpscRing<motion::Waypoints>& queue);
  TrajectoryReceiver(const TrajectoryReceiver&) = delete;
  TrajectoryReceiver& operator=(const TrajectoryReceiver&) = delete;

  /// Checks, decodes and queues one message; returns an empty string or why it was refused.
  std::string receive(const void* data, size_t size);

 private:
  std::vector<std::string> names_;  // the arm's joints, root to tip
  joint_trajectory_t message_;
  motion::Waypoints waypoints_;
  std::vector<int> column_;  // the message's column of each of the arm's joints
  SpscRing<motion::Waypoints>& queue_;
};

/// A decoded control_mode_t (counts already checked against the arm: 0 or n; the law's value by
/// WireTable<Law>, wire.hpp) as LawSettings sized for
/// n joints: an empty string, or why its structure cannot be a law (an unknown law, a quaternion not
/// of unit norm, a joint impedance without stiffness). What the numbers mean — bounds, positive
/// definiteness, limits — is law_problem's, which the controller and `chasles mode` both apply.
std::string law_from_message(const control_mode_t& message, int num_joints, LawSettings& settings);

/// control_mode_t → LawSettings in `queue` (structure checked here, meaning by Controller::set_law).
class ModeReceiver {
 public:
  ModeReceiver(int num_joints, SpscRing<LawSettings>& queue);
  ModeReceiver(const ModeReceiver&) = delete;
  ModeReceiver& operator=(const ModeReceiver&) = delete;
  std::string receive(const void* data, size_t size);

 private:
  int num_joints_;
  control_mode_t message_;
  LawSettings settings_;
  SpscRing<LawSettings>& queue_;
};

/// payload_t → a checked Payload in `mailbox` (the newest wins: each replaces the one before);
/// `bell` is rung for whoever builds the model that carries it.
/// A scene_t's bytes as heard, for the worker to decode: a scene builds hulls, which the bus's
/// handler (the real-time loop's thread) must not. The buffer is sized once for the largest scene
/// taken.
struct SceneBytes {
  static constexpr size_t kMax = size_t(1) << 20;  ///< bytes; every cap of scene_t fits
  std::vector<uint8_t> bytes = std::vector<uint8_t>(kMax);
  size_t size = 0;
};

/// Hands a scene_t's bytes to the worker (bell rung): no decoding on the bus's thread. Refuses one
/// larger than SceneBytes::kMax. Allocates nothing.
class SceneReceiver {
 public:
  SceneReceiver(Mailbox<SceneBytes>& mailbox, Doorbell& bell) : mailbox_(mailbox), bell_(bell) {}
  SceneReceiver(const SceneReceiver&) = delete;
  SceneReceiver& operator=(const SceneReceiver&) = delete;
  std::string receive(const void* data, size_t size);

 private:
  Mailbox<SceneBytes>& mailbox_;
  Doorbell& bell_;
};

class PayloadReceiver {
 public:
  PayloadReceiver(Mailbox<Payload>& mailbox, Doorbell& bell);
  PayloadReceiver(const PayloadReceiver&) = delete;
  PayloadReceiver& operator=(const PayloadReceiver&) = delete;
  std::string receive(const void* data, size_t size);

 private:
  payload_t message_;
  Mailbox<Payload>& mailbox_;
  Doorbell& bell_;
};

/// The commands this process has sent, by (seq, utime), so that whoever hears the command channel
/// can tell them from another sender's: LCM over UDP multicast delivers our own messages back to
/// us. The real-time loop records before each send (two atomic stores, no allocation); the LCM
/// thread asks.
class SentCommands {
 public:
  SentCommands();
  /// Real-time thread: the command about to be sent. seq starts at 1 and grows by 1.
  void record(int64_t seq, int64_t utime);
  /// Any thread: whether this process sent the command with this seq and utime, among the last
  /// kWindow, and has not been asked about it before: our own multicast comes back once, so a
  /// second copy is a replay (lcm-logplayer onto the live bus), not ours.
  bool take(int64_t seq, int64_t utime);

  /// About 4 s at 1 kHz: far longer than our own multicast takes to come back.
  static constexpr int64_t kWindow = 4096;

 private:
  std::array<std::atomic<int64_t>, kWindow> utime_;  // slot seq % kWindow
  std::atomic<int64_t> latest_{0};
};

/// Listens on the command channel for commands this process did not send (another controller on
/// the same channels, a log replayed onto the live bus), which mean someone else drives the arm.
/// Runs on the thread that handles the bus and reports through atomics, so the real-time loop
/// only loads them.
class CommandWatch {
 public:
  explicit CommandWatch(SentCommands& sent);
  CommandWatch(const CommandWatch&) = delete;
  CommandWatch& operator=(const CommandWatch&) = delete;

  /// Judges one message heard on the command channel; true if it is foreign. Anything that is not
  /// one of our own commands is foreign, a message that is not even a joint_torque_command_t too.
  bool receive(const void* data, size_t size);
  /// Foreign messages so far.
  int64_t foreign() const { return foreign_.load(std::memory_order_acquire); }
  /// seq and state_seq of the first foreign command (both −1 if it did not decode as one); valid
  /// once foreign() > 0.
  int64_t first_seq() const { return first_seq_.load(std::memory_order_relaxed); }
  int64_t first_state_seq() const { return first_state_seq_.load(std::memory_order_relaxed); }

 private:
  SentCommands& sent_;
  joint_torque_command_t message_;  // any arm's: another controller may drive another arm
  std::atomic<int64_t> first_seq_{-1}, first_state_seq_{-1};
  std::atomic<int64_t> foreign_{0};
};

}  // namespace chasles::controller
