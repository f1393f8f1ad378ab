// A smooth, unconstrained parametrisation of the physically consistent rigid bodies: the
// log-Cholesky map of Rucker and Wensing ("Smooth parameterization of rigid-body inertia", IEEE
// RA-L 2022). An optimiser (Ceres) can move θ ∈ R¹⁰ freely and every θ is a body some mass
// distribution has, so a fit of π can never leave the physical set.
//
// A body's pseudo-inertia (Wensing, Kim and Slotine, RA-L 2017) is the 4×4 second moment of its mass
// distribution in homogeneous coordinates,
//   J = ∫ρ [r; 1][r; 1]ᵀ = [[Σ, h], [hᵀ, m]],   Σ = ∫ρ r rᵀ = ½ tr(I) 1 − I,
// with m, h and I (about the frame's origin) the body's π (identification/regressor.hpp). A π is
// physical exactly when J ⪰ 0; J ≻ 0 leaves out only the boundary (point masses, rods, plates).
// Any J ≻ 0 factors uniquely as J = U Uᵀ with U upper triangular and positive on the diagonal
// (Cholesky with the rows and columns reversed, so that m = U₄₄² comes from one entry), and
//   U = e^α [[e^d₁, s₁₂, s₁₃, t₁], [0, e^d₂, s₂₃, t₂], [0, 0, e^d₃, t₃], [0, 0, 0, 1]],
//   θ = (α, d₁, d₂, d₃, s₁₂, s₂₃, s₁₃, t₁, t₂, t₃)   (the paper's order),
// so that m = e^{2α}, h = m t (t is the centre of mass) and Σ = m (D Dᵀ + t tᵀ) with D the upper
// 3×3 block. The map θ → π is smooth with a smooth inverse on J ≻ 0.
#pragma once

#include <cmath>

#include "core/identification/regressor.hpp"

namespace chasles {

/// π (m, h, I) of the body with log-Cholesky coordinates θ, for any scalar T with exp (double,
/// ceres::Jet, Eigen's AutoDiffScalar): the form a Ceres cost functor calls. θ and π hold ten
/// entries each in the orders above.
template <class T>
void inertia_from_log_cholesky(const T* theta, T* pi) {
  using std::exp;
  const T& alpha = theta[0];
  const T e1 = exp(theta[1]), e2 = exp(theta[2]), e3 = exp(theta[3]);
  const T &s12 = theta[4], &s23 = theta[5], &s13 = theta[6], &t1 = theta[7], &t2 = theta[8], &t3 = theta[9];
  const T m = exp(2.0 * alpha);
  // Σ = m V Vᵀ over the upper 3×4 rows of V = U / e^α: row i is (D_i, t_i).
  const T S11 = m * (e1 * e1 + s12 * s12 + s13 * s13 + t1 * t1);
  const T S12 = m * (s12 * e2 + s13 * s23 + t1 * t2);
  const T S13 = m * (s13 * e3 + t1 * t3);
  const T S22 = m * (e2 * e2 + s23 * s23 + t2 * t2);
  const T S23 = m * (s23 * e3 + t2 * t3);
  const T S33 = m * (e3 * e3 + t3 * t3);
  pi[0] = m;
  pi[1] = m * t1;
  pi[2] = m * t2;
  pi[3] = m * t3;
  // I = tr(Σ) 1 − Σ.
  pi[4] = S22 + S33;
  pi[5] = -S12;
  pi[6] = -S13;
  pi[7] = S11 + S33;
  pi[8] = -S23;
  pi[9] = S11 + S22;
}

/// The same for double vectors.
Vector10d inertia_from_log_cholesky(const Vector10d& theta);

/// θ of a body with J ≻ 0. Throws ArgumentError, saying what is not physical, for a non-finite
/// entry, a mass that is not positive, or a rotational inertia about the centre of mass that is not
/// positive definite with strict triangle inequalities (each principal moment less than the sum of
/// the other two): no mass distribution has it, or it lies on the boundary (a point mass, a thin
/// rod or a flat plate), where θ runs off to infinity.
Vector10d log_cholesky_from_inertia(const Vector10d& pi);

/// J = [[½ tr(I) 1 − I, h], [hᵀ, m]].
Eigen::Matrix4d pseudo_inertia(const Vector10d& pi);

}  // namespace chasles
