// The plant's world in one process, in simulated time (environment_rig.hpp): pushes and walls on
// the arm's tip, each held against a fact that does not come from the plant's code — statics
// (τ = g − J_bᵀ F holds an arm against a wrench F), a trapezoid drawn by hand, a spring's rest
// length, energy. The arm the plant hides from the controller is environment_model_test.cpp's,
// what it reports environment_io_test.cpp's, in the same binary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/kinematics/kinematics.hpp"
#include "tests/tools/environment_rig.hpp"

namespace chasles::testing {
namespace {

// Statics: an arm commanded τ = g(q) − J_bᵀ F_b, F_b the push as the tip frame sees it, stays at
// rest under the push: the plant applies it in the frame and with the sign the contract gives (a
// push read in the tip frame, about another point or with the opposite sign moves the arm, as the
// same command without the push does). Its truth reports the push as given and, as the joint
// torque, J_bᵀ F_b. Four wrenches (a force, a moment, both) on the Panda and the UR5.
TEST(environment, AnArmHeldAgainstAPushStaysAtRest) {
  const std::vector<Vector6d> pushes = {wrench(0, 0, 0, 0, 0, -20), wrench(0, 0, 0, 12, -7, 5),
                                        wrench(1.5, -0.8, 0.6, 0, 0, 0), wrench(-0.7, 1.1, 0.4, -9, 4, 15)};
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    Data data(arm.model);
    for (const Vector6d& W : pushes) {
      SCOPED_TRACE(arm.name + ", push (" + list(W) + ")");
      const auto hold = [&](const Eigen::VectorXd& q) {
        return holding_torque(arm.model, data, q, in_tip_frame(forward_kinematics(arm.model, data, q).linear(), W));
      };
      EnvironmentOptions env;
      env.pushes.push_back({0.0, 10.0, 0.0, W});
      Rig rig(arm.model, arm.q0, lockstep(env));
      constexpr int kSteps = 200;
      for (int k = 0; k < kSteps; ++k) rig.step(hold(position(rig.states().back())));
      ASSERT_EQ(rig.states().size(), size_t{kSteps + 1});
      ASSERT_EQ(rig.truths().size(), size_t{kSteps + 1});
      double drift = 0.0;
      for (size_t k = 0; k <= kSteps; ++k) {
        const robot_state_t& state = rig.states()[k];
        const sim_truth_t& truth = rig.truths()[k];
        ASSERT_EQ(truth.seq, state.seq);
        drift = std::max(drift, max_abs_diff(position(state), arm.q0));
        EXPECT_TRUE(matrices_near(tip_wrench(truth), W, 0.0)) << "seq " << k;
        EXPECT_TRUE(truth.contact);
        const Eigen::VectorXd q = position(state);
        const Eigen::VectorXd expected =
            body_jacobian(arm.model, data, q).transpose() * in_tip_frame(data.T_sb.linear(), W);
        EXPECT_TRUE(matrices_near(as_vector(truth.tau_ext.data(), truth.num_joints), expected, 1e-9)) << "seq " << k;
      }
      // Rounding only: q̈ is M⁻¹ of a sum that cancels to ~1e-13, integrated over 0.2 s.
      EXPECT_LT(drift, 1e-9);

      // The control: the same command without the push moves the arm within the same time.
      Rig free(arm.model, arm.q0, lockstep());
      for (int k = 0; k < kSteps; ++k) free.step(hold(free.q()));
      EXPECT_GT(max_abs_diff(free.q(), arm.q0), 1e-3);
    }
  }
}

// The trapezoid, drawn by hand: push A from 0.1 s for 0.3 s with 0.05 s ramps, push B a step from
// 0.2 s to 0.25 s; they add. The values at chosen samples (t = seq × 1 ms) are read off the
// drawing, not computed from Push::profile.
TEST(environment, PushesFollowTheirRampsAndAdd) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  const Vector6d A = wrench(0.4, -0.2, 0.1, 3, -6, 30), B = wrench(0, 0.5, 0, -10, 0, 0);
  EnvironmentOptions env;
  env.pushes.push_back({0.1, 0.3, 0.05, A});
  env.pushes.push_back({0.2, 0.05, 0.0, B});
  Rig rig(arm.model, arm.q0, lockstep(env), Eigen::VectorXd::Constant(7, 2.0));
  for (int k = 0; k < 450; ++k) rig.step(gravity_torques(arm.model, data, position(rig.states().back())));
  ASSERT_EQ(rig.truths().size(), 451u);

