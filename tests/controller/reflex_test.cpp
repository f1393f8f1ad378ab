// Contact, collision and the reflexes, on the controller alone: hand-made states of an arm held
// still (or moved slowly) with the torque that holds it, so the external torque the observer must
// find is known exactly, and its lag (1 − e^{−K t}) says at which sample each threshold is crossed.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <string>
#include <vector>

#include "controller/contact.hpp"
#include "controller/controller.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/contact_off.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::matrices_near;

constexpr int64_t kMs = 1'000'000;
constexpr double kInf = std::numeric_limits<double>::infinity();

class Reflexes : public ::testing::Test {
 protected:
  Reflexes() : model_(testing::panda()), data_(model_), state_(7) {
    config_ = Config::critically_damped(7, 20.0);
    // The states carry the effort of a known external torque, not the torque commanded: the
    // torque-semantics check is semantics_check_test's and the World's.
    config_.check_torque_semantics = false;
    q0_ << 0.1, 0.5, -0.2, -1.2, 0.1, 1.0, 0.3;
  }

  // The joint torque of a wrench on the tip given base-aligned at the tip's origin, (m, f).
  VectorXd torque_of(const VectorXd& q, const Vector6d& F_base) {
    const Matrix6Xd& J_b = body_jacobian(model_, data_, q);
    const Matrix3d R = data_.T_sb.linear();
    Vector6d F_tip;
    F_tip << R.transpose() * F_base.head<3>(), R.transpose() * F_base.tail<3>();
    return J_b.transpose() * F_tip;
  }

  // State k of an arm at rest at q, held by its actuators against gravity and against τ_ext:
  // effort = g(q) − τ_ext. Arrives at k ms.
  const JointState* still(int64_t k, const VectorXd& q, const VectorXd& tau_ext) {
    state_.seq = k;
    state_.arrival_ns = k * kMs;
    state_.q = q;
    state_.qd.setZero();
    state_.effort = gravity_torques(model_, data_, q) - tau_ext;
    return &state_;
  }

  // The joint torque of a force f at point p of body b (both in the base frame): τ_j = S_jᵀ (p × f,
  // f) for the joints j ≤ b that move the body, nothing on the joints beyond it.
  VectorXd torque_of_force_on(int body, const VectorXd& q, const Vector3d& p, const Vector3d& f) {
    const Matrix6Xd& J_s = space_jacobian(model_, data_, q);
    Vector6d F;
    F << p.cross(f), f;
    VectorXd tau = VectorXd::Zero(7);
    tau.head(body) = J_s.leftCols(body).transpose() * F;
    return tau;
  }
  // A point 12 cm from body b's origin, off the joint axes.
  Vector3d point_on(int body, const VectorXd& q) {
    compute_tick_terms(model_, data_, q, VectorXd::Zero(7));
    return data_.T_body[static_cast<size_t>(body)] * Vector3d(0.08, 0.06, 0.07);
  }

  // The terms at a state, as the controller computes them before its monitor reads them.
  const Data& terms(const JointState& s) { return compute_tick_terms(model_, data_, s.q, s.qd); }

  const RobotModel& model_;
  Data data_;
  Config config_;
  JointState state_;
  VectorXd q0_ = VectorXd(7);
};

