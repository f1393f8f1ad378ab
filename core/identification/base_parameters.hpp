// The base (identifiable) parameters of a chain: the combinations of π that joint torques can
// tell apart at all. Some parameters never move τ (the mass of a first body that turns about a
// fixed vertical axis), and some move it only together (across a revolute joint, a body's mass and
// first moment along the axis act as parts of its parent's); identification fits β = P π of lower
// dimension instead (Gautier and Khalil 1990; Khalil and Dombre, Modeling, Identification and
// Control of Robots, ch. 12).
//
// Numerically (Gautier 1991): stack Y at random states into W, and factorise W Π = Q R with column
// pivoting. The first r pivoted columns are independent; each other column of W is a fixed linear
// combination of them, W_d = W_b K with K = R₁₁⁻¹ R₁₂. Then W π = W_b (π_b + K π_d) = W_b β. The
// rank r is decided by |R_kk| ≤ tolerance · |R_00|; the gap between the last kept and the first
// dropped |R_kk| says whether that decision was clear-cut.
#pragma once

#include <cstdint>
#include <vector>

#include "core/identification/regressor.hpp"

namespace chasles {

struct BaseParameters {
  int count = 0;                 ///< r: how many combinations of π the torques determine
  int inertial_count = 0;        ///< the same for the 10 n inertial parameters alone
  std::vector<int> independent;  ///< π's indices of the base columns, in pivot order (r of them)
  std::vector<int> dependent;    ///< π's other indices (13 n − r)
  Eigen::MatrixXd K;             ///< r × (13 n − r): Y_dependent = Y_independent K
  Eigen::MatrixXd projection;    ///< r × 13 n: β = projection π (π_b + K π_d)
  double smallest_kept = 0.0;    ///< |R_{r−1,r−1}| / |R_00|
  double largest_dropped = 0.0;  ///< |R_rr| / |R_00|, 0 when r = 13 n
  int rows = 0;                  ///< rows of the stacked regressor (samples × n)
};

/// The base parameters of `model` from `samples` random states (q uniform within the joint limits,
/// q̇ and q̈ standard normal, from `seed`), rank decided at `tolerance` relative to the largest
/// pivot. Throws ArgumentError when samples × n < 13 n (too few rows to find the rank).
/// Allocates: offline.
BaseParameters base_parameters(const RobotModel& model, int samples, uint64_t seed, double tolerance = 1e-9);

/// β = base.projection π.
Eigen::VectorXd base_parameter_values(const BaseParameters& base, const Eigen::VectorXd& pi);

/// Y_b: the base columns of a regressor Y (n × 13 n) into Y_b (n × r), sized by the caller
/// (allocates nothing). Y_b β = Y π for every π.
void base_regressor(const BaseParameters& base, const Eigen::MatrixXd& Y, Eigen::MatrixXd& Y_b);

}  // namespace chasles