  struct Sample {
    int seq;
    double a, b;  // how much of A and of B
    bool contact;
  };
  const std::vector<Sample> samples = {
      {0, 0, 0, false},    {50, 0, 0, false},    {99, 0, 0, false},  {101, 0.02, 0, true}, {110, 0.2, 0, true},
      {125, 0.5, 0, true}, {149, 0.98, 0, true}, {150, 1, 0, true},  {199, 1, 0, true},    {200, 1, 1, true},
      {225, 1, 1, true},   {250, 1, 1, true},    {251, 1, 0, true},  {350, 1, 0, true},    {375, 0.5, 0, true},
      {390, 0.2, 0, true}, {399, 0.02, 0, true}, {401, 0, 0, false}, {450, 0, 0, false}};
  for (const Sample& s : samples) {
    const sim_truth_t& truth = rig.truths()[static_cast<size_t>(s.seq)];
    ASSERT_EQ(truth.seq, s.seq);
    EXPECT_TRUE(matrices_near(tip_wrench(truth), s.a * A + s.b * B, 1e-12)) << "seq " << s.seq;
    EXPECT_EQ(truth.contact, s.contact) << "seq " << s.seq;
  }
}

// The tip origin's depth inside a wall, by forward kinematics.
double depth(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Wall& wall) {
  return -(forward_kinematics(model, data, q).translation() - wall.point).dot(wall.normal);
}

// A spring's rest: an arm pressing on a wall with a constant force F along −n (τ = g(q) − J_bᵀ F_b
// with F_b = (0, F n) in the tip frame, recomputed every state) comes to rest with the tip F/K
// inside it, the wall then pushing back with exactly F n. Settling is by the joints' damping alone;
// its slowest mode, the tip sliding along the wall, decays with a time constant of about 0.5 s, and
// after 5 s the rest depth is within 3e-11 m of F/K on both arms (measured): 1e-9 m, 5e-7 of the
// 2 mm, leaves room for other machines' rounding and fails any other rest. On the way, at every
// sample, the wall's force is along n, not negative, with no moment, and it acts exactly when the
// tip origin is inside (by the test's own kinematics). A floor under the Panda, a tilted wall
// beside the UR5.
TEST(environment, AnArmPressingOnAWallRestsAtForceOverStiffness) {
  constexpr double kForce = 20.0, kStiffness = 1e4;
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    Data data(arm.model);
    const Vector3d n = (arm.name == "panda" ? Vector3d(0, 0, 1) : Vector3d(1, -0.5, 2)).normalized();
    const Vector3d p0 = forward_kinematics(arm.model, data, arm.q0).translation();
    const Wall wall{p0 - 0.001 * n, n, kStiffness, 100.0};  // 1 mm from the tip
    EnvironmentOptions env;
    env.walls.push_back(wall);
    Rig rig(arm.model, arm.q0, lockstep(env), Eigen::VectorXd::Constant(arm.model.dof(), 5.0));
    const Vector6d pressed = wrench(0, 0, 0, kForce * n.x(), kForce * n.y(), kForce * n.z());
    constexpr int kSteps = 5000;
    for (int k = 0; k < kSteps; ++k) {
      const Eigen::VectorXd q = position(rig.states().back());
      rig.step(
          holding_torque(arm.model, data, q, in_tip_frame(forward_kinematics(arm.model, data, q).linear(), pressed)));
    }
    ASSERT_EQ(rig.truths().size(), size_t{kSteps + 1});
    bool touched = false;
    for (size_t k = 0; k < rig.truths().size(); ++k) {
      const sim_truth_t& truth = rig.truths()[k];
      const Vector6d F = tip_wrench(truth);
      const double along = F.tail<3>().dot(n);
      ASSERT_TRUE(matrices_near(F.head<3>(), Vector3d::Zero(), 0.0)) << "a moment about the tip origin, seq " << k;
      ASSERT_TRUE(matrices_near(F.tail<3>(), along * n, 1e-12)) << "not along the normal, seq " << k;
      ASSERT_GE(along, 0.0) << "the wall pulled, seq " << k;
      const bool inside = depth(arm.model, data, position(rig.states()[k]), wall) > 0.0;
      ASSERT_EQ(truth.contact, inside) << "seq " << k;
      if (!inside) {
        ASSERT_EQ(along, 0.0) << "seq " << k;
      }
      touched = touched || inside;
    }
    EXPECT_TRUE(touched);
    EXPECT_LT(rig.qd().cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_NEAR(depth(arm.model, data, rig.q(), wall), kForce / kStiffness, 1e-9);
    EXPECT_TRUE(matrices_near(tip_wrench(rig.truths().back()), pressed, 1e-5));
  }
}

