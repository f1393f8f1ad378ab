// Comma-separated numbers as the command-line tools take them ("0.1,-2,3e-1"): every entry a
// finite number, blanks after it allowed. Shared by chasles and chasles_plant.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace chasles::tools {

/// The numbers of `text`; `option` names it in messages ("--q0: entry 2 ('x') is not a number").
/// Throws std::invalid_argument.
inline std::vector<double> parse_number_list(const std::string& text, const std::string& option) {
  std::vector<double> values;
  size_t start = 0;
  while (true) {
    const size_t end = text.find(',', start);
    const std::string item = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    const std::string entry = option + ": entry " + std::to_string(values.size()) + " ('" + item + "')";
    size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos) {
      throw std::invalid_argument(entry + " is not a number");
    }
    if (!std::isfinite(value)) throw std::invalid_argument(entry + " is not finite");
    values.push_back(value);
    if (end == std::string::npos) return values;
    start = end + 1;
  }
}

}  // namespace chasles::tools
