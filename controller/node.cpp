#include "chasles/controller/node.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace chasles::controller {

Node::Snapshot::Snapshot(int n)
    : q(Eigen::VectorXd::Zero(n)),
      q_desired(Eigen::VectorXd::Zero(n)),
      error(Eigen::VectorXd::Zero(n)),
      torque(Eigen::VectorXd::Zero(n)),
      tau_ext(Eigen::VectorXd::Zero(n)) {}

void Node::Timing::record(const TickRecord& r) {
  jitter.record(r.jitter_us);
  compute.record(r.compute_us);
  if (r.latency_us >= 0.0) latency.record(r.latency_us);
  if (r.commanded) publish.record(r.publish_us);
}

void Node::Timing::merge(const Timing& other) {
  jitter.merge(other.jitter);
  compute.merge(other.compute);
  latency.merge(other.latency);
  publish.merge(other.publish);
}

void Node::Timing::reset() {
  jitter.reset();
  compute.reset();
  latency.reset();
  publish.reset();
}

Node::LoadedModel Node::loaded(const RobotModel& model, const std::optional<Payload>& payload) {
  if (!payload) return {model, 0.0};
  return {with_payload(model, *payload), payload->mass};
}

Node::Node(const RobotModel& model, const DaemonOptions& options, const Clock& clock, Buses buses)
    : model_(model),
      options_(options),
      clock_(clock),
      buses_(buses),
      n_(model.dof()),
      period_ns_(static_cast<int64_t>(std::llround(options.control.period * 1e9))),
      channels_(options.channel_prefix),
      models_(loaded(model, options.payload)),
      payloads_(Payload{}),
      modes_(8, LawSettings(n_)),
      states_(JointState(n_)),
      targets_(16, Target(n_)),
      snapshots_(Snapshot(n_)),
      requests_(CartesianRequest(n_)),
      paths_(2, JointPath(n_)),
      state_receiver_(n_, states_),
      target_receiver_(n_, targets_),
      mode_receiver_(n_, modes_),
      payload_receiver_(payloads_, planner_bell_),
      command_watch_(sent_commands_),
      command_encoder_(n_),
      controller_(models_.front().model, options.control),
      state_(n_),
      target_(n_),
      mode_(n_),
      payload_mass_(models_.front().payload_mass),
      request_(n_),
      path_(n_),
      solver_(model),
      ik_request_(n_),
      ik_path_(n_),
      data_(model),
      last_(n_) {
  subscriptions_.push_back(buses.receive.subscribe(channels_.state, [this](const uint8_t* data, size_t size) {
    if (const std::string why = state_receiver_.receive(data, size, arrival_ns(buses_.receive)); !why.empty()) {
      rejections_.add("robot state " + why);
    }
  }));
  subscriptions_.push_back(buses.receive.subscribe(channels_.target, [this](const uint8_t* data, size_t size) {
    if (const std::string why = target_receiver_.receive(data, size); !why.empty()) rejections_.add("target " + why);
  }));
  subscriptions_.push_back(buses.receive.subscribe(channels_.mode, [this](const uint8_t* data, size_t size) {
    if (const std::string why = mode_receiver_.receive(data, size); !why.empty()) rejections_.add("control mode " + why);
  }));
  subscriptions_.push_back(buses.receive.subscribe(channels_.payload, [this](const uint8_t* data, size_t size) {
    if (const std::string why = payload_receiver_.receive(data, size); !why.empty()) rejections_.add("payload " + why);
  }));
  subscriptions_.push_back(buses.receive.subscribe(
      channels_.command, [this](const uint8_t* data, size_t size) { command_watch_.receive(data, size); }));
  status_.num_joints = n_;
}

std::string Node::refusal() const {
  if (command_watch_.foreign() == 0) return {};
  return "another controller is already commanding " + channels_.command + " (heard " +
         std::to_string(command_watch_.foreign()) + " command(s) before this one sent any, first seq " +
         std::to_string(command_watch_.first_seq()) + "); refusing to start";
}

// When the message being handled reached this host: the kernel's stamp where the bus has one,
// so that the latency includes LCM's receive thread and the hand-over to this one; else now.
int64_t Node::arrival_ns(const Bus& bus) const {
  const int64_t now = clock_.now_ns();
  const int64_t stamp_us = bus.arrival_utime();
  if (stamp_us < 0) return now;
  const int64_t age_ns = (clock_.utime_us() - stamp_us) * 1000;
  return now - std::clamp<int64_t>(age_ns, 0, period_ns_ * 1000);  // a wall clock stepped meanwhile: bounded
}

int64_t Node::first_tick() const { return clock_.now_ns() + period_ns_; }

