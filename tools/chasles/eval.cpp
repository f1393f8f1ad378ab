// chasles eval: kinematics at a list of joint configurations.
#include <memory>

#include "core/dynamics/dynamics.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/distance.hpp"
#include "tools/cli/cases.hpp"
#include "command.hpp"

namespace chasles::cli {
namespace {

/// Each collision object's axis-aligned bounding box in the base frame at the poses of `data`
/// (the extremes of its support function along ±x, ±y, ±z, margins included): where the arm's
/// shapes are, to place a table or a fixture against them.
Json collision_boxes(const geometry::CollisionModel& geometry, const Data& data) {
  Json boxes = Json::array();
  for (const geometry::CollisionObject& object : geometry.objects) {
    const Transform T = data.T_body[size_t(object.body)] * object.T_body_object;
    Vector3d lo, hi;
    for (int axis = 0; axis < 3; ++axis) {
      for (const double sign : {-1.0, 1.0}) {
        const Vector3d d = sign * Vector3d::Unit(axis);
        int vertex = 0;
        const double reach = (T * geometry::support_of_core(object.shape, T.linear().transpose() * d, vertex)).dot(d) +
                             geometry::margin_of(object.shape);
        (sign < 0 ? lo : hi)[axis] = sign * reach;
      }
    }
    boxes.push_back({{"object", object.name}, {"link", object.link}, {"body", object.body},
                     {"min", vector_json(lo)}, {"max", vector_json(hi)}});
  }
  return boxes;
}

/// One case's answer; each quantity is one key, so more (dynamics) slot in beside them.
Json eval_case(const RobotModel& model, Data& data, const EvalCase& input, const geometry::CollisionModel* geometry) {
  Json out;
  link_poses(model, data, input.q);  // runs forward_kinematics: data.T_sb, data.T_link
  out["T"] = transform_json(data.T_sb);
  out["J_s"] = rows_json(space_jacobian(model, data, input.q));
  out["J_b"] = rows_json(body_jacobian(model, data, input.q));
  Json link_T = Json::object();
  for (size_t k = 0; k < model.links().size(); ++k) link_T[model.links()[k].name] = transform_json(data.T_link[k]);
  out["link_T"] = std::move(link_T);
  if (geometry != nullptr) out["collision_boxes"] = collision_boxes(*geometry, data);
  if (input.has_dynamics) {
    out["tau"] = vector_json(inverse_dynamics(model, data, input.q, input.qd, input.qdd));
    out["M"] = rows_json(mass_matrix(model, data, input.q));
    out["g"] = vector_json(gravity_torques(model, data, input.q));
    out["c"] = vector_json(velocity_product(model, data, input.q, input.qd));
  }
  return out;
}

Json eval_json(const RobotModel& model, const std::string& cases_path, const geometry::CollisionModel* geometry) {
  const std::vector<EvalCase> inputs = parse_eval_cases(read_json_file(cases_path, "cases file"), model, cases_path);
  Data data(model);
  Json results = Json::array();
  for (const EvalCase& input : inputs) results.push_back(eval_case(model, data, input, geometry));
  Json out;
  out["cases"] = std::move(results);
  return out;
}

struct EvalOptions {
  ModelOptions model;
  std::string cases;
  bool collision = false;
  std::vector<std::string> package_dirs;
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
  command->add_flag("--collision", options->collision,
                    "Also each collision object's bounding box in the base frame (\"collision_boxes\")");
  command->add_option("--package-dir", options->package_dirs,
                      "--collision: where package://NAME/... meshes are looked for, as DIR/NAME/... (repeatable; then "
                      "$ROS_PACKAGE_PATH's folders)")
      ->type_name("DIR");
  command->footer(
      "Output: {\"cases\": [{\"T\": tip pose 4x4 rows, \"J_s\": space Jacobian 6 rows,\n"
      "                      \"J_b\": body Jacobian 6 rows, \"link_T\": {link: 4x4 rows},\n"
      "                      and with qd and qdd: \"tau\": M qdd + c + g, \"M\": mass matrix rows,\n"
      "                      \"g\": gravity torques, \"c\": C(q, qd) qd, and with --collision\n"
      "                      \"collision_boxes\": [{\"object\", \"link\", \"body\", \"min\": [x, y, z],\n"
      "                      \"max\": [x, y, z]}, ...]}, ...]}\n"
      "Twists and Jacobian rows are angular first (w, v). Units: m, rad, s, N m; gravity (0, 0, -9.81).\n"
      "Example:\n"
      "  echo '{\"cases\": [{\"q\": [0, -1.57, 1.57, 0, 0, 0]}]}' > cases.json\n"
      "  chasles eval --urdf ur5.urdf --tip tool0 --cases cases.json");
  return {command, [options] {
            const RobotModel model = load_model(options->model);
            if (!options->collision) return eval_json(model, options->cases, nullptr);
            const geometry::CollisionModel geometry =
                geometry::load_collision_model(options->model.urdf, model, {geometry::with_ros_package_path(options->package_dirs), ""});
            return eval_json(model, options->cases, &geometry);
          }};
}

}  // namespace chasles::cli
