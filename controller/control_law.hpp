// The law in force at a tick (law.hpp holds the laws themselves): its settings and workspace, the
// gains, the joints' known friction fed forward along the reference, the reflex's compliant float
// in its place, and what an impedance pulls with on purpose, which the contact monitor allows.
#pragma once

#include <Eigen/Core>

#include "controller/config.hpp"
#include "controller/law.hpp"
#include "controller/reference/source.hpp"

namespace chasles::controller {

class ControlLaw {
 public:
  /// Keeps a reference to `config` (gains, friction).
  ControlLaw(int dof, const Config& config);
  void set(const LawSettings& settings) { settings_ = settings; }
  const LawSettings& settings() const { return settings_; }
  Law law() const { return settings_.law; }
  /// Whether the law is an impedance: a duration of 0 steps its equilibrium.
  bool is_impedance() const { return settings_.law == Law::kJointImpedance || settings_.law == Law::kCartesianImpedance; }

  /// The law's torque into tau at the state (q, q̇), whose terms are in `data`, toward `ref`; the
  /// Cartesian law reads frame c at the reference from `kinematics`. `compliant_damping` ≥ 0: the
  /// reflex's damped float at that rate instead. Adds D q̇_d and f_c tanh(q̇_d / v_c) where the
  /// joints' friction is known. Allocates nothing.
  void torque(const RobotModel& model, Data& data, ReferenceKinematics& kinematics, const motion::Reference& ref,
              const Eigen::VectorXd& q, const Eigen::VectorXd& qd, double compliant_damping, Eigen::VectorXd& tau);
  /// What an impedance pulled with on purpose at the last torque(), not a collision when the arm
  /// presses on something; zero for the other laws and the compliant float.
  const Eigen::VectorXd& allowance() const { return allowance_; }

 private:
  const Config& config_;
  LawSettings settings_;
  LawWorkspace work_;
  Eigen::VectorXd qdd_scratch_, allowance_;
};

}  // namespace chasles::controller
