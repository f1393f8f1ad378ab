#include "controller/world.hpp"

#include "core/error.hpp"
#include "core/kinematics/kinematics.hpp"

namespace chasles::controller {

bool parse_collision_mode(const std::string& text, CollisionMode& mode) {
  if (text == "auto") return mode = CollisionMode::kAuto, true;
  if (text == "on") return mode = CollisionMode::kOn, true;
  if (text == "off") return mode = CollisionMode::kOff, true;
  return false;
}

geometry::CollisionModel load_arm_geometry(const RobotModel& model, const WorldOptions& options,
                                           std::vector<std::string>& notes) {
  if (options.mode == CollisionMode::kOff) return {};
  geometry::CollisionModel arm;
  try {
    arm = geometry::load_collision_model(options.urdf, model, options.geometry);
  } catch (const ModelError& e) {
    if (options.mode == CollisionMode::kOn) throw;
    notes.push_back(std::string("no collision geometry: ") + e.what() + " (--package-dir finds meshes; --collision off says none)");
    return {};
  }
  if (arm.objects.empty()) {
    notes.push_back("no collision geometry: " + options.urdf + " has no <collision> element");
    return arm;
  }
  Data data(model);
  forward_kinematics(model, data, Eigen::VectorXd::Zero(model.dof()));
  for (const std::string& pair : geometry::drop_pairs_closer_than(arm, data.T_body, options.proximity.self.stop)) {
    notes.push_back("not checked: " + pair + ", in contact at q = 0");
  }
  notes.push_back("collision geometry: " + std::to_string(arm.objects.size()) + " objects, " +
                  std::to_string(arm.pairs.size()) + " pairs of the arm checked");
  return arm;
}

std::shared_ptr<ClearanceWorld> make_world(const RobotModel& model, const geometry::CollisionModel& arm,
                                           const geometry::Scene& scene, const geometry::ProximityOptions& options) {
  if (arm.objects.empty()) return nullptr;
  return std::make_shared<ClearanceWorld>(model, geometry::Proximity(arm, scene, options));
}

}  // namespace chasles::controller
