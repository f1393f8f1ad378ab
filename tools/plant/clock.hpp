// The plant's two clocks: CLOCK_MONOTONIC for scheduling and timeouts, CLOCK_REALTIME for the
// utime stamps LCM messages carry.
#pragma once

#include <time.h>

#include <cstdint>

namespace chasles::plant {

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

}  // namespace chasles::plant
