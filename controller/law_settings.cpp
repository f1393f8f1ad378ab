#include "controller/law_settings.hpp"

namespace chasles::controller {

const char* to_string(Law law) {
  switch (law) {
    case Law::kComputedTorque:
      return "computed-torque";
    case Law::kJointImpedance:
      return "joint-impedance";
    case Law::kCartesianImpedance:
      return "cartesian-impedance";
    case Law::kFreeDrive:
      return "free-drive";
  }
  return "?";
}

bool parse_law(const std::string& text, Law& law) {
  for (Law l : {Law::kComputedTorque, Law::kJointImpedance, Law::kCartesianImpedance, Law::kFreeDrive}) {
    if (text == to_string(l)) {
      law = l;
      return true;
    }
  }
  return false;
}

LawSettings::LawSettings(int n)
    : joint_stiffness(Eigen::VectorXd::Zero(n)),
      joint_damping(Eigen::VectorXd::Zero(n)),
      nullspace_posture(Eigen::VectorXd::Zero(n)) {
  cartesian_stiffness.diagonal().head<3>().setConstant(LawDefaults::kRotationalStiffness);
  cartesian_stiffness.diagonal().tail<3>().setConstant(LawDefaults::kTranslationalStiffness);
}

}  // namespace chasles::controller