// The wall's spring energy ½ K δ² while the tip origin is inside.
double wall_energy(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Wall& wall) {
  const double d = depth(model, data, q, wall);
  return d > 0.0 ? 0.5 * wall.stiffness * d * d : 0.0;
}

// Energy: the Panda falls from a bent pose with no torque and no joint damping onto a floor 2 cm
// under its tip and bounces. A wall without damping is a spring: kinetic + potential + ½ K δ² stays
// constant (it does no work the spring does not store); with damping it never grows and ends
// lower (it does no positive work: its force is at most K δ, and zero while the tip leaves fast).
// Away from the wall's surface RK4 keeps this energy to 1e-9 J per step; in the step where the tip
// enters or leaves, the force's slope jumps and RK4's error there is second order in the step:
// measured at up to 2.5 m/s, 4.5e-4 J at one RK4 step per 1 ms step, 8e-6 J with 10 substeps
// (either sign). The test runs 10 substeps and allows 3e-5 J per step and 1e-4 J over the run:
// far below what a wall doing work would show (1e4 N/m over millimetres: 1e-2 J and more).
TEST(environment, AWallStoresOrDissipatesEnergyButNeverGivesAny) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  const Vector3d p0 = forward_kinematics(arm.model, data, arm.q0).translation();
  for (const double damping : {0.0, 100.0}) {
    SCOPED_TRACE("wall damping " + std::to_string(damping));
    const Wall wall{p0 - Vector3d(0, 0, 0.02), Vector3d::UnitZ(), 1e4, damping};
    EnvironmentOptions env;
    env.walls.push_back(wall);
    SimulationOptions options = lockstep(env);
    options.substeps = 10;
    Rig rig(arm.model, arm.q0, options);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(7);
    std::vector<double> energy;
    int inside = 0, clamped = 0;
    for (int k = 0; k <= 400; ++k) {
      const Eigen::VectorXd& q = rig.q();
      energy.push_back(kinetic_energy(arm.model, data, q, rig.qd()) + potential_energy(arm.model, data, q) +
                       wall_energy(arm.model, data, q, wall));
      const sim_truth_t& truth = rig.truths().back();
      inside += truth.contact;
      clamped += truth.contact && tip_wrench(truth).tail<3>().z() == 0.0;
      if (k < 400) rig.step(zero);
    }
    EXPECT_GT(inside, 20) << "the tip should have been in the wall for a while";
    double largest_rise = 0.0;
    for (size_t k = 1; k < energy.size(); ++k) largest_rise = std::max(largest_rise, energy[k] - energy[k - 1]);
    EXPECT_LT(largest_rise, 3e-5);
    if (damping == 0.0) {
      EXPECT_NEAR(energy.back(), energy.front(), 1e-4);
      EXPECT_EQ(clamped, 0);
    } else {
      EXPECT_LT(energy.back(), energy.front() - 0.01) << "the wall's damping should have taken energy";
      EXPECT_GT(clamped, 0) << "the tip should have left faster than the wall relaxes (the clamp)";
    }
  }
}

}  // namespace
}  // namespace chasles::testing
