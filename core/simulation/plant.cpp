#include "core/simulation/plant.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

#include "core/dynamics/dynamics.hpp"
#include "core/identification/perturbation.hpp"

namespace chasles::plant {
namespace {

// Configurations sampled for κ (see friction_velocity()), besides q0. The Panda's κ over 256 seeded
// samples is within 2 % of its value over 2000 (226 (kg·m²)⁻¹, set by the hand spinning on joint 7).
constexpr int kInertiaSamples = 256;

// A joint's range to sample: its limits, ±π where they are not finite (continuous joints).
double sample_joint(const JointLimits& limits, uint64_t bits) {
  const double lower = std::isfinite(limits.lower) ? limits.lower : -kPi;
  const double upper = std::isfinite(limits.upper) ? limits.upper : kPi;
  const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;  // [0, 1), the same on every platform
  return lower + u * (upper - lower);
}

// The arm as it really is, when it is not its model: its inertias perturbed, then the payload on its
// last body (the load is what it is; the arm's own bodies are what the CAD got wrong).
std::unique_ptr<const RobotModel> own_model(const RobotModel& model, const EnvironmentOptions& environment) {
  const std::optional<InertiaPerturbation>& perturbation = environment.perturbation;
  if (!perturbation && !environment.payload) return nullptr;
  RobotModel arm = perturbation ? with_perturbed_inertias(model, perturbation->fraction, perturbation->seed) : model;
  if (environment.payload) arm = with_payload(arm, *environment.payload);
  return std::make_unique<const RobotModel>(std::move(arm));
}

}  // namespace

Plant::Plant(const RobotModel& model, const Eigen::VectorXd& q0, const Eigen::VectorXd& damping, double dt,
             int substeps, const EnvironmentOptions& environment)
    : model_(model),
      environment_(checked_environment(environment, model)),
      own_model_(own_model(model, environment_)),
      true_model_(own_model_ ? *own_model_ : model),
      data_(true_model_),
      nominal_data_(model),
      dt_(dt),
      substeps_(substeps),
      q_(q0),
      damping_(damping),
      has_contact_(!environment_.pushes.empty() || !environment_.walls.empty()),
      has_friction_(!environment_.friction.empty()) {
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
  truth_.tau_ext.setZero(n);
  friction_velocity_.setZero(n);
  if (has_friction_) {
    const double h = dt / substeps;
    const Friction& friction = environment_.friction;
    const double kappa = largest_inverse_inertia(q0);
    for (Eigen::Index i = 0; i < n; ++i) friction_velocity_[i] = h * kappa * friction.breakaway(i);
  }
}

double Plant::largest_inverse_inertia(const Eigen::VectorXd& q0) {
  const int n = true_model_.dof();
  std::mt19937_64 rng(1);
  Eigen::VectorXd q = q0;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(n);
  double kappa = 0.0;
  for (int s = 0; s <= kInertiaSamples; ++s) {
    if (s > 0) {
      for (int i = 0; i < n; ++i) q[i] = sample_joint(true_model_.joint(i).limits, rng());
    }
    solver.compute(mass_matrix(true_model_, data_, q), Eigen::EigenvaluesOnly);
    kappa = std::max(kappa, 1.0 / solver.eigenvalues()[0]);
  }
  return kappa;
}

void Plant::step(const Eigen::Ref<const Eigen::VectorXd>& tau) {
  effort_ = tau.cwiseMax(-effort_limit_).cwiseMin(effort_limit_);
  const double h = dt_ / substeps_;
  const double t0 = time();
  for (int i = 0; i < substeps_; ++i) rk4_step(t0 + i * h, h);
  ++steps_;
}

const Eigen::VectorXd& Plant::brake_torque(double time_constant) {
  brake_ = gravity_torques(true_model_, data_, q_);
  brake_.noalias() -= (1.0 / time_constant) * mass_matrix(true_model_, data_, q_) * qd_;
  return brake_;
}

Vector6d Plant::contact_wrench(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, bool& contact) {
  Vector6d F = Vector6d::Zero();
  contact = false;
  for (const Push& push : environment_.pushes) {
    const double s = push.profile(t);
    if (s > 0.0 && (push.wrench.array() != 0.0).any()) {
      F += s * push.wrench;
      contact = true;
    }
  }
  if (environment_.walls.empty()) return F;
  body_jacobian(true_model_, data_, q);
  const Vector3d& p = data_.T_sb.translation();
  Vector6d V_b;
  V_b.noalias() = data_.J_b * qd;
  const Vector3d v = data_.T_sb.linear() * V_b.tail<3>();  // the tip origin's velocity, base frame
  for (const Wall& wall : environment_.walls) {
    const double depth = -(p - wall.point).dot(wall.normal);
    if (!(depth > 0.0)) continue;
    contact = true;
    F.tail<3>() += std::max(0.0, wall.stiffness * depth - wall.damping * v.dot(wall.normal)) * wall.normal;
  }
  return F;
}

const Eigen::VectorXd& Plant::acceleration(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
  tau_stage_ = effort_ - damping_.cwiseProduct(qd);
  if (has_friction_) {
    const Friction& friction = environment_.friction;
    tau_stage_ -= friction.viscous.cwiseProduct(qd);
    for (Eigen::Index i = 0; i < qd.size(); ++i) {
      if (!(friction_velocity_[i] > 0.0)) continue;
      const double stribeck = qd[i] / friction.stribeck_velocity;
      const double level =
          friction.coulomb[i] + (friction.breakaway(i) - friction.coulomb[i]) * std::exp(-stribeck * stribeck);
      tau_stage_[i] -= level * std::tanh(qd[i] / friction_velocity_[i]);
    }
  }
  Vector6d F_tip = Vector6d::Zero();  // what the tip applies to the environment, tip frame
  if (has_contact_) {
    bool contact = false;
    const Vector6d F_env = contact_wrench(t, q, qd, contact);
    if (contact) {
      if (environment_.walls.empty()) forward_kinematics(true_model_, data_, q);  // else contact_wrench ran it
      const Matrix3d& R_sb = data_.T_sb.linear();
      F_tip.head<3>().noalias() = -(R_sb.transpose() * F_env.head<3>());
      F_tip.tail<3>().noalias() = -(R_sb.transpose() * F_env.tail<3>());
    }
  }
  return forward_dynamics(true_model_, data_, q, qd, tau_stage_, F_tip);
}

// x = (q, q̇), ẋ = (q̇, q̈(t, q, q̇)); the stages k_i = (qd_k_[i], qdd_k_[i]) at t, t + h/2, t + h/2, t + h.
void Plant::rk4_step(double t, double h) {
  qd_k_[0] = qd_;
  qdd_k_[0] = acceleration(t, q_, qd_k_[0]);
  for (int i = 1; i < 4; ++i) {
    const double a = i < 3 ? 0.5 * h : h;  // stages 2 and 3 at the midpoint, 4 at the end
    q_stage_ = q_ + a * qd_k_[i - 1];
    qd_k_[i] = qd_ + a * qdd_k_[i - 1];
    qdd_k_[i] = acceleration(t + a, q_stage_, qd_k_[i]);
  }
  q_ += (h / 6.0) * (qd_k_[0] + 2.0 * qd_k_[1] + 2.0 * qd_k_[2] + qd_k_[3]);
  qd_ += (h / 6.0) * (qdd_k_[0] + 2.0 * qdd_k_[1] + 2.0 * qdd_k_[2] + qdd_k_[3]);
}

// The nominal model's view: q̈ is what the arm really does; whatever the nominal equation of motion
// needs besides τ − D q̇ to produce it is external.
const Truth& Plant::sample_truth() {
  truth_.steps = steps_;
  truth_.time = time();
  truth_.tip_wrench_ext = contact_wrench(truth_.time, q_, qd_, truth_.contact);
  const Eigen::VectorXd& qdd = acceleration(truth_.time, q_, qd_);
  truth_.tau_ext = inverse_dynamics(model_, nominal_data_, q_, qd_, qdd);
  truth_.tau_ext += damping_.cwiseProduct(qd_) - effort_;
  return truth_;
}

}  // namespace chasles::plant
