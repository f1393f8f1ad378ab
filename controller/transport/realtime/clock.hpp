// Time for the daemon's loops, its receivers and the plant, behind one seam: production reads
// CLOCK_MONOTONIC and sleeps with clock_nanosleep; tests run controller and plant in one thread
// on a SimulatedClock they advance, so every tick happens at an exact, repeatable time.
#pragma once

#include <time.h>

#include <atomic>
#include <cstdint>

namespace chasles::controller {

/// CLOCK_MONOTONIC, ns: schedules, ages and latencies.
inline int64_t monotonic_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

/// CLOCK_REALTIME, µs since the Unix epoch: only for the utime stamps messages carry across hosts.
inline int64_t realtime_us() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return int64_t{t.tv_sec} * 1'000'000 + t.tv_nsec / 1000;
}

/// Sleeps until the absolute CLOCK_MONOTONIC time t_ns (restarting after signals).
inline void sleep_until(int64_t t_ns) {
  const timespec t{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) != 0) {
  }
}

class Clock {
 public:
  virtual ~Clock() = default;
  /// Monotonic time, ns.
  virtual int64_t now_ns() const = 0;
  /// Wall-clock time for message stamps, µs since the Unix epoch.
  virtual int64_t utime_us() const = 0;
  /// Returns once now_ns() ≥ t_ns.
  virtual void sleep_until(int64_t t_ns) const = 0;
};

/// The machine's clocks.
class SystemClock final : public Clock {
 public:
  int64_t now_ns() const override { return monotonic_ns(); }
  int64_t utime_us() const override { return realtime_us(); }
  void sleep_until(int64_t t_ns) const override { controller::sleep_until(t_ns); }
};

/// Time that moves only when the test moves it. sleep_until() moves it too: with everything on
/// one thread, a component that sleeps is the only one running, so time jumps to its wake-up.
class SimulatedClock final : public Clock {
 public:
  /// Starts at `start_ns`; message stamps are `epoch_us` plus the time elapsed.
  explicit SimulatedClock(int64_t start_ns = 0, int64_t epoch_us = 1'800'000'000'000'000)
      : start_ns_(start_ns), epoch_us_(epoch_us), now_ns_(start_ns) {}

  int64_t now_ns() const override { return now_ns_.load(std::memory_order_acquire); }
  int64_t utime_us() const override { return epoch_us_ + (now_ns() - start_ns_) / 1000; }
  void sleep_until(int64_t t_ns) const override { advance_to(t_ns); }
  /// Moves time forward to t_ns (never back).
  void advance_to(int64_t t_ns) const {
    int64_t now = now_ns_.load(std::memory_order_acquire);
    while (t_ns > now && !now_ns_.compare_exchange_weak(now, t_ns, std::memory_order_acq_rel)) {
    }
  }

 private:
  int64_t start_ns_, epoch_us_;
  mutable std::atomic<int64_t> now_ns_;
};

}  // namespace chasles::controller
