#include "controller/daemon.hpp"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <thread>

#include "controller/node.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "controller/transport/realtime/realtime.hpp"

namespace chasles::controller {
namespace {

// How long a controller listens on its command channel before it starts: several periods of a
// controller that is already running, at any rate a sender at 20 Hz or more would show.
constexpr double kListenBeforeStart_s = 0.05;
// How long an idle thread waits before it looks at the stop flag again (a doorbell or the bus
// wakes it sooner when there is work).
constexpr int64_t kIdleNs = 100'000'000;
constexpr int64_t kReceiverPollNs = 20'000'000;

void warn(const std::vector<std::string>& warnings) {
  for (const auto& w : warnings) std::fprintf(stderr, "chasles_controller: warning: %s\n", w.c_str());
}

}  // namespace

struct Daemon::Impl {
  DaemonOptions options;
  SystemClock clock;
  Bus receive;
  std::string receive_warning;
  Bus command, status;
  Node node;
  std::atomic<bool> done{false};

  Impl(const RobotModel& model, const DaemonOptions& o)
      : options(o),
        receive(o.lcm_url, o.direct_receive ? Bus::Receive::kDirect : Bus::Receive::kLcm),
        // Before the Node subscribes: LCM's receive thread (when LCM receives) starts under
        // SCHED_FIFO with --realtime, because every state passes through it before the loop sees it.
        receive_warning(o.realtime ? receive.start_receiving(o.priority) : std::string()),
        command(o.lcm_url),
        status(o.lcm_url),
        node(model, options, clock, Buses{receive, command, status}) {
    if (!receive_warning.empty()) warn({receive_warning});
  }

  bool state_driven() const { return options.tick == TickSource::kState; }

  // Handles what arrives on the receiving bus until `until` (or done).
  void receive_until(int64_t until) {
    for (int64_t now = clock.now_ns(); !done.load(std::memory_order_relaxed) && now < until; now = clock.now_ns()) {
      if (wait_readable(receive.fileno(), std::min(until, now + kReceiverPollNs))) receive.handle_pending();
    }
  }

  void ik_loop() {
    while (!done.load(std::memory_order_relaxed)) {
      if (!node.plan()) node.planner_bell().wait_until(clock.now_ns() + kIdleNs);
    }
  }

  void locator_loop() {
    while (!done.load(std::memory_order_relaxed)) {
      const int64_t due = node.locate();
      node.locator_bell().wait_until(std::min(due, clock.now_ns() + kIdleNs));
    }
  }

  void status_loop() {
    while (!done.load(std::memory_order_relaxed)) {
      const int64_t due = node.report();
      node.reporter_bell().wait_until(std::min(due, clock.now_ns() + kIdleNs));
    }
  }

  void realtime_loop(const std::atomic<bool>& stop) {
    minimise_timer_slack();
    std::optional<CpuWakeLatency> wake_latency;  // held while the loop runs
    if (options.realtime) {
      auto warnings = make_realtime(options.priority, options.cpu);
      if (options.cpu_wake_latency_us >= 0) {
        wake_latency.emplace(options.cpu_wake_latency_us);
        if (!wake_latency->warning().empty()) warnings.push_back(wake_latency->warning());
      }
      warn(warnings);
      node.set_realtime_granted(warnings.empty());
    }
    const int64_t start = clock.now_ns();
    const int64_t end = options.seconds > 0.0 ? start + static_cast<int64_t>(options.seconds * 1e9) : INT64_MAX;
    int64_t next = node.first_tick();
    if (state_driven()) {
      // One thread from the state's arrival to the command: this thread reads the datagram off its
      // socket (or, receiving through LCM, takes it from LCM's pipe), dispatches it and ticks.
      const int fd = receive.fileno();
      while (!stop.load(std::memory_order_relaxed) && next <= end) {
        if (wait_readable(fd, next)) receive.handle_pending();
        if (node.state_waiting() || clock.now_ns() >= next) next = node.tick(next);
      }
    } else {
      while (!stop.load(std::memory_order_relaxed) && next <= end) {
        clock.sleep_until(next);
        next = node.tick(next);
      }
    }
  }
};

Daemon::Daemon(const RobotModel& model, const DaemonOptions& options) : impl_(std::make_unique<Impl>(model, options)) {}

Daemon::~Daemon() = default;

Summary Daemon::run(const std::atomic<bool>& stop) {
  Impl& d = *impl_;
  const int64_t start = d.clock.now_ns();
  // Whatever is heard on the command channel before this controller sends comes from another.
  d.receive_until(start + static_cast<int64_t>(std::max(3.0 * d.options.control.period, kListenBeforeStart_s) * 1e9));
  if (const std::string why = d.node.refusal(); !why.empty()) throw Error(why);
  // Clock-driven, a thread of its own receives; state-driven, the loop does.
  std::thread receiver;
  if (!d.state_driven()) receiver = std::thread([&d] { d.receive_until(INT64_MAX); });
  std::thread status([&d] { d.status_loop(); });
  std::thread ik([&d] { d.ik_loop(); });
  std::thread locator([&d] { d.locator_loop(); });
  std::thread loop([&d, &stop] { d.realtime_loop(stop); });
  loop.join();
  d.done = true;
  d.node.planner_bell().ring();
  d.node.reporter_bell().ring();
  d.node.locator_bell().ring();
  status.join();
  ik.join();
  locator.join();
  if (receiver.joinable()) receiver.join();
  return d.node.summary(1e-9 * static_cast<double>(d.clock.now_ns() - start));
}

}  // namespace chasles::controller
