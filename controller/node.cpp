#include "controller/node.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "controller/transport/scene_message.hpp"
#include "controller/transport/wire.hpp"
#include "controller/world.hpp"
#include "core/dynamics/dynamics.hpp"

namespace chasles::controller {

Node::Snapshot::Snapshot(int n)
    : q(Eigen::VectorXd::Zero(n)),
      q_desired(Eigen::VectorXd::Zero(n)),
      error(Eigen::VectorXd::Zero(n)),
      torque(Eigen::VectorXd::Zero(n)),
      tau_ext(Eigen::VectorXd::Zero(n)),
      generator{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n)} {}

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

Node::Loop::Loop(const RobotModel& model, const DaemonOptions& options, const Payload& payload_in)
    : controller(model, options.control),
      command_writer(options.protocol, model.dof(),
                     options.torque_semantics.value_or(default_torque_semantics(options.protocol)),
                     options.iiwa_positions),
      driver_gravity(Eigen::VectorXd::Zero(model.dof())),
      state(model.dof()),
      target(model.dof()),
      waypoints(model.dof()),
      setpoint(model.dof()),
      jog(model.dof()),
      mode(model.dof()),
      payload(payload_in),
      request(model.dof()),
      path(model.dof()),
      plant_state(model.dof()) {}

Node::Planner::Planner(const RobotModel& model, const motion::LimitConfig& config)
    : solver(model),
      limits(model, config),
      request(model.dof()),
      path(model.dof()),
      data(model),
      sampler(model.dof()),
      sampled(model.dof()) {
  checked.position = [this](double t, Eigen::VectorXd& q) {
    sampler.sample(t, sampled);
    q = sampled.q;
  };
  checked.speed = limits.velocity;  // what the path keeps to (plan_cartesian_path checks it)
  if (!checked.speed.allFinite()) checked.speed.resize(0);
}

void Node::Planner::use(const RobotModel& model, std::shared_ptr<const ClearanceWorld> next) {
  world = std::move(next);
  checker.reset(world ? new geometry::PathChecker(model, world->proximity) : nullptr);
  along_path.reset(world ? new geometry::ProximityData(world->proximity) : nullptr);
}

void Node::Planner::check(const RobotModel& model, JointPath& planned) {
  if (!world || !planned.ok) return;
  sampler.start(planned);
  checked.duration = sampler.duration();
  geometry::PathClearance c;
  try {
    c = checker->check(model, world->proximity, data, *along_path, checked);
  } catch (const Error& e) {  // a joint without a velocity limit: nothing bounds the path's speed
    planned.ok = false;
    std::snprintf(planned.reason, sizeof(planned.reason), "%.180s", e.what());
    return;
  }
  if (c.clear) return;
  planned.ok = false;
  if (c.pair < 0) {
    std::snprintf(planned.reason, sizeof(planned.reason), "the tip's path could not be checked to its end");
    return;
  }
  char name[128];
  world->proximity.name_pair(c.pair, name, sizeof(name));
  std::snprintf(planned.reason, sizeof(planned.reason),
                "the tip's path: %.96s would come within its stop distance %.3f m at t = %.3f s of %.3f s", name,
                world->proximity.pairs()[static_cast<size_t>(c.pair)].clearance.stop, c.time, checked.duration);
}

Node::Reporter::Reporter(const RobotModel& model) : data(model), last(model.dof()) {}

Node::Locating::Locating(const RobotModel& model) : data(model) {
  message = contact_estimate_t{};
  message.state = contact_estimate_t::NONE;
  message.link.reserve(256);
  bytes.resize(static_cast<size_t>(message.getEncodedSize()) + 256);
}

// chasles's channels with the prefix, the driver's status and command channels as the protocol
// names them unless given.
Channels channels_of(const DaemonOptions& options) {
  Channels channels(options.channel_prefix);
  const ProtocolChannels driver = default_channels(options.protocol, options.channel_prefix);
  channels.state = options.status_channel.empty() ? driver.status : options.status_channel;
  channels.command = options.command_channel.empty() ? driver.command : options.command_channel;
  return channels;
}

