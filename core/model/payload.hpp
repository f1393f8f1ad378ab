// A load rigidly fixed to the tip — a tool, a grasped part — and the model that carries it.
#pragma once

#include <string>

#include "core/model/model.hpp"

namespace chasles {

/// Mass, centre of mass and rotational inertia of a rigid load at the tip, all in the tip frame.
struct Payload {
  double mass = 0.0;                     ///< kg, ≥ 0
  Vector3d centre = Vector3d::Zero();    ///< its centre of mass in the tip frame, m
  Matrix3d inertia = Matrix3d::Zero();   ///< about its centre of mass, tip-frame axes, kg·m² (0: a point mass)
};

/// Bounds no arm's load comes near: kg, m from the tip frame's origin, kg·m² per inertia entry.
inline constexpr double kMaxPayloadMass = 1000.0, kMaxPayloadReach = 5.0, kMaxPayloadInertia = 1000.0;

/// Empty, or why the payload cannot be a body: a non-finite number, a negative mass, a mass, centre
/// or inertia beyond the bounds above, an inertia that is not symmetric or breaks the triangle
/// inequalities (check_inertia).
std::string payload_problem(const Payload& payload);

/// The model with the payload on its last body: at c = T_last_tip · centre in the last body's
/// frame, the load adds G = [[R I Rᵀ + m[c]ᵀ[c], m[c]], [m[c]ᵀ, m 1]] (MR eq. 8.32 moved to the body
/// frame). Throws ModelError for a payload_problem. Allocates: built once, off any real-time loop.
RobotModel with_payload(const RobotModel& model, const Payload& payload);

/// τ += what the payload's weight asks of the joints at the state whose tip pose and J_b are in
/// `data` (forward kinematics and body_jacobian, or compute_tick_terms): J_bᵀ (c × f, f) with f
/// the weight m g in the tip frame — what with_payload adds to the arm's gravity torques g(q), from
/// the Data of the tick instead of another pass over the chain. Subtracted from the loaded
/// model's g(q), the bare arm's. Allocates nothing.
void add_payload_gravity(const RobotModel& model, const Data& data, const Payload& payload, Eigen::VectorXd& tau);

}  // namespace chasles
