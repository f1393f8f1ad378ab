// Contact and collision, as libfranka's two levels: the momentum observer's external torque and
// the tip wrench that explains it, held against per-joint torque thresholds and tip force and
// moment thresholds. Crossing a *contact* threshold is reported; crossing a *collision* threshold
// starts the controller's reflex. One monitor per controller, on the real-time thread:
// everything is sized when it is built.
//
// Which link was hit decides what a collision means (LinkPolicy). In the tick, isolation: a force
// on body b moves joints 1…b only, so the body is the most distal joint whose |τ̂_ext| is over its
// isolation floor. From the locator's thread, a few milliseconds later, where on the body and how
// hard (LocatedContact): a located force over the link's collision force is a collision even when
// no joint's threshold is crossed — a 20 N push on the elbow reads as 4 N at the tip.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/contact/observer.hpp"
#include "core/model/model.hpp"

namespace chasles::controller {

/// What the controller does on a collision, until a new target.
enum class Reflex : int8_t {
  kStop = 0,       ///< brake to rest from the arm's motion when it trips, within its effort; hold there
  kCompliant = 1,  ///< gravity compensation plus damping: the arm yields to whatever pushes it
  kRetract = 2,    ///< back along the tip's recent path by retract_distance, then hold
};
const char* to_string(Reflex reflex);
/// "stop", "compliant" or "retract"; false for anything else.
bool parse_reflex(const std::string& text, Reflex& reflex);

/// What a contact on one link of the chain means: per link, as a person touches an elbow and a
/// tool hits a table.
struct LinkPolicy {
  std::string link;  ///< a link of the chain; one fixed to a moving body stands for that body
  /// N: a force located on the link (LocatedContact) at least this large is a collision (∞: only the
  /// joint and tip thresholds say so).
  double collision_force = 15.0;
  Reflex reflex = Reflex::kStop;  ///< what a collision on the link starts
  /// Under free drive a push on the link is a person guiding the arm: a contact, never a reflex.
  bool guided = true;
};
/// The chain body `link` rides on (0: the fixed base), −1 for a link off the root → tip path.
int body_of_link(const RobotModel& model, const std::string& link);
/// "LINK,FORCE,REFLEX,guided|strict" (FORCE in N, inf for none): false with why for anything else.
bool parse_link_policy(const std::string& text, LinkPolicy& policy, std::string& why);

struct ContactConfig {
  /// K_O, 1/s per joint: the estimate follows the external torque with a lag of 1/K_O. Empty: 200.
  Eigen::VectorXd observer_gain;
  /// |τ̂_ext,i| thresholds, N·m or N per joint. Empty: 5 % (contact) and 15 % (collision) of the
  /// joint's effort limit; no limit, no threshold.
  Eigen::VectorXd contact_torque, collision_torque;
  double contact_force = 5.0, collision_force = 15.0;  ///< |f̂| at the tip, N (∞: none)
  double contact_moment = 2.0, collision_moment = 6.0;  ///< |m̂| about the tip's origin, N·m
  Reflex reflex = Reflex::kStop;
  double retract_distance = 0.01;  ///< m of the tip's path, for Reflex::kRetract
  double retract_duration = 0.3;   ///< s
  /// The rate at which the compliant reflex damps the joints' velocity, 1/s (q̈ = −k q̇ unpushed).
  double compliant_damping = 10.0;
  /// |τ̂_ext,i| under which joint i is taken to feel no contact when isolating the body hit, N·m or
  /// N per joint. Empty: 1 % of the joint's effort limit (0.87 N·m on the Panda's shoulder).
  Eigen::VectorXd isolation_torque;
  /// The links with a policy of their own; every other body's is {collision_force, reflex, guided}.
  std::vector<LinkPolicy> links;

