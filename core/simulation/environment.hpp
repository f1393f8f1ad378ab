// What the simulated arm meets that its controller does not know: wrenches pushed onto the tip,
// one-sided walls, a payload at the tip, joint friction and inertias off the URDF's, each given as a
// plain spec (EnvironmentOptions, from chasles_plant's --push, --wall, --payload, --friction and
// --perturb-inertia or set by an in-process test) and applied by Plant (plant.hpp). Physics only:
// the command-line forms are chasles_plant's (tools/simulation/environment_forms.hpp).
//
// Frames: a wrench is (m, f), N·m then N. A push is given and the contact is reported with the
// base frame's orientation at the tip frame's origin (libfranka's O_F_ext_hat_K, in Modern
// Robotics' order), the wrench the environment applies to the tip; forward_dynamics wants the
// opposite (what the tip applies to the environment) in the tip frame, F_tip = −[R_sbᵀ m; R_sbᵀ f].
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "core/model/payload.hpp"

namespace chasles::plant {

/// The trapezoid in [0, 1] of a window of simulated time: 0 before `start` and after start +
/// duration, ramped linearly in over `ramp` s and out over `ramp` s, 1 between. With no ramp the
/// window is closed, [start, start + duration]. A push's and a press's (tools/mujoco) profile.
double trapezoid(double t, double start, double duration, double ramp);
/// Throws ArgumentError, `what` first, unless the window's numbers are finite, start ≥ 0,
/// duration > 0 and 0 ≤ ramp ≤ duration / 2.
void check_window(double start, double duration, double ramp, const std::string& what);

/// A wrench the environment applies to the tip over a window of simulated time, ramped linearly in
/// over `ramp` seconds from `start` and out over `ramp` seconds ending at start + duration.
struct Push {
  double start = 0.0;                  ///< s of simulated time since the plant's first step (steps × period)
  double duration = 0.0;               ///< s, the ramps included; > 0
  double ramp = 0.0;                   ///< s; 0 ≤ ramp ≤ duration / 2 (0: a step on and off)
  Vector6d wrench = Vector6d::Zero();  ///< (m, f), N·m and N, base-aligned at the tip origin

  /// trapezoid(t, start, duration, ramp).
  double profile(double t) const;
};

/// A one-sided plane acting on the tip frame's origin p: penetration δ = −(p − point)·normal; when
/// δ > 0 the force on the tip is normal · max(0, K δ − D (v·normal)), v the origin's velocity in the
/// base frame, applied at the origin (no moment about it). It pushes, damps and never pulls.
struct Wall {
  Vector3d point = Vector3d::Zero();    ///< a point of the plane, m, base frame
  Vector3d normal = Vector3d::UnitZ();  ///< towards the free side, base frame; normalised by the plant
  double stiffness = 10'000.0;          ///< K, N/m; > 0
  double damping = 100.0;               ///< D, N·s/m; ≥ 0
};

/// A load rigidly attached to the tip (core/model/payload.hpp), added to the last body of the model
/// the plant integrates; the controller's model does not have it. --payload gives a point mass.
using chasles::Payload;
using chasles::with_payload;

/// Joint friction the controller's model does not have, on top of the known viscous damping, with
/// stiction and the Stribeck effect as a real joint's (Olsson et al. 1998, "Friction models and
/// friction compensation", eq. 6):
///   τ_f = −b q̇ − (f_c + (f_s − f_c) exp(−(q̇ / v_st)²)) tanh(q̇ / v_s)
/// per joint (v_s: Plant::friction_velocity()). Breaking away takes f_s; once moving, friction falls
/// to f_c within a few v_st. Below v_s the joint creeps instead of sticking: it holds any torque
/// under f_s while it moves slower than about v_s.
struct Friction {
  Eigen::VectorXd viscous;  ///< b, N·m·s/rad or N·s/m, one per joint; empty: no friction
  Eigen::VectorXd coulomb;  ///< f_c, N·m or N, one per joint; empty: no friction
  /// f_s ≥ f_c, the breakaway torque, one per joint; empty: f_c (none). (Initialised, so that
  /// {viscous, coulomb} still says all a friction without stiction needs.)
  Eigen::VectorXd stiction = Eigen::VectorXd();
  double stribeck_velocity = 0.05;  ///< v_st, rad/s or m/s, > 0
  bool empty() const { return viscous.size() == 0 && coulomb.size() == 0; }
  /// f_s where given, else f_c: the largest friction a joint sees.
  double breakaway(Eigen::Index i) const { return stiction.size() > 0 ? stiction[i] : coulomb[i]; }
};

/// The arm's own inertias off its model's, as a real arm's are off its CAD's: every body's mass,
/// centre of mass, spread of mass and principal axes perturbed by up to ±fraction, drawn from
/// `seed` (identification/perturbation.hpp, with_perturbed_inertias, says exactly how). The payload
/// goes on top of the perturbed arm.
struct InertiaPerturbation {
  double fraction = 0.0;  ///< in [0, 1)
  uint64_t seed = 0;
};

struct EnvironmentOptions {
  std::vector<Push> pushes;        ///< they add
  std::vector<Wall> walls;         ///< they add
  std::optional<Payload> payload;  ///< none: the model as loaded
  Friction friction;
  std::optional<InertiaPerturbation> perturbation;  ///< none: the model's inertias
  /// Whether anything is simulated that the nominal model lacks (then the plant publishes its truth).
  bool any() const {
    return !pushes.empty() || !walls.empty() || payload.has_value() || !friction.empty() || perturbation.has_value();
  }
};

/// The options with every wall's normal made unit, checked: throws chasles::ArgumentError naming the
/// item ("push 2: ...", "wall 1: ...", "payload: ...", "friction: joint panda_joint3 ...",
/// "perturbation: ...") when a number is not finite, a push's duration is not positive or its ramp
/// does not fit in half of it, a normal is zero, a stiffness is not positive, or a damping, mass or
/// friction coefficient is negative, the friction does not have one entry per joint, or the
/// perturbation's fraction is not in [0, 1). Plant calls it.
EnvironmentOptions checked_environment(const EnvironmentOptions& options, const RobotModel& model);

// The checks checked_environment makes, one item at a time, for a caller that builds the items
// itself (chasles_plant's command-line forms, tools/simulation/environment_forms.hpp). Each throws
// chasles::ArgumentError "<what>: <why>".

/// A push's numbers finite, START ≥ 0, DURATION > 0, 0 ≤ RAMP ≤ DURATION / 2.
void check_push(const Push& push, const std::string& what);
/// A wall's numbers finite, its normal not zero (normalised here), K > 0, D ≥ 0.
void check_wall(Wall& wall, const std::string& what);
/// One viscous and one Coulomb coefficient per joint of `model`, finite and ≥ 0; stiction, if
/// given, one per joint and no less than Coulomb's; the Stribeck velocity finite and > 0.
void check_friction(const Friction& friction, const RobotModel& model, const std::string& what);
/// FRACTION in [0, 1): at 1 a body's mass or spread could vanish.
void check_perturbation(const InertiaPerturbation& perturbation, const std::string& what);

}  // namespace chasles::plant