Node::LoadedModel Node::loaded(const RobotModel& model, const std::optional<Payload>& payload) {
  if (!payload) return {model, Payload{}};
  return {with_payload(model, *payload), *payload};
}

Node::Node(const RobotModel& model, const DaemonOptions& options, const Clock& clock, Buses buses)
    : model_(model),
      options_(options),
      clock_(clock),
      buses_(buses),
      n_(model.dof()),
      period_ns_(static_cast<int64_t>(std::llround(options.control.period * 1e9))),
      channels_(channels_of(options)),
      inbox_(model, options.protocol, channels_, clock, period_ns_, buses.receive, planner_bell_),
      models_(loaded(model, options.payload)),
      snapshots_(Snapshot(n_)),
      requests_(CartesianRequest(n_)),
      worlds_(options.clearance),
      paths_(2, JointPath(n_)),
      locate_inputs_(LocateInput{Eigen::VectorXd::Zero(n_), Eigen::VectorXd::Zero(n_)}),
      located_(contact_estimate_t{}),
      locations_(LocatedContact{}),
      loop_(models_.front().model, options, models_.front().payload),
      planner_(model, options.control.limits),
      locating_(model),
      reporter_(model) {
  reporter_.status.num_joints = n_;
  const DaemonOptions::Locate& locate = options.locate;
  if (!(locate.rate_hz > 0.0) || !std::isfinite(locate.rate_hz) || !(locate.floor >= 0.0) || !std::isfinite(locate.floor)) {
    throw ArgumentError("contact localisation: the rate must be > 0 Hz and the floor >= 0 N*m, both finite");
  }
  if (locate.enabled && !options.arm.objects.empty()) {
    locating_.locator = std::make_unique<geometry::ContactLocator>(model_, options.arm, locate.locator);
  }
  planner_.use(model_, options_.clearance);
  if (!loop_.controller.set_clearance_world(options_.clearance.get())) {
    throw ArgumentError("the collision geometry was built for another arm");
  }
}

std::string Node::refusal() const {
  if (foreign_commands() == 0) return {};
  char first[96];
  inbox_.own_commands().describe_first_foreign(first, sizeof(first));
  return "another controller is already commanding " + channels_.command + " (heard " +
         std::to_string(foreign_commands()) + " command(s) before this one sent any, the first " + first +
         "); refusing to start";
}

int64_t Node::first_tick() const { return clock_.now_ns() + period_ns_; }