// A 20 N step of force at the tip: the estimate is 20 (1 − e^{−K t}) N at sample t, so with
// K = 200 /s and 1 ms samples it passes 5 N (contact) at the 2nd sample and 15 N (collision) at
// the 7th: ln(4/3)/0.2 = 1.44 and ln 4/0.2 = 6.93.
TEST_F(Reflexes, ThresholdsAreCrossedWhenTheLagOfAForceStepSaysAndTheReasonNamesTheForce) {
  ContactConfig config;
  config.contact_torque = config.collision_torque = VectorXd::Constant(7, kInf);  // the force alone
  ContactMonitor monitor(model_, config, VectorXd(), 1e-3);
  Vector6d F = Vector6d::Zero();
  F.tail<3>() << 0.0, 20.0, 0.0;
  const VectorXd tau_ext = torque_of(q0_, F);
  const JointState* s = still(0, q0_, VectorXd::Zero(7));
  monitor.update(terms(*s), s->q, s->qd, s->effort, 0.0);
  for (int k = 1; k <= 20; ++k) {
    s = still(k, q0_, tau_ext);
    monitor.update(terms(*s), s->q, s->qd, s->effort, 1e-3);
    const ContactEstimate& e = monitor.estimate();
    const double expected = 20.0 * (1.0 - std::exp(-0.2 * k));
    EXPECT_NEAR(e.wrench_base(4), expected, 1e-9) << "sample " << k;
    EXPECT_NEAR(e.wrench_base.head<3>().norm() + std::abs(e.wrench_base(3)) + std::abs(e.wrench_base(5)), 0.0, 1e-9);
    EXPECT_TRUE(matrices_near(e.tau_ext, (1.0 - std::exp(-0.2 * k)) * tau_ext, 1e-9));
    EXPECT_EQ(e.contact, k >= 2) << "sample " << k;
    EXPECT_EQ(e.collision, k >= 7) << "sample " << k;
    if (k == 7) {
      // The Panda's tip is on joint 7's axis: a force there turns joint 7 not at all, so isolation
      // by the joints names the body before it.
      ASSERT_NEAR(tau_ext(6), 0.0, 1e-12);
      char expected_reason[160];
      std::snprintf(expected_reason, sizeof(expected_reason), "collision: tip force %.3g N over 15, on panda_link6 or beyond",
                    expected);
      EXPECT_STREQ(monitor.reason(), expected_reason);
    }
  }
}

TEST_F(Reflexes, AJointOverItsThresholdIsNamed) {
  ContactConfig config;
  config.contact_force = config.collision_force = config.contact_moment = config.collision_moment = kInf;
  ContactMonitor monitor(model_, config, VectorXd(), 1e-3);
  // Default thresholds: 5 % and 15 % of the effort limit; the Panda's fifth joint has 12 N·m.
  EXPECT_DOUBLE_EQ(monitor.config().collision_torque(4), 0.15 * model_.joint(4).limits.effort);
  VectorXd tau_ext = VectorXd::Zero(7);
  tau_ext(4) = -4.0;
  for (int k = 0; k <= 50; ++k) {
    const JointState* s = still(k, q0_, k == 0 ? VectorXd::Zero(7) : tau_ext);
    monitor.update(terms(*s), s->q, s->qd, s->effort, k == 0 ? 0.0 : 1e-3);
  }
  EXPECT_TRUE(monitor.estimate().collision);
  EXPECT_EQ(std::string(monitor.reason()).rfind("collision: joint " + model_.joint(4).name + " external torque 4 over 1.8",
                                                0),
            0u)
      << monitor.reason();
}

TEST_F(Reflexes, ConfigsThatCannotDetectAreRefused) {
  ContactConfig config;
  config.contact_force = 20.0;  // above the collision threshold
  EXPECT_THROW(ContactMonitor(model_, config, VectorXd(), 1e-3), ArgumentError);
  config = ContactConfig();
  config.collision_torque = VectorXd::Constant(3, 10.0);
  EXPECT_THROW(ContactMonitor(model_, config, VectorXd(), 1e-3), ArgumentError);
  config = ContactConfig();
  config.contact_moment = std::nan("");
  EXPECT_THROW(ContactMonitor(model_, config, VectorXd(), 1e-3), ArgumentError);
  config = ContactConfig();
  config.observer_gain = VectorXd::Constant(7, -1.0);
  EXPECT_THROW(ContactMonitor(model_, config, VectorXd(), 1e-3), ArgumentError);
  config = ContactConfig();
  config.retract_distance = 0.0;
  EXPECT_THROW(ContactMonitor(model_, config, VectorXd(), 1e-3), ArgumentError);
}

