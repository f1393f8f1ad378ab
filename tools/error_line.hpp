// How the command-line tools report an error: one line "<tool>: <message>" on stderr. Messages
// come from several libraries (urdfdom, Ceres, CLI11) and some span lines; a script reading stderr
// should get exactly one (chasles::one_line, core/error.hpp, which the controller's main uses too).
// Warnings take one line each too. Shared by the tools.
#pragma once

#include <iostream>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace chasles::tools {

/// Prints "<tool>: <message>" as one line on stderr and returns `code`, the exit status.
inline int fail(const char* tool, const std::string& message, int code) {
  std::cerr << tool << ": " << one_line(message) << std::endl;
  return code;
}

/// Prints "<tool>: warning: <source>: <warning>" on stderr, one line per warning: what a model
/// loaded with but a user should know (RobotModel::warnings()).
inline void warn(const char* tool, const std::string& source, const std::vector<std::string>& warnings) {
  for (const std::string& warning : warnings) std::cerr << tool << ": warning: " << source << ": " << one_line(warning) << "\n";
  std::cerr.flush();
}

}  // namespace chasles::tools