int64_t Node::tick(int64_t scheduled) {
  const int64_t wake = clock_.now_ns();
  const bool state_driven = options_.tick == TickSource::kState;
  const Mode mode_before = loop_.controller.mode();
  TickRecord record;

  const bool fresh = inbox_.states.read(loop_.state);
  if (fresh) loop_.have_state = true;
  const int64_t trigger = state_driven && fresh ? loop_.state.arrival_ns : scheduled;
  record.jitter_us = 1e-3 * static_cast<double>(wake - trigger);
  // The controller's time: this host's clock, or with --simulator the plant's (its states' utime),
  // which stands still while the simulator pauses.
  int64_t now = wake;
  const JointState* state = loop_.have_state ? &loop_.state : nullptr;
  bool silent_simulator = false;
  if (options_.simulator && loop_.have_state) {
    if (fresh) follow_plant_time(wake);
    const int64_t silent = fresh ? 0 : wake - loop_.state.arrival_ns;
    silent_simulator = !fresh && silent <= options_.control.stale_ns;
    now = loop_.plant_ns + silent;
    state = &loop_.plant_state;
  }
  if (foreign_commands() > 0 && !loop_.controller.stood_down()) stand_down();
  if (worlds_.take()) loop_.controller.set_clearance_world(worlds_.front().get());  // a new scene
  if (locations_.take()) loop_.controller.take_location(locations_.front());
  if (models_.take()) {  // a payload built by the worker, between two ticks
    loop_.controller.set_model(models_.front().model);
    loop_.payload = models_.front().payload;
  }
  // Modes before targets: a target sent after a law is meant for it.
  while (inbox_.modes.pop(loop_.mode)) loop_.controller.set_law(loop_.mode, now);
  while (inbox_.targets.pop(loop_.target)) loop_.controller.set_target(loop_.target, now);
  while (inbox_.trajectories.pop(loop_.waypoints)) loop_.controller.set_trajectory(loop_.waypoints, now);
  while (inbox_.setpoints.pop(loop_.setpoint)) loop_.controller.set_setpoint(loop_.setpoint, now);
  while (inbox_.jogs.pop(loop_.jog)) loop_.controller.set_jog(loop_.jog, now);
  while (inbox_.tip_setpoints.pop(loop_.tip_setpoint)) loop_.controller.set_tip_setpoint(loop_.tip_setpoint, now);
  if (loop_.controller.take_request(loop_.request)) {
    requests_.write(loop_.request);
    planner_bell_.ring();
  }
  if (paths_.pop(loop_.path)) {
    loop_.controller.follow(loop_.path, now);
    planner_bell_.ring();  // room for a path the worker may be holding
  }
  // A simulator that pauses is waited for: no tick until it speaks again, or until the pause is
  // longer than the stale limit (the watchdog's tick then finds the state stale).
  const bool command = !silent_simulator && loop_.controller.tick(now, state);
  int64_t utime = 0;
  if (command) {
    if (loop_.command_writer.semantics() == TorqueSemantics::kOverlay) {
      // The controller's Data holds g(q) at this state of the arm it drives, payload included:
      // less the payload's part, from the same Data, it is the bare arm's.
      const Data& data = loop_.controller.data();
      loop_.driver_gravity.setZero();
      add_payload_gravity(loop_.controller.model(), data, loop_.payload, loop_.driver_gravity);
      loop_.driver_gravity = data.g - loop_.driver_gravity;
    }
    loop_.command_writer.write(utime = clock_.utime_us(), ++loop_.seq, loop_.state, loop_.controller.torque(),
                               loop_.driver_gravity);
  }
  const int64_t computed = clock_.now_ns();
  record.compute_us = 1e-3 * static_cast<double>(computed - wake);
  int64_t sent = computed;
  if (command) {
    // Before the send: our own copy may come back at once.
    inbox_.own_commands().record(loop_.seq, utime, loop_.command_writer.bytes());
    if (!buses_.command.publish(channels_.command, loop_.command_writer.bytes())) ++loop_.counters.send_failures;
    sent = clock_.now_ns();
    record.publish_us = 1e-3 * static_cast<double>(sent - computed);
    if (loop_.state.seq != loop_.answered_seq) {
      record.latency_us = 1e-3 * static_cast<double>(sent - loop_.state.arrival_ns);
      loop_.answered_seq = loop_.state.seq;
    }
    record.commanded = true;
    record.error_max = loop_.controller.error().cwiseAbs().maxCoeff();
    record.error_sq = loop_.controller.error().squaredNorm();
    ++loop_.counters.commands;
  }
  const int64_t finished = clock_.now_ns();

  ++loop_.counters.ticks;
  int64_t next = 0;
  if (state_driven) {
    if (fresh && sent - trigger > period_ns_) ++loop_.counters.overruns;
    next = fresh ? trigger + period_ns_ + period_ns_ / 2 : scheduled + period_ns_;
    next = std::max(next, finished);
  } else {
    next = scheduled + period_ns_;
    if (finished > next) {
      const int64_t missed = (finished - next) / period_ns_ + 1;
      loop_.counters.overruns += missed;
      next += missed * period_ns_;
    }
  }
  if (!records_.push(record)) ++loop_.counters.lost_records;
  publish_snapshot();
  if (fresh && locating_.locator) hand_to_locator();
  // The status goes out at once on what an operator must hear about now.
  const int64_t rejected = loop_.controller.rejected_targets() + loop_.controller.rejected_modes(),
                foreign = foreign_commands();
  const TrajectoryProgress::Outcome outcome = loop_.controller.trajectory().outcome;
  if (loop_.controller.mode() != mode_before || rejected != loop_.noticed_rejections ||
      foreign != loop_.noticed_foreign || outcome != loop_.noticed_outcome) {
    loop_.noticed_rejections = rejected;
    loop_.noticed_foreign = foreign;
    loop_.noticed_outcome = outcome;
    reporter_bell_.ring();
  }
  return next;
}

