// The arm the plant integrates and the controller does not know of, in simulated time
// (environment_rig.hpp): a hidden payload, friction, perturbed inertias, each held against a fact
// that does not come from the plant's code — a point mass's kinetic and potential energy, the
// friction law, the forward dynamics of the perturbed model. Apart from the plant's world of
// pushes and walls (environment_test.cpp): here the arm itself differs from its model.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "core/identification/perturbation.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/so3.hpp"
#include "support/decompositions.hpp"
#include "tests/tools/environment_rig.hpp"

namespace chasles::testing {
namespace {

// J_p: the base-frame velocity of a point fixed at c in the tip frame, ṗ = R_sb (v_b + ω_b × c).
Eigen::MatrixXd point_jacobian(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Vector3d& c) {
  const Matrix6Xd& J_b = body_jacobian(model, data, q);
  return data.T_sb.linear() * (J_b.bottomRows<3>() - hat3(c) * J_b.topRows<3>());
}

// A point mass m at c has kinetic energy ½ m |J_p q̇|² and potential −m gᵀ p, so it adds
// m J_pᵀ J_p to M(q) and −m J_pᵀ g to g(q). with_payload's model says the same, at seeded
// configurations of both arms.
TEST(environment, APayloadAddsAPointMassToTheModel) {
  const plant::Payload payload{1.7, Vector3d(0.03, -0.05, 0.12)};
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    const RobotModel loaded = plant::with_payload(arm.model, payload);
    Data nominal(arm.model), data(loaded);
    std::srand(5);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd q = arm.q0 + 0.5 * Eigen::VectorXd::Random(arm.model.dof());
      const Eigen::MatrixXd J_p = point_jacobian(arm.model, nominal, q, payload.centre);
      const Eigen::MatrixXd M0 = mass_matrix(arm.model, nominal, q);
      const Eigen::VectorXd g0 = gravity_torques(arm.model, nominal, q);
      EXPECT_TRUE(matrices_near(mass_matrix(loaded, data, q) - M0, payload.mass * J_p.transpose() * J_p, 1e-12));
      EXPECT_TRUE(matrices_near(gravity_torques(loaded, data, q) - g0,
                                -payload.mass * J_p.transpose() * arm.model.gravity(), 1e-12));
    }
  }
}

// A hidden payload, seen from the nominal model: an arm holding still with the true gravity torques
// g_true = g − m J_pᵀ g_vec (the test's own, from the point mass) stays still, and its truth is
// τ_ext = g − g_true, the payload's weight on the joints; no contact. At the first sample, at rest
// with no torque yet, the arm falls with M_true q̈ = −g_true, so the nominal model sees
// τ_ext = M q̈ + g = g − M M_true⁻¹ g_true: the payload's inertia is in it too (held with only the
// nominal g(q) the arm sags the same way, and τ_ext = g − g_true holds only while q̈ = 0).
TEST(environment, AHiddenPayloadIsExternalTorqueToTheNominalModel) {
  const plant::Payload payload{2.5, Vector3d(0.02, -0.04, 0.1)};
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    Data data(arm.model);
    const Eigen::Vector3d& g_vec = arm.model.gravity();
    const auto true_gravity = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
      const Eigen::MatrixXd J_p = point_jacobian(arm.model, data, q, payload.centre);
      return gravity_torques(arm.model, data, q) - payload.mass * J_p.transpose() * g_vec;
    };
    EnvironmentOptions env;
    env.payload = payload;
    Rig rig(arm.model, arm.q0, lockstep(env));

    const Eigen::VectorXd g0 = gravity_torques(arm.model, data, arm.q0);
    const Eigen::MatrixXd J_p0 = point_jacobian(arm.model, data, arm.q0, payload.centre);
    const Eigen::MatrixXd M0 = mass_matrix(arm.model, data, arm.q0);
    const Eigen::MatrixXd M_true0 = M0 + payload.mass * J_p0.transpose() * J_p0;
    const Eigen::VectorXd g_true0 = true_gravity(arm.q0);
    const Eigen::VectorXd expected0 = g0 - M0 * M_true0.llt().solve(g_true0);
    const sim_truth_t& first = rig.truths().front();
    EXPECT_TRUE(matrices_near(as_vector(first.tau_ext.data(), first.num_joints), expected0, 1e-9));
    EXPECT_GT(max_abs_diff(expected0, g0 - g_true0), 0.1) << "the payload's inertia should show at the first sample";

    for (int k = 0; k < 300; ++k) rig.step(true_gravity(position(rig.states().back())));
    double drift = 0.0;
    for (size_t k = 1; k < rig.states().size(); ++k) {
      const Eigen::VectorXd q = position(rig.states()[k]);
      const sim_truth_t& truth = rig.truths()[k];
      drift = std::max(drift, max_abs_diff(q, arm.q0));
      EXPECT_TRUE(matrices_near(as_vector(truth.tau_ext.data(), truth.num_joints),
                                gravity_torques(arm.model, data, q) - true_gravity(q), 1e-9))
          << "seq " << k;
      EXPECT_TRUE(matrices_near(tip_wrench(truth), Vector6d::Zero(), 0.0));
      EXPECT_FALSE(truth.contact);
    }
    EXPECT_LT(drift, 1e-9);
    EXPECT_GT(max_abs_diff(g0, g_true0), 1.0) << "the payload should weigh on the joints";
  }
}

