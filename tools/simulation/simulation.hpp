// The simulated arm on a bus: its dynamics (a Physics: chasles's own Plant in its environment, or
// MuJoCo's), zero-order hold of the latest valid command, the watchdog's brake, injected faults on
// the states it sends, the truth beside them, one step at a time on a Clock. It speaks one
// protocol (controller/transport/protocol.hpp): chasles's own, or Drake's iiwa or Panda driver's,
// with that driver's conventions (docs/protocols.md, "The plant speaks them too").
// chasles_plant runs it on the system clock and UDP multicast; the in-process tests run it beside
// a controller::Node on a SimulatedClock and a memq:// bus.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <atomic>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/model/model.hpp"
#include "core/simulation/environment.hpp"
#include "core/simulation/physics.hpp"
#include "tools/simulation/driver.hpp"
#include "tools/simulation/messaging.hpp"

namespace chasles::plant {

struct SimulationOptions {
  /// Steps per second; one status per step. A real iiwa's driver publishes at 200 Hz (FRI's 5 ms,
  /// controller::nominal_status_period), a Panda's at 1 kHz; chasles_plant takes the protocol's
  /// rate when --rate is not given.
  double rate_hz = 1000.0;
  int substeps = 1;         ///< RK4 steps per step
  /// One step per command answering the latest state, at once (deterministic); else real time.
  bool lockstep = false;
  double timeout_ms = 50.0;  ///< real time: brake after this long without a valid command
  /// Real time: a command answering a state more than this much older than the newest counts as
  /// none (< 0: timeout_ms). The injected delays are added.
  double max_lag_ms = -1.0;
  /// Real time: brake after this many late cycles in a row (0: never), as Franka's FCI stops
  /// the arm after 20 (communication_constraints_violation).
  int max_late = 20;
  std::string prefix = "CHASLES_";  ///< channels PREFIX STATE, PREFIX COMMAND (chasles's protocol) and PREFIX TRUTH
  /// The protocol spoken: chasles's robot_state_t / joint_torque_command_t, or Drake's
  /// lcmt_iiwa_status / lcmt_iiwa_command or lcmt_panda_status / lcmt_panda_command, as their
  /// drivers speak them.
  controller::Protocol protocol = controller::Protocol::kChasles;
  /// Empty: the protocol's (controller::default_channels: PREFIX STATE and PREFIX COMMAND, or
  /// IIWA_STATUS / IIWA_COMMAND, PANDA_STATUS / PANDA_COMMAND).
  std::string status_channel, command_channel;
  /// What a command's torque is: the whole joint torque (kFull), or the torque on top of the
  /// gravity the driver compensates (kOverlay: the plant applies command + g(q) of its nominal
  /// model, the bare arm, as the driver does with the model it was configured with). None: the
  /// protocol's (controller::default_torque_semantics: full for chasles, overlay for Drake's).
  std::optional<controller::TorqueSemantics> torque_semantics;
  Faults faults;
  /// Pushes, walls, a hidden payload, hidden friction (core/simulation/environment.hpp).
  EnvironmentOptions environment;
  /// Publish chasles.sim_truth_t on PREFIX TRUTH after every state even with an empty environment
  /// (with anything in it, always). Off by default: a fleet of arms pays no extra datagram per step.
  bool truth = false;
  /// Real time: pauses of the whole simulation (stall_due).
  Stalls stalls;
};

/// A clock that stops while the simulation pauses: the base clock's time less every pause so far.
/// The plant's watchdog, its deadlines and its commands' arrival times then see no gap, and its
/// states' utime (seq periods from the start) none either: a simulator that stalls resumes where
/// it stopped, as one paced by a busy process does.
class PausableClock final : public Clock {
 public:
  explicit PausableClock(const Clock& base) : base_(base) {}
  int64_t now_ns() const override { return base_.now_ns() - paused(); }
  int64_t utime_us() const override { return base_.utime_us() - paused() / 1000; }
  void sleep_until(int64_t t_ns) const override { base_.sleep_until(t_ns + paused()); }
  /// Counts `ns` more as paused (the caller has waited them, or will).
  void pause(int64_t ns) { paused_ns_.fetch_add(ns, std::memory_order_relaxed); }
  int64_t paused() const { return paused_ns_.load(std::memory_order_relaxed); }

 private:
  const Clock& base_;
  std::atomic<int64_t> paused_ns_{0};
};

/// When a stalling simulation pauses (SimulationOptions::stalls): each time the simulated time
/// passes another every_s, for a time drawn uniformly from [min_ms, max_ms] by a seeded generator.
class StallSchedule {
 public:
  /// Throws ArgumentError unless 0 ≤ min_ms ≤ max_ms.
  StallSchedule(const Stalls& stalls, double rate_hz);
  /// How long to pause after the step that produced state `seq`, ns (0: none).
  int64_t due(int64_t seq);