// --simulator: the plant's time at the state just read, its utime on this host's clock from the
// first state on, and the state stamped with it. A utime that does not move forward (a simulation
// started again from 0) continues the plant's time one period on, as a restarted count does.
void Node::follow_plant_time(int64_t wake) {
  const int64_t utime_ns = loop_.state.utime * 1000;
  if (!loop_.plant_anchored || utime_ns + loop_.plant_offset_ns <= loop_.plant_ns) {
    loop_.plant_offset_ns = (loop_.plant_anchored ? loop_.plant_ns + period_ns_ : wake) - utime_ns;
    loop_.plant_anchored = true;
  }
  loop_.plant_ns = utime_ns + loop_.plant_offset_ns;
  loop_.plant_state = loop_.state;
  loop_.plant_state.arrival_ns = loop_.plant_ns;
}

// Someone else commands this arm (a second controller, a log replayed onto the live bus): two
// senders on one command channel drive the arm with whatever torque came last, so this one stops
// commanding for good and reports a FAULT; the arm's own watchdog takes over if the other sender
// stops too. Latched: only an operator can tell which sender should drive.
void Node::stand_down() {
  char first[96];
  inbox_.own_commands().describe_first_foreign(first, sizeof(first));
  const bool by_seq = inbox_.own_commands().by_seq();  // else by the utime of the status answered
  const int64_t latest = !loop_.have_state ? -1 : by_seq ? loop_.state.seq : loop_.state.utime;
  loop_.controller.stand_down("another sender is commanding %s (%s; our latest state %s%lld): stopped commanding",
                              channels_.command.c_str(), first, by_seq ? "" : "utime ",
                              static_cast<long long>(latest));
}

// The locator is woken only while there is something to find, and once more when it has gone (to
// say so); otherwise it takes the newest state when it looks.
void Node::hand_to_locator() {
  LocateInput& in = locate_inputs_.back();
  in.q = loop_.state.q;
  in.tau_ext = loop_.controller.contact().tau_ext;
  in.utime = loop_.state.utime;
  in.seq = loop_.state.seq;
  const bool above = in.tau_ext.norm() >= options_.locate.floor;
  locate_inputs_.publish();
  if (above || above_floor_) locator_bell_.ring();
  above_floor_ = above;
}

// Its own thread: a search over the arm's surface takes milliseconds, many ticks. A state under
// the floor is NONE, published once when the last estimate was LOCATED.
int64_t Node::locate() {
  constexpr int64_t kIdleNs = 100'000'000;
  const int64_t now = clock_.now_ns();
  if (!locating_.locator) return now + kIdleNs;
  if (now < locating_.next_ns) return locating_.next_ns;
  if (!locate_inputs_.take()) return now + kIdleNs;
  const LocateInput& in = locate_inputs_.front();
  contact_estimate_t& m = locating_.message;
  const double norm = in.tau_ext.norm();
  const bool above = norm >= options_.locate.floor;
  if (!above && !locating_.located) return now + kIdleNs;
  if (!above) m = contact_estimate_t{};  // NONE: every field zero
  m.utime = in.utime;
  m.seq = in.seq;
  m.tau_ext_norm = norm;
  if (above) {
    space_jacobian(model_, locating_.data, in.q);
    const geometry::ContactEstimate& e = locating_.locator->locate(locating_.data, in.tau_ext);
    m.state = contact_estimate_t::LOCATED;
    m.link.assign(e.link);
    m.body = e.body;
    for (int k = 0; k < 3; ++k) m.point[k] = e.point[k], m.normal[k] = e.normal[k], m.force[k] = e.force[k];
    m.residual = e.residual;
    m.contact = e.force.norm() >= options_.control.contact.contact_force;
    locations_.write(LocatedContact{e.body, e.link, e.point, e.force});
  }
  locating_.located = above;
  const int64_t done = clock_.now_ns();
  m.compute_us = 1e-3 * static_cast<double>(done - now);
  const auto size = static_cast<size_t>(m.getEncodedSize());
  if (size > locating_.bytes.size()) locating_.bytes.resize(size);
  m.encode(locating_.bytes.data(), 0, static_cast<int>(size));
  buses_.status.publish(channels_.contact, locating_.bytes.data(), size);
  located_.write(m);
  locating_.next_ns = now + static_cast<int64_t>(std::llround(1e9 / options_.locate.rate_hz));
  return locating_.next_ns;
}

