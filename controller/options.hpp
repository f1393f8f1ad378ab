// What the daemon is asked to do and what a run measured: the settings and the summary that the
// Daemon (daemon.hpp) and the Node whose steps it runs (node.hpp) share. A header of their own, so
// that the node does not include the daemon that calls it.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "controller/controller.hpp"
#include "controller/transport/protocol.hpp"
#include "core/geometry/contact_locator.hpp"
#include "controller/statistics.hpp"
#include "core/model/payload.hpp"

namespace chasles::controller {

/// What starts a tick.
enum class TickSource {
  kState,  ///< a state's arrival (and the clock, as the watchdog, when states stop)
  kClock,  ///< the clock, every period: for a plant that does not stream (a --lockstep plant)
};

struct DaemonOptions {
  Config control;
  /// The arm's collision geometry and its scene, built before the loop starts (world.hpp); nullptr:
  /// none, nothing kept clear. A scene_t received replaces the scene: the worker builds its world
  /// from `arm` and `proximity` (an arm without objects: the scene is refused).
  std::shared_ptr<ClearanceWorld> clearance;
  geometry::CollisionModel arm;
  geometry::ProximityOptions proximity;
  /// A load known at the tip from the start, on the model the daemon is given (which carries none);
  /// a payload_t received at run time replaces it.
  std::optional<Payload> payload;
  std::string lcm_url;  ///< empty: LCM's default (or $LCM_DEFAULT_URL)
  std::string channel_prefix = "CHASLES_";
  /// The arm driver's protocol (protocol.hpp, docs/protocols.md): the status read and the command
  /// sent, on the channels below (empty: the protocol's, PREFIX STATE / COMMAND for chasles's);
  /// every other channel is chasles's, with the prefix.
  Protocol protocol = Protocol::kChasles;
  std::string status_channel, command_channel;
  /// What the command's torque means to the driver; unset: the protocol's default.
  std::optional<TorqueSemantics> torque_semantics;
  /// The position fields of an iiwa torque command.
  IiwaPositions iiwa_positions = IiwaPositions::kNone;
  bool realtime = false;  ///< SCHED_FIFO, mlockall, CPU affinity and wake latency for the loop (warn if refused)
  int priority = 80;
  int cpu = -1;
  /// With --realtime: the longest wake-up from idle allowed every CPU while the loop runs, µs
  /// (CpuWakeLatency; 0: idle cores poll); < 0: nothing asked.
  int cpu_wake_latency_us = 0;
  double seconds = 0.0;  ///< stop after this long; 0: run until stopped
  double status_hz = 100.0;
  /// Where on the arm a contact is (core/geometry/contact_locator.hpp), on a thread of its own, from
  /// the observer's τ̂_ext of the newest state: at most rate_hz times a second while |τ̂_ext| ≥
  /// floor N·m, published as contact_estimate_t on PREFIX CONTACT. Needs `arm`'s collision objects
  /// (none: no locator).
  struct Locate {
    bool enabled = true;
    double rate_hz = 100.0;
    double floor = 0.2;
    geometry::ContactLocatorOptions locator;
  } locate;
  TickSource tick = TickSource::kState;
  /// Read the receiving socket on the loop's own thread (Bus::Receive::kDirect, udpm:// only)
  /// rather than through LCM's receive thread.
  bool direct_receive = true;
  /// The plant is a simulator that may pause (Drake's, paced by Python on a busy host): the
  /// controller keeps the plant's time — its states' utime — for the motion, the observer and the
  /// stale rule, so a pause in this host's time is no stale state and the motion waits for it;
  /// control.stale_ns is then how long a silent simulator is waited for before the FAULT. Never for
  /// a real arm, whose time does not stop.
  bool simulator = false;
};

/// What a run measured; the figures of --summary.
struct Summary {
  int64_t ticks = 0;
  double rate_hz = 0.0;
  double seconds = 0.0;
  /// Clock ticks: periods missed by a tick that ran late. State-driven: commands sent more than a
  /// period after their state arrived (the plant's next step came first).
  int64_t overruns = 0;
  bool state_driven = true;
  Percentiles jitter_us;   ///< tick start minus its trigger: the state's arrival at this host (kernel
                           ///< receive time) for a state-driven tick, else the scheduled time
  Percentiles compute_us;  ///< state read → command encoded (the control computation)
  Percentiles publish_us;  ///< the send system call: LCM over UDP multicast delivers to every
                           ///< local subscriber socket inside it, so it grows with their number
  Percentiles latency_us;  ///< state arrival at this host (kernel receive time on udpm://) → its
                           ///< command sent
  double tracking_rms = 0.0, tracking_max = 0.0;  ///< |q_d − q| over commanding ticks, rad or m
  int64_t commands = 0;
  int64_t send_failures = 0;
  int64_t lost_timing_records = 0;  ///< ticks missing from the figures (the status thread fell behind)
  int64_t stale_states = 0;
  int64_t rejected_messages = 0;
  int64_t faults = 0;
  int64_t foreign_commands = 0;  ///< messages heard on the command channel that this process did not send
  int64_t contacts = 0;          ///< times the contact flag rose
  int64_t reflexes = 0;          ///< collisions that started the reflex
  double peak_tip_force = 0.0;   ///< the largest estimated external force at the tip, N
  bool realtime_granted = false;
};

}  // namespace chasles::controller
