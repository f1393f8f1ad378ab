// chasles log plot: the figures of a run, drawn by gnuplot from what one pass over the log collects
// (the controller's status, the commands sent, the plant's truth, and a mark wherever a target,
// trajectory, stream, jog or law change set the arm going). Apart from the export (log_export.cpp):
// it reads the channels as a run, not one channel as a table, and owns the gnuplot process.
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "tools/chasles/log_command.hpp"
#include "tools/cli/lcm_log.hpp"
#include "tools/cli/messages.hpp"
#include "tools/cli/state_log.hpp"

extern char** environ;

namespace chasles::cli {
namespace {

struct Series {
  std::vector<double> t;                  ///< s since the log's first event
  std::vector<std::vector<double>> rows;  ///< one row of values per message
};

struct TargetMark {
  double t;
  std::string label;
};

// A run of consecutive statuses whose clearance_slowed_by names the same pair.
struct SlowedRun {
  std::string pair;
  double from = 0.0, to = 0.0;          ///< s since the log's first event
  int64_t from_utime = 0, to_utime = 0;  ///< the statuses' log event utimes
  int64_t statuses = 0;
  double least = INFINITY;  ///< the least clearance_distance while the slowing pair was the closest (else any)
  std::string least_pair;   ///< the closest pair at that least distance
};

// What the figures are drawn from, collected in one pass over the log.
struct PlotData {
  int joints = 0;
  Series status;    ///< q[n], q_desired[n], tracking_error[n], jitter p50/p99/max, compute p50/p99/max,
                    ///< tip_wrench_ext (m, f)
  Series commands;  ///< torque[n]
  Series truth;     ///< the plant's contact wrench (TRUTH): (m, f) base-aligned at the tip
  std::vector<int64_t> command_utimes;
  std::vector<TargetMark> targets;
  /// Clearance: whether any status named a closest pair (the controller had collision geometry),
  /// the least distance of the run and the runs of statuses slowed by a pair.
  bool clearance = false;
  double clearance_least = INFINITY;
  std::string clearance_least_pair;
  double clearance_least_t = NAN;
  std::vector<SlowedRun> slowed;
  std::vector<std::string> problems;
  int64_t rejected = 0;  ///< messages on our channels that did not decode
};

std::string mode_name(int8_t mode) {
  switch (mode) {
    case arm_target_t::HOLD: return "HOLD";
    case arm_target_t::JOINT: return "JOINT";
    case arm_target_t::CARTESIAN: return "CARTESIAN";
    default: return "mode " + std::to_string(int{mode});
  }
}

std::string law_name(int8_t law) {
  switch (law) {
    case control_mode_t::COMPUTED_TORQUE: return "computed torque";
    case control_mode_t::JOINT_IMPEDANCE: return "joint impedance";
    case control_mode_t::CARTESIAN_IMPEDANCE: return "Cartesian impedance";
    case control_mode_t::FREE_DRIVE: return "free drive";
    default: return "law " + std::to_string(int{law});
  }
}

// A stream or a jog is a run of messages: its first, after this much silence, starts a segment.
constexpr double kSegmentGap = 0.5;  // s

PlotData collect(const LogOptions& options) {
  const std::string status_channel = options.prefix + "STATUS",
                    command_channel = options.command_channel.empty() ? options.prefix + "COMMAND" : options.command_channel,
                    target_channel = options.prefix + "TARGET", truth_channel = options.prefix + "TRUTH";
  // Every other way to set the arm going is marked as a target is: the segment's first message.
  const std::string trajectory_channel = options.prefix + "TRAJECTORY", setpoint_channel = options.prefix + "SETPOINT",
                    tip_setpoint_channel = options.prefix + "TIP_SETPOINT", jog_channel = options.prefix + "JOG",
                    mode_channel = options.prefix + "MODE";
  std::map<std::string, double> last_of_run;  // stream and jog channels: when their latest message came
  const auto starts_run = [&](const std::string& channel, double t) {
    const auto last = last_of_run.find(channel);
    const bool first = last == last_of_run.end() || t - last->second > kSegmentGap;
    last_of_run[channel] = t;
    return first;
  };
  PlotData data;
  LogReader reader(options.log);
  LogEvent event;
  std::optional<int64_t> first_utime;
  int64_t last_status_utime = -1;  // the previous status with joint values: slowed runs are consecutive statuses
  std::map<std::string, int64_t> counts;
  const auto skip = [&](const std::string& why) {
    data.problems.push_back("byte " + std::to_string(event.offset) + ": event #" + std::to_string(event.number) +
                            " on " + event.channel + " is " + (why.rfind("not a", 0) == 0 ? "" : "a message ") + why +
                            "; skipped");
  };
  // The event as a message of its channel's type; false (and the event skipped) when it is not one.
  const auto decoded = [&](auto& message) {
    const std::string why = decode_checked(event.data.data(), event.data.size(), message);
    if (!why.empty()) skip(why);
    return why.empty();
  };
  // Every joint-space message must have the first status's joint count.
  const auto joints_ok = [&](int n) {
    if (data.joints == 0) data.joints = n;
    if (n == data.joints) return true;
    skip("for " + std::to_string(n) + " joints, where the first had " + std::to_string(data.joints));
    return false;
  };
  while (reader.next(event)) {
    if (!first_utime) first_utime = event.utime;
    ++counts[event.channel];
    const double t = double(event.utime - *first_utime) * 1e-6;
    if (event.channel == status_channel) {
      controller_status_t m;
      if (!decoded(m)) continue;
      if (m.num_joints == 0 || !joints_ok(m.num_joints)) continue;  // WAITING: no joint values yet
      std::vector<double> row;
      for (const auto* v : {&m.q, &m.q_desired, &m.tracking_error}) row.insert(row.end(), v->begin(), v->end());
      row.insert(row.end(), {m.jitter_p50_us, m.jitter_p99_us, m.jitter_max_us, m.compute_p50_us, m.compute_p99_us,
                             m.compute_max_us});
      row.insert(row.end(), m.tip_wrench_ext, m.tip_wrench_ext + 6);
      // Clearance: the closest pair's distance, and the same again where a pair slowed the reference
      // (NaN elsewhere, and both NaN without collision geometry).
      const bool named = !m.clearance_pair.empty(), slowed = !m.clearance_slowed_by.empty();
      row.push_back(named ? m.clearance_distance : NAN);
      row.push_back(named && slowed ? m.clearance_distance : NAN);
      if (named) {
        data.clearance = true;
        if (m.clearance_distance < data.clearance_least) {
          data.clearance_least = m.clearance_distance;
          data.clearance_least_pair = m.clearance_pair;
          data.clearance_least_t = t;
        }
      }
      if (slowed) {
        if (data.slowed.empty() || data.slowed.back().pair != m.clearance_slowed_by ||
            data.slowed.back().to_utime != last_status_utime) {
          data.slowed.push_back({m.clearance_slowed_by, t, t, event.utime, event.utime, 0, INFINITY, ""});
        }
        SlowedRun& run = data.slowed.back();
        run.to = t, run.to_utime = event.utime, ++run.statuses;
        // The slowing pair's own distance once it is the closest; before that, the closest pair's.
        const bool own = m.clearance_pair == run.pair, had_own = run.least_pair == run.pair;
        if (named && ((own && (!had_own || m.clearance_distance < run.least)) ||
                      (!own && !had_own && m.clearance_distance < run.least))) {
          run.least = m.clearance_distance, run.least_pair = m.clearance_pair;
        }
      }
      last_status_utime = event.utime;
      data.status.t.push_back(t);
      data.status.rows.push_back(std::move(row));
    } else if (event.channel == command_channel) {
      // chasles's command, or the torque of a Drake driver's (what was sent: less g(q) under
      // overlay semantics).
      std::vector<double> torque;
      int64_t utime = 0;
      std::string why;
      switch (message_type(event.data.data(), event.data.size())) {
        case MessageType::IiwaCommand: {
          drake::lcmt_iiwa_command m;
          why = decode_checked(event.data.data(), event.data.size(), m);
          torque = m.joint_torque, utime = m.utime;
          break;
        }
        case MessageType::PandaCommand: {
          drake::lcmt_panda_command m;
          why = decode_checked(event.data.data(), event.data.size(), m);
          torque = m.joint_torque, utime = m.utime;
          break;
        }
        default: {
          joint_torque_command_t m;
          why = decode_checked(event.data.data(), event.data.size(), m);
          torque = m.torque, utime = m.utime;
        }
      }
      if (!why.empty()) {
        skip(why);
        continue;
      }
      if (!joints_ok(static_cast<int>(torque.size()))) continue;
      data.commands.t.push_back(t);
      data.commands.rows.push_back(std::move(torque));
      data.command_utimes.push_back(utime);
    } else if (event.channel == truth_channel) {
      sim_truth_t m;
      if (!decoded(m)) continue;
      data.truth.t.push_back(t);
      data.truth.rows.emplace_back(m.tip_wrench_ext, m.tip_wrench_ext + 6);
    } else if (event.channel == target_channel) {
      arm_target_t m;
      if (!decoded(m)) continue;
      data.targets.push_back({t, mode_name(m.mode)});
    } else if (event.channel == trajectory_channel) {
      joint_trajectory_t m;
      if (!decoded(m)) continue;
      data.targets.push_back({t, "TRAJECTORY " + std::to_string(m.id)});
    } else if (event.channel == setpoint_channel || event.channel == tip_setpoint_channel) {
      if (starts_run(event.channel, t)) data.targets.push_back({t, event.channel == setpoint_channel ? "STREAM" : "TIP STREAM"});
    } else if (event.channel == jog_channel) {
      jog_command_t m;
      if (!decoded(m)) continue;
      if (starts_run(event.channel, t)) {
        data.targets.push_back({t, m.kind == jog_command_t::TWIST ? "JOG twist" : "JOG joints"});
      }
    } else if (event.channel == mode_channel) {
      control_mode_t m;
      if (!decoded(m)) continue;
      data.targets.push_back({t, law_name(m.law)});
    }
  }
  data.problems.insert(data.problems.begin(), reader.problems().begin(), reader.problems().end());
  if (data.status.t.empty() && data.commands.t.empty()) {
    if (!data.problems.empty()) fail_damaged(options.log, data.problems, "nothing to plot");
    throw InputError(options.log + ": nothing to plot: no " + status_channel + " or " + command_channel +
                     " messages with joint values (channels in the log: " + channel_list(counts) +
                     "; another --prefix?)");
  }
  return data;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return NAN;
  const size_t k = std::min(values.size() - 1, size_t(p / 100.0 * double(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '\n') {
      out += "\\n";  // gnuplot's line break in a double-quoted string
      continue;
    }
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string fixed(double x, int digits) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", digits, x);
  return text;
}

// A temporary directory for the data files and the script, removed with the object.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& parent) {
    std::string pattern = parent + "/.chasles-plot-XXXXXX";
    if (::mkdtemp(pattern.data()) == nullptr) {
      throw InputError(parent + ": cannot create a scratch directory (" + std::strerror(errno) + ")");
    }
    path = pattern;
  }
  ~ScratchDir() {
    for (const std::string& file : files) std::remove(file.c_str());
    ::rmdir(path.c_str());
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  std::string file(const std::string& name) {
    files.push_back(path + "/" + name);
    return files.back();
  }

  std::string path;
  std::vector<std::string> files;
};

void write_series(const std::string& path, const Series& series) {
  std::ofstream file(path);
  file.precision(10);
  for (size_t i = 0; i < series.t.size(); ++i) {
    file << series.t[i];
    for (const double x : series.rows[i]) file << ' ' << x;
    file << '\n';
  }
  if (!file) throw InputError(path + ": cannot write");
}

// Runs gnuplot on `script`; its complaints become the error.
void run_gnuplot(const std::string& script, const std::string& errors) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, errors.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  std::string program = "gnuplot";
  std::vector<char*> argv{program.data(), const_cast<char*>(script.c_str()), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    throw InputError(std::string("cannot run gnuplot (") + std::strerror(spawned) +
                     "): install it (Debian: apt-get install gnuplot-nox)");
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::ifstream file(errors);
    std::string said, line;
    while (std::getline(file, line)) {
      if (line.find_first_not_of(" ^") != std::string::npos) said += (said.empty() ? "" : " ") + line;
    }
    throw InputError("gnuplot failed" + (said.empty() ? std::string() : ": " + said.substr(0, 400)) +
                     (said.find("terminal") != std::string::npos ? " (its pngcairo terminal is needed: Debian's "
                                                                   "gnuplot-nox has it)"
                                                                 : ""));
  }
}

constexpr int kWidth = 1200, kHeight = 800;

// A round tick step near x: 1, 2, 2.5 or 5 times a power of ten.
double nice_step(double x) {
  if (!(x > 0)) return 1.0;
  const double decade = std::pow(10.0, std::floor(std::log10(x)));
  for (const double m : {1.0, 2.0, 2.5, 5.0}) {
    if (m * decade >= x * 0.75) return m * decade;
  }
  return 10.0 * decade;
}

}  // namespace

Json run_log_plot(const LogOptions& options) {
  const std::optional<JointInfo> joints = load_joints(options);
  PlotData data = collect(options);
  const int n = data.joints;
  const std::vector<std::string> names = labels_for(joints, n, "the messages on " + options.prefix + "*");

  if (::mkdir(options.out.c_str(), 0777) != 0 && errno != EEXIST) {
    throw InputError(options.out + ": cannot create the directory (" + std::strerror(errno) + ")");
  }
  struct stat info {};
  if (::stat(options.out.c_str(), &info) != 0 || !S_ISDIR(info.st_mode)) {
    throw InputError(options.out + ": not a directory");
  }

  bool prismatic = false, revolute = !joints;
  if (joints) {
    for (const JointType type : joints->types) (type == JointType::Prismatic ? prismatic : revolute) = true;
  }
  const std::string unit = prismatic && revolute ? "rad or m" : prismatic ? "m" : "rad";
  const std::string milli = prismatic && revolute ? "mrad or mm" : prismatic ? "mm" : "mrad";
  const std::string torque_unit = prismatic && revolute ? "N·m or N" : prismatic ? "N" : "N·m";
  const std::string time_axis = "set xlabel \"time since the log's first message (s)\"\n";

  ScratchDir scratch(options.out);
  const std::string status_file = scratch.file("status.dat"), command_file = scratch.file("commands.dat"),
                    period_file = scratch.file("period.dat");
  write_series(status_file, data.status);
  write_series(command_file, data.commands);
  const std::string truth_file = scratch.file("truth.dat");
  write_series(truth_file, data.truth);

  // The spread of the tick period: consecutive commands' utime (stamped by the controller as it
  // computes each) differ by the period plus the difference of two ticks' wake-up and compute
  // delays. Per-tick wake-up jitter is not on the wire; the status only has window percentiles.
  std::vector<double> deviations;
  double period_us = NAN;
  {
    std::vector<double> intervals;
    for (size_t i = 1; i < data.command_utimes.size(); ++i) {
      intervals.push_back(double(data.command_utimes[i] - data.command_utimes[i - 1]));
    }
    period_us = percentile(intervals, 50);
    for (const double interval : intervals) deviations.push_back(interval - period_us);
    std::ofstream file(period_file);
    for (const double d : deviations) file << d << '\n';
  }

  std::ostringstream gp;
  gp << "set terminal pngcairo size " << kWidth << "," << kHeight << " noenhanced font \"DejaVu Sans,11\"\n"
     << "set grid lc rgb \"#d0d0d0\"\n"
     << "set key outside right top box opaque\n"
     << "set datafile missing \"nan\"\n"
     << "set linetype 1 lc rgb \"#1f77b4\"\nset linetype 2 lc rgb \"#ff7f0e\"\nset linetype 3 lc rgb \"#2ca02c\"\n"
     << "set linetype 4 lc rgb \"#d62728\"\nset linetype 5 lc rgb \"#9467bd\"\nset linetype 6 lc rgb \"#8c564b\"\n"
     << "set linetype 7 lc rgb \"#e377c2\"\nset linetype 8 lc rgb \"#7f7f7f\"\nset linetype 9 lc rgb \"#bcbd22\"\n"
     << "set linetype cycle 9\n"
     << "set autoscale xfix\nset offsets 0, 0, graph 0.04, graph 0.04\n";
  // Targets as dotted vertical lines, labelled with their mode, on the time plots.
  std::string marks;
  {
    std::ostringstream m;
    for (size_t i = 0; i < data.targets.size(); ++i) {
      m << "set arrow " << i + 1 << " from " << data.targets[i].t << ", graph 0 to " << data.targets[i].t
        << ", graph 1 nohead dt 3 lc rgb \"#808080\"\n"
        << "set label " << i + 1 << " " << quoted(data.targets[i].label) << " at " << data.targets[i].t
        << ", graph " << (i % 2 == 0 ? 0.98 : 0.95)  // alternate heights: close targets stay legible
        << " left offset 0.3,0 textcolor rgb \"#606060\" font \",9\"\n";
    }
    marks = m.str();
  }
  const std::string unmark = "unset arrow\nunset label\n";
  std::vector<std::string> produced;
  const auto output = [&](const std::string& name) {
    produced.push_back(name);
    gp << "set output " << quoted(options.out + "/" + name + ".tmp") << "\n";
  };
  const std::string source = " (" + std::to_string(data.status.t.size()) + " " + options.prefix + "STATUS messages)";

  if (!data.status.t.empty()) {
    // Columns of status.dat: 1 t, then q, q_desired, tracking_error (n each), then timing.
    const int q0 = 2, qd0 = 2 + n, e0 = 2 + 2 * n, timing0 = 2 + 3 * n;
    output("joint_positions.png");
    gp << "set title " << quoted("Joint positions: measured q (coloured) and desired q_d (black dashed)" + source)
       << "\n" << time_axis << "set ylabel " << quoted("joint position (" + unit + ")") << "\n" << marks << "plot ";
    for (int j = 0; j < n; ++j) {
      gp << (j ? ", " : "") << quoted(status_file) << " using 1:" << q0 + j << " with lines lt " << j + 1
         << " lw 2.5 title " << quoted(names[size_t(j)]);
    }
    // The reference drawn over the measurement: where they part, the tracking error shows.
    for (int j = 0; j < n; ++j) {
      gp << ", " << quoted(status_file) << " using 1:" << qd0 + j << " with lines lc rgb \"black\" lw 1 dt (4,4) "
         << (j == 0 ? "title \"q_d (each joint)\"" : "notitle");
    }
    gp << "\n";

    output("tracking_error.png");
    gp << "set title " << quoted("Tracking error e = q_d - q" + source) << "\n"
       << "set ylabel " << quoted("tracking error (" + milli + ")") << "\n" << marks << "plot ";
    for (int j = 0; j < n; ++j) {
      gp << (j ? ", " : "") << quoted(status_file) << " using 1:($" << e0 + j << "*1000) with lines lt " << j + 1
         << " lw 1.5 title " << quoted(names[size_t(j)]);
    }
    gp << "\n" << unmark;

    output("compute_time.png");
    gp << "set title " << quoted("Tick compute time (state read to command encoded), per status window" + source)
       << "\nset ylabel \"compute time (µs, log scale)\"\nset logscale y\nset offsets 0, 0, 0, 0\nset key inside top right box opaque width 1.5\n"
       << marks << "plot " << quoted(status_file) << " using 1:" << timing0 + 4
       << " with lines lt 2 lw 1.5 title \"p99\", " << quoted(status_file) << " using 1:" << timing0 + 3
       << " with lines lt 1 lw 2 title \"p50\", " << quoted(status_file) << " using 1:" << timing0 + 5
       << " with points pt 7 ps 0.5 lc rgb \"#d62728\" title \"max\"\n"
       << "unset logscale y\nset offsets 0, 0, graph 0.04, graph 0.04\nset key outside right top box opaque\n"
       << unmark;
  }

  if (!data.commands.t.empty()) {
    // One panel per joint, each with its effort limits: how much headroom the controller had.
    output("torques.png");
    const int columns = n <= 3 ? 1 : 2, rows = (n + columns - 1) / columns;
    gp << "set multiplot layout " << rows << "," << columns
       << " margins 0.07, 0.98, 0.08, 0.93 spacing 0.08, 0.075 title "
       << quoted("Commanded joint torques (" + std::to_string(data.commands.t.size()) + " " + options.prefix +
                 "COMMAND messages)" +
                 (joints ? "; dashed red: the URDF's effort limits" : "; effort limits unknown: give --urdf"))
       << " font \",13\"\n"
       << "set key off\n";
    for (int j = 0; j < n; ++j) {
      // Only the bottom panel of each column names the time axis.
      gp << "set xlabel " << (j + columns >= n ? "\"time since the log's first message (s)\" offset 0,0.6" : "\"\"")
         << "\n";
      double peak = 0.0;
      for (const auto& row : data.commands.rows) peak = std::max(peak, std::abs(row[size_t(j)]));
      std::string title = names[size_t(j)] + ": peak |τ| " + fixed(peak, 2) + " " + torque_unit;
      gp << "set ylabel " << quoted("τ (" + torque_unit + ")") << " offset 1,0\n";
      if (joints && joints->effort[size_t(j)] > 0) {
        const double limit = joints->effort[size_t(j)];
        title += " = " + fixed(100.0 * peak / limit, 1) + " % of its limit " + number_text(limit) + " " + torque_unit;
        gp << "set yrange [" << -1.15 * limit << ":" << 1.15 * limit << "]\nset ytics " << nice_step(limit / 2)
           << "\n";
        gp << "set title " << quoted(title) << " offset 0,-0.6\nplot " << quoted(command_file) << " using 1:" << 2 + j
           << " with lines lt " << j + 1 << " lw 1.5, " << limit << " with lines lc rgb \"#d62728\" dt 2 lw 1.5, "
           << -limit << " with lines lc rgb \"#d62728\" dt 2 lw 1.5\n";
      } else {
        gp << "set autoscale y\nset ytics autofreq\nset title " << quoted(title) << " offset 0,-0.6\nplot " << quoted(command_file)
           << " using 1:" << 2 + j << " with lines lt " << j + 1 << " lw 1.5\n";
      }
    }
    gp << "unset multiplot\nset autoscale y\nset ytics autofreq\nset key outside right top box opaque\n"
       << "set xlabel offset 0,0\nset ylabel offset 0,0\n";
  }

  if (deviations.size() >= 2) {
    // The axis spans twice the 99th percentile of |deviation| (at least ±20 µs), in bins of whole
    // µs; the rare stalls beyond are counted in the title rather than squeezing the rest into a
    // few bins.
    std::vector<double> magnitudes;
    for (const double d : deviations) magnitudes.push_back(std::abs(d));
    const double range = std::max(20.0, std::ceil(2.0 * percentile(magnitudes, 99)));
    const double bin = std::max(1.0, std::round(range / 50.0));
    int64_t outside = 0;
    double worst = 0.0;
    for (const double d : deviations) {
      if (std::abs(d) > range) ++outside;
      worst = std::max(worst, std::abs(d));
    }
    output("jitter_histogram.png");
    gp << "set title "
       << quoted("Tick period jitter: the interval between consecutive " + options.prefix +
                 "COMMAND utime stamps minus their median, " + fixed(period_us, 0) + " µs\n" +
                 std::to_string(deviations.size()) + " intervals; p99 of |deviation| " +
                 fixed(percentile(magnitudes, 99), 1) + " µs" +
                 (outside > 0 ? "; " + std::to_string(outside) + " beyond ±" + fixed(range, 0) +
                                    " µs not shown, the largest " + fixed(worst, 0) + " µs"
                              : ""))
       << "\nset xlabel \"interval - median interval (µs)\"\nset ylabel \"ticks (log scale)\"\n"
       << "set logscale y\nset yrange [0.8:*]\nset xrange [" << -range - bin << ":" << range + bin << "]\n"
       << "set style fill solid 0.7 border lc rgb \"#1f4f7f\"\nset boxwidth " << bin * 0.9 << "\nset key off\n"
       << "bin(x) = " << bin << " * floor(x / " << bin << " + 0.5)\n"
       << "plot " << quoted(period_file) << " using (bin($1)):(abs($1) <= " << range
       << " ? 1 : 0) smooth frequency with boxes lc rgb \"#1f77b4\"\n"
       << "unset logscale y\nset autoscale\nset key outside right top box opaque\n";
  }

  if (!data.truth.t.empty() && !data.status.t.empty()) {
    // Columns: truth.dat 1 t, then (m_x, m_y, m_z, f_x, f_y, f_z); status.dat's estimate after its
    // timing, f_x at 2 + 3n + 6 + 3.
    const int estimate_f0 = 2 + 3 * n + 6 + 3;
    output("external_force.png");
    gp << unmark << "set title "
       << quoted("External force on the tip (base-aligned): estimate on " + options.prefix +
                 "STATUS (solid), truth on " + options.prefix + "TRUTH (dashed)")
       << "\n" << time_axis << "set ylabel \"force (N)\"\n" << marks << "plot ";
    const char* axes[] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
      gp << (k ? ", " : "") << quoted(status_file) << " using 1:" << estimate_f0 + k << " with lines lt " << k + 1
         << " lw 2.5 title " << quoted(std::string("f_") + axes[k] + " estimated");
    }
    for (int k = 0; k < 3; ++k) {
      gp << ", " << quoted(truth_file) << " using 1:" << 5 + k << " with lines lt " << k + 1 << " lw 1.5 dt (4,4) title "
         << quoted(std::string("f_") + axes[k] + " true");
    }
    gp << "\n";
  }