  /// The empty vectors filled from the model (see above).
  void fill_defaults(const RobotModel& model);
  /// Throws ArgumentError naming what is wrong: sizes, non-positive or NaN thresholds, a contact
  /// threshold above its collision threshold, non-positive gains or retract settings, a policy for
  /// a link off the chain or two for one body.
  void validate(const RobotModel& model) const;
};

/// The estimate of one tick.
struct ContactEstimate {
  Eigen::VectorXd tau_ext;                          ///< τ̂_ext, N·m or N per joint
  Vector6d wrench_tip = Vector6d::Zero();           ///< F̂_ext on the tip, tip frame, (m, f)
  Vector6d wrench_base = Vector6d::Zero();          ///< the same, base-aligned at the tip origin
  Vector3d tip_position = Vector3d::Zero();         ///< p_sb of the state it was computed from, m
  bool contact = false, collision = false;
  /// The body in contact (1…n; 0: none): the locator's while its estimate is under 50 ms old, else
  /// the most distal joint over its isolation floor. Its policy decides a collision's reflex.
  int body = 0;
  explicit ContactEstimate(int n = 0) : tau_ext(Eigen::VectorXd::Zero(n)) {}
};

/// Where the locator (core/geometry/contact_locator.hpp) put the newest contact, as the loop hears it.
struct LocatedContact {
  int body = 0;          ///< the chain body, 1…n
  std::string_view link; ///< the URDF link it is on (the locator's copy, alive as long as it is)
  Vector3d point = Vector3d::Zero();  ///< m, base frame
  Vector3d force = Vector3d::Zero();  ///< N, base frame, on the arm
};

class ContactMonitor {
 public:
  /// `damping` and `coulomb` are the known viscous and Coulomb joint friction (each empty: none);
  /// `period` the state's nominal period, s (it sizes the recent path kept for the retract reflex).
  /// Keeps a reference to the model. Throws ArgumentError (a bad config) or ObserverError.
  ContactMonitor(const RobotModel& model, const ContactConfig& config, const Eigen::VectorXd& damping, double period,
                 const Eigen::VectorXd& coulomb = {});

  /// Takes a state — `data` holding the terms at its (q, q̇) (compute_tick_terms), `effort` the
  /// torque applied over the interval that ended at it — `dt` seconds after the previous state
  /// taken. dt ≤ 0 or not finite (a first state, a gap, a sender that restarted) starts the
  /// observer again, reporting no contact until it has run one step. Allocates nothing.
  void update(const Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& effort,
              double dt);
  const ContactEstimate& estimate() const { return estimate_; }
  /// The joint torque the controller's law means the arm to apply to its surroundings (an
  /// impedance pressing on a surface; zero under computed torque and free drive): a contact still,
  /// but no collision, so from the next update each collision threshold is raised by it — per
  /// joint by |τ_i|, at the tip by the force and moment it makes there. Allocates nothing.
  void set_allowance(const Eigen::VectorXd& torque) { allowance_ = torque; }

  /// The locator's newest contact: the next update() judges it against its link's collision force.
  /// Allocates nothing.
  void take_location(const LocatedContact& located);
  /// The policy of body b (0…n).
  const LinkPolicy& policy(int body) const { return policies_[static_cast<size_t>(body)]; }

  /// Estimates with `model` from now on (the same chain, another payload); the observer starts
  /// again at the next state. Keeps a reference; allocates nothing.
  void set_model(const RobotModel& model);
  /// Why the latest collision (or, without one, contact) was flagged, naming the joint or the force.
  const char* reason() const { return reason_; }
  const ContactConfig& config() const { return config_; }

  /// The configuration the tip was at `distance` back along its recent path (the oldest kept, about
  /// two seconds, if it moved less). Allocates nothing.
  void retract_goal(double distance, Eigen::VectorXd& q) const;

 private:
  void classify();
  void isolate();
  bool location_fresh() const;  // the locator's estimate names the body (isolate())
  void judge_location();
  void remember(const Eigen::VectorXd& q);

  const RobotModel* model_;
  ContactConfig config_;
  MomentumObserver observer_;
  ContactEstimate estimate_;
  Eigen::VectorXd allowance_;
  Vector6d allowance_base_ = Vector6d::Zero();  // allowance_ as a wrench at the tip, base-aligned
  bool started_ = false;
  char reason_[160] = {};  // room for the reflex to be named after it in 192
  // The recent path: joint positions and tip positions, a ring of the newest `history_size_`.
  Eigen::MatrixXd history_q_;
  Eigen::Matrix3Xd history_tip_;
  int history_next_ = 0, history_count_ = 0;
  std::vector<LinkPolicy> policies_;  // per body 0…n
  LocatedContact located_;
  bool location_pending_ = false;  // taken, not yet judged
  double location_age_ = std::numeric_limits<double>::infinity();  // s of states since it was taken
  std::string_view isolated_link_;  // the link named for estimate_.body
};

}  // namespace chasles::controller