// Holding, pushed: REFLEX at the 7th sample, the message naming the force; the stop reflex holds
// where the arm was; only a new target ends it.
TEST_F(Reflexes, ACollisionStopsTheArmUntilANewTarget) {
  config_.contact.contact_torque = config_.contact.collision_torque = VectorXd::Constant(7, kInf);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
  ASSERT_EQ(controller.mode(), Mode::kHolding);
  Vector6d F = Vector6d::Zero();
  F(5) = -20.0;
  const VectorXd tau_ext = torque_of(q0_, F);
  for (int k = 1; k <= 6; ++k) {
    ASSERT_TRUE(controller.tick(k * kMs, still(k, q0_, tau_ext)));
    EXPECT_EQ(controller.mode(), Mode::kHolding) << k;
  }
  ASSERT_TRUE(controller.tick(7 * kMs, still(7, q0_, tau_ext)));
  EXPECT_EQ(controller.mode(), Mode::kReflex);
  EXPECT_EQ(controller.reflexes(), 1);
  EXPECT_EQ(controller.contacts(), 1);
  EXPECT_EQ(std::string(controller.reflex_reason()).rfind("collision: tip force 15.1 N over 15, on panda_link6 or beyond; reflex stop", 0), 0u)
      << controller.reflex_reason();
  EXPECT_TRUE(matrices_near(controller.reference().q, q0_, 0.0));
  // Still pushed: still REFLEX, once.
  for (int k = 8; k <= 30; ++k) ASSERT_TRUE(controller.tick(k * kMs, still(k, q0_, tau_ext)));
  EXPECT_EQ(controller.mode(), Mode::kReflex);
  EXPECT_EQ(controller.reflexes(), 1);
  EXPECT_NEAR(controller.peak_tip_force(), 20.0 * (1.0 - std::exp(-0.2 * 30)), 1e-9);

  // The push ends; a HOLD target ends the reflex, holding where the arm is.
  for (int k = 31; k <= 80; ++k) ASSERT_TRUE(controller.tick(k * kMs, still(k, q0_, VectorXd::Zero(7))));
  EXPECT_FALSE(controller.contact().contact);
  Target hold(7);
  hold.mode = Target::kHold;
  ASSERT_TRUE(controller.set_target(hold, 80 * kMs));
  EXPECT_EQ(controller.mode(), Mode::kHolding);
}

// Isolation: for a force on each body of the arm in turn, the body the estimate names once it has
// converged is that body (the force's point off the axes, so that the body's own joint turns).
TEST_F(Reflexes, IsolationNamesTheBodyAForceActsOn) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int body = 1; body <= 7; ++body) {
    int checked = 0;
    for (int draw = 0; draw < 10; ++draw) {
      // Toward a_b = v_b + ω_b × p, what the body's own joint feels of a force at p, and askew.
      const Vector3d p = point_on(body, q0_);
      const Matrix6Xd& J_s = space_jacobian(model_, data_, q0_);
      const Vector3d a = J_s.col(body - 1).tail<3>() + J_s.col(body - 1).head<3>().cross(p);
      const Vector3d f =
          40.0 * (a.normalized() + 0.7 * Vector3d(unit(random), unit(random), unit(random)).normalized()).normalized();
      const VectorXd tau_ext = torque_of_force_on(body, q0_, p, f);
      ContactMonitor monitor(model_, ContactConfig(), VectorXd(), 1e-3);
      if (std::abs(tau_ext(body - 1)) < 2.0 * monitor.config().isolation_torque(body - 1)) continue;
      for (int k = 0; k <= 60; ++k) {
        const JointState* s = still(k, q0_, k == 0 ? VectorXd::Zero(7) : tau_ext);
        monitor.update(terms(*s), s->q, s->qd, s->effort, k == 0 ? 0.0 : 1e-3);
      }
      EXPECT_EQ(monitor.estimate().body, body) << "draw " << draw << ", τ_ext " << tau_ext.transpose();
      ++checked;
    }
    EXPECT_GE(checked, 8) << "body " << body << ": draws too weak to turn its own joint";
  }
  // The floor: 1 % of each joint's effort limit.
  ContactMonitor monitor(model_, ContactConfig(), VectorXd(), 1e-3);
  EXPECT_DOUBLE_EQ(monitor.config().isolation_torque(0), 0.01 * model_.joint(0).limits.effort);
  EXPECT_EQ(monitor.policy(4).link, "panda_link4");
  EXPECT_EQ(monitor.policy(7).link, "panda_link7");
}

