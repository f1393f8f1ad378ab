// Whether the arm applies the torque this controller means. A driver that adds its own gravity
// compensation (Drake's iiwa drivers, libfranka) must be sent τ − g(q); one that adds nothing
// (chasles's plant) the whole τ (protocol.hpp, TorqueSemantics). Sent the wrong one, the arm gets
// τ ± g(q): it sags or floats a few milliradians off every goal while the status says HOLDING,
// and nothing else notices. Every status reports the torque the arm applied over its last step;
// against the torque this controller commanded for that step, the difference is 0 when the two
// agree and ±g(q) when they do not — the sign telling which way. TorqueSemanticsCheck measures
// that difference's share of g(q) over each second of states.
#pragma once

#include <Eigen/Core>

namespace chasles::controller {

class TorqueSemanticsCheck {
 public:
  enum class Verdict {
    kUndecided,          ///< not a whole window yet, or too little gravity in it to tell
    kAgreed,             ///< the arm applies what is commanded
    kDriverAddsGravity,  ///< the arm applies the command + g(q): send τ − g(q) (overlay)
    kDriverAddsNothing,  ///< sent τ − g(q), the arm applies just that: send the whole τ (full)
  };
  /// How long a window of states is, s of the states' own time: short, because an arm sent τ − g(q)
  /// that adds no gravity falls (a Panda's wrist reached its velocity limit within 0.5 s), and
  /// long enough that a step's lag between command and torque, noise and friction average out.
  static constexpr double kWindow = 0.25;
  /// Below this RMS of g(q) over a window (N·m), a pose too near to upright to tell.
  static constexpr double kMinGravity = 2.0;

  /// One state: the torque the arm applied over the step of `dt` s that ended at it, the torque
  /// this controller commanded for that step (both whole joint torques, in the model's joints),
  /// and g(q) at the state. A verdict at the end of each window, else kUndecided. Allocates nothing.
  Verdict update(const Eigen::Ref<const Eigen::VectorXd>& applied, const Eigen::Ref<const Eigen::VectorXd>& commanded,
                 const Eigen::Ref<const Eigen::VectorXd>& g, double dt);
  /// The share of g(q) in the difference over the last window decided: ≈ 0 agreed, ≈ +1 the driver
  /// adds gravity, ≈ −1 it adds none to what was sent as τ − g(q).
  double share() const { return share_; }
  /// Starts a new window (after a gap in the states, or when commanding resumes).
  void restart() { along_ = squared_ = time_ = 0.0; }

 private:
  double along_ = 0.0, squared_ = 0.0, time_ = 0.0, share_ = 0.0;
};

}  // namespace chasles::controller
