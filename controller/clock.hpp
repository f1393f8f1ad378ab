// The controller's clocks: CLOCK_MONOTONIC for scheduling, ages and latencies; CLOCK_REALTIME
// only for the utime stamps that messages carry across hosts.
#pragma once

#include <time.h>

#include <cstdint>

namespace chasles::controller {

inline int64_t monotonic_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

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

}  // namespace chasles::controller
