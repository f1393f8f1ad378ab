#include "harness.hpp"

#include <chrono>
#include <stdexcept>
#include <type_traits>

#include "controller/transport/realtime/clock.hpp"
#include "lcmtypes/checked.hpp"

namespace chasles::faults {
namespace {

using controller::monotonic_ns;

// Room for about 8 s of states by seq, far more than any state a command can still answer.
constexpr size_t kPositions = 8192;

// The checked decoder of the type; states with finite values only (not the test's own NaN bursts).
template <typename Message>
bool decode(const lcm_recv_buf_t* rbuf, Message& message) {
  return messages::decode_checked(rbuf->data, rbuf->data_size, message, messages::kAnyArm,
                                  std::is_same_v<Message, robot_state_t> ? messages::Finite::Required
                                                                         : messages::Finite::NotRequired)
      .empty();
}

}  // namespace

Seat::Seat(const std::string& url, const std::string& prefix)
    : prefix_(prefix), rx_(lcm_create(url.c_str())), tx_(lcm_create(url.c_str())), positions_(kPositions) {
  if (rx_ == nullptr || tx_ == nullptr) throw std::runtime_error("LCM did not start on " + url + ": run under tools/netns.sh");
  // Bursts (the 10 kHz flood, a burst after a delay spike) must not be lost in the test's own
  // receive queue, or commands would go unjudged.
  for (auto* s : {lcm_subscribe(rx_, (prefix + "STATE").c_str(), &Seat::on_state, this),
                  lcm_subscribe(rx_, (prefix + "COMMAND").c_str(), &Seat::on_command, this),
                  lcm_subscribe(rx_, (prefix + "STATUS").c_str(), &Seat::on_status, this)}) {
    lcm_subscription_set_queue_capacity(s, 100'000);
  }
  thread_ = std::thread([this] {
    while (!done_.load()) lcm_handle_timeout(rx_, 20);
  });
}

Seat::~Seat() {
  done_ = true;
  thread_.join();
  lcm_destroy(rx_);
  lcm_destroy(tx_);
}

bool Seat::until(const std::function<bool(const Seat&)>& done, double seconds) const {
  const int64_t deadline = monotonic_ns() + static_cast<int64_t>(seconds * 1e9);
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (done(*this)) return true;
    }
    if (monotonic_ns() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void Seat::listen(double seconds) const {
  until([](const Seat&) { return false; }, seconds);
}

bool Seat::status_is(int8_t mode) const { return status_.has_value() && status_->state == mode; }

bool Seat::wait_for(int8_t mode, double seconds) const {
  return until([mode](const Seat& bus) { return bus.status_is(mode); }, seconds);
}

void Seat::publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
  lcm_publish(tx_, (prefix_ + channel).c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
}

void Seat::publish_command(const joint_torque_command_t& command) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    own_commands_.insert({command.seq, command.utime});
  }
  publish("COMMAND", command);
}

std::vector<HeardCommand> Seat::commands() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return commands_;
}
std::vector<HeardStatus> Seat::statuses() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return statuses_;
}
std::optional<controller_status_t> Seat::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}
std::optional<robot_state_t> Seat::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}
int64_t Seat::state_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_count_;
}
void Seat::clear_commands() {
  std::lock_guard<std::mutex> lock(mutex_);
  commands_.clear();
}

void Seat::on_state(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  robot_state_t m{};
  if (!decode(rbuf, m) || m.seq < 0) return;
  auto* bus = static_cast<Seat*>(self);
  std::lock_guard<std::mutex> lock(bus->mutex_);
  ++bus->index_;
  ++bus->state_count_;
  auto& slot = bus->positions_[static_cast<size_t>(m.seq) % kPositions];
  slot.seq = m.seq;
  slot.arrival_ns = monotonic_ns();
  slot.q = vector_of(m.position);
  bus->state_ = std::move(m);
}

void Seat::on_command(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  HeardCommand c{};
  if (!decode(rbuf, c.message)) return;
  auto* bus = static_cast<Seat*>(self);
  std::lock_guard<std::mutex> lock(bus->mutex_);
  if (bus->own_commands_.count({c.message.seq, c.message.utime}) > 0) return;
  c.index = ++bus->index_;
  if (c.message.state_seq >= 0) {
    const auto& slot = bus->positions_[static_cast<size_t>(c.message.state_seq) % kPositions];
    if (slot.seq == c.message.state_seq) {
      c.q_answered = slot.q;
      c.round_trip_us = 1e-3 * static_cast<double>(monotonic_ns() - slot.arrival_ns);
    }
  }
  bus->commands_.push_back(std::move(c));
}

void Seat::on_status(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  HeardStatus s{};
  if (!decode(rbuf, s.message)) return;
  auto* bus = static_cast<Seat*>(self);
  std::lock_guard<std::mutex> lock(bus->mutex_);
  s.index = ++bus->index_;
  bus->status_ = s.message;
  bus->statuses_.push_back(std::move(s));
}

}  // namespace chasles::faults
