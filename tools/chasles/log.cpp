// chasles log export | plot: what happened in a run, from the LCM log lcm-logger wrote.
//
// export: one channel's messages as CSV, one column per field, joint arrays by joint name.
// plot:   PNG figures made with gnuplot — joint positions against the reference, tracking error,
//         torques against the effort limits, compute time, and the spread of the tick period.
// A damaged log is read as far as it can be framed; what was readable is written, then the
// command fails naming the byte offsets of the damage.
//
// This file registers both and holds what they share (log_command.hpp); each subcommand lives in its
// own source, log_export.cpp and log_plot.cpp.
#include <algorithm>
#include <memory>

#include "tools/chasles/log_command.hpp"
#include "tools/cli/messages.hpp"

namespace chasles::cli {

std::optional<JointInfo> load_joints(const LogOptions& options) {
  if (options.urdf.empty()) return std::nullopt;
  const RobotModel model = load_model({options.urdf, options.tip});
  JointInfo info;
  for (const Joint& joint : model.joints()) {
    info.names.push_back(joint.name);
    info.types.push_back(joint.type);
    info.effort.push_back(joint.limits.effort);
  }
  return info;
}

std::vector<std::string> labels_for(const std::optional<JointInfo>& joints, int count, const std::string& what) {
  if (!joints) return joint_labels({}, count);
  if (joints->names.size() != size_t(count)) {
    throw InputError(what + " carry " + std::to_string(count) + " joints; the URDF's chain has " +
                     std::to_string(joints->names.size()) + " (is --tip right?)");
  }
  return joints->names;
}

[[noreturn]] void fail_damaged(const std::string& log, const std::vector<std::string>& problems,
                               const std::string& written) {
  std::string text = log + ": ";
  const size_t shown = std::min<size_t>(problems.size(), 3);
  for (size_t i = 0; i < shown; ++i) text += (i > 0 ? "; " : "") + problems[i];
  if (problems.size() > shown) text += "; and " + std::to_string(problems.size() - shown) + " more";
  throw InputError(text + " (" + written + ")");
}

namespace {

void add_robot_options(CLI::App& command, LogOptions& options) {
  command.add_option("--urdf,--robot", options.urdf, "Robot description: joint names (and, for plots, effort limits)")
      ->type_name("FILE");
  command.add_option("--tip", options.tip, "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
}

}  // namespace

Command register_log(CLI::App& app) {
  auto options = std::make_shared<LogOptions>();
  CLI::App* log = app.add_subcommand("log", "Read an LCM log of a run (lcm-logger's): export a channel as CSV, plot");
  log->require_subcommand(1);

  CLI::App* exporter = log->add_subcommand("export", "One channel's messages as CSV, one column per field");
  exporter->add_option("log", options->log, "LCM log file (lcm-logger's)")->required()->type_name("LOG");
  exporter->add_option("--channel", options->channel, "The channel to export, e.g. CHASLES_STATUS")
      ->required()
      ->type_name("CHANNEL");
  exporter->add_option("--out", options->out, "The CSV file to write ('-': standard output)")
      ->required()
      ->type_name("FILE");
  add_robot_options(*exporter, *options);
  exporter->footer(
      "Columns: log_t (s since the log's first message), log_utime (the logger's receive time, µs since the\n"
      "epoch), log_event (its event number), then the message's fields in the .lcm contract's order: joint\n"
      "arrays one column per joint, named by the URDF's joints with --urdf (else j0, j1, ...), e.g.\n"
      "position[panda_joint1]; tip_position[x], tip_quaternion[w]. Numbers are exact (shortest round trip).\n"
      "Prints {\"log\", \"channel\", \"type\", \"messages\", \"columns\", \"out\"}. A damaged log: the readable\n"
      "messages are written, then exit 1 with the byte offsets of the damage.\n"
      "Example:\n"
      "  chasles log export build/demo/<time>/chasles.lcmlog --channel CHASLES_STATUS --out status.csv \\\n"
      "      --urdf tests/data/panda.urdf --tip panda_hand");

  CLI::App* plotter = log->add_subcommand("plot", "PNG figures of a run, drawn with gnuplot");
  plotter->add_option("log", options->log, "LCM log file (lcm-logger's)")->required()->type_name("LOG");
  plotter->add_option("--out", options->out, "Directory for the PNGs (created if missing)")
      ->required()
      ->type_name("DIR");
  plotter->add_option("--prefix", options->prefix, "Channel prefix: PREFIX STATUS, PREFIX COMMAND, PREFIX TARGET")
      ->type_name("PREFIX")
      ->capture_default_str();
  plotter->add_option("--command-channel", options->command_channel,
                      "The commands' channel, when not PREFIX COMMAND: an arm driven over Drake's protocols "
                      "(IIWA_COMMAND, PANDA_COMMAND; their torque is plotted as sent)")
      ->type_name("CHANNEL");
  add_robot_options(*plotter, *options);
  plotter->footer(
      "Writes 1200x800 PNGs: joint_positions.png (q and q_d), tracking_error.png, compute_time.png (from\n"
      "PREFIX STATUS), torques.png (commanded, against the URDF's effort limits) and jitter_histogram.png\n"
      "(the spread of the interval between commands), from PREFIX COMMAND; targets are marked on the time\n"
      "axes. Prints {\"log\", \"plots\", \"status_messages\", \"command_messages\", \"targets\"}.\n"
      "Example:\n"
      "  chasles log plot build/demo/<time>/chasles.lcmlog --out plots/ --urdf tests/data/panda.urdf --tip panda_hand");

  return {log, [options, exporter] { return exporter->parsed() ? run_log_export(*options) : run_log_plot(*options); }};
}

}  // namespace chasles::cli
