#include "chasles/controller/daemon.hpp"

#include <lcm/lcm.h>

#include <chasles/controller_status_t.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

#include "chasles/controller/clock.hpp"
#include "chasles/controller/lcm_io.hpp"
#include "chasles/controller/mailbox.hpp"
#include "chasles/controller/realtime.hpp"
#include "chasles/core/kinematics/kinematics.hpp"

namespace chasles::controller {
namespace {

// One tick's measurements, queued by the loop for the status thread.
struct TickRecord {
  double jitter_us = 0.0;
  double compute_us = 0.0;  // state read → command encoded
  double publish_us = 0.0;  // the send system call (LCM hands the datagram to every local subscriber)
  double latency_us = -1.0;  // < 0: the tick answered no new state
  double error_max = 0.0;    // max |e_i|, when the tick commanded
  double error_sq = 0.0;     // Σ e_i²
  bool commanded = false;
};

// The loop's own counts, totals since start.
struct LoopCounters {
  int64_t ticks = 0, overruns = 0, commands = 0, send_failures = 0;
  int64_t lost_records = 0;  // timing records the status thread fell too far behind to take
};

// What the loop shows the status thread, every tick.
struct Snapshot {
  Mode mode = Mode::kWaiting;
  char fault[192] = {};
  char rejection[192] = {};
  Eigen::VectorXd q, q_desired, error, torque;
  int ik_iterations = 0;
  double ik_residual = 0.0;
  bool ik_converged = false;
  LoopCounters loop;
  int64_t stale = 0, faults = 0, rejected_targets = 0, foreign_commands = 0;
  explicit Snapshot(int n = 0)
      : q(Eigen::VectorXd::Zero(n)), q_desired(Eigen::VectorXd::Zero(n)), error(Eigen::VectorXd::Zero(n)),
        torque(Eigen::VectorXd::Zero(n)) {}
};

// An lcm_t that lives as long as the member holding it (declared before its subscribers, so it
// is destroyed after they unsubscribe).
class Lcm {
 public:
  explicit Lcm(const std::string& url) : lcm_(lcm_create(url.empty() ? nullptr : url.c_str())) {
    if (lcm_ == nullptr) {
      throw Error("LCM could not start on " + (url.empty() ? std::string("its default URL") : url) +
                               " (no multicast route? inside a network namespace run tools/netns.sh)");
    }
  }
  ~Lcm() { lcm_destroy(lcm_); }
  Lcm(const Lcm&) = delete;
  Lcm& operator=(const Lcm&) = delete;
  lcm_t* get() const { return lcm_; }

 private:
  lcm_t* lcm_;
};

// Timing figures of the status window and of the whole run.
struct Timing {
  Histogram jitter, compute, latency;
  void record(const TickRecord& r) {
    jitter.record(r.jitter_us);
    compute.record(r.compute_us);
    if (r.latency_us >= 0.0) latency.record(r.latency_us);
  }
  void merge(const Timing& other) {
    jitter.merge(other.jitter);
    compute.merge(other.compute);
    latency.merge(other.latency);
  }
  void reset() {
    jitter.reset();
    compute.reset();
    latency.reset();
  }
};

// How long a controller listens on its command channel before it starts: several periods of a
// controller that is already running, at any rate a sender at 20 Hz or more would show.
constexpr double kListenBeforeStart_s = 0.05;

}  // namespace

struct Daemon::Impl {
  const RobotModel& model;
  DaemonOptions options;
  int n;
  Channels channels;
  // Three LCM instances, so that the loop's publish never waits on a lock another thread holds.
  Lcm lcm_rx, lcm_command, lcm_status;
  Rejections rejections;
  Mailbox<JointState> states;
  SpscRing<Target> targets;
  Mailbox<Snapshot> snapshots;
  SpscRing<TickRecord> records{8192};
  // Loop → IK worker: only the newest request matters (a newer target supersedes the others).
  Mailbox<CartesianRequest> requests;
  // IK worker → loop.
  SpscRing<JointPath> paths;            // IK worker → loop
  StateReceiver state_receiver;
  TargetReceiver target_receiver;
  CommandPublisher command_publisher;
  SentCommands sent_commands;
  CommandWatch command_watch;  // on the LCM thread, beside the receivers
  Controller controller;
  std::atomic<bool> done{false};
  bool realtime_granted = false;

  // Status thread's side.
  Snapshot last;  // the newest snapshot read
  Timing window, total;
  Histogram publish_window, publish_total;
  double error_sq_sum = 0.0, error_max = 0.0;
  int64_t error_samples = 0;

