// The simulated arm on a bus: dynamics (Plant) in its environment, zero-order hold of the latest
// valid command, the watchdog's brake, injected faults on the states it sends, the truth beside
// them, one step at a time on a Clock.
// chasles_plant runs it on the system clock and UDP multicast; the in-process tests run it beside
// a controller::Node on a SimulatedClock and a memq:// bus.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "chasles/controller/realtime/bus.hpp"
#include "chasles/controller/realtime/clock.hpp"
#include "chasles/core/model/model.hpp"
#include "chasles/core/simulation/plant.hpp"
#include "chasles/tools/simulation/messaging.hpp"

namespace chasles::plant {

struct SimulationOptions {
  double rate_hz = 1000.0;  ///< steps per second; one robot_state_t per step
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
  std::string prefix = "CHASLES_";  ///< channels PREFIX STATE, PREFIX COMMAND and PREFIX TRUTH
  Faults faults;
  /// Pushes, walls, a hidden payload, hidden friction (core/simulation/environment.hpp).
  EnvironmentOptions environment;
  /// Publish chasles.sim_truth_t on PREFIX TRUTH after every state even with an empty environment
  /// (with anything in it, always). Off by default: a fleet of arms pays no extra datagram per step.
  bool truth = false;
};

class Simulation {
 public:
  /// Starts at rest at q0 with viscous joint damping `damping`; subscribes to the command channel.
  /// Keeps references to model (the nominal model; see Plant), bus and clock. Throws
  /// chasles::ArgumentError when options.environment is not valid (checked_environment).
  Simulation(const RobotModel& model, const SimulationOptions& options, const Eigen::VectorXd& q0,
             const Eigen::VectorXd& damping, Bus& bus, const Clock& clock);
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

  int64_t period_ns() const { return period_ns_; }
  const Plant& plant() const { return plant_; }
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
  /// or a non-empty environment).
  bool publishes_truth() const { return publish_truth_; }
  /// The truth at the latest state produced (Truth::steps is its seq); steps −1 when the truth is
  /// not published (it is then not computed either).
  const Truth& truth() const { return plant_.truth(); }
  /// Truths whose send failed.
  int64_t truths_not_sent() const { return truth_publisher_.not_sent(); }
  /// One line on stderr: what the run did.
  void print_summary() const;

 private:
  static int max_in_flight(const SimulationOptions& options);
  int64_t max_command_lag() const;
  void on_command(const uint8_t* data, size_t size);
  void step_and_publish(const Eigen::Ref<const Eigen::VectorXd>& tau);
  /// Sends the latest state produced (through the faults) and its truth (past them).
  void publish_state(int64_t now_ns);
  void count_late_cycle(int64_t now_ns);
  std::string truth_summary() const;
  void update_brake(int64_t now_ns);

  SimulationOptions options_;
  Bus& bus_;
  const Clock& clock_;
  const std::string command_channel_;
  Plant plant_;
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
  Bus::Subscription subscription_;  // last: ended before what it feeds
};

}  // namespace chasles::plant