int64_t Node::tick(int64_t scheduled) {
  const int64_t wake = clock_.now_ns();
  const bool state_driven = options_.tick == TickSource::kState;
  const Mode mode_before = controller_.mode();
  TickRecord record;

  const bool fresh = states_.read(state_);
  if (fresh) have_state_ = true;
  const int64_t trigger = state_driven && fresh ? state_.arrival_ns : scheduled;
  record.jitter_us = 1e-3 * static_cast<double>(wake - trigger);
  if (command_watch_.foreign() > 0 && !controller_.stood_down()) stand_down();
  if (models_.take()) {  // a payload built by the worker, between two ticks
    controller_.set_model(models_.front().model);
    payload_mass_ = models_.front().payload_mass;
  }
  // Modes before targets: a target sent after a law is meant for it.
  while (modes_.pop(mode_)) controller_.set_law(mode_, wake);
  while (targets_.pop(target_)) controller_.set_target(target_, wake);
  if (controller_.take_request(request_)) {
    requests_.write(request_);
    planner_bell_.ring();
  }
  if (paths_.pop(path_)) {
    controller_.follow(path_, wake);
    planner_bell_.ring();  // room for a path the worker may be holding
  }
  const bool command = controller_.tick(wake, have_state_ ? &state_ : nullptr);
  int64_t utime = 0;
  if (command) command_encoder_.encode(utime = clock_.utime_us(), ++seq_, state_.seq, controller_.torque());
  const int64_t computed = clock_.now_ns();
  record.compute_us = 1e-3 * static_cast<double>(computed - wake);
  int64_t sent = computed;
  if (command) {
    sent_commands_.record(seq_, utime);  // before the send: our own copy may come back at once
    if (!buses_.command.publish(channels_.command, command_encoder_.bytes())) ++counters_.send_failures;
    sent = clock_.now_ns();
    record.publish_us = 1e-3 * static_cast<double>(sent - computed);
    if (state_.seq != answered_seq_) {
      record.latency_us = 1e-3 * static_cast<double>(sent - state_.arrival_ns);
      answered_seq_ = state_.seq;
    }
    record.commanded = true;
    record.error_max = controller_.error().cwiseAbs().maxCoeff();
    record.error_sq = controller_.error().squaredNorm();
    ++counters_.commands;
  }
  const int64_t finished = clock_.now_ns();

  ++counters_.ticks;
  int64_t next = 0;
  if (state_driven) {
    if (fresh && sent - trigger > period_ns_) ++counters_.overruns;
    next = fresh ? trigger + period_ns_ + period_ns_ / 2 : scheduled + period_ns_;
    next = std::max(next, finished);
  } else {
    next = scheduled + period_ns_;
    if (finished > next) {
      const int64_t missed = (finished - next) / period_ns_ + 1;
      counters_.overruns += missed;
      next += missed * period_ns_;
    }
  }
  if (!records_.push(record)) ++counters_.lost_records;
  publish_snapshot();
  // The status goes out at once on what an operator must hear about now.
  const int64_t rejected = controller_.rejected_targets() + controller_.rejected_modes(),
                foreign = command_watch_.foreign();
  if (controller_.mode() != mode_before || rejected != noticed_rejections_ || foreign != noticed_foreign_) {
    noticed_rejections_ = rejected;
    noticed_foreign_ = foreign;
    reporter_bell_.ring();
  }
  return next;
}

// Someone else commands this arm (a second controller, a log replayed onto the live bus): two
// senders on one command channel drive the arm with whatever torque came last, so this one stops
// commanding for good and reports a FAULT; the arm's own watchdog takes over if the other sender
// stops too. Latched: only an operator can tell which sender should drive.
void Node::stand_down() {
  controller_.stand_down("another sender is commanding %s (seq %lld answering state %lld; our latest state %lld): "
                         "stopped commanding",
                         channels_.command.c_str(), static_cast<long long>(command_watch_.first_seq()),
                         static_cast<long long>(command_watch_.first_state_seq()),
                         static_cast<long long>(have_state_ ? state_.seq : -1));
}

