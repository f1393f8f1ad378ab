// The wires the simulated-time suites run over: each protocol the controller speaks with an arm's
// driver (controller/transport/protocol.hpp) at its driver's rate and at the other — chasles's own, Drake's
// iiwa (FRI's 200 Hz) and Drake's Panda (libfranka's 1 kHz) — and the options of a controller and
// a plant on one.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "controller/daemon.hpp"
#include "controller/transport/protocol.hpp"
#include "tools/simulation/simulation.hpp"
#include "checks.hpp"

namespace chasles::faults {

struct Wire {
  controller::Protocol protocol;
  double rate_hz;
  double period() const { return 1.0 / rate_hz; }
  int64_t period_ns() const { return std::llround(1e9 / rate_hz); }
  /// The daemon's stale limit at this rate (controller::default_stale_ns).
  int64_t stale_ns() const { return controller::default_stale_ns(period()); }
  /// The driver's channels.
  controller::ProtocolChannels channels() const { return controller::default_channels(protocol); }
};

inline std::vector<Wire> every_wire() {
  using controller::Protocol;
  return {{Protocol::kChasles, 1000.0},   {Protocol::kChasles, 200.0},   {Protocol::kDrakeIiwa, 200.0},
          {Protocol::kDrakeIiwa, 1000.0}, {Protocol::kDrakePanda, 1000.0}, {Protocol::kDrakePanda, 200.0}};
}

/// The wires a suite runs on: every one, but in the sanitizer build (which looks for memory errors,
/// not for the protocols' semantics, and runs the loop several times slower) chasles's at 1 kHz and
/// the iiwa driver's at 200 Hz — both protocols' code, both rates.
inline std::vector<Wire> wires_to_run() {
#ifdef CHASLES_SANITIZED
  return {{controller::Protocol::kChasles, 1000.0}, {controller::Protocol::kDrakeIiwa, 200.0}};
#else
  return every_wire();
#endif
}

/// "drakeiiwa_200Hz".
inline std::string wire_name(const ::testing::TestParamInfo<Wire>& info) {
  std::string name = controller::to_string(info.param.protocol);
  name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
  return name + "_" + std::to_string(static_cast<int>(info.param.rate_hz)) + "Hz";
}

/// A controller on the wire: critically damped at 20 rad/s, the plant's damping 0.5 fed forward,
/// the daemon's stale limit at that rate unless given, a status every 10 ms.
inline controller::DaemonOptions controller_on(const Wire& wire, int64_t stale_ns = 0,
                                               controller::TickSource tick = controller::TickSource::kState) {
  controller::DaemonOptions o;
  o.protocol = wire.protocol;
  o.tick = tick;
  o.control = controller::Config::critically_damped(7, 20.0);
  o.control.damping = Eigen::VectorXd::Constant(7, 0.5);  // the World plant's, known
  o.control.period = wire.period();
  o.control.stale_ns = stale_ns > 0 ? stale_ns : wire.stale_ns();
  o.status_hz = 100.0;
  return o;
}

/// A plant that speaks the wire's protocol at its rate, with its driver's semantics.
inline plant::SimulationOptions plant_on(const Wire& wire) {
  plant::SimulationOptions p;
  p.protocol = wire.protocol;
  p.rate_hz = wire.rate_hz;
  return p;
}

/// The suites' JOINT move from the bent pose: four joints at once, 0.2 to 0.4 rad.
inline Eigen::VectorXd goal_a() {
  Eigen::VectorXd q = bent_pose();
  q(0) += 0.4, q(1) -= 0.3, q(3) += 0.3, q(5) += 0.2;
  return q;
}

}  // namespace chasles::faults
