#include "core/simulation/environment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.hpp"
#include "core/lie/so3.hpp"
#include "core/number_text.hpp"

namespace chasles::plant {
namespace {

[[noreturn]] void refuse(const std::string& what, const std::string& why) {
  throw ArgumentError(what + ": " + why);
}

bool finite(const Eigen::Ref<const Eigen::MatrixXd>& values) { return values.allFinite(); }

void check_payload(const Payload& payload, const std::string& what) {
  if (const std::string problem = payload_problem(payload); !problem.empty()) refuse(what, problem);
}

}  // namespace

void check_push(const Push& push, const std::string& what) {
  if (!finite(push.wrench)) refuse(what, "a number is not finite");
  check_window(push.start, push.duration, push.ramp, what);
}

void check_wall(Wall& wall, const std::string& what) {
  if (!finite(wall.point) || !finite(wall.normal) || !std::isfinite(wall.stiffness) || !std::isfinite(wall.damping)) {
    refuse(what, "a number is not finite");
  }
  const double length = wall.normal.stableNorm();
  if (!(length > 0.0) || !std::isfinite(length)) {
    refuse(what, "the normal (" + number_text(wall.normal.x()) + ", " + number_text(wall.normal.y()) + ", " +
                     number_text(wall.normal.z()) + ") has no direction; give one pointing to the free side");
  }
  wall.normal /= length;
  if (!(wall.stiffness > 0.0)) refuse(what, "stiffness K " + number_text(wall.stiffness) + " N/m is not positive");
  if (wall.damping < 0.0) refuse(what, "damping D " + number_text(wall.damping) + " N*s/m is negative");
}

void check_friction(const Friction& friction, const RobotModel& model, const std::string& what) {
  const int n = model.dof();
  if (friction.viscous.size() != n || friction.coulomb.size() != n) {
    refuse(what, "has " + std::to_string(friction.viscous.size()) + " viscous and " +
                     std::to_string(friction.coulomb.size()) + " Coulomb coefficients; the arm has " +
                     std::to_string(n) + " joints");
  }
  for (int i = 0; i < n; ++i) {
    const std::string joint = "joint " + model.joint(i).name;
    if (!std::isfinite(friction.viscous[i]) || !std::isfinite(friction.coulomb[i])) {
      refuse(what, joint + ": a coefficient is not finite");
    }
    const bool prismatic = model.joint(i).type == JointType::Prismatic;
    if (friction.viscous[i] < 0.0) {
      refuse(what, joint + ": viscous friction " + number_text(friction.viscous[i]) + (prismatic ? " N*s/m" : " N*m*s/rad") +
                       " is negative");
    }
    if (friction.coulomb[i] < 0.0) {
      refuse(what, joint + ": Coulomb friction " + number_text(friction.coulomb[i]) + (prismatic ? " N" : " N*m") +
                       " is negative");
    }
    if (friction.stiction.size() > 0 && !(friction.stiction[i] >= friction.coulomb[i])) {
      refuse(what, joint + ": stiction " + number_text(friction.stiction[i]) + (prismatic ? " N" : " N*m") +
                       " is below Coulomb friction " + number_text(friction.coulomb[i]) + " (or not finite)");
    }
  }
  if (friction.stiction.size() > 0 && friction.stiction.size() != n) {
    refuse(what, "has " + std::to_string(friction.stiction.size()) + " stiction values; the arm has " +
                     std::to_string(n) + " joints");
  }
  if (!(friction.stribeck_velocity > 0.0) || !std::isfinite(friction.stribeck_velocity)) {
    refuse(what, "the Stribeck velocity " + number_text(friction.stribeck_velocity) + " is not a positive number");
  }
}

void check_perturbation(const InertiaPerturbation& perturbation, const std::string& what) {
  if (!(perturbation.fraction >= 0.0 && perturbation.fraction < 1.0)) {
    refuse(what, "FRACTION " + number_text(perturbation.fraction) +
                     " is not in [0, 1): a body's mass and spread are scaled by as little as 1 - FRACTION, which "
                     "must stay positive (0.2 is +-20 %)");
  }
}

void check_window(double start, double duration, double ramp, const std::string& what) {
  if (!std::isfinite(start) || !std::isfinite(duration) || !std::isfinite(ramp)) refuse(what, "a number is not finite");
  if (start < 0.0) refuse(what, "START " + number_text(start) + " s is before the plant's first step (0)");
  if (!(duration > 0.0)) refuse(what, "DURATION " + number_text(duration) + " s is not positive");
  if (ramp < 0.0) refuse(what, "RAMP " + number_text(ramp) + " s is negative");
  if (ramp > 0.5 * duration) {
    refuse(what, "RAMP " + number_text(ramp) + " s is longer than half of DURATION " + number_text(duration) +
                     " s: the ramps in and out must both fit in the window (RAMP <= DURATION/2)");
  }
}

double trapezoid(double t, double start, double duration, double ramp) {
  const double end = start + duration;
  if (t < start || t > end) return 0.0;
  if (ramp <= 0.0) return 1.0;
  return std::min({1.0, (t - start) / ramp, (end - t) / ramp});
}

double Push::profile(double t) const { return trapezoid(t, start, duration, ramp); }

EnvironmentOptions checked_environment(const EnvironmentOptions& options, const RobotModel& model) {
  EnvironmentOptions out = options;
  for (size_t i = 0; i < out.pushes.size(); ++i) check_push(out.pushes[i], "push " + std::to_string(i + 1));
  for (size_t i = 0; i < out.walls.size(); ++i) check_wall(out.walls[i], "wall " + std::to_string(i + 1));
  if (out.payload) check_payload(*out.payload, "payload");
  if (!out.friction.empty()) check_friction(out.friction, model, "friction");
  if (out.perturbation) check_perturbation(*out.perturbation, "perturbation");
  return out;
}

}  // namespace chasles::plant
