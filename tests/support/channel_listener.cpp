#include "support/channel_listener.hpp"

#include <chrono>
#include <stdexcept>

namespace chasles::testing {

ChannelListener::ChannelListener(const char* lcm_url, const std::string& channel) : lcm_(lcm_create(lcm_url)) {
  if (lcm_ == nullptr) throw std::runtime_error("LCM did not start: is the test running under tools/netns.sh?");
  lcm_subscribe(lcm_, channel.c_str(), &ChannelListener::on_message, this);
  lcm_get_fileno(lcm_);  // starts the receive socket now
}

ChannelListener::~ChannelListener() { lcm_destroy(lcm_); }

const std::vector<std::vector<uint8_t>>& ChannelListener::listen(double seconds, size_t count) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  while (received_.size() < count) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    lcm_handle_timeout(lcm_, static_cast<int>(left));
  }
  return received_;
}

void ChannelListener::on_message(const lcm_recv_buf_t* rbuf, const char*, void* self) {
  const auto* data = static_cast<const uint8_t*>(rbuf->data);
  static_cast<ChannelListener*>(self)->received_.emplace_back(data, data + rbuf->data_size);
}

}  // namespace chasles::testing
