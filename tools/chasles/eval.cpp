// chasles eval: kinematics at a list of joint configurations.
#include <memory>

#include "core/dynamics/dynamics.hpp"
#include "tools/cli/cases.hpp"
#include "command.hpp"

namespace chasles::cli {
namespace {

/// One case's answer; each quantity is one key, so more (dynamics) slot in beside them.
Json eval_case(const RobotModel& model, Data& data, const EvalCase& input) {
  Json out;
  link_poses(model, data, input.q);  // runs forward_kinematics: data.T_sb, data.T_link
  out["T"] = transform_json(data.T_sb);
  out["J_s"] = rows_json(space_jacobian(model, data, input.q));
  out["J_b"] = rows_json(body_jacobian(model, data, input.q));
  Json link_T = Json::object();
  for (size_t k = 0; k < model.links().size(); ++k) link_T[model.links()[k].name] = transform_json(data.T_link[k]);
  out["link_T"] = std::move(link_T);
  if (input.has_dynamics) {
    out["tau"] = vector_json(inverse_dynamics(model, data, input.q, input.qd, input.qdd));
    out["M"] = rows_json(mass_matrix(model, data, input.q));
    out["g"] = vector_json(gravity_torques(model, data, input.q));
    out["c"] = vector_json(velocity_product(model, data, input.q, input.qd));
  }
  return out;
}

Json eval_json(const RobotModel& model, const std::string& cases_path) {
  const std::vector<EvalCase> inputs = parse_eval_cases(read_json_file(cases_path, "cases file"), model, cases_path);
  Data data(model);
  Json results = Json::array();
  for (const EvalCase& input : inputs) results.push_back(eval_case(model, data, input));
  Json out;
  out["cases"] = std::move(results);
  return out;
}

struct EvalOptions {
  ModelOptions model;
  std::string cases;
};

}  // namespace

Command register_eval(CLI::App& app) {
  auto options = std::make_shared<EvalOptions>();
  CLI::App* command = app.add_subcommand("eval",
                                         "Kinematics at each q of a cases file, and dynamics where a case "
                                         "also has qd and qdd");
  add_model_options(*command, options->model);
  command
      ->add_option("--cases", options->cases,
                   "JSON file {\"cases\": [{\"q\": [n numbers], \"qd\", \"qdd\": optional}, ...]}; other keys "
                   "are ignored; - reads stdin")
      ->required()
      ->type_name("FILE");
  command->footer(
      "Output: {\"cases\": [{\"T\": tip pose 4x4 rows, \"J_s\": space Jacobian 6 rows,\n"
      "                      \"J_b\": body Jacobian 6 rows, \"link_T\": {link: 4x4 rows},\n"
      "                      and with qd and qdd: \"tau\": M qdd + c + g, \"M\": mass matrix rows,\n"
      "                      \"g\": gravity torques, \"c\": C(q, qd) qd}, ...]}\n"
      "Twists and Jacobian rows are angular first (w, v). Units: m, rad, s, N m; gravity (0, 0, -9.81).\n"
      "Example:\n"
      "  echo '{\"cases\": [{\"q\": [0, -1.57, 1.57, 0, 0, 0]}]}' > cases.json\n"
      "  chasles eval --urdf ur5.urdf --tip tool0 --cases cases.json");
  return {command, [options] { return eval_json(load_model(options->model), options->cases); }};
}

}  // namespace chasles::cli