// The policy of the link hit decides: under free drive a push on a guided link is a person's (the
// collision is flagged, the arm is not stopped); on a strict link it starts that link's reflex.
TEST_F(Reflexes, UnderFreeDriveAGuidedLinkIsAPersonAndAStrictLinkStartsItsReflex) {
  const Vector3d p = point_on(4, q0_);
  const VectorXd tau_ext = torque_of_force_on(4, q0_, p, Vector3d(0.0, 0.0, 80.0));
  ASSERT_GT(std::abs(tau_ext(1)), 0.15 * model_.joint(1).limits.effort) << "the push must cross joint 2's threshold";
  for (bool strict : {false, true}) {
    Config config = config_;
    if (strict) config.contact.links.push_back(LinkPolicy{"panda_link4", kInf, Reflex::kCompliant, false});
    Controller controller(model_, config);
    ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
    LawSettings free_drive(7);
    free_drive.law = Law::kFreeDrive;
    ASSERT_TRUE(controller.set_law(free_drive, 0)) << controller.mode_rejection();
    bool flagged = false;
    for (int k = 1; k <= 40; ++k) {
      ASSERT_TRUE(controller.tick(k * kMs, still(k, q0_, tau_ext)));
      flagged = flagged || controller.contact().collision;
    }
    EXPECT_TRUE(flagged);
    EXPECT_EQ(controller.contact().body, 4);
    if (strict) {
      EXPECT_EQ(controller.mode(), Mode::kReflex);
      EXPECT_NE(std::string(controller.reflex_reason()).find(", on panda_link4 or beyond; reflex compliant"), std::string::npos)
          << controller.reflex_reason();
    } else {
      EXPECT_EQ(controller.mode(), Mode::kHolding);
      EXPECT_EQ(controller.reflexes(), 0) << controller.reflex_reason();
    }
  }
}

// A 20 N push on the elbow crosses no joint threshold (joint 4's is 13 N·m); located by the locator
// it is a collision by its link's force, judged at the next state, once. Under that force, or on a
// link whose force is ∞, it is not.
TEST_F(Reflexes, ALocatedForceOverItsLinksCollisionForceIsACollision) {
  const Vector3d p = point_on(4, q0_), f(0.0, 20.0, 0.0);
  const VectorXd tau_ext = torque_of_force_on(4, q0_, p, f);
  struct Case {
    double located_newtons;
    double link_force;
    bool reflex;
  } cases[] = {{20.0, 15.0, true}, {12.0, 15.0, false}, {20.0, kInf, false}};
  for (const Case& c : cases) {
    Config config = config_;
    config.contact.links.push_back(LinkPolicy{"panda_link4", c.link_force, Reflex::kStop, true});
    Controller controller(model_, config);
    ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
    for (int k = 1; k <= 40; ++k) ASSERT_TRUE(controller.tick(k * kMs, still(k, q0_, tau_ext)));
    ASSERT_EQ(controller.mode(), Mode::kHolding) << "the joint thresholds alone: " << controller.reflex_reason();
    EXPECT_FALSE(controller.contact().collision);
    controller.take_location(LocatedContact{4, "panda_link4", p, c.located_newtons / 20.0 * f});
    ASSERT_TRUE(controller.tick(41 * kMs, still(41, q0_, tau_ext)));
    EXPECT_EQ(controller.mode(), c.reflex ? Mode::kReflex : Mode::kHolding) << c.located_newtons << " N";
    if (c.reflex) {
      char expected[192];
      std::snprintf(expected, sizeof(expected),
                    "collision: 20 N located on panda_link4 at (%.3f, %.3f, %.3f) m, over 15; reflex stop", p.x(),
                    p.y(), p.z());
      EXPECT_STREQ(controller.reflex_reason(), expected);
      EXPECT_EQ(controller.contact().body, 4);
    }
    ASSERT_TRUE(controller.tick(42 * kMs, still(42, q0_, tau_ext)));
    EXPECT_FALSE(controller.contact().collision) << "a location is judged once";
    EXPECT_EQ(controller.reflexes(), c.reflex ? 1 : 0);
  }
}

