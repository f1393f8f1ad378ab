#include "controller/transport/protocol.hpp"

#include <algorithm>
#include <cmath>

#include "lcmtypes/checked.hpp"

namespace chasles::controller {

const char* to_string(Protocol protocol) { return conventions(protocol).name; }

bool parse_protocol(std::string_view text, Protocol& protocol) {
  for (const ProtocolConventions& row : kProtocolConventions) {
    if (text == row.name) {
      protocol = row.protocol;
      return true;
    }
  }
  return false;
}

const char* to_string(TorqueSemantics semantics) {
  return semantics == TorqueSemantics::kFull ? "full" : "overlay";
}

bool parse_torque_semantics(std::string_view text, TorqueSemantics& semantics) {
  if (text == "full") {
    semantics = TorqueSemantics::kFull;
  } else if (text == "overlay") {
    semantics = TorqueSemantics::kOverlay;
  } else {
    return false;
  }
  return true;
}

TorqueSemantics default_torque_semantics(Protocol protocol) { return conventions(protocol).torque_semantics; }

ProtocolChannels default_channels(Protocol protocol, const std::string& prefix) {
  const ProtocolConventions& row = conventions(protocol);
  const std::string before = row.prefixed_channels ? prefix : std::string();
  return {before + row.status_channel, before + row.command_channel};
}

double nominal_status_period(Protocol protocol) { return conventions(protocol).status_period; }

int64_t default_stale_ns(double period) {
  return std::max<int64_t>(10'000'000, std::llround(3e9 * period));
}

const char* to_string(IiwaPositions positions) { return positions == IiwaPositions::kNone ? "none" : "measured"; }

bool parse_iiwa_positions(std::string_view text, IiwaPositions& positions) {
  if (text == "none") {
    positions = IiwaPositions::kNone;
  } else if (text == "measured") {
    positions = IiwaPositions::kMeasured;
  } else {
    return false;
  }
  return true;
}

StatusSequence::Verdict StatusSequence::judge(int64_t utime) {
  if (utime < 0) return Verdict::kUntimed;
  if (!any_ || utime > last_utime_) {
    any_ = true;
    last_utime_ = utime;
    ++seq_;
    run_ = 0;
    return Verdict::kNext;
  }
  if (utime == last_utime_) {
    run_ = 0;
    return Verdict::kDuplicate;
  }
  run_ = run_ > 0 && utime > run_utime_ ? run_ + 1 : 1;
  run_utime_ = utime;
  if (run_ < kRestartRun) return Verdict::kStale;
  last_utime_ = utime;
  seq_ = 0;
  run_ = 0;
  return Verdict::kRestart;
}

namespace {

using ConstMap = Eigen::Map<const Eigen::VectorXd>;

ConstMap map(const std::vector<double>& values) { return ConstMap(values.data(), Eigen::Index(values.size())); }

}  // namespace

// The signs are the conventions table's (the iiwa's measured torque negated on the wire, the Panda's
// external torque negated), the same rows the plant encodes by.
void state_from_iiwa(const drake::lcmt_iiwa_status& status, int64_t seq, int64_t arrival_ns, JointState& state,
                     Eigen::VectorXd& tau_ext) {
  constexpr const ProtocolConventions& iiwa = conventions(Protocol::kDrakeIiwa);
  state.seq = seq;
  state.utime = status.utime;
  state.arrival_ns = arrival_ns;
  state.q = map(status.joint_position_measured);
  state.qd = map(status.joint_velocity_estimated);
  state.effort = factor(iiwa.effort) * map(status.joint_torque_measured);
  tau_ext = factor(iiwa.tau_ext) * map(status.joint_torque_external);
}

void state_from_panda(const drake::lcmt_panda_status& status, int64_t seq, int64_t arrival_ns, JointState& state,
                      Eigen::VectorXd& tau_ext) {
  constexpr const ProtocolConventions& panda = conventions(Protocol::kDrakePanda);
  state.seq = seq;
  state.utime = status.utime;
  state.arrival_ns = arrival_ns;
  state.q = map(status.joint_position);
  state.qd = map(status.joint_velocity);
  state.effort = factor(panda.effort) * map(status.joint_torque);               // tau_J
  tau_ext = factor(panda.tau_ext) * map(status.joint_torque_external);          // tau_ext_hat_filtered
}

// Every protocol's command torque is in chasles's sign (the table's command_torque: kSame on each),
// so the torque is written as the law computed it, less g under overlay.
void torque_for_receiver(const Eigen::VectorXd& tau, const Eigen::VectorXd& g, TorqueSemantics semantics,
                         double* out) {
  Eigen::Map<Eigen::VectorXd> torque(out, tau.size());
  if (semantics == TorqueSemantics::kOverlay) {
    torque = tau - g;
  } else {
    torque = tau;
  }
}
static_assert(conventions(Protocol::kChasles).command_torque == Sign::kSame &&
                  conventions(Protocol::kDrakeIiwa).command_torque == Sign::kSame &&
                  conventions(Protocol::kDrakePanda).command_torque == Sign::kSame,
              "torque_for_receiver writes every protocol's command torque in chasles's sign");

void iiwa_command(int64_t utime, const Eigen::VectorXd& tau, const Eigen::VectorXd& g, TorqueSemantics semantics,
                  IiwaPositions positions, const Eigen::VectorXd& q_measured, drake::lcmt_iiwa_command& command) {
  const auto n = size_t(tau.size());
  command.utime = utime;
  command.num_joints = positions == IiwaPositions::kMeasured ? int32_t(n) : 0;
  command.joint_position.resize(size_t(command.num_joints));
  if (positions == IiwaPositions::kMeasured) {
    std::copy(q_measured.data(), q_measured.data() + n, command.joint_position.begin());
  }
  command.num_torques = int32_t(n);
  command.joint_torque.resize(n);
  torque_for_receiver(tau, g, semantics, command.joint_torque.data());
}

void panda_command(int64_t utime, const Eigen::VectorXd& tau, const Eigen::VectorXd& g, TorqueSemantics semantics,
                   drake::lcmt_panda_command& command) {
  const auto n = size_t(tau.size());
  command.utime = utime;
  command.num_joint_position = 0;
  command.joint_position.clear();
  command.num_joint_velocity = 0;
  command.joint_velocity.clear();
  command.num_joint_torque = int32_t(n);
  command.joint_torque.resize(n);
  torque_for_receiver(tau, g, semantics, command.joint_torque.data());
  command.control_mode_expected = conventions(Protocol::kDrakePanda).command_control_mode;
}

StatusReader::StatusReader(Protocol protocol, int num_joints)
    : protocol_(protocol), num_joints_(num_joints), tau_ext_(Eigen::VectorXd::Zero(num_joints)) {
  // Sized for the arm once, so that decoding a status of the arm allocates nothing.
  const auto n = size_t(num_joints);
  chasles_.num_joints = iiwa_.num_joints = panda_.num_joints = num_joints;
  if (protocol == Protocol::kChasles) {
    for (auto* v : {&chasles_.position, &chasles_.velocity, &chasles_.effort}) v->assign(n, 0.0);
  } else if (protocol == Protocol::kDrakeIiwa) {
    for (auto* v : {&iiwa_.joint_position_measured, &iiwa_.joint_velocity_estimated, &iiwa_.joint_position_commanded,
                    &iiwa_.joint_position_ipo, &iiwa_.joint_torque_measured, &iiwa_.joint_torque_commanded,
                    &iiwa_.joint_torque_external}) {
      v->assign(n, 0.0);
    }
  } else {
    for (auto* v : {&panda_.joint_position, &panda_.joint_position_desired, &panda_.joint_velocity,
                    &panda_.joint_velocity_desired, &panda_.joint_acceleration_desired, &panda_.joint_torque,
                    &panda_.joint_torque_desired, &panda_.joint_torque_external}) {
      v->assign(n, 0.0);
    }
  }
}

std::string StatusReader::read(const void* data, size_t size, int64_t arrival_ns, JointState& state) {
  constexpr auto kFinite = messages::Finite::Required;
  int64_t utime = 0;
  if (protocol_ == Protocol::kChasles) {
    if (std::string why = messages::decode_checked(data, size, chasles_, num_joints_, kFinite); !why.empty()) {
      return why;
    }
    state.seq = chasles_.seq;
    state.utime = chasles_.utime;
    state.arrival_ns = arrival_ns;
    state.q = map(chasles_.position);
    state.qd = map(chasles_.velocity);
    state.effort = factor(conventions(Protocol::kChasles).effort) * map(chasles_.effort);
    return {};
  }
  if (protocol_ == Protocol::kDrakeIiwa) {
    if (std::string why = messages::decode_checked(data, size, iiwa_, num_joints_, kFinite); !why.empty()) return why;
    utime = iiwa_.utime;
  } else {
    if (std::string why = messages::decode_checked(data, size, panda_, num_joints_, kFinite); !why.empty()) return why;
    utime = panda_.utime;
  }
  const int64_t last = sequence_.last_utime();
  switch (sequence_.judge(utime)) {
    case StatusSequence::Verdict::kDuplicate:
      ++duplicates_;
      return "a duplicate: utime " + std::to_string(utime) + " again";
    case StatusSequence::Verdict::kStale:
      ++stale_;
      return "stale: utime " + std::to_string(utime) + " is " + std::to_string(last - utime) +
             " µs before the last status taken";
    case StatusSequence::Verdict::kUntimed:
      ++untimed_;
      return "untimed: utime " + std::to_string(utime) + " (the driver's clock is not synchronised yet)";
    case StatusSequence::Verdict::kRestart:
      ++restarts_;
      break;
    case StatusSequence::Verdict::kNext:
      break;
  }
  if (protocol_ == Protocol::kDrakeIiwa) {
    state_from_iiwa(iiwa_, sequence_.seq(), arrival_ns, state, tau_ext_);
  } else {
    state_from_panda(panda_, sequence_.seq(), arrival_ns, state, tau_ext_);
  }
  return {};
}

CommandWriter::CommandWriter(Protocol protocol, int num_joints, TorqueSemantics semantics, IiwaPositions iiwa_positions)
    : protocol_(protocol), semantics_(semantics), iiwa_positions_(iiwa_positions) {
  const auto n = size_t(num_joints);
  chasles_.utime = chasles_.seq = 0;
  chasles_.state_seq = -1;
  chasles_.num_joints = num_joints;
  chasles_.torque.assign(n, 0.0);
  iiwa_.utime = 0;
  iiwa_.num_joints = iiwa_positions == IiwaPositions::kMeasured ? num_joints : 0;
  iiwa_.joint_position.assign(size_t(iiwa_.num_joints), 0.0);
  iiwa_.num_torques = num_joints;
  iiwa_.joint_torque.assign(n, 0.0);
  panda_.utime = 0;
  panda_.num_joint_position = panda_.num_joint_velocity = 0;
  panda_.num_joint_torque = num_joints;
  panda_.joint_torque.assign(n, 0.0);
  panda_.control_mode_expected = conventions(Protocol::kDrakePanda).command_control_mode;
  // Every command of a protocol has one size.
  const int size = protocol == Protocol::kChasles     ? chasles_.getEncodedSize()
                   : protocol == Protocol::kDrakeIiwa ? iiwa_.getEncodedSize()
                                                      : panda_.getEncodedSize();
  bytes_.resize(size_t(size));
}

void CommandWriter::write(int64_t utime, int64_t seq, const JointState& state, const Eigen::VectorXd& tau,
                          const Eigen::VectorXd& g) {
  const int size = static_cast<int>(bytes_.size());
  switch (protocol_) {
    case Protocol::kChasles:
      chasles_.utime = utime;
      chasles_.seq = seq;
      chasles_.state_seq = state.seq;
      torque_for_receiver(tau, g, semantics_, chasles_.torque.data());
      chasles_.encode(bytes_.data(), 0, size);  // the buffer fits by construction
      break;
    case Protocol::kDrakeIiwa:
      iiwa_command(state.utime, tau, g, semantics_, iiwa_positions_, state.q, iiwa_);
      iiwa_.encode(bytes_.data(), 0, size);
      break;
    case Protocol::kDrakePanda:
      panda_command(state.utime, tau, g, semantics_, panda_);
      panda_.encode(bytes_.data(), 0, size);
      break;
  }
}

SentDigests::SentDigests() {
  for (auto& slot : slots_) slot.store(0, std::memory_order_relaxed);
}

uint64_t SentDigests::digest(const void* data, size_t size) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  uint64_t h = 0xcbf29ce484222325u;
  for (size_t i = 0; i < size; ++i) h = (h ^ bytes[i]) * 0x100000001b3u;
  return h == 0 ? 1 : h;
}

