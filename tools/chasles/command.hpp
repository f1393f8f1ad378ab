// The pieces every chasles subcommand shares. A subcommand is a register_<name>() function that
// adds a CLI11 subcommand with its options and returns a Command whose run() builds the whole
// JSON answer; main prints it only once it is complete, so an error never leaves half a document.
// A command whose output is not a JSON document (the monitor's screen, a CSV on standard output)
// writes it itself and returns a null Json, and main prints nothing more.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "tools/cli/json_io.hpp"

namespace chasles::cli {

struct Command {
  CLI::App* app = nullptr;    ///< the CLI11 subcommand
  std::function<Json()> run;  ///< the answer, or null if run() wrote its own; throws InputError or ModelError
};

/// --urdf FILE and --tip LINK, as every model-based subcommand takes them.
struct ModelOptions {
  std::string urdf;
  std::string tip;
};

/// Adds --urdf (required) and --tip to `command`, stored in `options`.
void add_model_options(CLI::App& command, ModelOptions& options);

/// The model the options name; throws ModelError naming the file and the joint or link at fault.
RobotModel load_model(const ModelOptions& options);

/// Where a sending subcommand (target, mode, payload) sends: the channel prefix and the LCM URL.
struct WireOptions {
  std::string prefix = "CHASLES_";
  std::string lcm_url;
};

/// Adds --channel-prefix (checked: characters that match themselves in the controller's channel
/// names) and --lcm-url to `command`; `what` goes out on PREFIX `channel` ("target", "TARGET").
void add_wire_options(CLI::App& command, WireOptions& wire, const std::string& what, const std::string& channel);

/// A comma-separated list of exactly n finite numbers ("0.1,-2,3e-1"), the form single-shot
/// commands take joint vectors in; `option` names it in errors ("--q").
Eigen::VectorXd parse_list(const std::string& text, Eigen::Index n, const std::string& option);

// The subcommands, in the order --help lists them.
Command register_inspect(CLI::App& app);
Command register_eval(CLI::App& app);
Command register_rnea(CLI::App& app);
Command register_fd(CLI::App& app);
Command register_ik(CLI::App& app);      ///< inverse kinematics (chasles::ik)
Command register_target(CLI::App& app);  ///< sends an arm_target_t over LCM
Command register_mode(CLI::App& app);    ///< sends a control_mode_t (the control law) over LCM
Command register_payload(CLI::App& app); ///< sends a payload_t (the load at the tip) over LCM
Command register_jog(CLI::App& app);     ///< jogs the arm: jog_command_t at a steady rate, then a stop
Command register_stream(CLI::App& app);  ///< plays joint or tip setpoints (a stream) at their times
Command register_monitor(CLI::App& app); ///< a live view of the controller's status, in the terminal
Command register_log(CLI::App& app);     ///< LCM logs of a run: export a channel as CSV, plot
Command register_view(CLI::App& app);    ///< the 3D view in the browser (python -m chasles.view)
/// Becomes the interpreter running chasles.view with `arguments`; throws InputError if it cannot.
void run_view(const std::vector<std::string>& arguments);

}  // namespace chasles::cli