// A push on the tool's centre leaves joint 7 still, so the joints alone name panda_link6; the
// locator, which saw the hand's shape, names the hand, and while its estimate is fresh (50 ms) the
// collision is the hand's, with the hand's reflex. Older, the joints decide again.
TEST_F(Reflexes, TheLocatorsLinkChoosesTheReflexWhileItsEstimateIsFresh) {
  Config config = config_;
  config.contact.links.push_back(LinkPolicy{"panda_hand", 15.0, Reflex::kCompliant, true});
  Vector6d F = Vector6d::Zero();
  F(5) = -30.0;
  const VectorXd tau_ext = torque_of(q0_, F);
  for (int64_t located_at : {int64_t{1}, int64_t{-100}}) {
    Controller controller(model_, config);
    ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
    if (located_at > 0) {
      controller.take_location(LocatedContact{7, "panda_hand", Vector3d::Zero(), Vector3d(0.0, 0.0, -5.0)});
    }
    int k = 1;
    for (; controller.mode() != Mode::kReflex && k < 40; ++k) ASSERT_TRUE(controller.tick(k * kMs, still(k, q0_, tau_ext)));
    ASSERT_EQ(controller.mode(), Mode::kReflex);
    const std::string reason = controller.reflex_reason();
    if (located_at > 0) {
      EXPECT_NE(reason.find(", on panda_hand; reflex compliant"), std::string::npos) << reason;
    } else {
      EXPECT_NE(reason.find(", on panda_link6 or beyond; reflex stop"), std::string::npos) << reason;
    }
  }
}

