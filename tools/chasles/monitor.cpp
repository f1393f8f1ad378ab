// chasles monitor: the running controller on one terminal screen, refreshed 10 times a second —
// for a shell over SSH where lcm-spy has no display. It listens to <prefix>STATUS for the
// controller's own report, counts <prefix>STATE and <prefix>COMMAND to show that the loop is
// closed, and shows the last <prefix>TARGET and, from the status, the progress of the latest
// waypoint trajectory. Once the status stops, the screen says so instead of showing numbers that
// are no longer true.
#include <sys/select.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "controller/law_settings.hpp"
#include "controller/transport/wire.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "tools/cli/messages.hpp"
#include "command.hpp"
#include "lcm_start.hpp"

namespace chasles::cli {
namespace {

using controller::monotonic_ns;

// The status comes at about 100 Hz; half a second without one is fifty missed reports.
constexpr double kStatusSilenceS = 0.5;
constexpr double kRefreshS = 0.1;
constexpr double kPipeRefreshS = 1.0;  // to a file or a pipe: a frame a second, not ten
constexpr double kRateWindowS = 1.0;

struct MonitorOptions {
  std::string lcm_url;
  std::string prefix = "CHASLES_";
  std::string urdf, tip;
  bool once = false;
  double seconds = 0.0;  ///< 0: until quit (live), 1 s (--once)
};

volatile std::sig_atomic_t g_quit = 0;
void on_signal(int) { g_quit = 1; }

double seconds_since(int64_t then_ns, int64_t now_ns) { return double(now_ns - then_ns) * 1e-9; }

// Arrival times within the last second, for a message rate.
class RateMeter {
 public:
  void add(int64_t now_ns) {
    arrivals_.push_back(now_ns);
    trim(now_ns);
  }
  /// Messages per second over the last second (over the time since `start_ns` if shorter).
  double rate(int64_t now_ns, int64_t start_ns) {
    trim(now_ns);
    const double span = std::min(kRateWindowS, seconds_since(start_ns, now_ns));
    return span > 0.05 ? double(arrivals_.size()) / span : 0.0;
  }

 private:
  void trim(int64_t now_ns) {
    while (!arrivals_.empty() && seconds_since(arrivals_.front(), now_ns) > kRateWindowS) arrivals_.pop_front();
  }
  std::deque<int64_t> arrivals_;
};

struct Joints {
  std::vector<std::string> names;
  std::vector<bool> prismatic;
  std::vector<double> effort;
};

class Monitor {
 public:
  Monitor(const MonitorOptions& options, std::optional<Joints> joints, lcm_t* lcm)
      : options_(options), joints_(std::move(joints)), lcm_(lcm), start_ns_(monotonic_ns()) {
    lcm_subscribe(lcm_, (options.prefix + "STATUS").c_str(), &Monitor::on_status, this);
    lcm_subscribe(lcm_, (options.prefix + "STATE").c_str(), &Monitor::on_state, this);
    lcm_subscribe(lcm_, (options.prefix + "COMMAND").c_str(), &Monitor::on_command, this);
    lcm_subscribe(lcm_, (options.prefix + "TARGET").c_str(), &Monitor::on_target, this);
  }

  bool has_status() const { return status_.has_value(); }
  bool status_is_fresh(int64_t now_ns) const {
    return status_ && seconds_since(status_ns_, now_ns) <= kStatusSilenceS;
  }
  double silence_s(int64_t now_ns) const { return seconds_since(status_ ? status_ns_ : start_ns_, now_ns); }

  std::string frame(int64_t now_ns);

