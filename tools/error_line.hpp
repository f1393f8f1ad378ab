// How the command-line tools report an error: one line "<tool>: <message>" on stderr. Messages
// come from several libraries (urdfdom, Ceres, CLI11) and some span lines; a script reading stderr
// should get exactly one. Warnings take one line each too. Shared by the tools.
#pragma once

#include <iostream>
#include <string>
#include <vector>

namespace chasles::tools {

/// `text` without trailing line breaks and with inner ones turned into spaces.
inline std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

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
