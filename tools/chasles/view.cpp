// chasles view: the live 3D view in the browser and the replay of a log, which the Python package
// serves (python -m chasles.view, docs/view.md). This command is the door to it: every argument
// after `view` goes to the module as it is, and the process becomes the interpreter's.
//
// The interpreter: $CHASLES_PYTHON, else the one this build's Python package was configured with
// (the project's venv, tools/python.sh), else python3 on the PATH. In a build tree the package is
// found in its build/python folder (put first on PYTHONPATH); installed, where pip put it.
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "command.hpp"

namespace chasles::cli {
namespace {

bool exists(const std::string& path) {
  struct stat info {};
  return !path.empty() && ::stat(path.c_str(), &info) == 0;
}

std::string interpreter() {
  if (const char* chosen = std::getenv("CHASLES_PYTHON"); chosen != nullptr && *chosen != '\0') return chosen;
  if (exists(CHASLES_VIEW_PYTHON)) return CHASLES_VIEW_PYTHON;
  return "python3";
}

}  // namespace

void run_view(const std::vector<std::string>& arguments) {
  const std::string python = interpreter();
  std::vector<std::string> args = {python, "-m", "chasles.view"};
  args.insert(args.end(), arguments.begin(), arguments.end());
  if (exists(CHASLES_VIEW_PACKAGE_DIR)) {
    const char* path = std::getenv("PYTHONPATH");
    const std::string joined =
        std::string(CHASLES_VIEW_PACKAGE_DIR) + (path != nullptr && *path != '\0' ? std::string(":") + path : "");
    ::setenv("PYTHONPATH", joined.c_str(), 1);
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  ::execvp(argv[0], argv.data());
  throw InputError("cannot run " + python + " -m chasles.view: " + std::strerror(errno) +
                   " (set CHASLES_PYTHON to an interpreter with chasles and its 'view' extra: pip install '.[view]')");
}

Command register_view(CLI::App& app) {
  // Listed in --help only: main hands `chasles view ...` to run_view before parsing anything.
  CLI::App* command = app.add_subcommand(
      "view",
      "The arm in 3D in the browser, live from the bus or replaying a log: python -m chasles.view with "
      "these arguments ('chasles view --help' is its help; docs/view.md)");
  return {command, [] { return Json(); }};
}

}  // namespace chasles::cli