 private:
  static void on_status(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    auto* monitor = static_cast<Monitor*>(self);
    controller_status_t status;
    const std::string why = decode_checked(rbuf->data, rbuf->data_size, status);
    const int64_t now = monotonic_ns();
    if (!why.empty()) {
      ++monitor->malformed_;
      monitor->last_malformed_ = monitor->options_.prefix + "STATUS: " + why;
      return;
    }
    monitor->status_ = std::move(status);
    monitor->status_ns_ = now;
    monitor->status_rate_.add(now);
    monitor->ticks_.push_back({now, monitor->status_->ticks});
    while (monitor->ticks_.size() > 2 && seconds_since(monitor->ticks_.front().first, now) > kRateWindowS) {
      monitor->ticks_.pop_front();
    }
  }
  static void on_state(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    auto* monitor = static_cast<Monitor*>(self);
    if (message_type(rbuf->data, rbuf->data_size) == MessageType::State) monitor->state_rate_.add(monotonic_ns());
  }
  static void on_command(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    auto* monitor = static_cast<Monitor*>(self);
    if (message_type(rbuf->data, rbuf->data_size) == MessageType::Command) monitor->command_rate_.add(monotonic_ns());
  }
  static void on_target(const lcm_recv_buf_t* rbuf, const char*, void* self) {
    auto* monitor = static_cast<Monitor*>(self);
    arm_target_t target;
    if (decode_checked(rbuf->data, rbuf->data_size, target).empty()) {
      monitor->target_ = std::move(target);
      monitor->target_ns_ = monotonic_ns();
    }
  }

  void joint_table(std::ostream& out) const;
  /// Units of the joint table: with a URDF whose joint count matches, those of its joint types.
  bool named() const { return joints_ && status_ && joints_->names.size() == size_t(std::max(0, status_->num_joints)); }
  bool mixed_units() const {
    return !named() || std::count(joints_->prismatic.begin(), joints_->prismatic.end(), true) > 0;
  }
  const char* milli_unit() const { return mixed_units() ? "mrad|mm" : "mrad"; }