// Hidden friction is exactly the law at every sample, τ_ext = −b q̇ − (f_c + (f_s − f_c)
// exp(−(q̇ / v_st)²)) tanh(q̇ / v_s) with the state's q̇ (Olsson et al. 1998's stiction and Stribeck
// effect, written out here), while the joints run through both signs and both regimes of the tanh
// (|q̇| well below and well above v_s). v_s keeps the stiffest mode friction adds resolved: at every
// configuration the arm passes through, f_s / v_s ≤ λ_min(M(q)) / h, so h λ ≤ 1 for λ of M⁻¹ times
// the friction's slope, well inside RK4's real-axis limit of 2.79.
TEST(environment, HiddenFrictionIsTheFrictionLaw) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  Eigen::VectorXd b(7), f_c(7), f_s(7), wobble(7);
  b << 0.3, 0.3, 0.2, 0.2, 0.05, 0.05, 0.02;
  f_c << 1.0, 1.0, 0.8, 0.8, 0.3, 0.3, 0.1;
  f_s << 1.5, 1.0, 1.2, 0.8, 0.45, 0.3, 0.15;
  wobble << 6, -5, 4, 6, -1.5, 1.2, 0.8;
  const double v_st = 0.2;
  EnvironmentOptions env;
  env.friction = {b, f_c, f_s, v_st};
  Rig rig(arm.model, arm.q0, lockstep(env));
  const Eigen::VectorXd v_s = rig.plant().friction_velocity();
  EXPECT_TRUE((v_s.array() > 0.0).all());
  int slow = 0, fast = 0;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::VectorXd q = position(rig.states().back());
    const double s = std::sin(2 * kPi * k * kDt / 0.4);  // torques that turn the joints back and forth
    rig.step(gravity_torques(arm.model, data, q) + s * wobble);
  }
  for (size_t k = 0; k < rig.states().size(); ++k) {
    const Eigen::VectorXd q = position(rig.states()[k]), qd = velocity(rig.states()[k]);
    const sim_truth_t& truth = rig.truths()[k];
    Eigen::VectorXd expected(7);
    for (int i = 0; i < 7; ++i) {
      const double level = f_c[i] + (f_s[i] - f_c[i]) * std::exp(-(qd[i] / v_st) * (qd[i] / v_st));
      expected[i] = -b[i] * qd[i] - level * std::tanh(qd[i] / v_s[i]);
    }
    ASSERT_TRUE(matrices_near(as_vector(truth.tau_ext.data(), truth.num_joints), expected, 1e-9)) << "seq " << k;
    EXPECT_FALSE(truth.contact);
    const double lambda_min =
        test::symmetric_eigenvalues(mass_matrix(arm.model, data, q))[0];
    ASSERT_LE((f_s.array() / v_s.array()).maxCoeff(), lambda_min / kDt) << "seq " << k;
    for (int i = 0; i < 7; ++i) {
      slow += std::abs(qd[i]) > 0.0 && std::abs(qd[i]) < 0.3 * v_s[i];
      fast += std::abs(qd[i]) > 3.0 * v_s[i];
    }
  }
  EXPECT_GT(slow, 100);
  EXPECT_GT(fast, 100);
}

