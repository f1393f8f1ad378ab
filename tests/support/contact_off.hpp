// Contact thresholds that never trip: for tests whose state is not an arm's answer to the torque
// (the monitor would read the difference as a push), or whose knocks and pushes are the test's own.
#pragma once

#include <Eigen/Core>
#include <limits>

#include "controller/contact.hpp"

namespace chasles::testing {

/// Every contact and collision threshold of `c` (joint torques of a `dof`-joint arm, the tip's force
/// and moment) at ∞: the monitor still estimates, it never flags.
inline void never_trip(controller::ContactConfig& c, int dof) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  c.contact_torque = c.collision_torque = Eigen::VectorXd::Constant(dof, kInf);
  c.contact_force = c.collision_force = c.contact_moment = c.collision_moment = kInf;
}

}  // namespace chasles::testing
