// Real-time scheduling of the calling thread, asked for and reported, never required: a system
// that refuses it still runs the controller, with a clear warning. And the two waits the loops
// block in: on a file descriptor (the bus) and on a doorbell (work handed to a worker).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace chasles::controller {

/// Sets the calling thread's timer slack to 1 ns: by default Linux may delay a sleeping thread's
/// wake-up by 50 µs to batch timers, most of a 1 kHz loop's measured jitter.
void minimise_timer_slack();

/// SCHED_FIFO at `priority` for the calling thread; 0, or the error (errno value) that refused it.
int request_fifo(int priority);

/// SCHED_FIFO at `priority`, all memory locked (mlockall), and pinned to `cpu` (−1: not pinned).
/// Returns one warning per request the OS refused; empty when all were granted.
std::vector<std::string> make_realtime(int priority, int cpu);

/// The kernel's PM QoS asked to keep every CPU out of idle states that take longer than
/// `max_wake_us` to leave (0: none but polling), for as long as this object lives: the value written
/// to /dev/cpu_dma_latency, whose file stays open (closing it withdraws the request), as cyclictest
/// does. A loop that sleeps between states otherwise finds its core halted and its caches and
/// branch predictors cold: on this project's VM the tick's p99 after a 900 µs sleep falls from
/// 16–30 µs to 3–12 µs under it (docs/benchmarks.md). The price is a core that polls instead of
/// halting when idle. Only root may write the file.
class CpuWakeLatency {
 public:
  explicit CpuWakeLatency(int32_t max_wake_us);
  ~CpuWakeLatency();
  CpuWakeLatency(const CpuWakeLatency&) = delete;
  CpuWakeLatency& operator=(const CpuWakeLatency&) = delete;

  /// Empty when the request holds, else why the OS refused it.
  const std::string& warning() const { return warning_; }

 private:
  int fd_ = -1;
  std::string warning_;
};

/// Blocks until `fd` is readable or CLOCK_MONOTONIC reaches `until_ns`; whether it is readable.
/// A signal ends the wait early (false), so a stop request is seen at once.
bool wait_readable(int fd, int64_t until_ns);

/// A wake-up one thread rings and another waits on (an eventfd). Ringing is one non-blocking
/// write and allocates nothing, so the real-time loop can wake a worker that would otherwise
/// poll: an idle worker costs no wake-ups.
class Doorbell {
 public:
  Doorbell();
  ~Doorbell();
  Doorbell(const Doorbell&) = delete;
  Doorbell& operator=(const Doorbell&) = delete;

  void ring();
  /// Waits until rung or until CLOCK_MONOTONIC reaches `until_ns`; whether it was rung (the rings
  /// so far are consumed: several count as one).
  bool wait_until(int64_t until_ns);
  /// Consumes the rings so far without waiting.
  void clear();
  /// Readable while rung (for poll or epoll beside other descriptors).
  int fileno() const { return fd_; }

 private:
  int fd_;
};

}  // namespace chasles::controller
