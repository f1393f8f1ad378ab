// The MuJoCo plant against chasles's own model: MuJoCo reads the URDF itself, so where the two
// agree (the mass matrix and gravity behind a step's acceleration, the Jacobian behind a contact's
// joint torque) each checks the other. And the plant's contact truth against statics: a pusher
// pressing a held arm is balanced by exactly the force it is driven with.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/dynamics/dynamics.hpp"
#include "core/error.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "tests/support/allocation_counter.hpp"
#include "tests/support/reference.hpp"
#include "tools/mujoco/mujoco_plant.hpp"

namespace chasles::plant {
namespace {

using chasles::testing::data_path;

struct Arm {
  std::string urdf, tip;
};

struct Loaded {
  RobotModel model;
  geometry::CollisionModel geometry;
};

Loaded load(const Arm& arm) {
  UrdfOptions options;
  options.tip_link = arm.tip;
  RobotModel model = load_urdf_file(data_path(arm.urdf), options);
  geometry::CollisionModel geometry = geometry::load_collision_model(data_path(arm.urdf), model, {{data_path("packages")}, ""});
  return {std::move(model), std::move(geometry)};
}

Eigen::VectorXd mid_range(const RobotModel& model, std::mt19937_64& rng) {
  Eigen::VectorXd q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const JointLimits& l = model.joint(i).limits;
    const double lo = std::isfinite(l.lower) ? l.lower : -M_PI, hi = std::isfinite(l.upper) ? l.upper : M_PI;
    q[i] = std::uniform_real_distribution<double>(0.75 * lo + 0.25 * hi, 0.25 * lo + 0.75 * hi)(rng);
  }
  return q;
}

class MujocoArms : public ::testing::TestWithParam<Arm> {};

// From rest, one step of dt under τ = g(q) + M(q) a (chasles's g and M, armature included) gives
// q̇ = a dt in MuJoCo exactly when MuJoCo's M and g (from its own reading of the URDF) are chasles's.
TEST_P(MujocoArms, StepFromRestAcceleratesAsChaslesModelSays) {
  const Loaded arm = load(GetParam());
  const RobotModel& model = arm.model;
  Data data(model);
  std::mt19937_64 rng(7);
  const double dt = 1e-3;
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = mid_range(model, rng);
    Eigen::VectorXd a(model.dof());
    for (int i = 0; i < model.dof(); ++i) a[i] = std::uniform_real_distribution<double>(-2.0, 2.0)(rng);
    const Eigen::VectorXd tau = gravity_torques(model, data, q) + mass_matrix(model, data, q) * a;
    MujocoPlant plant(model, data_path(GetParam().urdf), arm.geometry, {}, q, Eigen::VectorXd::Zero(model.dof()), dt);
    ASSERT_TRUE(plant.contacts().empty());
    plant.step(tau);
    const Eigen::VectorXd a_mujoco = plant.qd() / dt;
    EXPECT_LT((a_mujoco - a).norm(), 1e-6 * (1.0 + a.norm())) << "trial " << trial << ": MuJoCo "
                                                               << a_mujoco.transpose() << ", chasles " << a.transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(Arms, MujocoArms,
                         ::testing::Values(Arm{"panda.urdf", "panda_hand"}, Arm{"iiwa14.urdf", "iiwa_link_ee"}, Arm{"ur5.urdf", "tool0"}),
                         [](const auto& arm) { return arm.param.urdf.substr(0, arm.param.urdf.find('.')); });

// τ = g(q) + M(q) (ω² (q0 − q) − 2 ω q̇), chasles's model: holds the arm near q0 against a push,
// every joint critically damped at ω = 20 rad/s whatever its inertia.
Eigen::VectorXd hold(const RobotModel& model, Data& data, const Eigen::VectorXd& q0, const MujocoPlant& plant) {
  constexpr double w = 20.0;
  const Eigen::VectorXd a = w * w * (q0 - plant.q()) - 2.0 * w * plant.qd();
  return gravity_torques(model, data, plant.q()) + mass_matrix(model, data, plant.q()) * a;
}

TEST(MujocoPlant, PressOnTheElbowIsBalancedByTheArmAndExplainedByTheJacobian) {
  const Loaded arm = load({"panda.urdf", "panda_hand"});
  const RobotModel& model = arm.model;
  Data data(model);
  Eigen::VectorXd q0(7);
  q0 << 0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8;
  MujocoPlant plant(model, data_path("panda.urdf"), arm.geometry, {}, q0, Eigen::VectorXd::Zero(7), 1e-3);
  const Vector3d direction(0.0, 1.0, 0.0);
  const double force = 20.0;
  plant.press("panda_link4", Vector3d::Zero(), direction, force);
  for (int k = 0; k < 2000; ++k) plant.step(hold(model, data, q0, plant));

  ASSERT_FALSE(plant.contacts().empty());
  Vector3d total = Vector3d::Zero();
  for (const ArmContact& c : plant.contacts()) {
    EXPECT_EQ(c.link, "panda_link4");
    EXPECT_EQ(c.other, "pusher");
    EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
    total += c.force;
  }
  // At rest the pusher's drive is all it passes on.
  EXPECT_LT((total - force * direction).norm(), 1e-3 * force) << total.transpose();
  EXPECT_LT(plant.qd().norm(), 1e-4);

  // chasles's space Jacobian at the contacts: τ = J_sᵀ (p × f, f), the wrench in the base frame.
  Eigen::VectorXd tau_chasles = Eigen::VectorXd::Zero(7);
  const Matrix6Xd J_s = space_jacobian(model, data, plant.q());
  for (const ArmContact& c : plant.contacts()) {
    Vector6d wrench;
    wrench << c.point.cross(c.force), c.force;
    // Only the joints up to the link's body move it: the later columns are not its Jacobian's.
    tau_chasles.head(4) += J_s.leftCols(4).transpose() * wrench;
  }
  EXPECT_LT((plant.tau_ext() - tau_chasles).norm(), 1e-9 * (1.0 + tau_chasles.norm()))
      << plant.tau_ext().transpose() << "\n" << tau_chasles.transpose();
  // Statics: at rest the joint torque and the push together hold gravity up.
  const Eigen::VectorXd g = gravity_torques(model, data, plant.q());
  EXPECT_LT((plant.effort() + plant.tau_ext() - g).norm(), 1e-3) << (plant.effort() + plant.tau_ext() - g).transpose();

  plant.release();
  for (int k = 0; k < 10; ++k) plant.step(hold(model, data, q0, plant));
  EXPECT_TRUE(plant.contacts().empty());
  EXPECT_EQ(plant.tau_ext().norm(), 0.0);
}

// The step is the plant's real-time work: MuJoCo's arena and the plant's buffers are sized when
// it is built.
TEST(MujocoPlant, StepAllocatesNothingInContact) {
  const Loaded arm = load({"panda.urdf", "panda_hand"});
  Eigen::VectorXd q0(7);
  q0 << 0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8;
  MujocoPlant plant(arm.model, data_path("panda.urdf"), arm.geometry, {}, q0, Eigen::VectorXd::Zero(7), 1e-3);
  plant.press("panda_link4", Vector3d::Zero(), Vector3d::UnitY(), 20.0);
  Data data(arm.model);
  Eigen::VectorXd tau = gravity_torques(arm.model, data, q0);
  plant.step(tau);
  chasles::testing::AllocationCounter counter;
  for (int k = 0; k < 200; ++k) plant.step(tau);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_FALSE(plant.contacts().empty());
}

TEST(MujocoPlant, RefusesWhatItCannotDo) {
  const Loaded arm = load({"panda.urdf", "panda_hand"});
  const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(7), zero = Eigen::VectorXd::Zero(7);
  MujocoPlant plant(arm.model, data_path("panda.urdf"), arm.geometry, {}, q0, zero, 1e-3);
  EXPECT_THROW(plant.press("panda_link4", Vector3d::Zero(), Vector3d::UnitY(), 0.0), ArgumentError);
  EXPECT_THROW(plant.press("panda_link4", Vector3d::Zero(), Vector3d::Zero(), 10.0), ArgumentError);
  EXPECT_THROW(plant.press("no_such_link", Vector3d::Zero(), Vector3d::UnitY(), 10.0), ArgumentError);
  // From above, the line to link 1's origin meets the links over it first.
  try {
    plant.press("panda_link1", Vector3d::Zero(), -Vector3d::UnitZ(), 10.0);
    ADD_FAILURE() << "a press through other links was taken";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("before panda_link1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(MujocoPlant(arm.model, data_path("no_such.urdf"), arm.geometry, {}, q0, zero, 1e-3), ArgumentError);
  EXPECT_THROW(MujocoPlant(arm.model, data_path("panda.urdf"), arm.geometry, {}, Eigen::VectorXd::Zero(6), zero, 1e-3),
               ArgumentError);
  MujocoScene no_pusher;
  no_pusher.pusher_radius = 0.0;
  MujocoPlant bare(arm.model, data_path("panda.urdf"), arm.geometry, no_pusher, q0, zero, 1e-3);
  EXPECT_THROW(bare.press("panda_link4", Vector3d::Zero(), Vector3d::UnitY(), 10.0), ArgumentError);
}

}  // namespace
}  // namespace chasles::plant
