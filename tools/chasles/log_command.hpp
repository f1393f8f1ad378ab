// The pieces `chasles log`'s subcommands share (log.cpp registers them): their options, the URDF's
// joints that name the columns and bound the torques, and the one error a damaged log ends in. Each
// subcommand is a run_log_*() in a source of its own — log_export.cpp, log_plot.cpp — because they
// share the log reader and nothing else. Internal to the chasles program.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "tools/chasles/command.hpp"

namespace chasles::cli {

struct LogOptions {
  std::string log;
  std::string channel;
  std::string out;
  std::string urdf;
  std::string tip;
  std::string prefix = "CHASLES_";
  std::string command_channel;  ///< plot: the commands' channel (empty: PREFIX COMMAND)
};

// The joints of the URDF's chain, when one is given.
struct JointInfo {
  std::vector<std::string> names;
  std::vector<JointType> types;
  std::vector<double> effort;  ///< limits, N·m or N
};

/// The URDF's chain when --urdf is given; nothing otherwise.
std::optional<JointInfo> load_joints(const LogOptions& options);

// Labels for `count` joint columns: the URDF's names, which must then be as many.
std::vector<std::string> labels_for(const std::optional<JointInfo>& joints, int count, const std::string& what);

// The damage found, as one error: the first few places, and what was written regardless.
[[noreturn]] void fail_damaged(const std::string& log, const std::vector<std::string>& problems,
                               const std::string& written);

/// chasles log export: one channel as CSV (a null Json when the CSV went to standard output).
Json run_log_export(const LogOptions& options);

/// chasles log plot: the PNG figures of a run.
Json run_log_plot(const LogOptions& options);

}  // namespace chasles::cli
