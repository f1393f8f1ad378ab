#include "chasles/controller/bus.hpp"

#include <lcm/lcm.h>

#include <cstdlib>
#include <cstring>
#include <thread>

#include "chasles/controller/realtime.hpp"
#include "chasles/core/error.hpp"

namespace chasles::controller {

Bus::Subscription::~Subscription() {
  if (subscription_ != nullptr) lcm_unsubscribe(lcm_, subscription_);
}

Bus::Subscription::Subscription(Subscription&& other) noexcept
    : lcm_(other.lcm_), subscription_(other.subscription_), slot_(std::move(other.slot_)) {
  other.subscription_ = nullptr;
}

Bus::Subscription& Bus::Subscription::operator=(Subscription&& other) noexcept {
  if (this != &other) {
    if (subscription_ != nullptr) lcm_unsubscribe(lcm_, subscription_);
    lcm_ = other.lcm_;
    subscription_ = other.subscription_;
    slot_ = std::move(other.slot_);
    other.subscription_ = nullptr;
  }
  return *this;
}

namespace {

// The provider LCM will use for `url`: udpm:// (its default) stamps each datagram with the
// kernel's receive time.
bool stamps_arrival(const std::string& url) {
  const char* env = std::getenv("LCM_DEFAULT_URL");
  const std::string effective = !url.empty() ? url : env != nullptr && *env != '\0' ? env : "udpm://";
  return effective.rfind("udpm://", 0) == 0;
}

}  // namespace

Bus::Bus(const std::string& url)
    : lcm_(lcm_create(url.empty() ? nullptr : url.c_str())), kernel_stamps_(stamps_arrival(url)) {
  if (lcm_ == nullptr) {
    throw Error("LCM could not start on " + (url.empty() ? std::string("its default URL") : url) +
                " (no multicast route? inside a network namespace run tools/netns.sh)");
  }
}

Bus::~Bus() { lcm_destroy(lcm_); }

bool Bus::publish(const std::string& channel, const void* data, size_t size) {
  return lcm_publish(lcm_, channel.c_str(), data, static_cast<unsigned>(size)) == 0;
}

Bus::Subscription Bus::subscribe(const std::string& channel, Handler handler, int queue_capacity) {
  Subscription s;
  s.lcm_ = lcm_;
  s.slot_ = std::make_unique<Subscription::Slot>(Subscription::Slot{std::move(handler), this});
  // The C interface hands the channel over as a char*; the C++ one builds a std::string for every
  // message, which may allocate.
  s.subscription_ = lcm_subscribe(
      lcm_, channel.c_str(),
      [](const lcm_recv_buf_t* rbuf, const char*, void* context) {
        auto& slot = *static_cast<Subscription::Slot*>(context);
        slot.bus->arrival_utime_ = slot.bus->kernel_stamps_ ? rbuf->recv_utime : -1;
        slot.handler(static_cast<const uint8_t*>(rbuf->data), rbuf->data_size);
        slot.bus->arrival_utime_ = -1;
      },
      s.slot_.get());
  if (s.subscription_ == nullptr) throw Error("LCM could not subscribe to " + channel);
  if (queue_capacity > 0) lcm_subscription_set_queue_capacity(s.subscription_, queue_capacity);
  return s;
}

int Bus::handle(int timeout_ms) { return lcm_handle_timeout(lcm_, timeout_ms); }

int Bus::handle_pending() {
  int count = 0;
  while (lcm_handle_timeout(lcm_, 0) > 0) ++count;
  return count;
}

int Bus::fileno() const { return lcm_get_fileno(lcm_); }

std::string Bus::start_receiving(int priority) {
  std::string warning;
  std::thread starter([&] {
    if (const int err = request_fifo(priority); err != 0) {
      warning = std::string("SCHED_FIFO refused for LCM's receive thread (") + std::strerror(err) +
                "): it runs under SCHED_OTHER";
    }
    lcm_get_fileno(lcm_);  // udpm:// starts its receive thread here, which inherits this one's policy
  });
  starter.join();
  return warning;
}

}  // namespace chasles::controller
