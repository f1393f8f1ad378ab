#include "controller/transport/inbox.hpp"

#include <algorithm>
#include <cstdio>

namespace chasles::controller {

OwnCommands::OwnCommands(Protocol protocol)
    : chasles_(protocol == Protocol::kChasles), watch_(sent_), digest_watch_(sent_digests_) {}

void OwnCommands::record(int64_t seq, int64_t utime, const std::vector<uint8_t>& bytes) {
  if (chasles_) {
    sent_.record(seq, utime);
  } else {
    sent_digests_.record(bytes);
  }
}

void OwnCommands::receive(const void* data, size_t size) {
  if (chasles_) {
    watch_.receive(data, size);
  } else {
    digest_watch_.receive(data, size);
  }
}

void OwnCommands::describe_first_foreign(char* text, size_t size) const {
  if (chasles_) {
    std::snprintf(text, size, "seq %lld answering state %lld", static_cast<long long>(watch_.first_seq()),
                  static_cast<long long>(watch_.first_state_seq()));
  } else {
    std::snprintf(text, size, "a command not ours answering utime %lld",
                  static_cast<long long>(digest_watch_.first_utime()));
  }
}

Inbox::Inbox(const RobotModel& model, Protocol protocol, const Channels& channels, const Clock& clock,
             int64_t period_ns, Bus& bus, Doorbell& payload_bell)
    : states(JointState(model.dof())),
      payloads(Payload{}),
      scenes(SceneBytes{}),
      modes(8, LawSettings(model.dof())),
      targets(16, Target(model.dof())),
      trajectories(2, motion::Waypoints(model.dof())),
      setpoints(16, Setpoint(model.dof())),
      jogs(16, Jog(model.dof())),
      tip_setpoints(16, TipSetpoint{}),
      clock_(clock),
      period_ns_(period_ns),
      own_commands_(protocol),
      state_receiver_(model.dof(), states, protocol),
      target_receiver_(model.dof(), targets),
      trajectory_receiver_(model, trajectories),
      setpoint_receiver_(model.dof(), setpoints),
      jog_receiver_(model.dof(), jogs),
      tip_setpoint_receiver_(tip_setpoints),
      mode_receiver_(model.dof(), modes),
      payload_receiver_(payloads, payload_bell),
      scene_receiver_(scenes, payload_bell) {
  subscriptions_.push_back(bus.subscribe(channels.state, [this, &bus](const uint8_t* data, size_t size) {
    if (const std::string why = state_receiver_.receive(data, size, arrival_ns(bus)); !why.empty()) {
      rejections_.add("robot state " + why);
    }
  }));
  subscribe(bus, channels.target, "target", target_receiver_);
  subscribe(bus, channels.trajectory, "trajectory", trajectory_receiver_);
  subscribe(bus, channels.setpoint, "setpoint", setpoint_receiver_);
  subscribe(bus, channels.tip_setpoint, "tip setpoint", tip_setpoint_receiver_);
  subscribe(bus, channels.jog, "jog", jog_receiver_);
  subscribe(bus, channels.mode, "control mode", mode_receiver_);
  subscribe(bus, channels.payload, "payload", payload_receiver_);
  subscribe(bus, channels.scene, "scene", scene_receiver_);
  subscriptions_.push_back(bus.subscribe(
      channels.command, [this](const uint8_t* data, size_t size) { own_commands_.receive(data, size); }));
}

template <typename Receiver>
void Inbox::subscribe(Bus& bus, const std::string& channel, const char* what, Receiver& receiver) {
  subscriptions_.push_back(bus.subscribe(channel, [this, what, &receiver](const uint8_t* data, size_t size) {
    if (const std::string why = receiver.receive(data, size); !why.empty()) {
      rejections_.add(std::string(what) + " " + why);
    }
  }));
}

// When the message being handled reached this host: the kernel's stamp where the bus has one,
// so that the latency includes LCM's receive thread and the hand-over to this one; else now.
int64_t Inbox::arrival_ns(const Bus& bus) const {
  const int64_t now = clock_.now_ns();
  const int64_t stamp_us = bus.arrival_utime();
  if (stamp_us < 0) return now;
  const int64_t age_ns = (clock_.utime_us() - stamp_us) * 1000;
  return now - std::clamp<int64_t>(age_ns, 0, period_ns_ * 1000);  // a wall clock stepped meanwhile: bounded
}

}  // namespace chasles::controller
