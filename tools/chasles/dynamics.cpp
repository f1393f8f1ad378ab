// chasles rnea and chasles fd: inverse and forward dynamics at one state.
#include "core/dynamics/dynamics.hpp"

#include <memory>

#include "command.hpp"

namespace chasles::cli {
namespace {

struct DynamicsOptions {
  ModelOptions model;
  std::string q, qd, qdd, tau, f_tip;
};

// --f-tip is optional; without it the tip is free.
Vector6d tip_wrench(const std::string& text) {
  if (text.empty()) return Vector6d::Zero();
  return parse_list(text, 6, "--f-tip");
}

void add_state_options(CLI::App& command, DynamicsOptions& options, const char* third, std::string& third_value,
                       const char* third_help) {
  add_model_options(command, options.model);
  command.add_option("--q", options.q, "Joint positions, rad or m, comma-separated")->required()->type_name("LIST");
  command.add_option("--qd", options.qd, "Joint velocities, rad/s or m/s")->required()->type_name("LIST");
  command.add_option(third, third_value, third_help)->required()->type_name("LIST");
  command
      .add_option("--f-tip", options.f_tip,
                  "Wrench the tip applies to the environment, tip frame, m_x,m_y,m_z,f_x,f_y,f_z (N m, N); "
                  "default 0")
      ->type_name("LIST");
}

}  // namespace

Command register_rnea(CLI::App& app) {
  auto options = std::make_shared<DynamicsOptions>();
  CLI::App* command = app.add_subcommand("rnea", "Joint torques for a motion: tau = M qdd + c + g + J_b^T F_tip");
  add_state_options(*command, *options, "--qdd", options->qdd, "Joint accelerations, rad/s^2 or m/s^2");
  command->footer(
      "Output: {\"tau\": [n torques, N m or N]}\n"
      "Example:\n"
      "  chasles rnea --urdf ur5.urdf --tip tool0 --q 0,-1.57,1.57,0,0,0 --qd 0,0,0,0,0,0 --qdd 0,0,0,0,0,0");
  return {command, [options] {
            const RobotModel model = load_model(options->model);
            Data data(model);
            const Eigen::VectorXd q = parse_list(options->q, model.dof(), "--q");
            const Eigen::VectorXd qd = parse_list(options->qd, model.dof(), "--qd");
            const Eigen::VectorXd qdd = parse_list(options->qdd, model.dof(), "--qdd");
            Json out;
            out["tau"] = vector_json(inverse_dynamics(model, data, q, qd, qdd, tip_wrench(options->f_tip)));
            return out;
          }};
}

Command register_fd(CLI::App& app) {
  auto options = std::make_shared<DynamicsOptions>();
  CLI::App* command =
      app.add_subcommand("fd", "Joint accelerations under torques: qdd = M^-1 (tau - c - g - J_b^T F_tip)");
  add_state_options(*command, *options, "--tau", options->tau, "Joint torques, N m or N");
  command->footer(
      "Output: {\"qdd\": [n accelerations, rad/s^2 or m/s^2]}\n"
      "Example (the UR5 falling from rest, no torque):\n"
      "  chasles fd --urdf ur5.urdf --tip tool0 --q 0,-1.57,1.57,0,0,0 --qd 0,0,0,0,0,0 --tau 0,0,0,0,0,0");
  return {command, [options] {
            const RobotModel model = load_model(options->model);
            Data data(model);
            const Eigen::VectorXd q = parse_list(options->q, model.dof(), "--q");
            const Eigen::VectorXd qd = parse_list(options->qd, model.dof(), "--qd");
            const Eigen::VectorXd tau = parse_list(options->tau, model.dof(), "--tau");
            Json out;
            try {
              out["qdd"] = vector_json(forward_dynamics(model, data, q, qd, tau, tip_wrench(options->f_tip)));
            } catch (const DynamicsError& e) {
              throw InputError(options->model.urdf + ": " + e.what());
            }
            return out;
          }};
}

}  // namespace chasles::cli
