// The inputs of `chasles eval` and `chasles ik`, read from a parsed cases document and checked
// against the model, every case before any is computed, so a bad case late in a file fails fast.
// Keys other than these are ignored, so the reference files are valid input. Errors are
// InputError naming the file and the case ("f.json: cases[3].q has 5 entries, expected 6 ...").
#pragma once

#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "tools/cli/json_io.hpp"

namespace chasles::cli {

/// {"q": [n], "qd": [n], "qdd": [n]}; dynamics only when both qd and qdd are given.
struct EvalCase {
  Eigen::VectorXd q;
  bool has_dynamics = false;
  Eigen::VectorXd qd, qdd;
};

/// {"T_target": 4 rows of 4 (a finite rigid transform), "q_seed": [n], optional: the middle of
/// the limits}.
struct IkTarget {
  Matrix4d T_sd;
  Eigen::VectorXd q_seed;
};

/// `file` names the document in messages ("-" for standard input).
std::vector<EvalCase> parse_eval_cases(const Json& document, const RobotModel& model, const std::string& file);
std::vector<IkTarget> parse_ik_targets(const Json& document, const RobotModel& model, const std::string& file);

/// A rigid transform from 4 rows of 4 finite numbers; InputError naming `where` otherwise.
Matrix4d parse_transform(const Json& value, const std::string& where);

/// The middle of every joint's range (0 for continuous joints): the IK seed when none is given.
Eigen::VectorXd middle_of_limits(const RobotModel& model);

}  // namespace chasles::cli
