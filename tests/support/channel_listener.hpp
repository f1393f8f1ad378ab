// A test's ear on one LCM channel, over real LCM: the raw bytes of every message heard there, for
// the tests that run a sender as a process (chasles target, mode, payload) and judge what it sent.
// Subscribed through LCM's C interface (GCC 12 with -fsanitize=vptr miscompiles LCM's typed C++
// subscription); the receive socket exists from construction on, so nothing sent later is missed.
#pragma once

#include <lcm/lcm.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace chasles::testing {

class ChannelListener {
 public:
  /// Listens on `channel` of the bus at `lcm_url`; throws if LCM cannot start there.
  ChannelListener(const char* lcm_url, const std::string& channel);
  ~ChannelListener();
  ChannelListener(const ChannelListener&) = delete;
  ChannelListener& operator=(const ChannelListener&) = delete;

  /// Everything heard within `seconds`; returns early once `count` messages are in.
  const std::vector<std::vector<uint8_t>>& listen(double seconds, size_t count = SIZE_MAX);

 private:
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  lcm_t* lcm_;
  std::vector<std::vector<uint8_t>> received_;
};

}  // namespace chasles::testing
