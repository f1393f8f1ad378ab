#include "controller/config.hpp"

#include <cmath>
#include <string>

#include "core/error.hpp"

namespace chasles::controller {

Config Config::critically_damped(int dof, double omega) {
  Config config;
  config.kp = Eigen::VectorXd::Constant(dof, omega * omega);
  config.kd = Eigen::VectorXd::Constant(dof, 2.0 * omega);
  return config;
}

void Config::validate(int dof) const {
  auto check_gains = [dof](const Eigen::VectorXd& k, const char* name) {
    if (k.size() != dof) {
      throw ArgumentError(std::string(name) + " has " + std::to_string(k.size()) + " entries, the arm has " +
                                  std::to_string(dof) + " joints");
    }
    if (!k.allFinite() || (k.array() < 0.0).any()) {
      throw ArgumentError(std::string(name) + " must be finite and non-negative");
    }
  };
  check_gains(kp, "kp");
  check_gains(kd, "kd");
  if (!(period > 0.0) || !std::isfinite(period)) throw ArgumentError("the period must be positive");
  if (stale_ns <= 0) throw ArgumentError("the stale-state timeout must be positive");
  if (!(torque_ramp > 0.0)) throw ArgumentError("the torque ramp time must be positive");
  if (!(stream_timeout > 0.0) || !std::isfinite(stream_timeout)) {
    throw ArgumentError("the stream timeout must be positive and finite");
  }
  limits.validate(dof);
  jog.validate();
  if (damping.size() != 0) check_gains(damping, "damping");
  if (coulomb.size() != 0) check_gains(coulomb, "Coulomb friction");
  for (const auto& [value, name] : {std::pair{clearance.time_constant, "the clearance time constant"},
                                    std::pair{clearance.deceleration, "the clearance deceleration"}}) {
    if (!(value > 0.0) || !std::isfinite(value)) throw ArgumentError(std::string(name) + " must be positive and finite");
  }
  if (!(clearance.reference_margin >= 0.0) || !std::isfinite(clearance.reference_margin) ||
      !(clearance.repulsion >= 0.0) || !std::isfinite(clearance.repulsion)) {
    throw ArgumentError("the clearance margin and repulsion must be finite and non-negative");
  }
}

}  // namespace chasles::controller