void SentDigests::record(const std::vector<uint8_t>& bytes) {
  const uint64_t slot = next_.fetch_add(1, std::memory_order_relaxed) % kWindow;
  slots_[slot].store(digest(bytes.data(), bytes.size()), std::memory_order_release);
}

bool SentDigests::take(const void* data, size_t size) {
  const uint64_t d = digest(data, size);
  for (auto& slot : slots_) {
    uint64_t expected = d;
    if (slot.load(std::memory_order_acquire) == d &&
        slot.compare_exchange_strong(expected, 0, std::memory_order_acq_rel)) {
      return true;
    }
  }
  return false;
}

bool DigestCommandWatch::receive(const void* data, size_t size) {
  if (sent_.take(data, size)) return false;
  if (foreign_.load(std::memory_order_relaxed) == 0 && size >= 16) {
    // After the 8-byte fingerprint, utime as LCM encodes an int64: big-endian.
    const auto* bytes = static_cast<const uint8_t*>(data);
    uint64_t utime = 0;
    for (size_t i = 8; i < 16; ++i) utime = (utime << 8) | bytes[i];
    first_utime_.store(static_cast<int64_t>(utime), std::memory_order_relaxed);
  }
  foreign_.fetch_add(1, std::memory_order_release);
  return true;
}

}  // namespace chasles::controller
