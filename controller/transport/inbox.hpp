// What a controller hears, ready for its real-time loop: every input channel subscribed on one
// bus, each message checked and decoded by its receiver (lcm_io.hpp) into a lock-free mailbox or
// ring the loop drains at its tick, each refusal counted with why; and the command channel watched
// for a sender that is not this process. The bus's handler writes, the loop reads: neither waits.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "controller/transport/lcm_io.hpp"
#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "controller/transport/realtime/mailbox.hpp"

namespace chasles::controller {

/// Our own commands told from another sender's on the command channel — by seq on chasles's
/// protocol (SentCommands, CommandWatch), by their bytes on Drake's, which carry none
/// (SentDigests, DigestCommandWatch) — so that the rest of the node need not know which.
class OwnCommands {
 public:
  explicit OwnCommands(Protocol protocol);
  OwnCommands(const OwnCommands&) = delete;
  OwnCommands& operator=(const OwnCommands&) = delete;

  /// The loop, before each send (our own copy may come back at once). Allocates nothing.
  void record(int64_t seq, int64_t utime, const std::vector<uint8_t>& bytes);
  /// The bus's handler: one message heard on the command channel.
  void receive(const void* data, size_t size);
  /// Messages heard on the command channel that this process did not send.
  int64_t foreign() const { return chasles_ ? watch_.foreign() : digest_watch_.foreign(); }
  /// The first of them, for an operator to find in a log, into `text` (snprintf's way, allocating
  /// nothing: the loop says it when it stands down): "seq 12 answering state 11" on chasles's
  /// protocol, "a command not ours answering utime 5000" on Drake's.
  void describe_first_foreign(char* text, size_t size) const;
  /// Whether commands are told by seq (chasles's protocol) rather than by their bytes.
  bool by_seq() const { return chasles_; }

 private:
  bool chasles_;
  SentCommands sent_;
  CommandWatch watch_;
  SentDigests sent_digests_;
  DigestCommandWatch digest_watch_;
};

class Inbox {
 public:
  /// Subscribes every input channel and the command channel on `bus`. `payload_bell` is rung for
  /// whoever builds the model that carries a payload received. States are stamped with their
  /// arrival on `clock`; `period_ns` bounds how far back a kernel's stamp may put it.
  Inbox(const RobotModel& model, Protocol protocol, const Channels& channels, const Clock& clock, int64_t period_ns,
        Bus& bus, Doorbell& payload_bell);
  Inbox(const Inbox&) = delete;
  Inbox& operator=(const Inbox&) = delete;

  /// Messages refused, with the latest reason.
  Rejections& rejections() { return rejections_; }
  const Rejections& rejections() const { return rejections_; }
  OwnCommands& own_commands() { return own_commands_; }
  const OwnCommands& own_commands() const { return own_commands_; }

  // The loop's side: the newest state and payload, every law, target, trajectory, setpoint, jog
  // and tip setpoint in the order they came.
  Mailbox<JointState> states;
  Mailbox<Payload> payloads;
  /// The newest scene's bytes, for the worker that decodes it (payload_bell rung).
  Mailbox<SceneBytes> scenes;
  SpscRing<LawSettings> modes;
  SpscRing<Target> targets;
  SpscRing<motion::Waypoints> trajectories;
  SpscRing<Setpoint> setpoints;
  SpscRing<Jog> jogs;
  SpscRing<TipSetpoint> tip_setpoints;

 private:
  int64_t arrival_ns(const Bus& bus) const;
  // Subscribes `channel`, whose messages `receiver` decodes; a refusal counts as "<what> <why>".
  template <typename Receiver>
  void subscribe(Bus& bus, const std::string& channel, const char* what, Receiver& receiver);

  const Clock& clock_;
  int64_t period_ns_;
  Rejections rejections_;
  OwnCommands own_commands_;
  StateReceiver state_receiver_;
  TargetReceiver target_receiver_;
  TrajectoryReceiver trajectory_receiver_;
  SetpointReceiver setpoint_receiver_;
  JogReceiver jog_receiver_;
  TipSetpointReceiver tip_setpoint_receiver_;
  ModeReceiver mode_receiver_;
  PayloadReceiver payload_receiver_;
  SceneReceiver scene_receiver_;
  std::vector<Bus::Subscription> subscriptions_;  // after what they feed: ended first
};

}  // namespace chasles::controller
