// A number as chasles's messages print it.
#pragma once

#include <cstdio>
#include <string>

namespace chasles {

/// x in %g: six significant digits, no trailing zeros ("0.05", "1e-09").
inline std::string number_text(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", x);
  return text;
}

}  // namespace chasles