  Impl(const RobotModel& m, const DaemonOptions& o)
      : model(m),
        options(o),
        n(m.dof()),
        channels(o.channel_prefix),
        lcm_rx(o.lcm_url),
        lcm_command(o.lcm_url),
        lcm_status(o.lcm_url),
        states(JointState(m.dof())),
        targets(16, Target(m.dof())),

        snapshots(Snapshot(m.dof())),
        requests(CartesianRequest(m.dof())),
        paths(2, JointPath(m.dof())),
        state_receiver(lcm_rx.get(), channels.state, m.dof(), states, rejections),
        target_receiver(lcm_rx.get(), channels.target, m.dof(), targets, rejections),
        command_publisher(lcm_command.get(), channels.command, m.dof()),
        command_watch(lcm_rx.get(), channels.command, sent_commands),
        controller(m, o.control),
        last(m.dof()) {}

  void receive_loop() {
    while (!done.load(std::memory_order_relaxed)) lcm_handle_timeout(lcm_rx.get(), 20);
  }

  // Plans Cartesian goals into joint paths with Ceres, which allocates and takes milliseconds:
  // never on the loop, which only hands over requests and paths without waiting.
  void ik_loop() {
    IkSolver solver(model);
    CartesianRequest request(n);
    JointPath path(n);
    while (!done.load(std::memory_order_relaxed)) {
      if (!requests.read(request)) {
        sleep_until(monotonic_ns() + 1'000'000);
        continue;
      }
      plan_cartesian_path(solver, request, path);
      while (!paths.push(path) && !done.load(std::memory_order_relaxed)) sleep_until(monotonic_ns() + 1'000'000);
    }
  }

  void realtime_loop(const std::atomic<bool>& stop) {
    minimise_timer_slack();
    if (options.realtime) {
      const auto warnings = make_realtime(options.priority, options.cpu);
      for (const auto& w : warnings) std::fprintf(stderr, "chasles_controller: warning: %s\n", w.c_str());
      realtime_granted = warnings.empty();
    }
    const auto period = static_cast<int64_t>(std::llround(options.control.period * 1e9));
    JointState state(n);
    Target target(n);
    CartesianRequest request(n);
    JointPath path(n);
    LoopCounters counters;
    bool have_state = false;
    int64_t answered_seq = -1, seq = 0, phase_shift = 0;
    const int64_t start = monotonic_ns();
    const int64_t end = options.seconds > 0.0 ? start + static_cast<int64_t>(options.seconds * 1e9) : INT64_MAX;
    int64_t next = start + period;
    while (!stop.load(std::memory_order_relaxed) && next <= end) {
      sleep_until(next);
      const int64_t wake = monotonic_ns();
      TickRecord record;
      record.jitter_us = 1e-3 * static_cast<double>(wake - next);

      if (states.read(state)) have_state = true;
      if (command_watch.foreign() > 0 && !controller.stood_down()) stand_down(state, have_state);
      while (targets.pop(target)) controller.set_target(target, wake);
      if (controller.take_request(request)) requests.write(request);
      if (paths.pop(path)) controller.follow(path, wake);
      const bool command = controller.tick(wake, have_state ? &state : nullptr);
      int64_t utime = 0;
      if (command) command_publisher.encode(utime = realtime_us(), ++seq, state.seq, controller.torque());
      const int64_t computed = monotonic_ns();
      record.compute_us = 1e-3 * static_cast<double>(computed - wake);
      if (command) {
        sent_commands.record(seq, utime);  // before the send: our own copy may come back at once
        if (!command_publisher.send()) ++counters.send_failures;
        const int64_t sent = monotonic_ns();
        record.publish_us = 1e-3 * static_cast<double>(sent - computed);
        if (state.seq != answered_seq) {
          record.latency_us = 1e-3 * static_cast<double>(sent - state.arrival_ns);
          answered_seq = state.seq;
          if (options.sync_margin_us > 0.0) phase_shift = sync_shift(wake - state.arrival_ns, period);
        }
        record.commanded = true;
        record.error_max = controller.error().cwiseAbs().maxCoeff();
        record.error_sq = controller.error().squaredNorm();
        ++counters.commands;
      }
      const int64_t finished = monotonic_ns();

      ++counters.ticks;
      next += period + phase_shift;
      phase_shift = 0;
      if (finished > next) {
        // Missed at least one deadline: count them and start again from the present rather than
        // run a burst of late ticks.
        const int64_t missed = (finished - next) / period + 1;
        counters.overruns += missed;
        next += missed * period;
      }
      if (!records.push(record)) ++counters.lost_records;
      publish_snapshot(counters);
    }
  }

