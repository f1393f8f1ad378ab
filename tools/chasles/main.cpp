// chasles: the model's answers as JSON on stdout, and `target`, `mode` and `payload`, which send the
// controller one goal, control law or tip load and print it; `monitor` shows the running controller
// and `log` exports and plots a run's log.
// Errors: one line "chasles: ..." on stderr, nothing on stdout; exit 2 for a usage
// error, 1 for bad input (URDF, cases file, a refused target, mode or payload) or when LCM cannot start.
#include <iostream>
#include <string>
#include <vector>

#include "core/model/urdf.hpp"
#include "tools/error_line.hpp"
#include "tools/run_main.hpp"
#include "command.hpp"

namespace {

int fail(const std::string& message, int code) { return chasles::tools::fail("chasles", message, code); }

}  // namespace

int main(int argc, char** argv) {
  using namespace chasles::cli;

  CLI::App app("chasles: kinematics and dynamics of a serial robot arm from its URDF, answered as JSON", "chasles");
  app.set_version_flag("--version", std::string("chasles ") + CHASLES_VERSION);
  bool pretty = false;
  app.add_flag("--pretty", pretty, "Indent the JSON output (default: one line)");
  app.require_subcommand(1);
  app.fallthrough();  // global flags may also follow the subcommand
  app.footer(
      "Conventions: Lynch & Park; twists and screw axes (w, v), angular first; SI units.\n"
      "Numbers are printed in shortest round-trip form (exact doubles); no limit prints as null.\n"
      "Examples:\n"
      "  chasles inspect --urdf ur5.urdf --tip tool0\n"
      "  chasles --pretty eval --urdf ur5.urdf --tip tool0 --cases cases.json\n"
      "  chasles ik --urdf ur5.urdf --tip tool0 --targets targets.json\n"
      "  chasles target --robot ur5.urdf --tip tool0 --joint 0,-1.57,1.57,0,0,0 --duration 2\n"
      "  chasles mode joint-impedance --robot ur5.urdf --tip tool0 --stiffness 300\n"
      "  chasles payload --mass 1.5 --com 0,0,0.05\n"
      "  chasles monitor --urdf ur5.urdf --tip tool0\n"
      "  chasles log plot run.lcmlog --out plots/ --urdf ur5.urdf --tip tool0\n"
      "  chasles view --urdf ur5.urdf --tip tool0\n"
      "Run 'chasles COMMAND --help' for a command's input and output.");

  const std::vector<Command> commands = {register_inspect(app), register_eval(app), register_rnea(app),
                                         register_fd(app), register_ik(app), register_target(app),
                                         register_mode(app), register_payload(app), register_jog(app), register_stream(app), register_monitor(app),
                                         register_log(app), register_view(app)};

  // chasles view: every argument after it is the Python module's, its --help included.
  if (argc >= 2 && std::string(argv[1]) == "view") {
    return chasles::tools::run_main("chasles", [&] {
      run_view(std::vector<std::string>(argv + 2, argv + argc));
      return 1;
    });
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help, --version
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string help = "chasles --help";
    for (const CLI::App* sub : app.get_subcommands()) {
      help = "chasles " + sub->get_name();
      for (const CLI::App* inner : sub->get_subcommands()) help += " " + inner->get_name();  // chasles log export
      help += " --help";
    }
    if (app.get_subcommands().empty()) {
      std::string names;
      for (const Command& command : commands) names += (names.empty() ? "" : ", ") + command.app->get_name();
      // CLI11 says "A subcommand is required" for a misspelt one too: name it when it is the first
      // word after the global flags.
      for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--pretty") continue;
        if (!arg.empty() && arg[0] != '-') {
          return fail("unknown command '" + arg + "' (commands: " + names + "; see '" + help + "')", 2);
        }
        break;
      }
      return fail(std::string(e.what()) + " (commands: " + names + "; see '" + help + "')", 2);
    }
    return fail(std::string(e.what()) + " (see '" + help + "')", 2);
  }

  return chasles::tools::run_main("chasles", [&] {
    for (const Command& command : commands) {
      if (!command.app->parsed()) continue;
      const Json answer = command.run();
      if (answer.is_null()) return 0;  // the command wrote its own output
      const std::string text = dump(answer, pretty);  // complete before anything is printed
      std::cout << text << '\n';
      std::cout.flush();
      if (!std::cout) return fail("cannot write the output", 1);
      return 0;
    }
    return fail("no command given (see 'chasles --help')", 2);
  });
}