// Friction takes energy and never gives any: the Panda swinging freely from a bent pose (no torque,
// no damping) under Coulomb friction alone loses energy at every step; with a v_s too small for
// the step RK4 would ring around q̇ = 0 and pump energy in. Without friction the same swing keeps it
// to 1e-9 J per step.
TEST(environment, FrictionOnlyTakesEnergy) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  EnvironmentOptions env;
  env.friction = {Eigen::VectorXd::Zero(7), Eigen::VectorXd::Constant(7, 2.0)};
  Rig rig(arm.model, arm.q0, lockstep(env));
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(7);
  double previous = 0.0, largest_rise = -1.0;
  for (int k = 0; k <= 2000; ++k) {
    const double e = kinetic_energy(arm.model, data, rig.q(), rig.qd()) + potential_energy(arm.model, data, rig.q());
    if (k > 0) largest_rise = std::max(largest_rise, e - previous);
    previous = e;
    if (k < 2000) rig.step(zero);
  }
  EXPECT_LT(largest_rise, 1e-9);
}

// M q̈ = τ − g at rest: the acceleration of a model under a torque from rest.
Eigen::VectorXd acceleration_from_rest(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& tau) {
  Data data(model);
  return mass_matrix(model, data, q).llt().solve(tau - gravity_torques(model, data, q));
}

// The plant integrates with_perturbed_inertias(model, f, seed), not the model it was given. One
// 0.1 ms step from rest under a fixed torque: q̇(h) = q̈(0) h + O(h³) (from rest q̈ changes only at
// second order: its first derivative is ∂q̈/∂q q̇ = 0 and the Coriolis terms are quadratic in q̇), so
// q̇(h)/h is M_perturbed⁻¹(τ − g_perturbed) to 1e-7 relative (measured; 1e-5 with 1 ms steps), and
// not the nominal model's acceleration (20 % of the largest away on the UR5, 83 % on the Panda).
// Its truth at rest, before any torque, is what the nominal model makes of that fall:
// τ_ext = M q̈_true + g with q̈_true = −M_perturbed⁻¹ g_perturbed. A payload goes on the perturbed
// arm: the plant with both moves bit for bit as a plant given that model.
TEST(environment, PerturbedInertiasAreTheArmThePlantIntegrates) {
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    const int n = arm.model.dof();
    const plant::InertiaPerturbation perturbation{0.2, 7};
    const RobotModel perturbed = with_perturbed_inertias(arm.model, perturbation.fraction, perturbation.seed);
    Data data(arm.model);
    const Eigen::VectorXd tau = 0.5 * gravity_torques(arm.model, data, arm.q0);
    EnvironmentOptions env;
    env.perturbation = perturbation;

    constexpr double kShortStep = 1e-4;
    plant::Plant plant(arm.model, arm.q0, Eigen::VectorXd::Zero(n), kShortStep, 1, env);
    plant.step(tau);
    const Eigen::VectorXd qdd = plant.qd() / kShortStep;
    const Eigen::VectorXd qdd_perturbed = acceleration_from_rest(perturbed, arm.q0, tau);
    const Eigen::VectorXd qdd_nominal = acceleration_from_rest(arm.model, arm.q0, tau);
    const double scale = qdd_perturbed.cwiseAbs().maxCoeff();
    EXPECT_LT(max_abs_diff(qdd, qdd_perturbed) / scale, 1e-6);
    EXPECT_GT(max_abs_diff(qdd, qdd_nominal) / scale, 0.05) << "the nominal model should not be what moves";

    Rig rig(arm.model, arm.q0, lockstep(env));
    EXPECT_TRUE(rig.simulation().publishes_truth());
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    const Eigen::VectorXd falling = acceleration_from_rest(perturbed, arm.q0, zero);
    const Eigen::VectorXd expected =
        mass_matrix(arm.model, data, arm.q0) * falling + gravity_torques(arm.model, data, arm.q0);
    const sim_truth_t& first = rig.truths().front();
    EXPECT_TRUE(matrices_near(as_vector(first.tau_ext.data(), n), expected, 1e-9));
    EXPECT_GT(expected.cwiseAbs().maxCoeff(), 0.5) << "the model error should weigh";

    env.payload = plant::Payload{1.5, Vector3d(0.02, 0.0, 0.08)};
    plant::Plant both(arm.model, arm.q0, Eigen::VectorXd::Zero(n), kDt, 1, env);
    const RobotModel reference_model = plant::with_payload(perturbed, *env.payload);
    plant::Plant reference(reference_model, arm.q0, Eigen::VectorXd::Zero(n), kDt, 1);
    for (int k = 0; k < 200; ++k) {
      both.step(tau);
      reference.step(tau);
    }
    EXPECT_EQ(both.q(), reference.q());
    EXPECT_EQ(both.qd(), reference.qd());
    EXPECT_GT(max_abs_diff(both.q(), arm.q0), 1e-3) << "it should have moved";
  }
}

}  // namespace
}  // namespace chasles::testing