// Written straight into the mailbox's free slot: nothing is copied twice on the loop.
void Node::publish_snapshot() {
  Snapshot& s = snapshots_.back();
  s.loop = counters_;
  s.mode = controller_.mode();
  std::memcpy(s.fault, controller_.fault_reason(), sizeof(s.fault));
  std::memcpy(s.rejection, controller_.last_rejection(), sizeof(s.rejection));
  std::memcpy(s.reflex, controller_.reflex_reason(), sizeof(s.reflex));
  const ContactEstimate& contact = controller_.contact();
  s.tau_ext = contact.tau_ext;
  s.wrench_ext = contact.wrench_base;
  s.contact = contact.contact;
  s.collision = contact.collision;
  s.contacts = controller_.contacts();
  s.reflexes = controller_.reflexes();
  s.peak_tip_force = controller_.peak_tip_force();
  s.q_desired = controller_.reference().q;
  s.error = controller_.error();
  s.q = s.q_desired - s.error;
  s.torque = controller_.torque();
  s.stale = controller_.stale_ticks();
  s.faults = controller_.faults();
  s.foreign_commands = command_watch_.foreign();
  s.rejected_targets = controller_.rejected_targets();
  s.law = controller_.law().law;
  s.payload_mass = payload_mass_;
  s.state_period = controller_.state_period();
  std::snprintf(s.period_warning, sizeof(s.period_warning), "%s", controller_.period_warning());
  std::memcpy(s.mode_rejection, controller_.mode_rejection(), sizeof(s.mode_rejection));
  // Which refusal is the newer, for the status message (targets are judged after modes in a tick).
  if (controller_.rejected_modes() != modes_seen_) mode_refused_last_ = true;
  if (controller_.rejected_targets() != targets_seen_) mode_refused_last_ = false;
  modes_seen_ = controller_.rejected_modes();
  targets_seen_ = controller_.rejected_targets();
  s.mode_refused_last = mode_refused_last_;
  s.rejected_modes = controller_.rejected_modes();
  s.ik_iterations = controller_.ik_iterations();
  s.ik_residual = controller_.ik_residual();
  s.ik_converged = controller_.ik_converged();
  snapshots_.publish();
}

// Ceres allocates and takes milliseconds: never on the loop, which only hands over requests and
// paths without waiting.
bool Node::plan() {
  if (payloads_.read(payload_)) {
    // The receiver checked it (payload_problem), so with_payload has nothing left to refuse; if it
    // does, the model in force stays, and the operator hears why.
    LoadedModel& next = models_.back();
    try {
      next.model = with_payload(model_, payload_);
    } catch (const Error& e) {
      std::fprintf(stderr, "chasles_controller: payload refused: %s\n", e.what());
      return false;
    }
    next.payload_mass = payload_.mass;
    models_.publish();
    return true;
  }
  if (!ik_path_waiting_) {
    if (!requests_.read(ik_request_)) return false;
    plan_cartesian_path(solver_, ik_request_, ik_path_);
    ik_path_waiting_ = true;
  }
  ik_path_waiting_ = !paths_.push(ik_path_);
  return !ik_path_waiting_;  // a path that found no room waits for the loop's ring
}

void Node::drain() {
  TickRecord r;
  while (records_.pop(r)) {
    window_.record(r);
    if (r.commanded) {
      error_sq_sum_ += r.error_sq;
      error_samples_ += n_;
      error_max_ = std::max(error_max_, r.error_max);
    }
  }
}

int64_t Node::report() {
  drain();
  const int64_t now = clock_.now_ns();
  const auto status_period = static_cast<int64_t>(1e9 / options_.status_hz);
  if (snapshots_.read(last_)) have_snapshot_ = true;
  if (!have_snapshot_) return now + status_period;
  const Snapshot& s = last_;
  const bool changed = s.mode != reported_mode_;
  if (s.faults != reported_faults_ && s.mode != Mode::kFault) {
    // A FAULT that was over before this step looked (a stall longer than the stale limit, then
    // fresh states again) is still said.
    std::fprintf(stderr, "chasles_controller: FAULT (over by now, %lld in all): %s\n",
                 static_cast<long long>(s.faults), s.fault);
  }
  reported_faults_ = s.faults;
  if (changed) {
    const char* detail = s.mode == Mode::kFault ? s.fault : s.mode == Mode::kReflex ? s.reflex : "";
    std::fprintf(stderr, "chasles_controller: %s%s%s\n", to_string(s.mode), *detail ? ": " : "", detail);
    reported_mode_ = s.mode;
  }
  if (s.rejected_targets != reported_rejections_) {
    const auto count = static_cast<long long>(s.rejected_targets - reported_rejections_);
    if (count == 1) {
      std::fprintf(stderr, "chasles_controller: target refused: %s\n", s.rejection);
    } else {
      std::fprintf(stderr, "chasles_controller: %lld targets refused, last: %s\n", count, s.rejection);
    }
    reported_rejections_ = s.rejected_targets;
  }
  if (s.rejected_modes != reported_modes_) {
    std::fprintf(stderr, "chasles_controller: control mode refused: %s\n", s.mode_rejection);
    reported_modes_ = s.rejected_modes;
  }
  if (const bool mismatch = *s.period_warning != '\0'; mismatch != period_warned_) {
    if (mismatch) {
      std::fprintf(stderr, "chasles_controller: warning: %s (give --rate the plant's)\n", s.period_warning);
    } else {
      std::fprintf(stderr, "chasles_controller: the robot states come at the configured period again\n");
    }
    period_warned_ = mismatch;
  }
  if (rejections_.count() != reported_wire_) {
    std::fprintf(stderr, "chasles_controller: rejected %lld message(s), last: %s\n",
                 static_cast<long long>(rejections_.count() - reported_wire_), rejections_.last());
    reported_wire_ = rejections_.count();
  }
  if (!changed && now - last_status_ns_ < status_period) return last_status_ns_ + status_period;
  last_status_ns_ = now;
  fill_status();
  total_.merge(window_);
  window_.reset();
  status_bytes_.resize(size_t(status_.getEncodedSize()));
  status_.encode(status_bytes_.data(), 0, static_cast<int>(status_bytes_.size()));
  buses_.status.publish(channels_.status, status_bytes_);
  return now + status_period;
}