// Written straight into the mailbox's free slot: nothing is copied twice on the loop.
void Node::publish_snapshot() {
  Snapshot& s = snapshots_.back();
  s.loop = loop_.counters;
  s.mode = loop_.controller.mode();
  std::memcpy(s.fault, loop_.controller.fault_reason(), sizeof(s.fault));
  std::memcpy(s.rejection, loop_.controller.last_rejection(), sizeof(s.rejection));
  std::memcpy(s.reflex, loop_.controller.reflex_reason(), sizeof(s.reflex));
  const ContactEstimate& contact = loop_.controller.contact();
  s.tau_ext = contact.tau_ext;
  s.wrench_ext = contact.wrench_base;
  s.contact = contact.contact;
  s.collision = contact.collision;
  s.contacts = loop_.controller.contacts();
  s.reflexes = loop_.controller.reflexes();
  s.peak_tip_force = loop_.controller.peak_tip_force();
  s.q_desired = loop_.controller.reference().q;
  s.error = loop_.controller.error();
  s.q = s.q_desired - s.error;
  s.torque = loop_.controller.torque();
  s.stale = loop_.controller.stale_ticks();
  s.faults = loop_.controller.faults();
  s.foreign_commands = foreign_commands();
  s.rejected_targets = loop_.controller.rejected_targets();
  s.law = loop_.controller.law().law;
  s.payload_mass = loop_.payload.mass;
  s.state_period = loop_.controller.state_period();
  std::snprintf(s.period_warning, sizeof(s.period_warning), "%s", loop_.controller.period_warning());
  std::memcpy(s.mode_rejection, loop_.controller.mode_rejection(), sizeof(s.mode_rejection));
  // Which refusal is the newer, for the status message (targets are judged after modes in a tick).
  if (loop_.controller.rejected_modes() != loop_.modes_seen) loop_.mode_refused_last = true;
  if (loop_.controller.rejected_targets() != loop_.targets_seen) loop_.mode_refused_last = false;
  loop_.modes_seen = loop_.controller.rejected_modes();
  loop_.targets_seen = loop_.controller.rejected_targets();
  s.mode_refused_last = loop_.mode_refused_last;
  s.rejected_modes = loop_.controller.rejected_modes();
  s.ik_iterations = loop_.controller.ik_iterations();
  s.ik_residual = loop_.controller.ik_residual();
  s.ik_converged = loop_.controller.ik_converged();
  s.trajectory = loop_.controller.trajectory();
  s.streaming = loop_.controller.streaming();
  s.setpoints = loop_.controller.setpoints();
  s.dropped_setpoints = loop_.controller.dropped_setpoints();
  s.jogging = loop_.controller.jogging();
  s.jogs = loop_.controller.jogs();
  s.dropped_jogs = loop_.controller.dropped_jogs();
  s.jog = loop_.controller.jog_progress();
  s.clearance = loop_.controller.clearance();
  s.generator = loop_.controller.generator_limits();
  snapshots_.publish();
}

