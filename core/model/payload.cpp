#include "core/model/payload.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/lie/so3.hpp"
#include "core/model/inertia.hpp"

namespace chasles {

std::string payload_problem(const Payload& payload) {
  if (!std::isfinite(payload.mass) || !payload.centre.allFinite() || !payload.inertia.allFinite()) {
    return "a number is not finite";
  }
  if (payload.mass < 0.0) {
    char text[64];
    std::snprintf(text, sizeof(text), "mass %g kg is negative", payload.mass);
    return text;
  }
  // Beyond these no arm carries the load, and the body it makes could overflow (m |c|², I).
  if (payload.mass > kMaxPayloadMass || payload.centre.norm() > kMaxPayloadReach ||
      payload.inertia.cwiseAbs().maxCoeff() > kMaxPayloadInertia) {
    char text[160];
    std::snprintf(text, sizeof(text),
                  "mass %g kg, centre %g m from the tip or an inertia entry of %g kg*m^2 is beyond any arm's load "
                  "(%g kg, %g m, %g kg*m^2)",
                  payload.mass, payload.centre.norm(), payload.inertia.cwiseAbs().maxCoeff(), kMaxPayloadMass,
                  kMaxPayloadReach, kMaxPayloadInertia);
    return text;
  }
  const double asymmetry = (payload.inertia - payload.inertia.transpose()).norm();
  if (asymmetry > std::max(1e-12 * payload.inertia.norm(), 1e-15)) return "the inertia is not symmetric";
  if (payload.inertia.isZero(0.0)) return {};  // a point mass
  const InertiaCheck check = check_inertia(payload.mass, payload.inertia);
  return check.problem;
}

RobotModel with_payload(const RobotModel& model, const Payload& payload) {
  if (const std::string problem = payload_problem(payload); !problem.empty()) {
    throw ModelError("payload: " + problem);
  }
  ChainDescription description = model.description();
  const Matrix3d& R = description.T_last_tip.linear();
  const Vector3d c = description.T_last_tip * payload.centre;  // in the last body's frame
  const Matrix3d C = hat3(c);
  Matrix6d G;
  G << R * payload.inertia * R.transpose() + payload.mass * C.transpose() * C, payload.mass * C,
      payload.mass * C.transpose(), payload.mass * Matrix3d::Identity();
  description.inertia.back() += G;
  return RobotModel(std::move(description));
}

void add_payload_gravity(const RobotModel& model, const Data& data, const Payload& payload, Eigen::VectorXd& tau) {
  // Holding the load still takes the wrench opposite its weight's, carried to the joints by J_bᵀ.
  const Vector3d f = data.T_sb.linear().transpose() * (-payload.mass * model.gravity());
  Vector6d wrench;
  wrench << payload.centre.cross(f), f;
  tau.noalias() += data.J_b.transpose() * wrench;
}

}  // namespace chasles