  if (data.clearance) {
    // Columns of status.dat after the tip wrench: the closest pair's distance, then the same where a
    // pair slowed the reference (2 + 3n + 12 and + 13).
    const int clearance0 = 2 + 3 * n + 12;
    output("clearance.png");
    gp << unmark << "set title "
       << quoted("Clearance: the closest pair's distance (clearance_distance on " + options.prefix +
                 "STATUS)\nred: a pair slowed the reference (clearance_slowed_by); the least " +
                 fixed(1e3 * data.clearance_least, 1) + " mm, " + data.clearance_least_pair + ", at " +
                 fixed(data.clearance_least_t, 2) + " s")
       << "\n" << time_axis << "set ylabel \"distance of the closest pair (mm)\"\n" << marks << "plot "
       << quoted(status_file) << " using 1:($" << clearance0 << "*1000) with lines lt 1 lw 2 title \"closest pair\", "
       << quoted(status_file) << " using 1:($" << clearance0 + 1
       << "*1000) with points pt 7 ps 0.4 lc rgb \"#d62728\" title \"slowed by a pair\"\n";
  }

  gp << "unset output\n";
  const std::string script = scratch.file("plots.gp");
  {
    std::ofstream file(script);
    file << gp.str();
    if (!file) throw InputError(script + ": cannot write");
  }
  for (const std::string& name : produced) scratch.files.push_back(options.out + "/" + name + ".tmp");
  run_gnuplot(script, scratch.file("gnuplot.err"));
  Json plots = Json::array();
  for (const std::string& name : produced) {
    const std::string path = options.out + "/" + name;
    if (std::rename((path + ".tmp").c_str(), path.c_str()) != 0) {
      throw InputError(path + ": gnuplot wrote no plot (" + std::strerror(errno) + ")");
    }
    plots.push_back(path);
  }
  if (!data.problems.empty()) {
    fail_damaged(options.log, data.problems, "plotted what was readable: " + std::to_string(produced.size()) +
                                                 " figures in " + options.out);
  }
  Json answer;
  answer["log"] = options.log;
  answer["plots"] = std::move(plots);
  answer["status_messages"] = data.status.t.size();
  answer["command_messages"] = data.commands.t.size();
  answer["targets"] = data.targets.size();
  answer["marks"] = nlohmann::json::array();
  for (const TargetMark& mark : data.targets) answer["marks"].push_back({{"t", mark.t}, {"label", mark.label}});
  answer["truth_messages"] = data.truth.t.size();
  if (data.clearance) {
    // What clearance.png shows, for a script: the least distance of the run and each run of
    // statuses in which a pair slowed the reference (its pair, its time, its least distance).
    Json slowed = Json::array();
    for (const SlowedRun& run : data.slowed) {
      slowed.push_back({{"pair", run.pair}, {"from", run.from}, {"to", run.to}, {"from_utime", run.from_utime},
                        {"to_utime", run.to_utime}, {"statuses", run.statuses},
                        {"least_distance", std::isfinite(run.least) ? Json(run.least) : Json()},
                        {"least_pair", run.least_pair}});
    }
    answer["clearance"] = {{"least_distance", data.clearance_least}, {"least_pair", data.clearance_least_pair},
                           {"least_t", data.clearance_least_t}, {"slowed", std::move(slowed)}};
  }
  return answer;
}

}  // namespace chasles::cli
