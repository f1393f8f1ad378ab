#include "tools/cli/cases.hpp"

#include <stdexcept>

#include "core/ik/ik.hpp"

namespace chasles::cli {

Eigen::VectorXd middle_of_limits(const RobotModel& model) {
  Eigen::VectorXd q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    q[i] = joint.type == JointType::Continuous ? 0.0 : 0.5 * (joint.limits.lower + joint.limits.upper);
  }
  return q;
}

Matrix4d parse_transform(const Json& value, const std::string& where) {
  Matrix4d T;
  if (!value.is_array() || value.size() != 4)
    throw InputError(where + " is " + describe_type(value) + ", expected 4 rows of 4 numbers");
  for (size_t i = 0; i < 4; ++i) {
    const Eigen::VectorXd row = parse_vector(value[i], 4, where + "[" + std::to_string(i) + "]", "a 4x4 row");
    T.row(static_cast<Eigen::Index>(i)) = row.transpose();
  }
  try {
    check_rigid_transform(T, where.c_str());
  } catch (const ArgumentError& e) {
    throw InputError(e.what());
  }
  return T;
}

std::vector<EvalCase> parse_eval_cases(const Json& document, const RobotModel& model, const std::string& file) {
  const Json& cases = cases_list(document, file);
  const std::string name = file == "-" ? "<stdin>" : file;
  std::vector<EvalCase> out;
  out.reserve(cases.size());
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string where = name + ": cases[" + std::to_string(i) + "]";
    const Json& item = cases[i];
    EvalCase input;
    input.q = parse_vector(member(item, "q", where), model.dof(), where + ".q", "one per joint");
    const auto qd = item.find("qd"), qdd = item.find("qdd");
    input.has_dynamics = qd != item.end() && qdd != item.end();
    if (input.has_dynamics) {
      input.qd = parse_vector(*qd, model.dof(), where + ".qd", "one per joint");
      input.qdd = parse_vector(*qdd, model.dof(), where + ".qdd", "one per joint");
    }
    out.push_back(std::move(input));
  }
  return out;
}

std::vector<IkTarget> parse_ik_targets(const Json& document, const RobotModel& model, const std::string& file) {
  const Json& cases = cases_list(document, file);
  const std::string name = file == "-" ? "<stdin>" : file;
  std::vector<IkTarget> out;
  out.reserve(cases.size());
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string where = name + ": cases[" + std::to_string(i) + "]";
    const Json& item = cases[i];
    IkTarget input;
    input.T_sd = parse_transform(member(item, "T_target", where), where + ".T_target");
    const auto seed = item.find("q_seed");
    input.q_seed = seed == item.end() ? middle_of_limits(model)
                                      : parse_vector(*seed, model.dof(), where + ".q_seed", "one per joint");
    out.push_back(std::move(input));
  }
  return out;
}

}  // namespace chasles::cli
