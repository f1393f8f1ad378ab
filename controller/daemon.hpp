// The running controller: four threads around one Controller, on the system clock and LCM.
//
//   LCM thread      receives states and targets, validates them, posts them to mailboxes
//   real-time loop  every period (absolute-time sleep): latest state → Controller::tick →
//                   command published from a preallocated buffer → a timing record queued
//   IK worker       plans Cartesian goals into joint paths with Ceres (milliseconds, allocating)
//   status thread   drains the timing records into histograms, publishes controller_status_t
//                   at status_hz (at once on a change of mode) and reports changes on stderr
//
// Only the status thread and the caller allocate or print; the loop and the receivers hand over
// through lock-free mailboxes and a ring. Each thread runs one step of a controller::Node
// (node.hpp) per turn, which the in-process tests run in simulated time.
#pragma once

#include <atomic>
#include <memory>
#include <cstdint>
#include <string>

#include "chasles/controller/controller.hpp"
#include "chasles/controller/statistics.hpp"

namespace chasles::controller {

struct DaemonOptions {
  Config control;
  std::string lcm_url;  ///< empty: LCM's default (or $LCM_DEFAULT_URL)
  std::string channel_prefix = "CHASLES_";
  bool realtime = false;  ///< SCHED_FIFO, mlockall, CPU affinity for the loop (warn if refused)
  int priority = 80;
  int cpu = -1;
  double seconds = 0.0;  ///< stop after this long; 0: run until stopped
  double status_hz = 100.0;
  /// > 0: lock the tick phase to the arrival of states, ticking this long after each (see
  /// Daemon). For a plant or driver that sends states at the control rate on its own clock; not
  /// for a lockstep plant, whose states answer the commands.
  double sync_margin_us = 0.0;
};

/// What a run measured; the figures of --summary.
struct Summary {
  int64_t ticks = 0;
  double rate_hz = 0.0;
  double seconds = 0.0;
  int64_t overruns = 0;
  Percentiles jitter_us;   ///< wake-up time minus scheduled time
  Percentiles compute_us;  ///< state read → command encoded (the control computation)
  Percentiles publish_us;  ///< the send system call: LCM over UDP multicast delivers to every
                           ///< local subscriber socket inside it, so it grows with their number
  Percentiles latency_us;  ///< state arrival at this process → its command sent
  double tracking_rms = 0.0, tracking_max = 0.0;  ///< |q_d − q| over commanding ticks, rad or m
  int64_t commands = 0;
  int64_t send_failures = 0;
  int64_t lost_timing_records = 0;  ///< ticks missing from the figures (the status thread fell behind)
  int64_t stale_states = 0;
  int64_t rejected_messages = 0;
  int64_t faults = 0;
  int64_t foreign_commands = 0;  ///< messages heard on the command channel that this process did not send
  bool realtime_granted = false;
};

class Daemon {
 public:
  /// Keeps a reference to `model`. Throws chasles::Error if LCM cannot start on the URL.
  Daemon(const RobotModel& model, const DaemonOptions& options);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Listens on the command channel first (at least 50 ms): if another sender is heard there,
  /// throws chasles::Error ("another controller is already commanding ...; refusing to
  /// start"). Then runs until `stop` becomes true or options.seconds have passed; returns the
  /// summary. A foreign command heard while running is a FAULT for good: no more commands.
  Summary run(const std::atomic<bool>& stop);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace chasles::controller