// Ceres allocates and takes milliseconds: never on the loop, which only hands over requests and
// paths without waiting.
bool Node::build_scene() {
  const SceneBytes& received = inbox_.scenes.front();
  char why[192];
  if (!decode_scene(received.bytes.data(), received.size, planner_.scene, why, sizeof(why))) {
    std::fprintf(stderr, "chasles_controller: scene refused: %s\n", why);
    return false;
  }
  if (options_.arm.objects.empty()) {
    std::fprintf(stderr, "chasles_controller: scene refused: the arm has no collision geometry (--collision)\n");
    return false;
  }
  try {
    worlds_.back() = make_world(model_, options_.arm, planner_.scene, options_.proximity);
  } catch (const Error& e) {  // a plane binding a link without a collision object
    std::fprintf(stderr, "chasles_controller: scene refused: %s\n", e.what());
    return false;
  }
  planner_.use(model_, worlds_.back());
  worlds_.publish();
  std::fprintf(stderr, "chasles_controller: scene: %zu objects, %zu planes\n", planner_.scene.objects.size(),
               planner_.scene.planes.size());
  return true;
}

bool Node::plan() {
  if (inbox_.scenes.take()) return build_scene();
  if (inbox_.payloads.read(planner_.payload)) {
    // The receiver checked it (payload_problem), so with_payload has nothing left to refuse; if it
    // does, the model in force stays, and the operator hears why.
    LoadedModel& next = models_.back();
    try {
      next.model = with_payload(model_, planner_.payload);
    } catch (const Error& e) {
      std::fprintf(stderr, "chasles_controller: payload refused: %s\n", e.what());
      return false;
    }
    next.payload = planner_.payload;
    models_.publish();
    return true;
  }
  if (!planner_.path_waiting) {
    if (!requests_.read(planner_.request)) return false;
    plan_cartesian_path(planner_.solver, planner_.limits, planner_.request, planner_.path);
    planner_.check(model_, planner_.path);
    planner_.path_waiting = true;
  }
  planner_.path_waiting = !paths_.push(planner_.path);
  return !planner_.path_waiting;  // a path that found no room waits for the loop's ring
}

void Node::drain() {
  TickRecord r;
  while (records_.pop(r)) {
    reporter_.window.record(r);
    if (r.commanded) {
      reporter_.error_sq_sum += r.error_sq;
      reporter_.error_samples += n_;
      reporter_.error_max = std::max(reporter_.error_max, r.error_max);
    }
  }
}