  const MonitorOptions& options_;
  std::optional<Joints> joints_;
  lcm_t* lcm_;
  int64_t start_ns_;
  std::optional<controller_status_t> status_;
  int64_t status_ns_ = 0;
  std::deque<std::pair<int64_t, int64_t>> ticks_;  ///< (arrival, ticks) over the last second
  RateMeter status_rate_, state_rate_, command_rate_;
  std::optional<arm_target_t> target_;
  int64_t target_ns_ = 0;
  int64_t malformed_ = 0;
  std::string last_malformed_;
};

std::string printf_text(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string printf_text(const char* format, ...) {
  char buffer[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof(buffer), format, args);
  va_end(args);
  return buffer;
}

// The status's values by the wire tables (controller/transport/wire.hpp), named as the controller
// names them; a value no enumerator has, as its number.
std::string state_name(int8_t state) {
  controller::Mode mode{};
  return controller::from_wire(state, mode) ? controller::to_string(mode) : "state " + std::to_string(int{state});
}

std::string outcome_name(int8_t outcome) {
  controller::TrajectoryProgress::Outcome value{};
  return controller::from_wire(outcome, value) ? controller::to_string(value)
                                               : "outcome " + std::to_string(int{outcome});
}

// The latest waypoint trajectory's progress, once the controller has seen one: its id and outcome,
// the time into it against its duration (after time scaling) and as a share of it (past its end,
// while the joints settle into the goal tolerance, 100 %), the waypoint approached (0-based; the
// point count once past the last), the time scale, and on a line of its own the controller's
// message about it.
std::string trajectory_lines(const controller_status_t& s) {
  if (s.trajectory_id == 0 && s.trajectory_outcome == controller_status_t::TRAJECTORY_NONE) return {};
  std::string share = "-";
  if (s.trajectory_duration > 0) {
    share = printf_text("%.1f %%", std::min(100.0, 100.0 * std::max(0.0, s.trajectory_elapsed) / s.trajectory_duration));
  }
  std::string text = printf_text("trajectory  %lld %s, %.3f of %.3f s (%s), waypoint %d, time scale %.3f\n",
                                 static_cast<long long>(s.trajectory_id), outcome_name(s.trajectory_outcome).c_str(),
                                 s.trajectory_elapsed, s.trajectory_duration, share.c_str(), s.trajectory_waypoint,
                                 s.trajectory_time_scale);
  if (!s.trajectory_message.empty()) text += "            " + s.trajectory_message + "\n";
  return text;
}

// Streams and jogs, once the controller has taken one: whether one drives the arm, the counts,
// and (a jog's, a Cartesian stream's) the condition number and what cut the speed.
std::string stream_lines(const controller_status_t& s) {
  if (s.setpoints == 0 && s.jogs == 0 && s.setpoints_dropped == 0 && s.jogs_dropped == 0) return {};
  std::string text = printf_text("stream      %s; %lld setpoints (%lld dropped), %lld jog commands (%lld dropped)\n",
                                 s.streaming ? "STREAMING" : s.jogging ? "JOGGING" : "none",
                                 static_cast<long long>(s.setpoints), static_cast<long long>(s.setpoints_dropped),
                                 static_cast<long long>(s.jogs), static_cast<long long>(s.jogs_dropped));
  if (s.jogs > 0 || s.jog_condition > 0) {
    std::string cut;
    switch (s.jog_limited_by) {
      case controller_status_t::JOG_NONE: cut = "nothing"; break;
      case controller_status_t::JOG_VELOCITY_LIMIT: cut = "joint " + std::to_string(s.jog_joint) + "'s velocity limit"; break;
      case controller_status_t::JOG_POSITION_LIMIT: cut = "joint " + std::to_string(s.jog_joint) + "'s position limit"; break;
      case controller_status_t::JOG_SINGULARITY: cut = "a singularity ahead"; break;
      default: cut = "limit " + std::to_string(int{s.jog_limited_by}); break;
    }
    text += printf_text("            J_b condition %.1f; speed %.0f %% of the asked, cut by %s\n", s.jog_condition,
                        100.0 * s.jog_scale, cut.c_str());
  }
  return text;
}

std::string wall_clock() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  ::localtime_r(&now, &local);
  char text[16];
  std::strftime(text, sizeof(text), "%H:%M:%S", &local);
  return text;
}

void Monitor::joint_table(std::ostream& out) const {
  const controller_status_t& s = *status_;
  const auto n = size_t(std::max(0, s.num_joints));
  const bool named = this->named();
  const std::vector<std::string> names = joint_labels(named ? joints_->names : std::vector<std::string>{}, int(n));
  size_t width = 8;
  for (const std::string& name : names) width = std::max(width, name.size() + 2);
  const char* unit = mixed_units() ? "rad|m" : "rad";
  const char* milli = milli_unit();
  const char* torque = mixed_units() ? "N·m|N" : "N·m";
  out << printf_text("%-*s %11s %11s %13s %13s %13s%s\n", int(width), "joint", ("q " + std::string(unit)).c_str(),
                     ("q_d " + std::string(unit)).c_str(), ("error " + std::string(milli)).c_str(),
                     ("torque " + std::string(torque)).c_str(), ("external " + std::string(torque)).c_str(),
                     named ? "   of limit" : "");
  for (size_t i = 0; i < n; ++i) {
    out << printf_text("%-*s %11.4f %11.4f %13.3f %13.2f %13.2f", int(width), names[i].c_str(), s.q[i], s.q_desired[i],
                       1000.0 * s.tracking_error[i], s.torque[i], i < s.tau_ext.size() ? s.tau_ext[i] : 0.0);
    if (named && joints_->effort[i] > 0) out << printf_text("   %6.1f %%", 100.0 * std::abs(s.torque[i]) / joints_->effort[i]);
    out << '\n';
  }
  if (joints_ && !named) {
    out << "(the URDF's chain has " << joints_->names.size() << " joints, the status " << n
        << ": joints are numbered; is --tip right?)\n";
  }
}

std::string Monitor::frame(int64_t now_ns) {
  std::ostringstream out;
  const std::string status_channel = options_.prefix + "STATUS";
  out << "chasles monitor   " << status_channel << " on " << (options_.lcm_url.empty() ? "LCM's default URL" : options_.lcm_url)
      << "   " << wall_clock() << "\n\n";
  const std::string bus = printf_text("plant states %.0f Hz, commands %.0f Hz", state_rate_.rate(now_ns, start_ns_),
                                      command_rate_.rate(now_ns, start_ns_));
  if (!status_ && silence_s(now_ns) < kStatusSilenceS) {
    out << "listening for the controller on " << status_channel << " ...\n" << bus << "\n";
  } else if (!status_is_fresh(now_ns)) {
    out << "no controller on " << status_channel << " for " << printf_text("%.1f", silence_s(now_ns)) << " s";
    if (status_) out << " (it was " << state_name(status_->state) << ", " << status_->ticks << " ticks)";
    out << "\n" << bus << "\n";
  } else {
    const controller_status_t& s = *status_;
    double tick_rate = 0.0;
    if (ticks_.size() >= 2) {
      const double span = seconds_since(ticks_.front().first, ticks_.back().first);
      if (span > 0.05) tick_rate = double(ticks_.back().second - ticks_.front().second) / span;
    }
    out << "controller  " << state_name(s.state) << (s.message.empty() ? "" : "  " + s.message) << "\n";
    out << printf_text("loop        %.1f Hz, %lld ticks; status %.0f Hz; ", tick_rate, static_cast<long long>(s.ticks),
                       status_rate_.rate(now_ns, start_ns_))
        << bus << "\n";
    controller::Law law = controller::Law::kComputedTorque;
    const bool known = controller::from_wire(s.law, law);
    out << "law         " << (known ? controller::to_string(law) : "law " + std::to_string(int{s.law}))
        << printf_text("; payload %.3f kg at the tip; states every %.3f ms\n\n", s.payload_mass,
                       1e3 * s.state_period);
    joint_table(out);
    double worst = 0.0;
    for (const double e : s.tracking_error) worst = std::max(worst, std::abs(e));
    out << printf_text("\ntip pose    p_sb (%.4f, %.4f, %.4f) m   R_sb as (w, x, y, z) (%.4f, %.4f, %.4f, %.4f)\n",
                       s.tip_position[0], s.tip_position[1], s.tip_position[2], s.tip_quaternion[0],
                       s.tip_quaternion[1], s.tip_quaternion[2], s.tip_quaternion[3]);
    out << printf_text("tracking    max |e| %.3f %s\n", 1000.0 * worst, milli_unit());
    out << trajectory_lines(s);
    out << stream_lines(s);
    const double* w = s.tip_wrench_ext;
    out << printf_text("contact     %s; external wrench at the tip (base-aligned) m (%.2f, %.2f, %.2f) N·m, "
                       "f (%.2f, %.2f, %.2f) N; %lld contacts, %lld reflexes\n",
                       s.collision ? "COLLISION" : s.contact ? "CONTACT" : "none", w[0], w[1], w[2], w[3], w[4], w[5],
                       static_cast<long long>(s.contacts), static_cast<long long>(s.reflexes));
    out << "\ntiming (us, last status window)      p50       p99       max\n"
        << printf_text("  wake-up jitter              %9.1f %9.1f %9.1f\n", s.jitter_p50_us, s.jitter_p99_us,
                       s.jitter_max_us)
        << printf_text("  compute (state to command)  %9.1f %9.1f %9.1f\n", s.compute_p50_us, s.compute_p99_us,
                       s.compute_max_us)
        << printf_text("  latency (arrival to sent)   %9.1f %9.1f %9.1f\n", s.latency_p50_us, s.latency_p99_us,
                       s.latency_max_us);
    if (s.ik_iterations == 0 && !s.ik_converged) {
      out << "\nIK          no Cartesian goal solved yet\n";
    } else {
      out << printf_text("\nIK          %d iterations, residual %.3g, %s\n", s.ik_iterations, s.ik_residual,
                         s.ik_converged ? "converged" : "NOT converged");
    }
    out << printf_text("counters    overruns %lld   stale states %lld   rejected messages %lld   faults %lld\n",
                       static_cast<long long>(s.overruns), static_cast<long long>(s.stale_states),
                       static_cast<long long>(s.rejected_messages), static_cast<long long>(s.faults));
  }
  if (target_) {
    const arm_target_t& t = *target_;
    std::string what = t.mode == arm_target_t::HOLD       ? "HOLD"
                       : t.mode == arm_target_t::JOINT    ? printf_text("JOINT in %.2f s", t.duration)
                       : t.mode == arm_target_t::CARTESIAN ? printf_text("CARTESIAN to (%.3f, %.3f, %.3f) m in %.2f s",
                                                                         t.tip_position[0], t.tip_position[1],
                                                                         t.tip_position[2], t.duration)
                                                          : "mode " + std::to_string(int{t.mode});
    out << printf_text("last target %s, %.1f s ago\n", what.c_str(), seconds_since(target_ns_, now_ns));
  }
  if (malformed_ > 0) {
    out << "ignored " << malformed_ << " malformed status messages (last: " << last_malformed_ << ")\n";
  }
  return out.str();
}

// Keys without Enter and without echo, while the monitor runs on a terminal.
class RawKeys {
 public:
  RawKeys() {
    if (::isatty(STDIN_FILENO) == 0 || ::tcgetattr(STDIN_FILENO, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= ~tcflag_t(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = ::tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
  }
  ~RawKeys() {
    if (active_) ::tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  RawKeys(const RawKeys&) = delete;
  RawKeys& operator=(const RawKeys&) = delete;
  bool active() const { return active_; }

 private:
  termios saved_{};
  bool active_ = false;
};

// SIGINT and SIGTERM end the loop (select returns EINTR) instead of the process, so the terminal
// is restored and the last frame stays on screen.
class QuitSignals {
 public:
  QuitSignals() {
    g_quit = 0;
    struct sigaction action {};
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, &saved_int_);
    ::sigaction(SIGTERM, &action, &saved_term_);
  }
  ~QuitSignals() {
    ::sigaction(SIGINT, &saved_int_, nullptr);
    ::sigaction(SIGTERM, &saved_term_, nullptr);
  }
  QuitSignals(const QuitSignals&) = delete;
  QuitSignals& operator=(const QuitSignals&) = delete;

 private:
  struct sigaction saved_int_ {};
  struct sigaction saved_term_ {};
};

std::optional<Joints> load_joints(const MonitorOptions& options) {
  if (options.urdf.empty()) return std::nullopt;
  const RobotModel model = load_model({options.urdf, options.tip});
  Joints joints;
  for (const Joint& joint : model.joints()) {
    joints.names.push_back(joint.name);
    joints.prismatic.push_back(joint.type == JointType::Prismatic);
    joints.effort.push_back(joint.limits.effort);
  }
  return joints;
}

Json run_monitor(const MonitorOptions& options) {
  std::optional<Joints> joints = load_joints(options);
  std::unique_ptr<lcm_t, void (*)(lcm_t*)> lcm(start_lcm(options.lcm_url), lcm_destroy);
  Monitor monitor(options, std::move(joints), lcm.get());
  QuitSignals signals;

  const bool screen = !options.once && ::isatty(STDOUT_FILENO) != 0;
  const double seconds = options.seconds > 0 ? options.seconds : options.once ? 1.0 : 0.0;
  const double refresh = options.once ? 1e9 : screen ? kRefreshS : kPipeRefreshS;
  std::optional<RawKeys> keys;
  if (screen) {
    keys.emplace();
    std::cout << "\x1b[?25l\x1b[2J" << std::flush;  // hide the cursor, clear the screen
  }
  const int64_t start = monotonic_ns();
  int64_t next_frame = screen ? start : start + int64_t(refresh * 1e9);  // a pipe gets no "listening" frame
  const int lcm_fd = lcm_get_fileno(lcm.get());
  while (g_quit == 0) {
    const int64_t now = monotonic_ns();
    if (seconds > 0 && seconds_since(start, now) >= seconds) break;
    if (now >= next_frame && !options.once) {
      const std::string text = monitor.frame(now);
      if (screen) {
        // Home, then each line followed by clear-to-end-of-line, then clear below: no flicker.
        std::string painted = "\x1b[H";
        for (const char c : text) painted += c == '\n' ? std::string("\x1b[K\n") : std::string(1, c);
        std::cout << painted << "q or Ctrl-C quits\x1b[K\n\x1b[J" << std::flush;
      } else {
        std::cout << text << std::endl;
      }
      next_frame += int64_t(refresh * 1e9);
      if (next_frame < now) next_frame = now + int64_t(refresh * 1e9);
    }
    int64_t wake = options.once ? start + int64_t(seconds * 1e9) : next_frame;
    if (seconds > 0) wake = std::min(wake, start + int64_t(seconds * 1e9));
    const int64_t wait_ns = std::max<int64_t>(0, wake - monotonic_ns());
    fd_set readable;
    FD_ZERO(&readable);
    FD_SET(lcm_fd, &readable);
    if (keys && keys->active()) FD_SET(STDIN_FILENO, &readable);
    timeval timeout{static_cast<time_t>(wait_ns / 1'000'000'000), static_cast<suseconds_t>(wait_ns % 1'000'000'000 / 1000)};
    const int ready = ::select(std::max(lcm_fd, STDIN_FILENO) + 1, &readable, nullptr, nullptr, &timeout);
    if (ready < 0) {
      if (errno == EINTR) continue;
      throw InputError(std::string("select failed: ") + std::strerror(errno));
    }
    if (ready == 0) continue;
    if (FD_ISSET(lcm_fd, &readable)) lcm_handle(lcm.get());
    if (keys && keys->active() && FD_ISSET(STDIN_FILENO, &readable)) {
      char key = 0;
      if (::read(STDIN_FILENO, &key, 1) == 1 && (key == 'q' || key == 'Q')) break;
    }
  }
  const int64_t end = monotonic_ns();
  if (screen) {
    std::cout << "\x1b[?25h" << std::flush;  // the cursor back; the last frame stays on screen
    return Json();
  }
  if (options.once) {
    std::cout << monitor.frame(end) << std::flush;
    if (!monitor.status_is_fresh(end)) {
      throw InputError(printf_text("no controller on %sSTATUS for %.1f s (is chasles_controller running, on this "
                                   "--lcm-url and --prefix?)",
                                   options.prefix.c_str(), monitor.silence_s(end)));
    }
  }
  return Json();
}

}  // namespace

Command register_monitor(CLI::App& app) {
  auto options = std::make_shared<MonitorOptions>();
  CLI::App* command =
      app.add_subcommand("monitor", "Watch the running controller in the terminal (no display needed)");
  command->add_option("--lcm-url", options->lcm_url, "LCM provider URL (default: $LCM_DEFAULT_URL, else LCM's default)")
      ->type_name("URL");
  command->add_option("--prefix,--channel-prefix", options->prefix, "Channels PREFIX STATUS, STATE, COMMAND, TARGET")
      ->type_name("PREFIX")
      ->capture_default_str();
  command->add_option("--urdf,--robot", options->urdf, "Robot description: joint names, units and effort limits")
      ->type_name("FILE");
  command->add_option("--tip", options->tip, "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
  command->add_flag("--once", options->once, "Listen for --seconds (default 1), print one frame as plain text, exit");
  command->add_option("--seconds", options->seconds, "Stop after this many seconds (default: until q or Ctrl-C)")
      ->type_name("S")
      ->check(CLI::PositiveNumber);
  command->footer(
      "Shows, 10 times a second: the controller's mode, the loop's rate and the rates of plant states and\n"
      "commands; per joint q, q_d, the tracking error and the torque (with --urdf: names, % of the effort\n"
      "limit); the tip pose; wake-up jitter, compute time and latency; IK figures; the overrun, stale-state,\n"
      "rejected-message and fault counters; the last target. Once a waypoint trajectory has been sent:\n"
      "its id and outcome, the time into it of its duration and as a %, the waypoint approached, the time\n"
      "scale, and the controller's message about it. Once a stream or a jog has come: whether one drives\n"
      "the arm, the setpoints and jog commands taken and dropped, J_b's condition number and what cut the\n"
      "speed (a joint's velocity or position limit, a singularity ahead). Without a status for 0.5 s it says\n"
      "\"no controller on PREFIX STATUS for N s\" instead of numbers. On a pipe it prints a frame a second.\n"
      "--once exits 1 if no controller was heard.\n"
      "Examples:\n"
      "  chasles monitor --urdf panda.urdf --tip panda_hand\n"
      "  chasles monitor --once --lcm-url 'udpm://239.255.76.67:7667?ttl=0'");
  return {command, [options] { return run_monitor(*options); }};
}

}  // namespace chasles::cli
