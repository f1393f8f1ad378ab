// The controller's side of the wire. Receivers run on the LCM thread and hand validated values
// to the real-time thread through mailboxes; the command publisher runs on the real-time thread
// and allocates nothing.
//
// Every received message is untrusted: each goes through the one checked decoder of its type
// (lcmtypes/checked.hpp), which reads the fingerprint and the count from the raw bytes before
// lcm-gen's decoder may trust them, then the exact size, then the values' finiteness.
#pragma once

#include <lcm/lcm.h>

#include <array>
#include <atomic>
#include <chasles/arm_target_t.hpp>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "chasles/controller/controller.hpp"
#include "chasles/controller/mailbox.hpp"

namespace chasles::controller {

/// Channel names: a configurable prefix, so several arms can share one network.
struct Channels {
  std::string state, command, target, status;
  explicit Channels(const std::string& prefix = "CHASLES_")
      : state(prefix + "STATE"), command(prefix + "COMMAND"), target(prefix + "TARGET"), status(prefix + "STATUS") {}
};

/// Counts rejected messages and keeps the latest reason, for the status report.
class Rejections {
 public:
  void add(const std::string& reason);
  int64_t count() const { return count_.load(std::memory_order_relaxed); }
  std::string last() const;

 private:
  std::atomic<int64_t> count_{0};
  mutable std::mutex mutex_;  // never taken on the real-time thread
  std::string last_;
};

/// robot_state_t on `channel` → validated JointState in `mailbox`.
class StateReceiver {
 public:
  StateReceiver(lcm_t* lcm, const std::string& channel, int num_joints, Mailbox<JointState>& mailbox,
                Rejections& rejections);
  ~StateReceiver();
  StateReceiver(const StateReceiver&) = delete;
  StateReceiver& operator=(const StateReceiver&) = delete;

  /// Checks and decodes one message; returns an empty string or why it was refused. Public so
  /// that tests can feed it bytes directly.
  std::string receive(const void* data, int size, int64_t arrival_ns);

 private:
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);

  lcm_t* lcm_;
  lcm_subscription_t* subscription_ = nullptr;
  int num_joints_;
  robot_state_t message_;
  Mailbox<JointState>& mailbox_;
  Rejections& rejections_;
};

/// arm_target_t on `channel` → Target in `queue` (structure checked here; meaning — limits,
/// durations, mode — by Controller::set_target). A queue, not a mailbox: every target is judged
/// and answered, even two sent within one tick.
class TargetReceiver {
 public:
  TargetReceiver(lcm_t* lcm, const std::string& channel, int num_joints, SpscRing<Target>& queue,
                 Rejections& rejections);
  ~TargetReceiver();
  TargetReceiver(const TargetReceiver&) = delete;
  TargetReceiver& operator=(const TargetReceiver&) = delete;

  std::string receive(const void* data, int size);

 private:
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);

  lcm_t* lcm_;
  lcm_subscription_t* subscription_ = nullptr;
  int num_joints_;
  arm_target_t message_;
  Target target_;
  SpscRing<Target>& queue_;
  Rejections& rejections_;
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
/// Runs on the LCM thread and reports through atomics, so the real-time loop only loads them.
class CommandWatch {
 public:
  CommandWatch(lcm_t* lcm, const std::string& channel, SentCommands& sent);
  ~CommandWatch();
  CommandWatch(const CommandWatch&) = delete;
  CommandWatch& operator=(const CommandWatch&) = delete;

  /// Judges one message heard on the command channel; true if it is foreign. Anything that is not
  /// one of our own commands is foreign, a message that is not even a joint_torque_command_t too.
  /// Public so that tests can feed it bytes.
  bool receive(const void* data, int size);
  /// Foreign messages so far.
  int64_t foreign() const { return foreign_.load(std::memory_order_acquire); }
  /// seq and state_seq of the first foreign command (both −1 if it did not decode as one); valid
  /// once foreign() > 0.
  int64_t first_seq() const { return first_seq_.load(std::memory_order_relaxed); }
  int64_t first_state_seq() const { return first_state_seq_.load(std::memory_order_relaxed); }

 private:
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);

  lcm_t* lcm_;
  lcm_subscription_t* subscription_ = nullptr;
  SentCommands& sent_;
  joint_torque_command_t message_;  // any arm's: another controller may drive another arm
  std::atomic<int64_t> first_seq_{-1}, first_state_seq_{-1};
  std::atomic<int64_t> foreign_{0};
};

/// joint_torque_command_t, encoded into a buffer sized once and sent with lcm_publish (LCM's C++
/// publish(channel, msg*) allocates a buffer per call).
class CommandPublisher {
 public:
  CommandPublisher(lcm_t* lcm, std::string channel, int num_joints);
  /// Encodes a command into the buffer.
  void encode(int64_t utime, int64_t seq, int64_t state_seq, const Eigen::VectorXd& torque);
  /// Sends the encoded command; false if LCM failed to.
  bool send();
  /// The bytes of the last command encoded.
  const std::vector<uint8_t>& bytes() const { return bytes_; }

 private:
  lcm_t* lcm_;
  std::string channel_;
  joint_torque_command_t message_;
  std::vector<uint8_t> bytes_;
};

}  // namespace chasles::controller
