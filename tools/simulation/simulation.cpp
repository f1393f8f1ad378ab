#include "tools/simulation/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.hpp"
#include "core/simulation/plant.hpp"

namespace chasles::plant {
namespace {

// Before the first command, and whenever the answer to a state is lost, a lockstep plant sends
// its latest state again this often, so a controller can start (or resume).
constexpr int64_t kLockstepRepeatNs = 10'000'000;
// The brake's velocity time constant. It is held over a step like any torque, so it must be
// several steps long to stay stable at low rates.
constexpr double kBrakeTimeConstant = 0.05;
constexpr int kBrakeStepsPerTimeConstant = 10;

controller::TorqueSemantics semantics_of(const SimulationOptions& options) {
  return options.torque_semantics.value_or(controller::default_torque_semantics(options.protocol));
}

std::string status_channel_of(const SimulationOptions& options) {
  return options.status_channel.empty() ? controller::default_channels(options.protocol, options.prefix).status
                                        : options.status_channel;
}

std::string command_channel_of(const SimulationOptions& options) {
  return options.command_channel.empty() ? controller::default_channels(options.protocol, options.prefix).command
                                         : options.command_channel;
}

}  // namespace

StallSchedule::StallSchedule(const Stalls& stalls, double rate_hz)
    : stalls_(stalls), every_(std::max<int64_t>(1, std::llround(stalls.every_s * rate_hz))), rng_(stalls.seed) {
  if (stalls.any() && !(stalls.min_ms >= 0.0 && stalls.min_ms <= stalls.max_ms)) {
    throw ArgumentError("stalls: 0 <= min <= max ms");
  }
}

int64_t StallSchedule::due(int64_t seq) {
  if (!stalls_.any()) return 0;
  if (next_seq_ == 0) next_seq_ = every_;
  if (seq < next_seq_) return 0;
  next_seq_ += every_;
  std::uniform_real_distribution<double> ms(stalls_.min_ms, stalls_.max_ms);
  return std::llround(ms(rng_) * 1e6);
}

Simulation::Simulation(const RobotModel& model, const SimulationOptions& options, const Eigen::VectorXd& q0,
                       const Eigen::VectorXd& damping, Bus& bus, const Clock& clock)
    : Simulation(model, options,
                 std::make_unique<Plant>(model, q0, damping, 1.0 / options.rate_hz, options.substeps, options.environment),
                 bus, clock, /*own_plant=*/true) {}

Simulation::Simulation(const RobotModel& model, const SimulationOptions& options, std::unique_ptr<Physics> physics,
                       Bus& bus, const Clock& clock)
    : Simulation(model, options, std::move(physics), bus, clock, /*own_plant=*/false) {}

Simulation::Simulation(const RobotModel& model, const SimulationOptions& options, std::unique_ptr<Physics> physics,
                       Bus& bus, const Clock& clock, bool own_plant)
    : options_(options),
      bus_(bus),
      clock_(clock),
      status_channel_(status_channel_of(options)),
      command_channel_(command_channel_of(options)),
      physics_(std::move(physics)),
      driver_(model, semantics_of(options)),
      times_(1.0 / options.rate_hz, &seq_),
      inbox_(clock, command_channel_, model.dof(), options.protocol, &times_),
      publisher_(bus, status_channel_, model.dof(), options.faults, max_in_flight(options), options.protocol),
      publish_truth_(options.truth || physics_->has_environment()),
      truth_publisher_(bus, options.prefix + "TRUTH", model.dof()),
      dt_(1.0 / options.rate_hz),
      period_ns_(static_cast<int64_t>(std::llround(1e9 / options.rate_hz))),
      brake_time_constant_(std::max(kBrakeTimeConstant, kBrakeStepsPerTimeConstant * dt_)),
      stalls_(options.stalls, options.rate_hz) {
  if (!own_plant && options.environment.any()) {
    throw ArgumentError("the plant's environment (pushes, walls, payload, friction, perturbed inertias) is chasles's "
                        "own plant's; another engine has its own scene");
  }
  if (options.protocol != controller::Protocol::kChasles && options.rate_hz > 1e6) {
    throw ArgumentError(std::string("a rate of more than 10^6 steps per second for ") +
                        controller::to_string(options.protocol) +
                        ": its statuses are told apart by their utime, which counts microseconds");
  }
  if (!options.lockstep) inbox_.require_recent(&seq_, max_command_lag());
  subscription_ = bus.subscribe(command_channel_, [this](const uint8_t* data, size_t size) { on_command(data, size); });
}

// Delayed states wait in a fixed queue: at most the steps of one delay, plus the lockstep repeats,
// plus slack.
int Simulation::max_in_flight(const SimulationOptions& options) {
  const double per_second = options.rate_hz + 1e9 / kLockstepRepeatNs;
  return static_cast<int>(std::ceil((options.faults.delay_ms + options.faults.spike_ms) * 1e-3 * per_second)) + 4;
}

// Real time: how many steps a command's state_seq may lag the newest state. The plant's own
// injected delays are added: they stand for the network, not for a late controller.
int64_t Simulation::max_command_lag() const {
  const double lag_ms = (options_.max_lag_ms < 0.0 ? options_.timeout_ms : options_.max_lag_ms) +
                        options_.faults.delay_ms + options_.faults.spike_ms;
  return static_cast<int64_t>(std::ceil(lag_ms * 1e-3 * options_.rate_hz));
}

void Simulation::start() {
  start_utime_ = clock_.utime_us();
  times_.start(start_utime_);
  publish_state(clock_.now_ns());
}

// The truth goes out right after the state it belongs to is produced, whatever the faults do to
// that state: a dropped or delayed state still has its truth, on time. Drake's statuses carry the
// external joint torque: the truth's, sampled first (zero with nothing in the environment).
void Simulation::publish_state(int64_t now_ns) {
  // The time of the sample: seq steps of the integrator after the start, whenever it was computed.
  const int64_t utime = times_.utime(seq_);
  const Truth* truth = nullptr;
  if (options_.protocol == controller::Protocol::kChasles) {
    publisher_.encode(utime, seq_, physics_->q(), physics_->qd(), physics_->effort());
  } else {
    if (physics_->has_environment()) truth = &physics_->sample_truth();
    const int64_t robot_utime = std::llround(1e6 * static_cast<double>(seq_) * dt_);
    publisher_.encode(utime, seq_, physics_->q(), driver_.report(*physics_, truth != nullptr ? &truth->tau_ext : nullptr, robot_utime));
  }
  publisher_.send(now_ns);
  last_send_ns_ = now_ns;
  if (!publish_truth_) return;
  if (truth == nullptr) truth = &physics_->sample_truth();
  truth_publisher_.publish(utime, seq_, *truth);
}

// Lockstep: one step per command that answers the latest state (state_seq == seq), applied at
// once; time stands still in between, so there is no watchdog. Commands answering an older state
// are ignored as stale.
void Simulation::on_command(const uint8_t* data, size_t size) {
  inbox_.receive(data, size);
  if (!options_.lockstep || !inbox_.fresh()) return;
  const Command& command = inbox_.take();
  if (command.state_seq != seq_) {
    ++stale_;
    return;
  }
  step_and_publish(driver_.command(command, true, physics_->q()));
}

void Simulation::step_and_publish(const Eigen::VectorXd& tau) {
  physics_->step(tau);
  ++seq_;
  publish_state(clock_.now_ns());
}

void Simulation::step() {
  const int64_t now = clock_.now_ns();
  count_late_cycle(now);
  update_brake(now);
  if (braking_) {
    step_and_publish(driver_.brake(physics_->brake_torque(brake_time_constant_), physics_->q()));
  } else {
    const bool fresh = inbox_.fresh();
    step_and_publish(driver_.command(inbox_.take(), fresh, physics_->q()));
  }
  publisher_.flush(now);
  inbox_.report_rejections(now);
}

int64_t Simulation::stall_due() { return options_.lockstep ? 0 : stalls_.due(seq_); }

int64_t Simulation::serve_lockstep() {
  const int64_t now = clock_.now_ns();
  if (now - last_send_ns_ >= kLockstepRepeatNs) {
    publisher_.send(now);
    last_send_ns_ = now;
  }
  const int64_t next_delayed = publisher_.flush(now);
  inbox_.report_rejections(now);
  return std::min(last_send_ns_ + kLockstepRepeatNs, next_delayed);
}

// The deadline an arm keeps: the command for this step must answer the state sent at the last.
// A step that comes early — this process was held up and catches up on its schedule — gave the
// controller less than a period, so it is not judged (a real arm's steps never come early).
void Simulation::count_late_cycle(int64_t now_ns) {
  if (!inbox_.any()) return;  // not commanded yet: nothing is late
  if (inbox_.latest_arrival_ns() != commanded_.last_command_ns) {  // the account up to the latest command
    if (commanded_.last_command_ns < 0) commanded_.first_step = seq_;
    commanded_ = {inbox_.latest_arrival_ns(), commanded_.first_step, seq_, late_cycles_, late_stops_};
  }
  if (now_ns - last_send_ns_ < period_ns_ - period_ns_ / 10) {
    ++unjudged_;
    return;
  }
  if (inbox_.latest().state_seq == seq_) {
    late_in_a_row_ = 0;
    return;
  }
  ++late_cycles_;
  ++late_in_a_row_;
}

// The watchdog: brake while no valid command has arrived for the timeout, and until the first;
// and, as an arm does, after max_late late cycles in a row, until a command is on time again.
void Simulation::update_brake(int64_t now_ns) {
  const auto timeout_ns = static_cast<int64_t>(options_.timeout_ms * 1e6);
  const bool silent = !inbox_.any() || now_ns - inbox_.latest_arrival_ns() > timeout_ns;
  const bool late = options_.max_late > 0 && late_in_a_row_ >= options_.max_late;
  const bool brake = silent || late;
  if (brake == braking_) return;
  braking_ = brake;
  if (!brake) {
    std::fprintf(stderr, "chasles_plant: commands on %s: brake released\n", command_channel_.c_str());
    return;
  }
  ++brakes_;
  if (silent) {
    std::fprintf(stderr, "chasles_plant: no valid command on %s for %g ms: braking to rest\n", command_channel_.c_str(),
                 options_.timeout_ms);
  } else {
    ++late_stops_;
    std::fprintf(stderr,
                 "chasles_plant: %lld late cycles in a row on %s (no command answered the previous state in time): "
                 "braking to rest\n",
                 static_cast<long long>(late_in_a_row_), command_channel_.c_str());
  }
}

// Late cycles are reported up to the last command, and apart after it: when a controller stops, the
// silence that follows is the end of its session (its late stop included), not deadlines it missed
// while it ran.
void Simulation::print_summary() const {
  const int64_t steps = commanded_.last_step - commanded_.first_step;
  std::fprintf(stderr,
               "chasles_plant: stopped after %lld steps (%.3f s simulated); late cycles %lld of %lld commanded steps "
               "(%.3f %%), late stops %lld; after the last command %lld late cycles, %lld late stops; early steps not "
               "judged %lld; commands rejected %lld, stale %lld; states not sent %lld; overruns %lld; brakes %lld%s\n",
               static_cast<long long>(seq_), static_cast<double>(seq_) * dt_,
               static_cast<long long>(commanded_.late_cycles), static_cast<long long>(steps),
               steps > 0 ? 100.0 * static_cast<double>(commanded_.late_cycles) / static_cast<double>(steps) : 0.0,
               static_cast<long long>(commanded_.late_stops), static_cast<long long>(late_cycles_ - commanded_.late_cycles),
               static_cast<long long>(late_stops_ - commanded_.late_stops), static_cast<long long>(unjudged_),
               static_cast<long long>(rejected_commands()), static_cast<long long>(stale_commands()),
               static_cast<long long>(publisher_.dropped()), static_cast<long long>(overruns_),
               static_cast<long long>(brakes_), truth_summary().c_str());
}

std::string Simulation::truth_summary() const {
  if (!publish_truth_) return {};
  return "; truths sent on " + options_.prefix + "TRUTH, not sent " + std::to_string(truth_publisher_.not_sent());
}

}  // namespace chasles::plant
