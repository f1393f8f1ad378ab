#include "support/decompositions.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

template class Eigen::JacobiSVD<Eigen::MatrixXd>;
template class Eigen::JacobiSVD<chasles::Matrix6Xd>;

namespace chasles::test {

Eigen6 symmetric_eigen(const Matrix6d& A) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(A);
  return {eigen.eigenvalues(), eigen.eigenvectors()};
}

Eigen6 generalized_symmetric_eigen(const Matrix6d& A, const Matrix6d& B) {
  const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix6d> eigen(A, B);
  if (eigen.info() != Eigen::Success) throw std::runtime_error("generalized_symmetric_eigen: B is not positive definite");
  return {eigen.eigenvalues(), eigen.eigenvectors()};
}

Matrix6d symmetric_sqrt(const Matrix6d& A) { return Eigen::SelfAdjointEigenSolver<Matrix6d>(A).operatorSqrt(); }

Matrix6d symmetric_inverse_sqrt(const Matrix6d& A) {
  return Eigen::SelfAdjointEigenSolver<Matrix6d>(A).operatorInverseSqrt();
}

Eigen::VectorXd symmetric_eigenvalues(const Eigen::MatrixXd& A) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A, Eigen::EigenvaluesOnly).eigenvalues();
}

Eigen::MatrixXd matrix_inverse(const Eigen::MatrixXd& A) { return A.partialPivLu().inverse(); }

}  // namespace chasles::test