void Node::fill_status() {
  const Snapshot& s = last_;
  controller_status_t& status = status_;
  status.utime = clock_.utime_us();
  status.state = static_cast<int8_t>(s.mode);
  status.message = s.mode == Mode::kFault    ? s.fault
                   : s.mode == Mode::kReflex ? s.reflex
                   : *s.period_warning != '\0' ? s.period_warning
                   : s.mode_refused_last     ? std::string("last control mode refused: ") + s.mode_rejection
                   : s.rejected_targets > 0  ? std::string("last target refused: ") + s.rejection
                                             : "";
  auto copy = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  status.q = copy(s.q);
  status.q_desired = copy(s.q_desired);
  status.tracking_error = copy(s.error);
  status.torque = copy(s.torque);
  status.tau_ext = copy(s.tau_ext);
  for (int i = 0; i < 6; ++i) status.tip_wrench_ext[i] = s.wrench_ext(i);
  status.contact = s.contact;
  status.collision = s.collision;
  status.contacts = s.contacts;
  status.reflexes = s.reflexes;
  status.law = law_to_wire(s.law);
  status.payload_mass = s.payload_mass;
  status.state_period = s.state_period;
  const Transform& T = forward_kinematics(model_, data_, s.q);
  const Eigen::Quaterniond quaternion(T.linear());
  for (int i = 0; i < 3; ++i) status.tip_position[i] = T.translation()(i);
  status.tip_quaternion[0] = quaternion.w();
  status.tip_quaternion[1] = quaternion.x();
  status.tip_quaternion[2] = quaternion.y();
  status.tip_quaternion[3] = quaternion.z();
  status.ik_iterations = s.ik_iterations;
  status.ik_residual = s.ik_residual;
  status.ik_converged = s.ik_converged;
  const Percentiles j = percentiles(window_.jitter), c = percentiles(window_.compute), l = percentiles(window_.latency);
  status.jitter_p50_us = j.p50, status.jitter_p99_us = j.p99, status.jitter_max_us = j.max;
  status.compute_p50_us = c.p50, status.compute_p99_us = c.p99, status.compute_max_us = c.max;
  status.latency_p50_us = l.p50, status.latency_p99_us = l.p99, status.latency_max_us = l.max;
  status.ticks = s.loop.ticks;
  status.overruns = s.loop.overruns;
  status.stale_states = s.stale;
  status.rejected_messages = rejections_.count() + s.rejected_targets + s.rejected_modes;
  status.faults = s.faults;
}

Summary Node::summary(double seconds) {
  drain();
  total_.merge(window_);
  window_.reset();
  if (snapshots_.read(last_)) have_snapshot_ = true;
  const Snapshot& s = last_;
  Summary summary;
  summary.ticks = s.loop.ticks;
  summary.seconds = seconds;
  summary.rate_hz = seconds > 0.0 ? static_cast<double>(s.loop.ticks) / seconds : 0.0;
  summary.overruns = s.loop.overruns;
  summary.state_driven = options_.tick == TickSource::kState;
  summary.jitter_us = percentiles(total_.jitter);
  summary.compute_us = percentiles(total_.compute);
  summary.latency_us = percentiles(total_.latency);
  summary.publish_us = percentiles(total_.publish);
  summary.send_failures = s.loop.send_failures;
  summary.lost_timing_records = s.loop.lost_records;
  summary.tracking_rms = error_samples_ ? std::sqrt(error_sq_sum_ / static_cast<double>(error_samples_)) : 0.0;
  summary.tracking_max = error_max_;
  summary.commands = s.loop.commands;
  summary.stale_states = s.stale;
  summary.rejected_messages = rejections_.count() + s.rejected_targets + s.rejected_modes;
  summary.faults = s.faults;
  summary.foreign_commands = s.foreign_commands;
  summary.contacts = s.contacts;
  summary.reflexes = s.reflexes;
  summary.peak_tip_force = s.peak_tip_force;
  summary.realtime_granted = realtime_granted_;
  return summary;
}

}  // namespace chasles::controller