  // Someone else commands this arm (a second controller, a log replayed onto the live bus): two
  // senders on one command channel drive the arm with whatever torque came last, so this one
  // stops commanding for good and reports a FAULT; the arm's own watchdog takes over if the
  // other sender stops too. Latched: only an operator can tell which sender should drive.
  void stand_down(const JointState& state, bool have_state) {
    controller.stand_down("another sender is commanding %s (seq %lld answering state %lld; our latest state %lld): "
                          "stopped commanding",
                          channels.command.c_str(), static_cast<long long>(command_watch.first_seq()),
                          static_cast<long long>(command_watch.first_state_seq()),
                          static_cast<long long>(have_state ? state.seq : -1));
  }

  // Before the loop starts: listen on the command channel for a while; whatever is heard there
  // comes from another sender (we have sent nothing yet). Empty, or why this controller must not
  // start.
  std::string bus_in_use() const {
    const double window_s = std::max(3.0 * options.control.period, kListenBeforeStart_s);
    sleep_until(monotonic_ns() + static_cast<int64_t>(window_s * 1e9));
    if (command_watch.foreign() == 0) return {};
    return "another controller is already commanding " + channels.command + " (heard " +
           std::to_string(command_watch.foreign()) + " command(s) in " + std::to_string(std::lround(window_s * 1e3)) +
           " ms, first seq " + std::to_string(command_watch.first_seq()) + "); refusing to start";
  }

  // Phase lock to a plant that sends states on its own clock: shifts the next deadline so that
  // ticks come sync_margin after a state arrives instead of anywhere up to a period later. A
  // first-order loop with a small gain (robust to arrival jitter) and a bounded step (the rate
  // never strays more than 2 % from nominal), so it also follows a plant on another host whose
  // clock drifts from this one.
  int64_t sync_shift(int64_t waited_ns, int64_t period) const {
    constexpr double kGain = 0.1;
    const double error = options.sync_margin_us * 1e3 - static_cast<double>(waited_ns);
    const double step = std::clamp(kGain * error, -0.02 * static_cast<double>(period), 0.02 * static_cast<double>(period));
    return static_cast<int64_t>(step);
  }

  // Written straight into the mailbox's free slot: nothing is copied twice on the loop.
  void publish_snapshot(const LoopCounters& counters) {
    Snapshot& s = snapshots.back();
    s.loop = counters;
    s.mode = controller.mode();
    std::memcpy(s.fault, controller.fault_reason(), sizeof(s.fault));
    std::memcpy(s.rejection, controller.last_rejection(), sizeof(s.rejection));
    s.q_desired = controller.reference().q;
    s.error = controller.error();
    s.q = s.q_desired - s.error;
    s.torque = controller.torque();
    s.stale = controller.stale_ticks();
    s.faults = controller.faults();
    s.foreign_commands = command_watch.foreign();
    s.rejected_targets = controller.rejected_targets();
    s.ik_iterations = controller.ik_iterations();
    s.ik_residual = controller.ik_residual();
    s.ik_converged = controller.ik_converged();
    snapshots.publish();
  }

  void drain() {
    TickRecord r;
    while (records.pop(r)) {
      window.record(r);
      if (r.commanded) publish_window.record(r.publish_us);
      if (r.commanded) {
        error_sq_sum += r.error_sq;
        error_samples += n;
        error_max = std::max(error_max, r.error_max);
      }
    }
  }

  void status_loop() {
    Data data(model);
    Snapshot& s = last;
    controller_status_t status;
    status.num_joints = n;
    std::vector<uint8_t> bytes;
    Mode reported = Mode::kWaiting;
    int64_t reported_rejections = 0, reported_wire = 0;
    const auto status_period = static_cast<int64_t>(1e9 / options.status_hz);
    int64_t last_status = 0;
    bool have = false;
    while (!done.load(std::memory_order_relaxed)) {
      sleep_until(monotonic_ns() + 1'000'000);
      drain();
      if (snapshots.read(s)) have = true;
      if (!have) continue;
      const int64_t now = monotonic_ns();
      const bool changed = s.mode != reported;
      if (changed) {
        std::fprintf(stderr, "chasles_controller: %s%s%s\n", to_string(s.mode), s.mode == Mode::kFault ? ": " : "",
                     s.mode == Mode::kFault ? s.fault : "");
        reported = s.mode;
      }
      if (s.rejected_targets != reported_rejections) {
        const auto count = static_cast<long long>(s.rejected_targets - reported_rejections);
        if (count == 1) {
          std::fprintf(stderr, "chasles_controller: target refused: %s\n", s.rejection);
        } else {
          std::fprintf(stderr, "chasles_controller: %lld targets refused, last: %s\n", count, s.rejection);
        }
        reported_rejections = s.rejected_targets;
      }
      if (rejections.count() != reported_wire) {
        std::fprintf(stderr, "chasles_controller: rejected %lld message(s), last: %s\n",
                     static_cast<long long>(rejections.count() - reported_wire), rejections.last().c_str());
        reported_wire = rejections.count();
      }
      if (!changed && now - last_status < status_period) continue;
      last_status = now;
      fill_status(status, s, data);
      total.merge(window);
      window.reset();
      publish_total.merge(publish_window);
      publish_window.reset();
      bytes.resize(size_t(status.getEncodedSize()));
      status.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      lcm_publish(lcm_status.get(), channels.status.c_str(), bytes.data(), static_cast<unsigned>(bytes.size()));
    }
  }

