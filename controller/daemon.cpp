#include "chasles/controller/daemon.hpp"

#include <algorithm>
#include <cstdio>
#include <thread>

#include "chasles/controller/bus.hpp"
#include "chasles/controller/clock.hpp"
#include "chasles/controller/node.hpp"
#include "chasles/controller/realtime.hpp"

namespace chasles::controller {
namespace {

// How long a controller listens on its command channel before it starts: several periods of a
// controller that is already running, at any rate a sender at 20 Hz or more would show.
constexpr double kListenBeforeStart_s = 0.05;
constexpr int64_t kIdleNs = 1'000'000;  // the IK worker's and the status thread's pace

}  // namespace

struct Daemon::Impl {
  DaemonOptions options;
  SystemClock clock;
  Bus receive, command, status;
  Node node;
  std::atomic<bool> done{false};

  Impl(const RobotModel& model, const DaemonOptions& o)
      : options(o),
        receive(o.lcm_url),
        command(o.lcm_url),
        status(o.lcm_url),
        node(model, options, clock, Buses{receive, command, status}) {}

  void receive_loop() {
    while (!done.load(std::memory_order_relaxed)) receive.handle(20);
  }

  void ik_loop() {
    while (!done.load(std::memory_order_relaxed)) {
      if (!node.plan()) clock.sleep_until(clock.now_ns() + kIdleNs);
    }
  }

  void status_loop() {
    while (!done.load(std::memory_order_relaxed)) {
      clock.sleep_until(clock.now_ns() + kIdleNs);
      node.report();
    }
  }

  void realtime_loop(const std::atomic<bool>& stop) {
    minimise_timer_slack();
    if (options.realtime) {
      const auto warnings = make_realtime(options.priority, options.cpu);
      for (const auto& w : warnings) std::fprintf(stderr, "chasles_controller: warning: %s\n", w.c_str());
      node.set_realtime_granted(warnings.empty());
    }
    const int64_t start = clock.now_ns();
    const int64_t end = options.seconds > 0.0 ? start + static_cast<int64_t>(options.seconds * 1e9) : INT64_MAX;
    int64_t next = node.first_tick();
    while (!stop.load(std::memory_order_relaxed) && next <= end) {
      clock.sleep_until(next);
      next = node.tick(next);
    }
  }
};

Daemon::Daemon(const RobotModel& model, const DaemonOptions& options) : impl_(std::make_unique<Impl>(model, options)) {}

Daemon::~Daemon() = default;

Summary Daemon::run(const std::atomic<bool>& stop) {
  Impl& d = *impl_;
  const int64_t start = d.clock.now_ns();
  std::thread receiver([&d] { d.receive_loop(); });
  // Whatever is heard on the command channel before this controller sends comes from another.
  d.clock.sleep_until(start + static_cast<int64_t>(std::max(3.0 * d.options.control.period, kListenBeforeStart_s) * 1e9));
  if (const std::string why = d.node.refusal(); !why.empty()) {
    d.done = true;
    receiver.join();
    throw Error(why);
  }
  std::thread status([&d] { d.status_loop(); });
  std::thread ik([&d] { d.ik_loop(); });
  std::thread loop([&d, &stop] { d.realtime_loop(stop); });
  loop.join();
  d.done = true;
  status.join();
  ik.join();
  receiver.join();
  return d.node.summary(1e-9 * static_cast<double>(d.clock.now_ns() - start));
}

}  // namespace chasles::controller
