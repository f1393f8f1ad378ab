#include "support/status_listener.hpp"

#include <chrono>
#include <stdexcept>

#include "chasles/lcmtypes/checked.hpp"

namespace chasles::testing {

StatusListener::StatusListener(const char* lcm_url, const std::string& channel) : lcm_(lcm_create(lcm_url)) {
  if (lcm_ == nullptr) throw std::runtime_error("LCM did not start: run the test under tools/netns.sh");
  lcm_subscribe(lcm_, channel.c_str(), &StatusListener::on_status, this);
}

StatusListener::~StatusListener() { lcm_destroy(lcm_); }

bool StatusListener::wait_for(int8_t state, double seconds) {
  return wait_until([state](const controller_status_t& status) { return status.state == state; }, seconds);
}

bool StatusListener::wait_until(const std::function<bool(const controller_status_t&)>& done, double seconds) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  while (!(latest && done(*latest)) && Clock::now() < deadline) lcm_handle_timeout(lcm_, 50);
  return latest && done(*latest);
}

void StatusListener::publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
  lcm_publish(lcm_, channel.c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
}

void StatusListener::on_status(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  controller_status_t status;
  if (messages::decode_checked(rbuf->data, rbuf->data_size, status).empty()) {
    static_cast<StatusListener*>(self)->latest = std::move(status);
  }
}

}  // namespace chasles::testing
