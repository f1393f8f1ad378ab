#include "tools/simulation/messaging.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "core/error.hpp"
#include "lcmtypes/checked.hpp"

namespace chasles::plant {

int64_t StateTimes::utime(int64_t seq) const {
  return start_utime_ + std::llround(1e6 * static_cast<double>(seq) * dt_);
}

int64_t StateTimes::seq(int64_t utime) const {
  const auto nearest = static_cast<int64_t>(std::llround(1e-6 * static_cast<double>(utime - start_utime_) / dt_));
  for (const int64_t seq : {nearest, nearest - 1, nearest + 1}) {
    if (seq >= 0 && seq <= *latest_seq_ && this->utime(seq) == utime) return seq;
  }
  return -1;
}

CommandInbox::CommandInbox(const Clock& clock, const std::string& channel, int num_joints, Protocol protocol,
                           const StateTimes* times)
    : clock_(clock),
      channel_(channel),
      num_joints_(num_joints),
      protocol_(protocol),
      times_(times),
      latest_(num_joints),
      incoming_(num_joints) {
  if (protocol != Protocol::kChasles && times == nullptr) {
    throw std::logic_error("CommandInbox: Drake's commands need the states' times");
  }
  const auto n = static_cast<size_t>(num_joints);
  chasles_.utime = chasles_.seq = 0;
  chasles_.state_seq = -1;
  chasles_.num_joints = num_joints;
  chasles_.torque.assign(n, 0.0);
  // Every array at its largest, so that decoding any valid command reuses the capacity.
  iiwa_.utime = 0;
  iiwa_.num_joints = iiwa_.num_torques = num_joints;
  iiwa_.joint_position.assign(n, 0.0);
  iiwa_.joint_torque.assign(n, 0.0);
  panda_.utime = 0;
  panda_.num_joint_position = panda_.num_joint_velocity = panda_.num_joint_torque = num_joints;
  panda_.joint_position.assign(n, 0.0);
  panda_.joint_velocity.assign(n, 0.0);
  panda_.joint_torque.assign(n, 0.0);
  panda_.control_mode_expected = conventions(Protocol::kDrakePanda).command_control_mode;
}

namespace {

void copy_to(const std::vector<double>& from, Eigen::VectorXd& to) {
  for (size_t i = 0; i < from.size(); ++i) to[static_cast<Eigen::Index>(i)] = from[i];
}

// A command's torque in chasles's sign, as the protocol's row says it comes.
void copy_torque(Protocol protocol, const std::vector<double>& from, Eigen::VectorXd& to) {
  const double sign = factor(conventions(protocol).command_torque);
  for (size_t i = 0; i < from.size(); ++i) to[static_cast<Eigen::Index>(i)] = sign * from[i];
}

}  // namespace

std::string CommandInbox::decode(const void* data, size_t size) {
  using messages::decode_checked;
  using messages::Finite;
  switch (protocol_) {
    case Protocol::kChasles:
      if (std::string why = decode_checked(data, size, chasles_, num_joints_, Finite::Required); !why.empty()) {
        return why;
      }
      incoming_.state_seq = chasles_.state_seq;
      copy_torque(Protocol::kChasles, chasles_.torque, incoming_.torque);
      incoming_.has_position = false;
      return {};
    case Protocol::kDrakeIiwa:
      if (std::string why = decode_checked(data, size, iiwa_, num_joints_, Finite::Required); !why.empty()) {
        return why;
      }
      if (iiwa_.num_torques != num_joints_) {  // Drake's simulated driver stops on it
        return "with no torques: the driver runs in torque mode, which needs num_torques " +
               std::to_string(num_joints_);
      }
      incoming_.state_seq = times_->seq(iiwa_.utime);
      copy_torque(Protocol::kDrakeIiwa, iiwa_.joint_torque, incoming_.torque);
      incoming_.has_position = iiwa_.num_joints == num_joints_;
      if (incoming_.has_position) copy_to(iiwa_.joint_position, incoming_.position);
      return {};
    case Protocol::kDrakePanda:
      if (std::string why = decode_checked(data, size, panda_, num_joints_, Finite::Required); !why.empty()) {
        return why;
      }
      if (const int8_t torque_mode = conventions(Protocol::kDrakePanda).command_control_mode;
          (panda_.control_mode_expected & torque_mode) == 0) {
        return "expecting control mode " + std::to_string(panda_.control_mode_expected) +
               ": the driver runs in torque mode (CONTROL_MODE_TORQUE, " + std::to_string(torque_mode) + ")";
      }
      if (panda_.num_joint_torque != num_joints_) {
        return "with no torques: the driver runs in torque mode, which needs num_joint_torque " +
               std::to_string(num_joints_);
      }
      incoming_.state_seq = times_->seq(panda_.utime);
      copy_torque(Protocol::kDrakePanda, panda_.joint_torque, incoming_.torque);
      incoming_.has_position = panda_.num_joint_position == num_joints_;
      if (incoming_.has_position) copy_to(panda_.joint_position, incoming_.position);
      return {};
  }
  return "of an unknown protocol";
}

void CommandInbox::receive(const void* data, size_t size) {
  if (std::string why = decode(data, size); !why.empty()) return reject(why);
  if (protocol_ != Protocol::kChasles && incoming_.state_seq < 0) {
    ++stale_;
    ++unreported_;
    std::snprintf(reason_, sizeof(reason_), "a command stamped utime %lld, which no state sent carries",
                  static_cast<long long>(protocol_ == Protocol::kDrakeIiwa ? iiwa_.utime : panda_.utime));
    return;
  }
  if (latest_seq_ != nullptr &&
      (incoming_.state_seq > *latest_seq_ || incoming_.state_seq < *latest_seq_ - max_lag_)) {
    ++stale_;
    ++unreported_;
    std::snprintf(reason_, sizeof(reason_), "a command answering state %lld, the latest is %lld (at most %lld steps behind)",
                  static_cast<long long>(incoming_.state_seq), static_cast<long long>(*latest_seq_),
                  static_cast<long long>(max_lag_));
    return;
  }
  latest_.swap(incoming_);
  fresh_ = true;
  arrival_ns_ = clock_.now_ns();
  ++received_;
}

void CommandInbox::reject(const std::string& why) {
  ++rejected_;
  ++unreported_;
  std::snprintf(reason_, sizeof(reason_), "a command %s", why.c_str());
}

void CommandInbox::report_rejections(int64_t now_ns) {
  if (unreported_ == 0 || now_ns - last_report_ns_ < 1'000'000'000) return;
  std::fprintf(stderr, "chasles_plant: rejected %lld command%s on %s (last: %s); not applied\n",
               static_cast<long long>(unreported_), unreported_ == 1 ? "" : "s", channel_.c_str(), reason_);
  unreported_ = 0;
  last_report_ns_ = now_ns;
}

void check_effort_noise(const EffortNoise& noise, const std::string& what) {
  if (!(noise.sigma >= 0.0) || !std::isfinite(noise.sigma)) {
    char text[64];
    std::snprintf(text, sizeof(text), "%g", noise.sigma);
    throw ArgumentError(what + ": SIGMA " + text +
                        " N*m is not a standard deviation (a finite number >= 0; 0 for no noise)");
  }
}

StatePublisher::StatePublisher(Bus& bus, std::string channel, int num_joints, const Faults& faults,
                               int max_in_flight, Protocol protocol)
    : bus_(bus),
      channel_(std::move(channel)),
      faults_(faults),
      protocol_(protocol),
      rng_(faults.seed),
      effort_rng_(faults.effort_noise.seed),
      measured_effort_(Eigen::VectorXd::Zero(num_joints)) {
  check_effort_noise(faults.effort_noise, "effort noise");
  const auto n = static_cast<size_t>(num_joints);
  size_t size = 0;
  switch (protocol) {
    case Protocol::kChasles:
      message_.utime = message_.seq = 0;
      message_.num_joints = num_joints;
      for (auto* v : {&message_.position, &message_.velocity, &message_.effort}) v->assign(n, 0.0);
      size = static_cast<size_t>(message_.getEncodedSize());
      break;
    case Protocol::kDrakeIiwa:
      iiwa_.utime = 0;
      iiwa_.num_joints = num_joints;
      for (auto* v : {&iiwa_.joint_position_measured, &iiwa_.joint_velocity_estimated, &iiwa_.joint_position_commanded,
                      &iiwa_.joint_position_ipo, &iiwa_.joint_torque_measured, &iiwa_.joint_torque_commanded,
                      &iiwa_.joint_torque_external}) {
        v->assign(n, 0.0);
      }
      size = static_cast<size_t>(iiwa_.getEncodedSize());
      break;
    case Protocol::kDrakePanda:
      panda_.utime = panda_.robot_utime = 0;
      panda_.num_joints = num_joints;
      for (auto* v : {&panda_.joint_position, &panda_.joint_position_desired, &panda_.joint_velocity,
                      &panda_.joint_velocity_desired, &panda_.joint_acceleration_desired, &panda_.joint_torque,
                      &panda_.joint_torque_desired, &panda_.joint_torque_external}) {
        v->assign(n, 0.0);
      }
      panda_.control_command_success_rate = 0.0;
      panda_.robot_mode = drake::lcmt_panda_status::kIdle;
      panda_.control_mode = 0;
      size = static_cast<size_t>(panda_.getEncodedSize());
      break;
  }
  bytes_.resize(size);
  queue_.resize(faults.delay_ms > 0.0 || faults.spikes() ? static_cast<size_t>(max_in_flight) : 0);
  for (Delayed& slot : queue_) slot.bytes.resize(bytes_.size());
}

double StatePublisher::noisy(double q) { return q + (faults_.noise > 0.0 ? faults_.noise * gaussian_(rng_) : 0.0); }

// Box–Muller: two uniforms from the generator's top 53 bits give two independent standard normals,
// joints (0, 1), (2, 3), … in turn; an odd arm's last second draw goes unused. u₁ ∈ (0, 1] keeps
// the logarithm finite, which bounds a draw at √(2 · 53 ln 2) ≈ 8.6 σ.
const Eigen::VectorXd& StatePublisher::measured(const Eigen::VectorXd& effort) {
  const double sigma = faults_.effort_noise.sigma;
  if (sigma == 0.0) return effort;
  const Eigen::Index n = effort.size();
  for (Eigen::Index i = 0; i < n; i += 2) {
    const double u1 = static_cast<double>((effort_rng_() >> 11) + 1) * 0x1.0p-53;
    const double u2 = static_cast<double>(effort_rng_() >> 11) * 0x1.0p-53;
    const double r = sigma * std::sqrt(-2.0 * std::log(u1)), angle = 2.0 * kPi * u2;
    measured_effort_[i] = effort[i] + r * std::cos(angle);
    if (i + 1 < n) measured_effort_[i + 1] = effort[i + 1] + r * std::sin(angle);
  }
  return measured_effort_;
}

void StatePublisher::encode(int64_t utime, int64_t seq, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                            const Eigen::VectorXd& effort) {
  message_.utime = utime;
  message_.seq = seq;
  const Eigen::VectorXd& effort_measured = measured(effort);
  const double effort_sign = factor(conventions(Protocol::kChasles).effort);
  for (size_t i = 0; i < message_.position.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    message_.position[i] = noisy(q[j]);
    message_.velocity[i] = qd[j];
    message_.effort[i] = effort_sign * effort_measured[j];
  }
  message_.encode(bytes_.data(), 0, static_cast<int>(bytes_.size()));
}

void StatePublisher::encode(int64_t utime, int64_t seq, const Eigen::VectorXd& q, const DriverReport& report) {
  switch (protocol_) {
    case Protocol::kChasles:
      return encode(utime, seq, q, report.qd, report.effort);
    case Protocol::kDrakeIiwa:
      return encode_iiwa(utime, q, report);
    case Protocol::kDrakePanda:
      return encode_panda(utime, q, report);
  }
}

// As Drake's simulated driver (manipulation/kuka_iiwa: BuildSimplifiedIiwaControl and
// IiwaStatusSender) reports, in the signs of the conventions table (the measured and the commanded
// torque both negated, the external one not: what StatusReader undoes); joint_position_ipo as
// drake-iiwa-driver: NaN outside FRI's commanding state.
void StatePublisher::encode_iiwa(int64_t utime, const Eigen::VectorXd& q, const DriverReport& report) {
  constexpr const ProtocolConventions& iiwa = conventions(Protocol::kDrakeIiwa);
  iiwa_.utime = utime;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd& effort_measured = measured(report.effort);
  for (size_t i = 0; i < iiwa_.joint_position_measured.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    iiwa_.joint_position_measured[i] = noisy(q[j]);
    iiwa_.joint_velocity_estimated[i] = report.qd[j];
    iiwa_.joint_position_commanded[i] = report.position_commanded[j];
    iiwa_.joint_position_ipo[i] = report.commanding ? report.position_commanded[j] : nan;
    iiwa_.joint_torque_measured[i] = factor(iiwa.effort) * effort_measured[j];
    iiwa_.joint_torque_commanded[i] = factor(iiwa.torque_commanded) * report.torque_commanded[j];
    iiwa_.joint_torque_external[i] = factor(iiwa.tau_ext) * report.tau_ext[j];
  }
  iiwa_.encode(bytes_.data(), 0, static_cast<int>(bytes_.size()));
}

// As libfranka's RobotState through drake-franka-driver: tau_J the torque at the joints (gravity
// included), tau_J_d the command without gravity, tau_ext_hat_filtered negated (the conventions
// table's signs).
void StatePublisher::encode_panda(int64_t utime, const Eigen::VectorXd& q, const DriverReport& report) {
  constexpr const ProtocolConventions& panda = conventions(Protocol::kDrakePanda);
  panda_.utime = utime;
  const Eigen::VectorXd& effort_measured = measured(report.effort);
  for (size_t i = 0; i < panda_.joint_position.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    panda_.joint_position[i] = noisy(q[j]);
    panda_.joint_position_desired[i] = report.position_commanded[j];
    panda_.joint_velocity[i] = report.qd[j];
    panda_.joint_velocity_desired[i] = 0.0;
    panda_.joint_acceleration_desired[i] = 0.0;
    panda_.joint_torque[i] = factor(panda.effort) * effort_measured[j];
    panda_.joint_torque_desired[i] = factor(panda.torque_commanded) * report.torque_desired[j];
    panda_.joint_torque_external[i] = factor(panda.tau_ext) * report.tau_ext[j];
  }
  panda_.control_command_success_rate = report.success_rate;
  panda_.robot_mode = report.robot_mode;
  panda_.robot_utime = report.robot_utime;
  panda_.control_mode = report.control_mode;
  panda_.encode(bytes_.data(), 0, static_cast<int>(bytes_.size()));
}

void StatePublisher::send(int64_t now_ns) {
  if (faults_.drop > 0.0 && uniform_(rng_) < faults_.drop) {
    ++dropped_;
    return;
  }
  if (faults_.spikes() && ++sends_ % faults_.spike_every == 0) {
    spike_end_ns_ = now_ns + static_cast<int64_t>(faults_.spike_ms * 1e6);
  }
  if (queue_.empty()) return publish(bytes_);
  if (size_ == queue_.size()) {  // more in flight than the delay can hold: lost, as on a full link
    ++dropped_;
    return;
  }
  Delayed& slot = queue_[(head_ + size_) % queue_.size()];
  // Never before the spike ends: the order of the states is kept.
  slot.due_ns = std::max(now_ns + static_cast<int64_t>(faults_.delay_ms * 1e6), spike_end_ns_);
  std::copy(bytes_.begin(), bytes_.end(), slot.bytes.begin());
  ++size_;
}

int64_t StatePublisher::flush(int64_t now_ns) {
  while (size_ > 0 && queue_[head_].due_ns <= now_ns) {
    publish(queue_[head_].bytes);
    head_ = (head_ + 1) % queue_.size();
    --size_;
  }
  return size_ > 0 ? queue_[head_].due_ns : std::numeric_limits<int64_t>::max();
}

void StatePublisher::publish(const std::vector<uint8_t>& bytes) {
  // A send that fails is a lost message, as on a real network; the receiver sees the seq gap.
  if (!bus_.publish(channel_, bytes)) ++dropped_;
}

TruthPublisher::TruthPublisher(Bus& bus, std::string channel, int num_joints)
    : bus_(bus), channel_(std::move(channel)) {
  constexpr auto kMax = static_cast<size_t>(sim_truth_t::MAX_CONTACTS);
  message_.utime = message_.seq = 0;
  message_.num_joints = num_joints;
  message_.tau_ext.assign(static_cast<size_t>(num_joints), 0.0);
  std::fill(std::begin(message_.tip_wrench_ext), std::end(message_.tip_wrench_ext), 0.0);
  message_.contact = false;
  // Every row is there from the start; num_contacts says how many are sent.
  message_.num_contacts = sim_truth_t::MAX_CONTACTS;
  for (auto* names : {&message_.contact_link, &message_.contact_other}) {
    names->assign(kMax, std::string(kNameRoom, 'x'));
  }
  for (auto* rows : {&message_.contact_point, &message_.contact_normal, &message_.contact_force}) {
    rows->assign(kMax, std::vector<double>(3, 0.0));
  }
  bytes_.resize(static_cast<size_t>(message_.getEncodedSize()));
  message_.num_contacts = 0;
  order_.reserve(4 * kMax);
}

void TruthPublisher::publish(int64_t utime, int64_t seq, const Truth& truth) {
  message_.utime = utime;
  message_.seq = seq;
  for (size_t i = 0; i < message_.tau_ext.size(); ++i) message_.tau_ext[i] = truth.tau_ext[static_cast<Eigen::Index>(i)];
  for (int i = 0; i < 6; ++i) message_.tip_wrench_ext[i] = truth.tip_wrench_ext[i];
  message_.contact = truth.contact;
  const auto& contacts = truth.contacts;
  order_.resize(contacts.size());
  for (size_t k = 0; k < order_.size(); ++k) order_[k] = static_cast<int>(k);
  const size_t sent = std::min(order_.size(), static_cast<size_t>(sim_truth_t::MAX_CONTACTS));
  if (sent < order_.size()) {
    std::nth_element(order_.begin(), order_.begin() + static_cast<std::ptrdiff_t>(sent), order_.end(), [&](int a, int b) {
      return contacts[static_cast<size_t>(a)].force.squaredNorm() > contacts[static_cast<size_t>(b)].force.squaredNorm();
    });
    std::sort(order_.begin(), order_.begin() + static_cast<std::ptrdiff_t>(sent));  // in the engine's order
  }
  message_.num_contacts = static_cast<int32_t>(sent);
  for (size_t k = 0; k < sent; ++k) {
    const ArmContact& c = contacts[static_cast<size_t>(order_[k])];
    message_.contact_link[k].assign(c.link);
    message_.contact_other[k].assign(c.other);
    for (int i = 0; i < 3; ++i) {
      message_.contact_point[k][static_cast<size_t>(i)] = c.point[i];
      message_.contact_normal[k][static_cast<size_t>(i)] = c.normal[i];
      message_.contact_force[k][static_cast<size_t>(i)] = c.force[i];
    }
  }
  const auto size = static_cast<size_t>(message_.getEncodedSize());
  if (size > bytes_.size()) bytes_.resize(size);  // names longer than kNameRoom: the one allocation
  message_.encode(bytes_.data(), 0, static_cast<int>(size));
  if (!bus_.publish(channel_, bytes_.data(), size)) ++not_sent_;
}

}  // namespace chasles::plant
