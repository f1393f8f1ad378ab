// Is a rigid body's inertia physically possible? The test of a URDF <inertial> and of a payload.
//
// A mass distribution ρ has mass m = ∫ρ ≥ 0 and, about its centre of mass, the second moment
// Σ = ∫ρ r rᵀ ⪰ 0. The rotational inertia is I_c = tr(Σ) 1 − Σ, so Σ = ½ tr(I_c) 1 − I_c, and
// Σ ⪰ 0 says at once that every principal moment is ≥ 0 and that each is at most the sum of the
// other two (the triangle inequalities): the eigenvalues of Σ are (λ_j + λ_k − λ_i) / 2. This is
// the pseudo-inertia condition of Wensing, Kim and Slotine (IEEE RA-L 2017) at the centre of mass.
#pragma once

#include <string>

#include "core/lie/types.hpp"

namespace chasles {

/// How far an inertia may fall short of physical before it is refused.
///
/// `relative` × the largest principal moment covers the digits a file was written with: a body at
/// the physical boundary (a thin rod or a flat plate, where Σ has a zero eigenvalue) whose six
/// entries were rounded to 4 significant digits moves each entry by ≤ 5e-4 of itself, so the
/// smallest eigenvalue of Σ by ≤ ½|tr ΔI| + ‖ΔI‖_F ≤ (0.75 + 0.87)·1e-3 of the largest moment.
/// 2e-3 accepts that worst case; the inconsistent real files we know of miss by 2 % to 50 %.
///
/// `gyration_radius` is a floor for point masses: moments below m·(1 µm)² are numerically zero.
/// Exporters that shift an inertia to the centre of mass by subtracting m|c|² leave rounding of
/// ε_machine·m|c|² ≈ 1e-16·m for |c| ≤ 1 m (iCub's files carry 1e-20-sized moments of either sign),
/// while the smallest real links (a finger phalanx) have radii of gyration near 1 cm.
struct InertiaTolerance {
  static constexpr double relative = 2e-3;
  static constexpr double gyration_radius = 1e-6;  // m
};

/// The verdict on one inertia; `problem` is empty when it is physical within the tolerance.
struct InertiaCheck {
  Vector3d principal_moments = Vector3d::Zero();  ///< eigenvalues of I_c, ascending (kg·m²)
  double tolerance = 0.0;                         ///< kg·m²: relative × largest moment + m·r₀²
  bool point_mass = false;                        ///< m > 0 and every moment within m·r₀² of 0
  std::string problem;                            ///< what is impossible, with the values; "" if none
  bool physical() const { return problem.empty(); }
};

/// Checks mass m (kg) and rotational inertia I_c about the centre of mass (kg·m², any frame).
/// Non-finite values and a negative mass are problems whatever their size.
InertiaCheck check_inertia(double mass, const Matrix3d& I_c);

/// The rotational inertia about the centre of mass of a spatial inertia given about another
/// point: I_c = I − m [c][c]ᵀ with c = h / m (MR eq. 8.32 read backwards); I itself when m = 0.
Matrix3d inertia_about_centre_of_mass(double mass, const Vector3d& h, const Matrix3d& I);

}  // namespace chasles
