// chasles inspect: what the model is (chain, joints, limits, home pose and screw axes).
#include <memory>

#include "command.hpp"

namespace chasles::cli {
namespace {

Json inspect_json(const RobotModel& model) {
  Json names = Json::array(), types = Json::array();
  Json lower = Json::array(), upper = Json::array(), velocity = Json::array(), effort = Json::array();
  for (const Joint& joint : model.joints()) {
    names.push_back(joint.name);
    types.push_back(to_string(joint.type));
    lower.push_back(number(joint.limits.lower));
    upper.push_back(number(joint.limits.upper));
    velocity.push_back(number(joint.limits.velocity));  // absent limit: +∞ → null
    effort.push_back(number(joint.limits.effort));
  }
  Json out;
  out["robot"] = model.name();
  out["base_link"] = model.base_link();
  out["tip_link"] = model.tip_link();
  out["dof"] = model.dof();
  out["joint_names"] = std::move(names);
  out["joint_types"] = std::move(types);
  out["limits"] = {{"lower", std::move(lower)},
                   {"upper", std::move(upper)},
                   {"velocity", std::move(velocity)},
                   {"effort", std::move(effort)}};
  out["home"] = {{"T", transform_json(model.home_tip())}, {"S", columns_json(model.space_axes())}};
  Json armature = Json::array();
  for (int i = 0; i < model.dof(); ++i) armature.push_back(number(model.armature()[i]));
  out["armature"] = std::move(armature);
  out["warnings"] = model.warnings();
  return out;
}

}  // namespace

Command register_inspect(CLI::App& app) {
  auto options = std::make_shared<ModelOptions>();
  CLI::App* command = app.add_subcommand("inspect",
                                         "Describe the chain: joints, types, limits, home pose M and "
                                         "space screw axes S");
  add_model_options(*command, *options);
  command->footer(
      "Output: {\"robot\", \"base_link\", \"tip_link\", \"dof\", \"joint_names\", \"joint_types\",\n"
      "         \"limits\": {\"lower\", \"upper\", \"velocity\", \"effort\"}  (null: no limit),\n"
      "         \"home\": {\"T\": 4x4 rows, \"S\": n screw axes (w, v)},\n"
      "         \"armature\": each joint's reflected rotor inertia, kg*m^2 or kg (Drake's\n"
      "                     drake:rotor_inertia * drake:gear_ratio^2; 0 where the URDF gives none),\n"
      "         \"warnings\": [questionable but loadable data, one sentence each; also on stderr]}\n"
      "Example:\n"
      "  chasles inspect --urdf ur5.urdf --tip tool0");
  return {command, [options] { return inspect_json(load_model(*options)); }};
}

}  // namespace chasles::cli
