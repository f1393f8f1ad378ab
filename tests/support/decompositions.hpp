// The decompositions the tests check against (singular values, symmetric eigenproblems, inverses),
// compiled once in the support library (decompositions.cpp) rather than in every test that uses
// them: each is seconds of compilation per file, and twenty under the sanitizers, where the CI's
// 20 minutes are spent (law_test alone spent 18 s of 32 instantiating eigensolvers and LU).
// Include this header wherever a test uses one of them.
#pragma once

#include <Eigen/Core>
#include <Eigen/SVD>

#include "core/model/model.hpp"

extern template class Eigen::JacobiSVD<Eigen::MatrixXd>;
extern template class Eigen::JacobiSVD<chasles::Matrix6Xd>;

namespace chasles::test {

/// Eigenvalues in ascending order and their eigenvectors (columns).
struct Eigen6 {
  Vector6d values;
  Matrix6d vectors;
};

/// A v = λ v for a symmetric A.
Eigen6 symmetric_eigen(const Matrix6d& A);
/// A v = σ B v for symmetric A and symmetric positive definite B; the eigenvectors B-orthonormal.
Eigen6 generalized_symmetric_eigen(const Matrix6d& A, const Matrix6d& B);
/// The symmetric square root of a symmetric positive semi-definite A, and of its inverse.
Matrix6d symmetric_sqrt(const Matrix6d& A);
Matrix6d symmetric_inverse_sqrt(const Matrix6d& A);
/// The eigenvalues of a symmetric A, ascending.
Eigen::VectorXd symmetric_eigenvalues(const Eigen::MatrixXd& A);
/// A⁻¹ of a square invertible A (LU with partial pivoting).
Eigen::MatrixXd matrix_inverse(const Eigen::MatrixXd& A);

}  // namespace chasles::test
