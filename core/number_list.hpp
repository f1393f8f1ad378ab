// Comma-separated numbers as the command-line programs take them ("0.1,-2,3e-1"): every entry a
// finite number, blanks after it allowed. Shared by the programs (chasles, chasles_plant,
// chasles_controller), which is why it lives in core, below all of them: text to numbers, no I/O.
// The caller names the input (`what`: a flag, a field), so the messages say where it came from.
// Not installed: a helper of the programs, not part of the library's API.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/model/payload.hpp"

namespace chasles {

/// The numbers of `text`; `what` names it in messages ("--q0: entry 2 ('x') is not a number").
/// Throws ArgumentError.
inline std::vector<double> parse_number_list(const std::string& text, const std::string& what) {
  std::vector<double> values;
  size_t start = 0;
  while (true) {
    const size_t end = text.find(',', start);
    const std::string item = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    const std::string entry = what + ": entry " + std::to_string(values.size()) + " ('" + item + "')";
    size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos) {
      throw ArgumentError(entry + " is not a number");
    }
    if (!std::isfinite(value)) throw ArgumentError(entry + " is not finite");
    values.push_back(value);
    if (end == std::string::npos) return values;
    start = end + 1;
  }
}

/// "KG[,CX,CY,CZ]": a point mass at the tip, kg, and its position in the tip frame, m (--payload
/// of chasles_plant and chasles_controller). Throws ArgumentError naming `what`.
inline Payload parse_payload(const std::string& text, const std::string& what) {
  const std::vector<double> v = parse_number_list(text, what);
  if (v.size() != 1 && v.size() != 4) {
    throw ArgumentError(what + " takes KG[,CX,CY,CZ] (1 or 4 numbers: kg, m in the tip frame); got " +
                        std::to_string(v.size()));
  }
  Payload payload;
  payload.mass = v[0];
  if (v.size() == 4) payload.centre = Vector3d(v[1], v[2], v[3]);
  if (const std::string problem = payload_problem(payload); !problem.empty()) {
    throw ArgumentError(what + ": " + problem);
  }
  return payload;
}

/// "A1,A2,...": the armature of every joint of a `joints`-joint arm, in chain order, kg·m² (kg for a
/// prismatic joint), each ≥ 0 (--armature of chasles_plant and chasles_controller, which hand it to
/// with_armature). Throws ArgumentError naming `what`.
inline Eigen::VectorXd parse_armature(const std::string& text, int joints, const std::string& what) {
  const std::vector<double> v = parse_number_list(text, what);
  if (static_cast<int>(v.size()) != joints) {
    throw ArgumentError(what + " has " + std::to_string(v.size()) + " values; the arm has " + std::to_string(joints) +
                        " joints: give one per joint, root to tip, kg*m^2 (kg for a prismatic joint)");
  }
  Eigen::VectorXd armature(joints);
  for (int i = 0; i < joints; ++i) {
    armature[i] = v[static_cast<size_t>(i)];
    if (armature[i] < 0.0) throw ArgumentError(what + ": entry " + std::to_string(i) + " is negative; armature is >= 0");
  }
  return armature;
}

}  // namespace chasles
