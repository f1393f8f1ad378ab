#include "chasles/tools/simulation/messaging.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>

#include "chasles/lcmtypes/checked.hpp"

namespace chasles::plant {

CommandInbox::CommandInbox(const Clock& clock, const std::string& channel, int num_joints)
    : clock_(clock), channel_(channel), num_joints_(num_joints) {
  for (joint_torque_command_t* message : {&latest_, &incoming_}) {
    message->utime = message->seq = 0;
    message->state_seq = -1;
    message->num_joints = num_joints;
    message->torque.assign(static_cast<size_t>(num_joints), 0.0);
  }
}

void CommandInbox::receive(const void* data, size_t size) {
  if (std::string why = messages::decode_checked(data, size, incoming_, num_joints_, messages::Finite::Required);
      !why.empty()) {
    return reject(why);
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
  std::swap(latest_, incoming_);
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

StatePublisher::StatePublisher(Bus& bus, std::string channel, int num_joints, const Faults& faults,
                               int max_in_flight)
    : bus_(bus), channel_(std::move(channel)), faults_(faults), rng_(faults.seed) {
  message_.utime = message_.seq = 0;
  message_.num_joints = num_joints;
  for (auto* v : {&message_.position, &message_.velocity, &message_.effort}) {
    v->assign(static_cast<size_t>(num_joints), 0.0);
  }
  bytes_.resize(static_cast<size_t>(message_.getEncodedSize()));
  queue_.resize(faults.delay_ms > 0.0 || faults.spikes() ? static_cast<size_t>(max_in_flight) : 0);
  for (Delayed& slot : queue_) slot.bytes.resize(bytes_.size());
}

void StatePublisher::encode(int64_t utime, int64_t seq, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                            const Eigen::VectorXd& effort) {
  message_.utime = utime;
  message_.seq = seq;
  for (size_t i = 0; i < message_.position.size(); ++i) {
    const auto j = static_cast<Eigen::Index>(i);
    message_.position[i] = q[j] + (faults_.noise > 0.0 ? faults_.noise * gaussian_(rng_) : 0.0);
    message_.velocity[i] = qd[j];
    message_.effort[i] = effort[j];
  }
  message_.encode(bytes_.data(), 0, static_cast<int>(bytes_.size()));
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
  message_.utime = message_.seq = 0;
  message_.num_joints = num_joints;
  message_.tau_ext.assign(static_cast<size_t>(num_joints), 0.0);
  std::fill(std::begin(message_.tip_wrench_ext), std::end(message_.tip_wrench_ext), 0.0);
  message_.contact = false;
  bytes_.resize(static_cast<size_t>(message_.getEncodedSize()));
}

void TruthPublisher::publish(int64_t utime, int64_t seq, const Eigen::VectorXd& tau_ext, const Vector6d& tip_wrench_ext,
                             bool contact) {
  message_.utime = utime;
  message_.seq = seq;
  for (size_t i = 0; i < message_.tau_ext.size(); ++i) message_.tau_ext[i] = tau_ext[static_cast<Eigen::Index>(i)];
  for (int i = 0; i < 6; ++i) message_.tip_wrench_ext[i] = tip_wrench_ext[i];
  message_.contact = contact;
  message_.encode(bytes_.data(), 0, static_cast<int>(bytes_.size()));
  if (!bus_.publish(channel_, bytes_)) ++not_sent_;
}

}  // namespace chasles::plant