 private:
  Stalls stalls_;
  int64_t every_ = 0;  // steps between pauses
  int64_t next_seq_ = 0;
  std::mt19937_64 rng_;
};

class Simulation {
 public:
  /// Starts at rest at q0 with viscous joint damping `damping`; subscribes to the command channel.
  /// Keeps references to model (the nominal model; see Plant), bus and clock. Throws
  /// chasles::ArgumentError when options.environment is not valid (checked_environment), or a
  /// Drake protocol is asked for more than 10^6 steps per second (its statuses are told apart by
  /// their utime, µs).
  Simulation(const RobotModel& model, const SimulationOptions& options, const Eigen::VectorXd& q0,
             const Eigen::VectorXd& damping, Bus& bus, const Clock& clock);
  /// The same on another engine (MuJoCo's: tools/mujoco), which steps at 1 / options.rate_hz and
  /// starts where the caller put it. options.environment and options.substeps are chasles's plant's:
  /// with an engine given, an environment is refused (ArgumentError); the engine's own scene is its
  /// environment.
  Simulation(const RobotModel& model, const SimulationOptions& options, std::unique_ptr<Physics> physics, Bus& bus,
             const Clock& clock);
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Sends the initial state (seq 0), and its truth.
  void start();
  /// Real time: one step of 1 / rate_hz at the clock's present — the deadline check, the
  /// watchdog, the held command (or the brake), the state sent — and the delayed states that
  /// are due. A step is a late cycle when, from the first command on, no command answering the
  /// previous state (state_seq = that state's seq) has arrived: the controller missed the cycle.
  /// A step that comes less than 0.9 periods after the last (this process catching up after it
  /// was held up) gave the controller no full period and is not judged.
  void step();
  /// Lockstep: sends the latest state again when nothing answered it for 10 ms, and the delayed
  /// states that are due; returns when it needs to run again (the steps themselves happen as
  /// commands arrive).
  int64_t serve_lockstep();
  /// Real time: a step that came more than a period late (the caller's schedule slipped).
  void count_overrun() { ++overruns_; }
  /// Real time, after a step: how long the whole simulation pauses now, ns (0: it goes on). Each
  /// time the simulated time passes another options.stalls.every_s, a pause drawn uniformly from
  /// [min_ms, max_ms]; the caller holds its step loop that long and counts it paused on the
  /// simulation's PausableClock.
  int64_t stall_due();

  int64_t period_ns() const { return period_ns_; }
  controller::Protocol protocol() const { return options_.protocol; }
  controller::TorqueSemantics torque_semantics() const { return driver_.semantics(); }
  const std::string& status_channel() const { return status_channel_; }
  const std::string& command_channel() const { return command_channel_; }
  /// The utime of the state numbered seq, µs: the plant's clock at start() plus seq periods.
  int64_t state_utime(int64_t seq) const { return times_.utime(seq); }
  /// The seq of the state sent stamped `utime`; −1 when none was.
  int64_t state_seq(int64_t utime) const { return times_.seq(utime); }
  const Physics& plant() const { return *physics_; }
  bool braking() const { return braking_; }
  int64_t steps() const { return seq_; }
  int64_t brakes() const { return brakes_; }
  /// Real time: steps whose previous state no command answered in time, in all and in a row now.
  int64_t late_cycles() const { return late_cycles_; }
  int64_t late_in_a_row() const { return late_in_a_row_; }
  /// Real time: brakes for --max-late late cycles in a row.
  int64_t late_stops() const { return late_stops_; }
  /// Real time: steps not judged because they came early (see step()).
  int64_t unjudged_steps() const { return unjudged_; }
  int64_t rejected_commands() const { return inbox_.rejected(); }
  int64_t stale_commands() const { return stale_ + inbox_.stale(); }
  int64_t states_not_sent() const { return publisher_.dropped(); }
  /// Whether a sim_truth_t goes out on PREFIX TRUTH right after every state produced (options.truth
  /// or an engine with an environment: Physics::has_environment).
  bool publishes_truth() const { return publish_truth_; }
  /// The truth at the latest state produced (Truth::steps is its seq); steps −1 when the truth is
  /// not published (it is then not computed either).
  const Truth& truth() const { return physics_->truth(); }
  /// Truths whose send failed.
  int64_t truths_not_sent() const { return truth_publisher_.not_sent(); }
  /// One line on stderr: what the run did.
  void print_summary() const;

 private:
  Simulation(const RobotModel& model, const SimulationOptions& options, std::unique_ptr<Physics> physics, Bus& bus,
             const Clock& clock, bool own_plant);
  static int max_in_flight(const SimulationOptions& options);
  int64_t max_command_lag() const;
  void on_command(const uint8_t* data, size_t size);
  /// One step under a command (`fresh`: it arrived since the last step), the driver's gravity
  /// added under overlay; or under the brake.
  void step_and_publish(const Eigen::VectorXd& tau);
  /// Sends the latest state produced (through the faults) and its truth (past them).
  void publish_state(int64_t now_ns);
  void count_late_cycle(int64_t now_ns);
  std::string truth_summary() const;
  void update_brake(int64_t now_ns);

  SimulationOptions options_;
  Bus& bus_;
  const Clock& clock_;
  const std::string status_channel_, command_channel_;
  std::unique_ptr<Physics> physics_;
  Driver driver_;
  StateTimes times_;
  CommandInbox inbox_;
  StatePublisher publisher_;
  const bool publish_truth_;
  TruthPublisher truth_publisher_;
  const double dt_;
  const int64_t period_ns_;
  const double brake_time_constant_;
  int64_t last_send_ns_ = 0;
  int64_t start_utime_ = 0;  // the wall-clock time of the first state, µs
  int64_t seq_ = 0, stale_ = 0, overruns_ = 0, brakes_ = 0;
  int64_t late_cycles_ = 0, late_in_a_row_ = 0, late_stops_ = 0, unjudged_ = 0;
  // The account as it stood when the latest command arrived (see print_summary).
  struct Commanded {
    int64_t last_command_ns = -1, first_step = 0, last_step = 0, late_cycles = 0, late_stops = 0;
  } commanded_;
  bool braking_ = true;  // real time: held until the first command
  StallSchedule stalls_;
  Bus::Subscription subscription_;  // last: ended before what it feeds
};

}  // namespace chasles::plant