TEST_F(Reflexes, LinkPoliciesAreParsedAndCheckedWithTheirReason) {
  LinkPolicy policy;
  std::string why;
  ASSERT_TRUE(parse_link_policy("panda_hand,10,retract,strict", policy, why)) << why;
  EXPECT_EQ(policy.link, "panda_hand");
  EXPECT_EQ(policy.collision_force, 10.0);
  EXPECT_EQ(policy.reflex, Reflex::kRetract);
  EXPECT_FALSE(policy.guided);
  ASSERT_TRUE(parse_link_policy("panda_link4,inf,stop,guided", policy, why)) << why;
  EXPECT_EQ(policy.collision_force, kInf);
  EXPECT_TRUE(policy.guided);
  const std::pair<const char*, const char*> bad[] = {
      {"panda_hand,10,retract", "4 fields, found 3"},
      {",10,stop,guided", "the link is empty"},
      {"panda_hand,-1,stop,guided", "the collision force '-1' must be a positive number"},
      {"panda_hand,10N,stop,guided", "the collision force '10N'"},
      {"panda_hand,10,halt,guided", "the reflex 'halt' is none of stop, compliant, retract"},
      {"panda_hand,10,stop,gentle", "'gentle' is neither guided"},
  };
  for (const auto& [text, expected] : bad) {
    EXPECT_FALSE(parse_link_policy(text, policy, why)) << text;
    EXPECT_NE(why.find(expected), std::string::npos) << text << ": " << why;
  }
  auto refused = [&](std::vector<LinkPolicy> links) {
    ContactConfig config;
    config.links = std::move(links);
    try {
      ContactMonitor monitor(model_, config, VectorXd(), 1e-3);
    } catch (const ArgumentError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(refused({{"panda_leftfinger", 10.0, Reflex::kStop, true}}).find("'panda_leftfinger': no such link on the chain"),
            std::string::npos);
  EXPECT_NE(refused({{"panda_link8", 10.0, Reflex::kStop, true}, {"panda_hand", 10.0, Reflex::kStop, true}})
                .find("'panda_link8' and 'panda_hand': both ride on one body"),
            std::string::npos);
  EXPECT_NE(refused({{"panda_hand", 0.0, Reflex::kStop, true}}).find("the collision force must be positive"),
            std::string::npos);
  EXPECT_EQ(refused({{"panda_hand", 10.0, Reflex::kStop, false}}), "");
}

// The stop reflex from speed: a joint measured past its velocity limit trips it, and the reference
// takes the arm's own motion and brakes it to rest as fast as the limits in force allow (the
// acceleration fitted to the effort at this pose, the jerk to the torque rate): each joint's speed
// falls monotonically, and it travels the distance of that brake, v²/(2A) + vA/(2J) (v√(v/J) for
// a v below A²/J, where the acceleration peaks before A). A reference held still instead asked a
// fast arm for more torque than it has (docs/controller.md, "Clearance").
TEST_F(Reflexes, AStopFromSpeedBrakesTheArmsOwnMotionToRestWithinTheLimitsInForce) {
  chasles::testing::never_trip(config_.contact, 7);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
  VectorXd v0(7);
  v0 << 0.5, -0.4, 0.3, 0.0, 0.0, 0.2, -0.3;
  v0(3) = -1.15 * model_.joint(3).limits.velocity;  // past the 10 % tolerance
  JointState state = *still(1, q0_, VectorXd::Zero(7));
  state.qd = v0;
  ASSERT_TRUE(controller.tick(kMs, &state));
  ASSERT_EQ(controller.mode(), Mode::kReflex);
  EXPECT_NE(std::string(controller.reflex_reason()).find("joint panda_joint4: velocity"), std::string::npos)
      << controller.reflex_reason();
  EXPECT_TRUE(matrices_near(controller.reference().q, q0_, 0.0));
  EXPECT_TRUE(matrices_near(controller.reference().qd, v0, 0.0)) << "from the arm's own motion";
  const motion::Limits limits = controller.generator_limits();
  double slowest = 0.0;  // s, the longest of the joints' brakes
  VectorXd rest = q0_;
  for (int i = 0; i < 7; ++i) {
    const double v = std::abs(v0(i)), A = limits.acceleration(i), J = limits.jerk(i);
    const double d = v >= A * A / J ? v * v / (2 * A) + v * A / (2 * J) : v * std::sqrt(v / J);
    rest(i) += std::copysign(d, v0(i));
    slowest = std::max(slowest, v >= A * A / J ? v / A + A / J : 2 * std::sqrt(v / J));
  }
  // The arm follows the reference exactly from here.
  VectorXd speed = v0.cwiseAbs();
  int ticks = 0;
  for (int64_t k = 2; controller.reference().qd.cwiseAbs().maxCoeff() > 0.0; ++k, ++ticks) {
    ASSERT_LT(ticks, 5000);
    state.seq = k, state.arrival_ns = k * kMs;
    state.q = controller.reference().q, state.qd = controller.reference().qd, state.effort = controller.torque();
    ASSERT_TRUE(controller.tick(k * kMs, &state));
    ASSERT_EQ(controller.mode(), Mode::kReflex);
    for (int i = 0; i < 7; ++i) {
      EXPECT_LE(std::abs(controller.reference().qd(i)), speed(i) + 1e-12) << "tick " << k << " joint " << i;
      EXPECT_LE(std::abs(controller.reference().qdd(i)), limits.acceleration(i) * (1 + 1e-9)) << "joint " << i;
      speed(i) = std::abs(controller.reference().qd(i));
    }
  }
  EXPECT_LE(ticks, std::ceil(slowest / 1e-3) + 1);
  EXPECT_GE(ticks, std::floor(slowest / 1e-3) - 1);
  EXPECT_TRUE(matrices_near(controller.reference().q, rest, 1e-9));
  // At rest, it holds there.
  state.seq = 9000, state.arrival_ns = 9000 * kMs;
  ASSERT_TRUE(controller.tick(9000 * kMs, &state));
  EXPECT_TRUE(matrices_near(controller.reference().q, rest, 1e-9));
  EXPECT_EQ(controller.mode(), Mode::kReflex);
}

TEST_F(Reflexes, TheCompliantReflexCompensatesGravityAndDampsTheJoints) {
  config_.contact.reflex = Reflex::kCompliant;
  config_.torque_ramp = 1e-9;  // no rate limit: this test is about the law
  Controller controller(model_, config_);
  VectorXd tau_ext = VectorXd::Zero(7);
  tau_ext(1) = 30.0;  // over the 13 N·m of joint 2's default collision threshold
  ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
  int64_t k = 1;
  while (controller.mode() != Mode::kReflex && k < 100) controller.tick(k * kMs, still(k, q0_, tau_ext)), ++k;
  ASSERT_EQ(controller.mode(), Mode::kReflex);
  // Pushed away, moving: τ = M(q)(−k q̇) + c(q, q̇) + g(q).
  JointState moving = *still(k, q0_ + VectorXd::Constant(7, 0.01), tau_ext);
  moving.qd = VectorXd::LinSpaced(7, -0.4, 0.4);
  ASSERT_TRUE(controller.tick(k * kMs, &moving));
  const VectorXd expected = mass_matrix(model_, data_, moving.q) * (-10.0 * moving.qd) +
                            velocity_product(model_, data_, moving.q, moving.qd) +
                            gravity_torques(model_, data_, moving.q);
  EXPECT_TRUE(matrices_near(controller.torque(), expected, 1e-9));
  EXPECT_TRUE(matrices_near(controller.reference().q, moving.q, 0.0)) << "no position to return to";
}

// The tip moved 20 mm along an arc (joint 1 turning); the retract reflex goes back to where the
// tip was 10 mm before, in retract_duration.
TEST_F(Reflexes, TheRetractReflexGoesBackAlongTheTipsPath) {
  config_.contact.reflex = Reflex::kRetract;
  Controller controller(model_, config_);
  VectorXd q = q0_;
  VectorXd g_before = gravity_torques(model_, data_, q);
  ASSERT_TRUE(controller.tick(0, still(0, q, VectorXd::Zero(7))));
  std::vector<VectorXd> path{q};
  std::vector<Vector3d> tips{forward_kinematics(model_, data_, q).translation()};
  // Quasi-static steps: q̇ = 0 in each sample, the effort the trapezoid of g, so no external torque.
  for (int k = 1; k <= 40; ++k) {
    q(0) += 0.0008;
    JointState s = *still(k, q, VectorXd::Zero(7));
    const VectorXd g_now = s.effort;
    s.effort = 0.5 * (g_before + g_now);
    g_before = g_now;
    ASSERT_TRUE(controller.tick(k * kMs, &s));
    ASSERT_FALSE(controller.contact().contact) << k;
    path.push_back(q);
    tips.push_back(forward_kinematics(model_, data_, q).translation());
  }
  // The newest sample at least 10 mm back along the tip's path.
  size_t back = path.size() - 1;
  while (back > 0 && (tips[back] - tips.back()).norm() < 0.01) --back;
  ASSERT_GT(back, 0u);
  VectorXd tau_ext = VectorXd::Zero(7);
  tau_ext(3) = 40.0;
  int64_t k = 41;
  for (; controller.mode() != Mode::kReflex && k < 100; ++k) {
    ASSERT_TRUE(controller.tick(k * kMs, still(k, q, tau_ext)));
  }
  ASSERT_EQ(controller.mode(), Mode::kReflex);
  const int64_t start = (k - 1) * kMs;
  ASSERT_TRUE(controller.tick(start + 300 * kMs, still(k + 300, q, tau_ext)));
  EXPECT_TRUE(matrices_near(controller.reference().q, path[back], 1e-12));
  EXPECT_GE((tips.back() - forward_kinematics(model_, data_, controller.reference().q).translation()).norm(), 0.01);
  EXPECT_EQ(controller.mode(), Mode::kReflex) << "holds there until a new target";
}

// The observer steps by the time between the states, from their utime, not by the configured
// period: a plant at 200 Hz under a controller configured for 1 kHz (ticking five times a state)
// still gives τ̂_ext = (1 − e^{−K t}) τ_ext at every state, and is reported once the mean of 100
// intervals is in. A sender that leaves utime at 0 is timed by the states' arrival.
TEST_F(Reflexes, TheObserverStepsByTheStatesOwnClockAndAnotherRateIsReported) {
  chasles::testing::never_trip(config_.contact, 7);
  VectorXd tau_ext = VectorXd::Zero(7);
  tau_ext << 2.0, -3.0, 1.5, 4.0, -0.5, 0.7, 0.2;
  for (const bool with_utime : {true, false}) {
    SCOPED_TRACE(with_utime ? "timed by utime" : "timed by arrival");
    Controller controller(model_, config_);
    for (int64_t k = 0; k <= 120; ++k) {
      JointState s = *still(k, q0_, k == 0 ? VectorXd::Zero(7) : tau_ext);
      s.utime = with_utime ? 1'700'000'000'000'000 + 5000 * k : 0;
      s.arrival_ns = 5 * k * kMs;
      for (int64_t tick = 0; tick < 5; ++tick) ASSERT_TRUE(controller.tick(s.arrival_ns + tick * kMs, &s));
      const double t = 0.005 * static_cast<double>(k);
      ASSERT_TRUE(matrices_near(controller.contact().tau_ext, (1.0 - std::exp(-200.0 * t)) * tau_ext, 1e-9))
          << "state " << k;
      EXPECT_STREQ(controller.period_warning(), k < 100 ? "" : "the robot states come every 5 ms (200 Hz), the "
                                                              "configured period is 1 ms")
          << "state " << k;
    }
    EXPECT_NEAR(controller.state_period(), 0.005, 1e-15);
  }
}

// Moving at constant velocity through states 5 ms apart, the applied effort the trapezoid of the
// torque that moves it so: no external torque, to the trapezoid rule's error. Stepping by the
// configured 1 ms instead would read five times the change of momentum per second.
TEST_F(Reflexes, AMovingArmAt200HzFeelsNoExternalTorque) {
  Controller controller(model_, config_);
  const VectorXd qd = VectorXd::LinSpaced(7, 0.3, -0.3);
  const VectorXd zero = VectorXd::Zero(7);
  VectorXd previous_bias;
  double worst = 0.0;
  for (int64_t k = 0; k <= 200; ++k) {
    JointState s = *still(k, q0_ + 0.005 * static_cast<double>(k) * qd, zero);
    s.qd = qd;
    const VectorXd bias = inverse_dynamics(model_, data_, s.q, s.qd, zero);
    s.effort = k == 0 ? bias : VectorXd(0.5 * (previous_bias + bias));
    previous_bias = bias;
    s.utime = 5000 * k;
    s.arrival_ns = 5 * k * kMs;
    ASSERT_TRUE(controller.tick(s.arrival_ns, &s));
    worst = std::max(worst, controller.contact().tau_ext.cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 2e-4) << "N*m";
  EXPECT_NE(std::string(controller.period_warning()), "");
}

TEST_F(Reflexes, ObservingAndReflexesAllocateNothing) {
  config_.contact.reflex = Reflex::kRetract;
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.tick(0, still(0, q0_, VectorXd::Zero(7))));
  VectorXd tau_ext = VectorXd::Zero(7);
  tau_ext(1) = 30.0;
  testing::AllocationCounter counter;
  for (int k = 1; k <= 100; ++k) controller.tick(k * kMs, still(k, q0_, tau_ext));
  EXPECT_EQ(counter.count(), 0);
  EXPECT_EQ(controller.mode(), Mode::kReflex);
}

}  // namespace
}  // namespace chasles::controller
