// How the command-line tools report an error: one line "<tool>: <message>" on stderr. Messages
// come from several libraries (urdfdom, Ceres, CLI11) and some span lines; a script reading stderr
// should get exactly one. Shared by chasles and chasles_calibrate.
#pragma once

#include <iostream>
#include <string>

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

}  // namespace chasles::tools