int64_t Node::report() {
  drain();
  const int64_t now = clock_.now_ns();
  const auto status_period = static_cast<int64_t>(1e9 / options_.status_hz);
  if (snapshots_.read(reporter_.last)) reporter_.have_snapshot = true;
  if (!reporter_.have_snapshot) return now + status_period;
  const Snapshot& s = reporter_.last;
  const bool changed = s.mode != reporter_.reported_mode;
  if (s.faults != reporter_.reported_faults && s.mode != Mode::kFault) {
    // A FAULT that was over before this step looked (a stall longer than the stale limit, then
    // fresh states again) is still said.
    std::fprintf(stderr, "chasles_controller: FAULT (over by now, %lld in all): %s\n",
                 static_cast<long long>(s.faults), s.fault);
  }
  reporter_.reported_faults = s.faults;
  if (changed) {
    const char* detail = s.mode == Mode::kFault ? s.fault : s.mode == Mode::kReflex ? s.reflex : "";
    std::fprintf(stderr, "chasles_controller: %s%s%s\n", to_string(s.mode), *detail ? ": " : "", detail);
    reporter_.reported_mode = s.mode;
  }
  if (s.rejected_targets != reporter_.reported_rejections) {
    const auto count = static_cast<long long>(s.rejected_targets - reporter_.reported_rejections);
    if (count == 1) {
      std::fprintf(stderr, "chasles_controller: target refused: %s\n", s.rejection);
    } else {
      std::fprintf(stderr, "chasles_controller: %lld targets refused, last: %s\n", count, s.rejection);
    }
    reporter_.reported_rejections = s.rejected_targets;
  }
  if (s.rejected_modes != reporter_.reported_modes) {
    std::fprintf(stderr, "chasles_controller: control mode refused: %s\n", s.mode_rejection);
    reporter_.reported_modes = s.rejected_modes;
  }
  if (const bool mismatch = *s.period_warning != '\0'; mismatch != reporter_.period_warned) {
    if (mismatch) {
      std::fprintf(stderr, "chasles_controller: warning: %s (give --rate the plant's)\n", s.period_warning);
    } else {
      std::fprintf(stderr, "chasles_controller: the robot states come at the configured period again\n");
    }
    reporter_.period_warned = mismatch;
  }
  if (s.trajectory.outcome != TrajectoryProgress::kRejected &&
      (s.trajectory.id != reporter_.reported_trajectory || s.trajectory.outcome != reporter_.reported_outcome)) {
    // Refusals are said above, as targets; what a trajectory taken becomes is said here.
    std::fprintf(stderr, "chasles_controller: trajectory %lld %s%s%s\n", static_cast<long long>(s.trajectory.id),
                 to_string(s.trajectory.outcome), *s.trajectory.message ? ": " : "", s.trajectory.message);
  }
  reporter_.reported_trajectory = s.trajectory.id;
  reporter_.reported_outcome = s.trajectory.outcome;
  if (inbox_.rejections().count() != reporter_.reported_wire) {
    std::fprintf(stderr, "chasles_controller: rejected %lld message(s), last: %s\n",
                 static_cast<long long>(inbox_.rejections().count() - reporter_.reported_wire), inbox_.rejections().last());
    reporter_.reported_wire = inbox_.rejections().count();
  }
  if (const int64_t lost = buses_.receive.lost(); lost != reporter_.reported_lost) {
    std::fprintf(stderr, "chasles_controller: lost %lld message(s) before they could be read, last: %s\n",
                 static_cast<long long>(lost - reporter_.reported_lost), buses_.receive.last_loss());
    reporter_.reported_lost = lost;
  }
  if (!changed && now - reporter_.last_status_ns < status_period) return reporter_.last_status_ns + status_period;
  reporter_.last_status_ns = now;
  fill_status();
  reporter_.total.merge(reporter_.window);
  reporter_.window.reset();
  reporter_.status_bytes.resize(size_t(reporter_.status.getEncodedSize()));
  reporter_.status.encode(reporter_.status_bytes.data(), 0, static_cast<int>(reporter_.status_bytes.size()));
  buses_.status.publish(channels_.status, reporter_.status_bytes);
  return now + status_period;
}

