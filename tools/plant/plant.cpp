#include "plant.hpp"

#include "chasles/core/dynamics/dynamics.hpp"

namespace chasles::plant {

Plant::Plant(const RobotModel& model, const Eigen::VectorXd& q0, const Eigen::VectorXd& damping)
    : model_(model), data_(model), q_(q0), damping_(damping) {
  const Eigen::Index n = model.dof();
  qd_.setZero(n);
  effort_.setZero(n);
  brake_.setZero(n);
  q_stage_.setZero(n);
  tau_stage_.setZero(n);
  for (auto& v : qd_k_) v.setZero(n);
  for (auto& v : qdd_k_) v.setZero(n);
  effort_limit_.resize(n);
  for (int i = 0; i < n; ++i) effort_limit_[i] = model.joint(i).limits.effort;
}

void Plant::step(const Eigen::Ref<const Eigen::VectorXd>& tau, double dt, int substeps) {
  effort_ = tau.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
  const double h = dt / substeps;
  for (int i = 0; i < substeps; ++i) rk4_step(h);
}

const Eigen::VectorXd& Plant::brake_torque(double time_constant) {
  brake_ = gravity_torques(model_, data_, q_);
  brake_.noalias() -= (1.0 / time_constant) * mass_matrix(model_, data_, q_) * qd_;
  return brake_;
}

void Plant::acceleration(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, Eigen::VectorXd& qdd) {
  tau_stage_ = effort_ - damping_.cwiseProduct(qd);
  qdd = forward_dynamics(model_, data_, q, qd, tau_stage_);
}

// x = (q, q̇), ẋ = (q̇, q̈(q, q̇)); the stages k_i = (qd_k_[i], qdd_k_[i]).
void Plant::rk4_step(double h) {
  qd_k_[0] = qd_;
  acceleration(q_, qd_k_[0], qdd_k_[0]);
  for (int i = 1; i < 4; ++i) {
    const double a = i < 3 ? 0.5 * h : h;  // stages 2 and 3 at the midpoint, 4 at the end
    q_stage_ = q_ + a * qd_k_[i - 1];
    qd_k_[i] = qd_ + a * qdd_k_[i - 1];
    acceleration(q_stage_, qd_k_[i], qdd_k_[i]);
  }
  q_ += (h / 6.0) * (qd_k_[0] + 2.0 * qd_k_[1] + 2.0 * qd_k_[2] + qd_k_[3]);
  qd_ += (h / 6.0) * (qdd_k_[0] + 2.0 * qdd_k_[1] + 2.0 * qdd_k_[2] + qdd_k_[3]);
}

}  // namespace chasles::plant
