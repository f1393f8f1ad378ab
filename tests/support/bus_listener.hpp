// A test's ear on one LCM channel, over real LCM: what the tests that run processes judge (the
// bytes a sender such as chasles target or mode sent) and wait on instead of sleeping (a status
// in some mode). Subscribed through LCM's C interface (GCC 12 with -fsanitize=vptr miscompiles
// LCM's typed C++ subscription); the receive socket exists from construction on, so nothing sent
// later is missed.
#pragma once

#include <lcm/lcm.h>

#include <chasles/controller_status_t.hpp>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace chasles::testing {

class BusListener {
 public:
  /// Listens on `channel` of the bus at `lcm_url`; throws if LCM cannot start there.
  BusListener(const char* lcm_url, const std::string& channel);
  virtual ~BusListener();
  BusListener(const BusListener&) = delete;
  BusListener& operator=(const BusListener&) = delete;

  /// Everything heard within `seconds`; returns early once `count` messages are in.
  const std::vector<std::vector<uint8_t>>& listen(double seconds, size_t count = SIZE_MAX);
  /// Handles messages until `done` holds or `seconds` pass; whether it held.
  bool until(const std::function<bool()>& done, double seconds);
  /// Sends raw bytes on `channel` (junk included).
  void publish(const std::string& channel, const std::vector<uint8_t>& bytes);

 protected:
  /// Called with each message as it is heard, after it is kept.
  virtual void heard(const std::vector<uint8_t>&) {}

 private:
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  lcm_t* lcm_;
  std::vector<std::vector<uint8_t>> received_;
};

/// The controller's status channel: the newest status that decoded (lcmtypes/checked.hpp).
class StatusListener : public BusListener {
 public:
  explicit StatusListener(const char* lcm_url, const std::string& channel = "CHASLES_STATUS")
      : BusListener(lcm_url, channel) {}

  /// Handles messages until a status in `state` arrives, or `seconds` pass; whether it arrived.
  bool wait_for(int8_t state, double seconds);
  /// The same for any condition on the newest status.
  bool wait_until(const std::function<bool(const controller_status_t&)>& done, double seconds);

  std::optional<controller_status_t> latest;

 private:
  void heard(const std::vector<uint8_t>& bytes) override;
};

}  // namespace chasles::testing