void Node::fill_status() {
  const Snapshot& s = reporter_.last;
  controller_status_t& status = reporter_.status;
  status.utime = clock_.utime_us();
  status.state = to_wire(s.mode);
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
  status.generator_velocity_limit = copy(s.generator.velocity);
  status.generator_acceleration_limit = copy(s.generator.acceleration);
  status.generator_jerk_limit = copy(s.generator.jerk);
  for (int i = 0; i < 6; ++i) status.tip_wrench_ext[i] = s.wrench_ext(i);
  status.contact = s.contact;
  status.collision = s.collision;
  status.contacts = s.contacts;
  status.reflexes = s.reflexes;
  status.law = to_wire(s.law);
  status.payload_mass = s.payload_mass;
  status.state_period = s.state_period;
  status.trajectory_id = s.trajectory.id;
  status.trajectory_outcome = to_wire(s.trajectory.outcome);
  status.trajectory_elapsed = s.trajectory.elapsed;
  status.trajectory_duration = s.trajectory.duration;
  status.trajectory_time_scale = s.trajectory.scale;
  status.trajectory_waypoint = s.trajectory.waypoint;
  status.trajectory_message = s.trajectory.message;
  status.streaming = s.streaming;
  status.setpoints = s.setpoints;
  status.setpoints_dropped = s.dropped_setpoints;
  status.jogging = s.jogging;
  status.jogs = s.jogs;
  status.jogs_dropped = s.dropped_jogs;
  status.jog_condition = s.jog.condition;
  status.jog_scale = s.jog.scale;
  status.jog_limited_by = to_wire(s.jog.limited_by);
  status.jog_joint = s.jog.joint;
  status.clearance_pair = s.clearance.closest >= 0 ? s.clearance.closest_name : "";
  status.clearance_distance = s.clearance.closest >= 0 ? s.clearance.closest_distance : 0.0;
  for (int k = 0; k < 3; ++k) {
    status.clearance_points[0][k] = s.clearance.closest >= 0 ? s.clearance.closest_arm[k] : 0.0;
    status.clearance_points[1][k] = s.clearance.closest >= 0 ? s.clearance.closest_other[k] : 0.0;
  }
  status.clearance_slowed_by = s.clearance.slowing >= 0 ? s.clearance.slowing_name : "";
  status.clearance_kept = s.clearance.kept;
  located_.read(reporter_.located);
  const contact_estimate_t& found = reporter_.located;
  const bool located = found.state == contact_estimate_t::LOCATED;
  status.contact_link = located ? found.link : "";
  status.contact_located_flag = located && found.contact;
  for (int k = 0; k < 3; ++k) {
    status.contact_point[k] = located ? found.point[k] : 0.0;
    status.contact_force[k] = located ? found.force[k] : 0.0;
  }
  const Transform& T = forward_kinematics(model_, reporter_.data, s.q);
  const Eigen::Quaterniond quaternion(T.linear());
  for (int i = 0; i < 3; ++i) status.tip_position[i] = T.translation()(i);
  status.tip_quaternion[0] = quaternion.w();
  status.tip_quaternion[1] = quaternion.x();
  status.tip_quaternion[2] = quaternion.y();
  status.tip_quaternion[3] = quaternion.z();
  status.ik_iterations = s.ik_iterations;
  status.ik_residual = s.ik_residual;
  status.ik_converged = s.ik_converged;
  const Timing& window = reporter_.window;
  const Percentiles j = percentiles(window.jitter), c = percentiles(window.compute), l = percentiles(window.latency);
  status.jitter_p50_us = j.p50, status.jitter_p99_us = j.p99, status.jitter_max_us = j.max;
  status.compute_p50_us = c.p50, status.compute_p99_us = c.p99, status.compute_max_us = c.max;
  status.latency_p50_us = l.p50, status.latency_p99_us = l.p99, status.latency_max_us = l.max;
  status.ticks = s.loop.ticks;
  status.overruns = s.loop.overruns;
  status.stale_states = s.stale;
  status.rejected_messages = inbox_.rejections().count() + s.rejected_targets + s.rejected_modes + buses_.receive.lost();
  status.faults = s.faults;
}

Summary Node::summary(double seconds) {
  drain();
  reporter_.total.merge(reporter_.window);
  reporter_.window.reset();
  if (snapshots_.read(reporter_.last)) reporter_.have_snapshot = true;
  const Snapshot& s = reporter_.last;
  Summary summary;
  summary.ticks = s.loop.ticks;
  summary.seconds = seconds;
  summary.rate_hz = seconds > 0.0 ? static_cast<double>(s.loop.ticks) / seconds : 0.0;
  summary.overruns = s.loop.overruns;
  summary.state_driven = options_.tick == TickSource::kState;
  summary.jitter_us = percentiles(reporter_.total.jitter);
  summary.compute_us = percentiles(reporter_.total.compute);
  summary.latency_us = percentiles(reporter_.total.latency);
  summary.publish_us = percentiles(reporter_.total.publish);
  summary.send_failures = s.loop.send_failures;
  summary.lost_timing_records = s.loop.lost_records;
  const Reporter& r = reporter_;
  summary.tracking_rms = r.error_samples ? std::sqrt(r.error_sq_sum / static_cast<double>(r.error_samples)) : 0.0;
  summary.tracking_max = reporter_.error_max;
  summary.commands = s.loop.commands;
  summary.stale_states = s.stale;
  summary.rejected_messages = inbox_.rejections().count() + s.rejected_targets + s.rejected_modes + buses_.receive.lost();
  summary.faults = s.faults;
  summary.foreign_commands = s.foreign_commands;
  summary.contacts = s.contacts;
  summary.reflexes = s.reflexes;
  summary.peak_tip_force = s.peak_tip_force;
  summary.realtime_granted = realtime_granted_;
  return summary;
}

}  // namespace chasles::controller
