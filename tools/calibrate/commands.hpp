// The pieces chasles_calibrate's subcommands share: their registration, the atomic writer, and the
// error type main maps to exit code 1.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "tools/cli/json_io.hpp"

namespace chasles {
class RobotModel;
}

namespace chasles::calibrate_cli {

using cli::InputError;
using cli::Json;

struct Command {
  CLI::App* app = nullptr;
  std::function<void()> run;  ///< does the work, writes its files, prints its summary; throws on bad input
};

Command register_fit(CLI::App& app);
Command register_synth(CLI::App& app);
Command register_excite(CLI::App& app);
Command register_dynamics(CLI::App& app);
Command register_payload(CLI::App& app);
Command register_check(CLI::App& app);

/// Writes every (path, content) pair or none: each goes to a temporary file in its target's
/// directory, is flushed to disk (fsync), and only when all are written are they renamed into
/// place (an atomic replace each) and the directories synced. Throws InputError naming the path.
void write_files_atomically(const std::vector<std::pair<std::string, std::string>>& files);

/// A report's first fields: the tool that wrote it, and the arm (name, URDF, base and tip link).
Json report_header(const RobotModel& nominal, const std::string& urdf);

/// The whole content of a text file; InputError naming it and `what` otherwise.
std::string read_text_file(const std::string& path, const std::string& what);

}  // namespace chasles::calibrate_cli
