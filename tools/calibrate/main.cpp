// chasles_calibrate: offline calibration (chasles::calibration, chasles::identification, Ceres).
//   fit       a dataset of joint positions and tracker measurements → a corrected URDF and a report
//   synth     a synthetic dataset from a perturbed copy of the robot, to test and to rehearse with
//   excite    an excitation trajectory for identifying the arm's dynamics, as waypoints to run
//   dynamics  an LCM log of the arm moving → its identified inertias, friction and rotors in its URDF
//   payload   an LCM log of the arm moving with a load → the load, as `chasles payload` sends it
// Errors: one line "chasles_calibrate: ..." on stderr and nothing written; exit 2 for a usage error,
// 1 for bad input (URDF, dataset, too few rows, a file that cannot be written).
#include <iostream>
#include <string>
#include <vector>

#include "tools/error_line.hpp"
#include "tools/run_main.hpp"
#include "commands.hpp"

namespace {

int fail(const std::string& message, int code) { return chasles::tools::fail("chasles_calibrate", message, code); }

}  // namespace

int main(int argc, char** argv) {
  using namespace chasles::calibrate_cli;

  CLI::App app("chasles_calibrate: kinematic calibration of a serial arm from tracker measurements, and dynamic "
               "identification from its logs (excitation, fit, payload)",
               "chasles_calibrate");
  app.set_version_flag("--version", std::string("chasles_calibrate ") + CHASLES_VERSION);
  app.require_subcommand(1);
  app.footer(
      "Examples:\n"
      "  chasles_calibrate synth --urdf panda.urdf --tip panda_hand --seed 3 --n 200 --out data.csv --truth truth.urdf\n"
      "  chasles_calibrate fit --urdf panda.urdf --tip panda_hand --data data.csv --holdout 0.2 \\\n"
      "      --out corrected.urdf --report report.json\n"
      "  chasles_calibrate excite --urdf panda.urdf --tip panda_hand --out excitation.json --report excitation_report.json\n"
      "  chasles_calibrate dynamics --urdf panda.urdf --tip panda_hand --log run.lcmlog --out identified.urdf \\\n"
      "      --report identified.json\n"
      "  chasles_calibrate payload --urdf identified.urdf --tip panda_hand --log with_box.lcmlog --out box.json\n"
      "Run 'chasles_calibrate COMMAND --help' for a command's input and output.");
  const std::vector<Command> commands = {register_fit(app), register_synth(app), register_excite(app),
                                         register_dynamics(app), register_payload(app), register_check(app)};

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help, --version
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string help = "chasles_calibrate --help";
    for (const CLI::App* sub : app.get_subcommands()) help = "chasles_calibrate " + sub->get_name() + " --help";
    if (app.get_subcommands().empty() && argc > 1 && argv[1][0] != '-') {
      return fail(std::string("unknown command '") + argv[1] + "' (commands: fit, synth, excite, dynamics, payload; see '" +
                      help + "')",
                  2);
    }
    return fail(std::string(e.what()) + " (see '" + help + "')", 2);
  }

  return chasles::tools::run_main("chasles_calibrate", [&] {
    for (const Command& command : commands) {
      if (!command.app->parsed()) continue;
      command.run();
      std::cout.flush();
      return 0;
    }
    return fail("no command given (see 'chasles_calibrate --help')", 2);
  });
}
