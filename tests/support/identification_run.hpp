// Synthetic logs for the dynamic-identification tests, made independently of the fit: an arm
// unlike its URDF (every body changed through its log-Cholesky coordinates, so physical by
// construction, with friction and rotors the URDF lacks), a smooth multi-sine trajectory written
// here, and the torques of that arm by RNEA (core/dynamics, not the regressor) plus friction, each
// averaged over its step as robot_state_t.effort is, plus Gaussian noise.
#pragma once

#include <cstdint>

#include "core/identification/dynamic_fit.hpp"

namespace chasles::testing {

/// The arm as it really is.
struct TrueArm {
  RobotModel model;         ///< bodies and armature
  Eigen::VectorXd viscous;  ///< f_v per joint, N·m·s/rad
  Eigen::VectorXd coulomb;  ///< f_c per joint, N·m
  /// π (13 n) in the layout of identification/regressor.hpp.
  Eigen::VectorXd parameters() const;
};

/// The Panda (testing::panda()) with every body's log-Cholesky θ moved by seeded normal offsets —
/// log-mass and log-radii by 0.1 (±10 % of mass and size), the centre of mass and the Cholesky
/// factor's off-diagonal by 1 cm — armature 0.05–0.3 kg·m², viscous friction 0.3–0.6 N·m·s/rad
/// and Coulomb friction 0.8–1.2 N·m on every joint.
TrueArm perturbed_panda(uint64_t seed);

/// The arm following a sum of five sines per joint (0.1–0.9 Hz, seeded amplitudes and phases,
/// within 80 % of each joint's range about its middle), sampled at `rate_hz` for `seconds`. The
/// torque of sample k is the one applied over (t_{k−1}, t_k] — the mean of the true torque over
/// the step: by Simpson's rule on RNEA and viscous friction, exactly for Coulomb friction (up to
/// the crossing, where q̇ changes sign) — plus Gaussian noise of `noise` N·m. Joint `still`, if
/// within the chain, is held at its middle.
JointSamples synthetic_run(const TrueArm& arm, double seconds, double rate_hz, double noise, uint64_t seed,
                           int still = -1);

}  // namespace chasles::testing
