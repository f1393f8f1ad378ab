#include "chasles/core/contact/observer.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "chasles/core/dynamics/dynamics.hpp"

namespace chasles {

MomentumObserver::MomentumObserver(const RobotModel& model, const Eigen::VectorXd& gain, const Eigen::VectorXd& damping)
    : model_(model), data_(model), gain_(gain), damping_(damping) {
  const int n = model.dof();
  if (gain_.size() != n) {
    throw ObserverError("the observer has " + std::to_string(gain_.size()) + " gains; the arm has " + std::to_string(n) +
                        " joints");
  }
  if (!gain_.allFinite() || !(gain_.array() > 0.0).all()) {
    throw ObserverError("the observer's gains must be positive and finite (1/s)");
  }
  if (damping_.size() == 0) damping_.setZero(n);
  if (damping_.size() != n || !damping_.allFinite() || (damping_.array() < 0.0).any()) {
    throw ObserverError("the observer's joint damping must be one finite, non-negative value per joint");
  }
  for (Eigen::VectorXd* v : {&r_, &p_, &gamma_, &p_prev_, &gamma_prev_, &mean_}) v->setZero(n);
}

void MomentumObserver::momentum_balance(const JointVector& q, const JointVector& qd, Eigen::VectorXd& p,
                                        Eigen::VectorXd& gamma) {
  p = momentum_terms(model_, data_, q, qd);
  gamma = data_.ct_qd - data_.g - damping_.cwiseProduct(qd);
}

void MomentumObserver::reset(const JointVector& q, const JointVector& qd) {
  momentum_balance(q, qd, p_prev_, gamma_prev_);
  r_.setZero();
  started_ = true;
}

const Eigen::VectorXd& MomentumObserver::update(const JointVector& q, const JointVector& qd, const JointVector& tau,
                                                double dt) {
  if (!started_ || !(dt > 0.0)) {
    reset(q, qd);
    return r_;
  }
  momentum_balance(q, qd, p_, gamma_);
  mean_ = (p_ - p_prev_) / dt - tau - 0.5 * (gamma_prev_ + gamma_);
  for (int i = 0; i < r_.size(); ++i) {
    const double a = std::exp(-gain_(i) * dt);
    r_(i) = a * r_(i) + (1.0 - a) * mean_(i);
  }
  p_prev_.swap(p_);
  gamma_prev_.swap(gamma_);
  return r_;
}

Vector6d tip_wrench_from_torque(const Matrix6Xd& J_b, const Eigen::VectorXd& tau, const WrenchDamping& damping) {
  // J_bᵀ F = τ in the least-squares sense: F = Σ_k v_k (v_kᵀ J_b τ) / (σ_k² + λ_k²) over the
  // eigenpairs (σ_k², v_k) of J_b J_bᵀ: fixed 6×6, whatever the number of joints.
  const Matrix6d A = J_b * J_b.transpose();
  const Vector6d b = J_b * tau;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(A);
  const Vector6d& sigma_sq = eigen.eigenvalues();
  const Matrix6d& V = eigen.eigenvectors();
  const double threshold_sq = damping.threshold * damping.threshold;
  const double lambda_max_sq = damping.lambda_max * damping.lambda_max;
  // Rounding in J_b Jᵀ_b: an eigenvalue this small is a direction the joints do not span.
  const double zero = 64.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, sigma_sq.maxCoeff());
  Vector6d F = Vector6d::Zero();
  for (int k = 0; k < 6; ++k) {
    const double s = std::max(sigma_sq(k), 0.0);
    if (s <= zero) continue;
    const double lambda_sq = s < threshold_sq ? lambda_max_sq * (1.0 - s / threshold_sq) : 0.0;
    F += V.col(k) * (V.col(k).dot(b) / (s + lambda_sq));
  }
  return F;
}

Vector6d base_aligned_wrench(const Transform& T_sb, const Vector6d& F_tip) {
  Vector6d F;
  F.head<3>().noalias() = T_sb.linear() * F_tip.head<3>();
  F.tail<3>().noalias() = T_sb.linear() * F_tip.tail<3>();
  return F;
}

}  // namespace chasles
