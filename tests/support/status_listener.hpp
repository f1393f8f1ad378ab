// A test's ear on the controller's status channel, over real LCM: what process tests wait on
// instead of sleeping (a mode reached, a move finished).
#pragma once

#include <lcm/lcm.h>

#include <chasles/controller_status_t.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace chasles::testing {

class StatusListener {
 public:
  /// Listens on `channel` of the bus at `lcm_url`; throws if LCM cannot start there.
  explicit StatusListener(const char* lcm_url, const std::string& channel = "CHASLES_STATUS");
  ~StatusListener();
  StatusListener(const StatusListener&) = delete;
  StatusListener& operator=(const StatusListener&) = delete;

  /// Handles messages until a status in `state` arrives, or `seconds` pass; whether it arrived.
  bool wait_for(int8_t state, double seconds);
  /// The same for any condition on the newest status.
  bool wait_until(const std::function<bool(const controller_status_t&)>& done, double seconds);
  /// Sends raw bytes on `channel` (junk included).
  void publish(const std::string& channel, const std::vector<uint8_t>& bytes);

  /// The newest status that decoded (lcmtypes/checked.hpp), if any.
  std::optional<controller_status_t> latest;

 private:
  static void on_status(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  lcm_t* lcm_;
};

}  // namespace chasles::testing
