#include "controller/control_law.hpp"

namespace chasles::controller {

ControlLaw::ControlLaw(int dof, const Config& config)
    : config_(config),
      settings_(dof),
      work_(dof),
      qdd_scratch_(Eigen::VectorXd::Zero(dof)),
      allowance_(Eigen::VectorXd::Zero(dof)) {
  work_.period = config.period;
}

void ControlLaw::torque(const RobotModel& model, Data& data, ReferenceKinematics& kinematics,
                        const motion::Reference& ref, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                        double compliant_damping, Eigen::VectorXd& tau) {
  const bool compliant = compliant_damping >= 0.0;
  if (compliant) {
    damped_float(model, data, compliant_damping, qd, qdd_scratch_, tau);
  } else {
    switch (settings_.law) {
      case Law::kComputedTorque:
        computed_torque(model, data, config_.kp, config_.kd, ref, q, qd, qdd_scratch_, tau);
        break;
      case Law::kJointImpedance:
        joint_impedance(model, data, work_, settings_, ref, q, qd, tau);
        break;
      case Law::kCartesianImpedance:
        cartesian_impedance(model, data, kinematics.at(model, ref.q), work_, settings_, ref, q, qd, tau);
        break;
      case Law::kFreeDrive:
        free_drive(model, data, settings_, qd, tau);
        break;
    }
  }
  if (!compliant && is_impedance()) {
    allowance_ = work_.spring;
  } else {
    allowance_.setZero();
  }
  if (config_.damping.size() != 0) tau += config_.damping.cwiseProduct(ref.qd);
  add_coulomb_friction(config_.coulomb, ref.qd, tau);
}

}  // namespace chasles::controller
