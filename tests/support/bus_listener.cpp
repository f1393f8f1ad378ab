#include "support/bus_listener.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "lcmtypes/checked.hpp"

namespace chasles::testing {

BusListener::BusListener(const char* lcm_url, const std::string& channel) : lcm_(lcm_create(lcm_url)) {
  if (lcm_ == nullptr) throw std::runtime_error("LCM did not start: is the test running under tools/netns.sh?");
  lcm_subscribe(lcm_, channel.c_str(), &BusListener::on_message, this);
  lcm_get_fileno(lcm_);  // starts the receive socket now
}

BusListener::~BusListener() { lcm_destroy(lcm_); }

bool BusListener::until(const std::function<bool()>& done, double seconds) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return false;
    lcm_handle_timeout(lcm_, static_cast<int>(std::min<int64_t>(left, 50)));
  }
  return true;
}

const std::vector<std::vector<uint8_t>>& BusListener::listen(double seconds, size_t count) {
  until([&] { return received_.size() >= count; }, seconds);
  return received_;
}

void BusListener::publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
  lcm_publish(lcm_, channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
}

void BusListener::on_message(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  auto* listener = static_cast<BusListener*>(self);
  const auto* data = static_cast<const uint8_t*>(rbuf->data);
  listener->received_.emplace_back(data, data + rbuf->data_size);
  listener->heard(listener->received_.back());
}

bool StatusListener::wait_for(int8_t state, double seconds) {
  return wait_until([state](const controller_status_t& status) { return status.state == state; }, seconds);
}

bool StatusListener::wait_until(const std::function<bool(const controller_status_t&)>& done, double seconds) {
  return until([&] { return latest && done(*latest); }, seconds);
}

void StatusListener::heard(const std::vector<uint8_t>& bytes) {
  controller_status_t status;
  if (messages::decode_checked(bytes.data(), bytes.size(), status).empty()) latest = std::move(status);
}

}  // namespace chasles::testing
