// The running controller: threads around one Controller, on the system clock and LCM.
//
//   real-time loop  state-driven (the default): blocks on the bus, and when a state arrives
//                   validates it, runs Controller::tick and publishes the command at once; with
//                   no state for 1.5 periods it ticks on the clock (the stale-state watchdog).
//                   --tick clock: ticks every period on an absolute-time sleep, with the latest
//                   state, and an LCM thread receives (for a plant that does not stream).
//   IK worker       plans Cartesian goals into joint paths with Ceres (milliseconds, allocating)
//   locator thread  finds where on the arm a contact is from the observer's external torque
//                   (milliseconds a search), woken by the loop while there is one; publishes
//                   contact_estimate_t on PREFIX CONTACT
//   status thread   drains the timing records into histograms, publishes controller_status_t
//                   at status_hz (at once on a change of mode) and reports changes on stderr
//
// Only the status thread and the caller allocate or print; the loop and the receivers hand over
// through lock-free mailboxes and a ring, and the loop wakes the workers with doorbells (idle,
// they cost no wake-ups). Each thread runs one step of a controller::Node (node.hpp) per turn,
// which the in-process tests run in simulated time.
#pragma once

#include <atomic>
#include <memory>

#include "controller/options.hpp"
#include "core/model/model.hpp"

namespace chasles::controller {

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
