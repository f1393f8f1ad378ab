#include "core/contact/observer.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>


namespace chasles {

void add_coulomb_friction(const Eigen::VectorXd& coulomb, const Eigen::VectorXd& qd, Eigen::VectorXd& tau) {
  for (Eigen::Index i = 0; i < coulomb.size(); ++i) tau(i) += coulomb(i) * std::tanh(qd(i) / kCoulombVelocity);
}

MomentumObserver::MomentumObserver(const RobotModel& model, const Eigen::VectorXd& gain, const Eigen::VectorXd& damping,
                                   const Eigen::VectorXd& coulomb)
    : gain_(gain), damping_(damping), coulomb_(coulomb) {
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
  if (coulomb_.size() != 0 && (coulomb_.size() != n || !coulomb_.allFinite() || (coulomb_.array() < 0.0).any())) {
    throw ObserverError("the observer's Coulomb friction must be one finite, non-negative value per joint");
  }
  for (Eigen::VectorXd* v : {&r_, &p_prev_, &gamma_, &gamma_prev_, &mean_}) v->setZero(n);
}

void MomentumObserver::momentum_balance(const Data& data, const JointVector& qd, Eigen::VectorXd& gamma) const {
  gamma = data.ct_qd - data.g - damping_.cwiseProduct(qd);
  for (Eigen::Index i = 0; i < coulomb_.size(); ++i) gamma(i) -= coulomb_(i) * std::tanh(qd(i) / kCoulombVelocity);
}

void MomentumObserver::reset(const Data& data, const JointVector& qd) {
  p_prev_ = data.p;
  momentum_balance(data, qd, gamma_prev_);
  r_.setZero();
  started_ = true;
}

const Eigen::VectorXd& MomentumObserver::update(const Data& data, const JointVector& qd, const JointVector& tau,
                                                double dt) {
  if (!(dt > 0.0 && dt <= std::numeric_limits<double>::max())) {  // NaN fails both
    std::ostringstream text;
    text << "the observer's step dt = " << dt << " s; it must be positive and finite";
    throw ArgumentError(text.str());
  }
  if (!started_) {
    reset(data, qd);
    return r_;
  }
  momentum_balance(data, qd, gamma_);
  mean_ = (data.p - p_prev_) / dt - tau - 0.5 * (gamma_prev_ + gamma_);
  for (int i = 0; i < r_.size(); ++i) {
    const double a = std::exp(-gain_(i) * dt);
    r_(i) = a * r_(i) + (1.0 - a) * mean_(i);
  }
  p_prev_ = data.p;
  gamma_prev_.swap(gamma_);
  return r_;
}

Vector6d tip_wrench_from_torque(const Matrix6Xd& J_b, const Eigen::VectorXd& tau, const WrenchDamping& damping) {
  // J_bᵀ F = τ in the least-squares sense, through A = J_b J_bᵀ (6×6 whatever the joints) and
  // b = J_b τ. Away from singularities F = A⁻¹ b, undamped: that is certified when the smallest
  // eigenvalue of A, bounded below by 1 / |A⁻¹|_F, is over the damping threshold σ², and costs a
  // Cholesky factorisation. Otherwise F = Σ_k v_k (v_kᵀ b) / (σ_k² + λ_k²) over A's eigenpairs.
  const Matrix6d A = J_b * J_b.transpose();
  const Vector6d b = J_b * tau;
  const double threshold_sq = damping.threshold * damping.threshold;
  const Eigen::LLT<Matrix6d> cholesky(A);
  if (cholesky.info() == Eigen::Success) {
    const Matrix6d A_inverse = cholesky.solve(Matrix6d::Identity());
    if (A_inverse.allFinite() && A_inverse.norm() * threshold_sq < 1.0) return A_inverse * b;
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(A);
  const Vector6d& sigma_sq = eigen.eigenvalues();
  const Matrix6d& V = eigen.eigenvectors();
  const double lambda_max_sq = damping.lambda_max * damping.lambda_max;
  // A direction the joints do not span (σ = 0) has v_kᵀ b = 0 but for rounding, and a damped
  // denominator: it gets no wrench, with no cut-off to tune.
  Vector6d F = Vector6d::Zero();
  for (int k = 0; k < 6; ++k) {
    const double s = std::max(sigma_sq(k), 0.0);
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
