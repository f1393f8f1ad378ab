// A model whose inertias are off its URDF's the way a real arm's are: the CAD's masses, centres of
// mass and inertias miss the cables, the grease, the motors' real windings. Identification is judged
// against a plant that integrates such a model while its controller keeps the nominal one
// (chasles_plant --perturb-inertia).
//
// What "±f" means, body by body (f the fraction, each u an independent draw, uniform in [−1, 1)):
//   mass                 m' = m (1 + f u₀);
//   centre of mass       c' = c + f ρ (u₁, u₂, u₃) in the body frame, ρ = √(tr Σ_c / m) the body's
//                        radius of gyration about its centre, the root mean square distance of its
//                        mass from there (its size: the centre of mass cannot leave the body, and |c|
//                        is no scale for a body centred on its joint's axis);
//   spread of the mass   Σ_c = ∫ρ r rᵀ about the centre has eigenvalues σ_k, the mass's second
//                        moment along principal axis k; each is scaled by (1 + f u₄₊ₖ), so that each
//                        principal moment of inertia, λ_i = σ_j + σ_k, changes by at most ±f too;
//   principal axes       turned by an angle f u₉ rad about an axis uniform on the sphere (u₇, u₈).
// Σ_c ⪰ 0 is exactly the physical condition (model/inertia.hpp), and a scale 1 + f u > 0 keeps every
// σ_k's sign: a body whose pseudo-inertia is ≻ 0 keeps it for every draw, with nothing to resample,
// and a body on the boundary (a point mass, a rod) stays there. Massless bodies stay as they are.
// The kinematics, joint limits and armature are the model's.
#pragma once

#include <cstdint>

#include "core/identification/regressor.hpp"

namespace chasles {

/// One body's π (regressor.hpp's ten parameters) perturbed as the header says, with `u` its ten
/// draws, each in [−1, 1]; π itself when m ≤ 0. `fraction` in [0, 1).
Vector10d perturbed_body_parameters(const Vector10d& pi, double fraction, const Vector10d& u);

/// The model with every body perturbed by up to ±fraction, the draws from std::mt19937_64 seeded
/// with `seed`, ten per body root to tip, mapped to [−1, 1) from their top 53 bits (the same on
/// every platform, unlike std::uniform_real_distribution's). The same seed gives the same model.
/// Throws ArgumentError when fraction is not in [0, 1) (at 1 a mass may vanish). Allocates: built
/// once, off any real-time loop.
RobotModel with_perturbed_inertias(const RobotModel& model, double fraction, uint64_t seed);

}  // namespace chasles
