// Real-time scheduling of the calling thread, asked for and reported, never required: a system
// that refuses it still runs the controller, with a clear warning.
#pragma once

#include <string>
#include <vector>

namespace chasles::controller {

/// Sets the calling thread's timer slack to 1 ns: by default Linux may delay a sleeping thread's
/// wake-up by 50 µs to batch timers, most of a 1 kHz loop's measured jitter.
void minimise_timer_slack();

/// SCHED_FIFO at `priority`, all memory locked (mlockall), and pinned to `cpu` (−1: not pinned).
/// Returns one warning per request the OS refused; empty when all were granted.
std::vector<std::string> make_realtime(int priority, int cpu);

}  // namespace chasles::controller