  void fill_status(controller_status_t& status, const Snapshot& s, Data& data) {
    status.utime = realtime_us();
    status.state = static_cast<int8_t>(s.mode);
    status.message = s.mode == Mode::kFault ? s.fault : s.rejected_targets > 0 ? std::string("last target refused: ") + s.rejection : "";
    auto copy = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
    status.q = copy(s.q);
    status.q_desired = copy(s.q_desired);
    status.tracking_error = copy(s.error);
    status.torque = copy(s.torque);
    const Transform& T = forward_kinematics(model, data, s.q);
    const Eigen::Quaterniond quaternion(T.linear());
    for (int i = 0; i < 3; ++i) status.tip_position[i] = T.translation()(i);
    status.tip_quaternion[0] = quaternion.w();
    status.tip_quaternion[1] = quaternion.x();
    status.tip_quaternion[2] = quaternion.y();
    status.tip_quaternion[3] = quaternion.z();
    status.ik_iterations = s.ik_iterations;
    status.ik_residual = s.ik_residual;
    status.ik_converged = s.ik_converged;
    const Percentiles j = percentiles(window.jitter), c = percentiles(window.compute), l = percentiles(window.latency);
    status.jitter_p50_us = j.p50, status.jitter_p99_us = j.p99, status.jitter_max_us = j.max;
    status.compute_p50_us = c.p50, status.compute_p99_us = c.p99, status.compute_max_us = c.max;
    status.latency_p50_us = l.p50, status.latency_p99_us = l.p99, status.latency_max_us = l.max;
    status.ticks = s.loop.ticks;
    status.overruns = s.loop.overruns;
    status.stale_states = s.stale;
    status.rejected_messages = rejections.count() + s.rejected_targets;
    status.faults = s.faults;
  }
};

Daemon::Daemon(const RobotModel& model, const DaemonOptions& options) : impl_(std::make_unique<Impl>(model, options)) {}

Daemon::~Daemon() = default;

Summary Daemon::run(const std::atomic<bool>& stop) {
  Impl& d = *impl_;
  const int64_t start = monotonic_ns();
  std::thread receiver([&d] { d.receive_loop(); });
  if (const std::string why = d.bus_in_use(); !why.empty()) {
    d.done = true;
    receiver.join();
    throw Error(why);
  }
  std::thread status([&d] { d.status_loop(); });
  std::thread ik([&d] { d.ik_loop(); });
  std::thread loop([&d, &stop] { d.realtime_loop(stop); });
  loop.join();
  d.done = true;
  status.join();
  ik.join();
  receiver.join();
  const double seconds = 1e-9 * static_cast<double>(monotonic_ns() - start);

  d.drain();
  d.total.merge(d.window);
  d.publish_total.merge(d.publish_window);
  d.snapshots.read(d.last);
  const Snapshot& s = d.last;
  Summary summary;
  summary.ticks = s.loop.ticks;
  summary.seconds = seconds;
  summary.rate_hz = seconds > 0.0 ? static_cast<double>(s.loop.ticks) / seconds : 0.0;
  summary.overruns = s.loop.overruns;
  summary.jitter_us = percentiles(d.total.jitter);
  summary.compute_us = percentiles(d.total.compute);
  summary.latency_us = percentiles(d.total.latency);
  summary.publish_us = percentiles(d.publish_total);
  summary.send_failures = s.loop.send_failures;
  summary.lost_timing_records = s.loop.lost_records;
  summary.tracking_rms = d.error_samples ? std::sqrt(d.error_sq_sum / static_cast<double>(d.error_samples)) : 0.0;
  summary.tracking_max = d.error_max;
  summary.commands = s.loop.commands;
  summary.stale_states = s.stale;
  summary.rejected_messages = d.rejections.count() + s.rejected_targets;
  summary.faults = s.faults;
  summary.foreign_commands = s.foreign_commands;
  summary.realtime_granted = d.realtime_granted;
  return summary;
}

}  // namespace chasles::controller
