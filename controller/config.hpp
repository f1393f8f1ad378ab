// The controller's configuration: gains, period, timeouts, the joints' known friction, and the
// contact, limit and jog settings. Every default is here, once: the daemon's flags start from
// Config{} (main.cpp), and the Python bindings read them from it.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "controller/clearance.hpp"
#include "controller/contact.hpp"
#include "controller/jog.hpp"
#include "core/motion/limits.hpp"

namespace chasles::controller {

struct Config {
  Eigen::VectorXd kp;  ///< position gains K_p, 1/s², one per joint
  Eigen::VectorXd kd;  ///< velocity gains K_d, 1/s
  double period = 1e-3;           ///< tick period, s
  int64_t stale_ns = 10'000'000;  ///< a state older than this stops the commands: FAULT
  /// Time to ramp through a joint's full effort range, s: the torque-rate limit is
  /// effort_limit / torque_ramp per joint (infinite where the URDF gives no effort limit).
  /// The same time is the fade of a switch between laws.
  double torque_ramp = 0.05;
  /// The joints' viscous damping D (N·m·s/rad or N·s/m), if known: the law adds D q̇_d, the
  /// torque that feeds it forward, and the contact observer counts it as the model's.
  /// Empty or zero: none.
  Eigen::VectorXd damping;
  /// The joints' Coulomb friction f_c (N·m or N), if known (chasles_calibrate dynamics identifies
  /// it): the law adds f_c tanh(q̇_d / v_c) — the reference's velocity, so the feedforward never
  /// chatters — and the observer counts f_c tanh(q̇ / v_c) as the model's (v_c = kCoulombVelocity,
  /// contact/observer.hpp). Empty: none.
  Eigen::VectorXd coulomb;
  /// Contact and collision thresholds, the observer's gains and the reflex.
  ContactConfig contact;
  /// Acceleration and jerk limits (the URDF gives position and velocity), the position margin
  /// and the measured velocity's tolerance.
  motion::LimitConfig limits;
  /// A stream or a jog with no message for this long, s, is taken as stopped: the arm decelerates
  /// to rest.
  double stream_timeout = 0.1;
  /// The condition numbers where a twist jog toward a singularity slows and stops.
  JogConfig jog;
  /// How the reference and free drive keep the arm clear of itself and the scene (clearance.hpp):
  /// in force once a world is set (Controller::set_clearance_world).
  ClearanceConfig clearance;
  /// FAULT when the arm applies the command ± g(q), a driver's gravity compensation added to a
  /// whole torque or missing from τ − g(q) (semantics_check.hpp): off only for a driver whose
  /// reported torque is not the torque it applies.
  bool check_torque_semantics = true;

  /// K_p = ω², K_d = 2ω (critically damped error dynamics at the natural frequency ω, rad/s).
  static Config critically_damped(int dof, double omega);
  /// Throws ArgumentError naming what is wrong (sizes, signs, non-finite values).
  void validate(int dof) const;
};

}  // namespace chasles::controller
