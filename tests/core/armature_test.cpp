// Armature — each joint's reflected rotor inertia on M's diagonal — on the KUKA iiwa 14 of Drake's
// models: read from the URDF's Drake transmissions, and M, RNEA and forward dynamics with it against
// Pinocchio's with model.armature (tests/data/iiwa14.json); the momentum observer on a plant with it;
// bad values in the URDF, in with_armature and in the programs' --armature list.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "core/contact/observer.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "core/number_list.hpp"
#include "core/simulation/plant.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::matrices_near;
using testing::matrices_near_relative;
using testing::relative_error;

const char* const kTip = "iiwa_link_ee";

::testing::AssertionResult contains(const std::string& text, const std::string& needle) {
  if (text.find(needle) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << needle << "' is not in '" << text << "'";
}

RobotModel load_iiwa(const std::string& tip = kTip) {
  return load_urdf_file(testing::data_path("iiwa14.urdf"), UrdfOptions{tip, {0.0, 0.0, -9.81}});
}

std::string iiwa_text() {
  std::ifstream file(testing::data_path("iiwa14.urdf"));
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

// The URDF text with the first occurrence of `from` replaced by `to` (which must be there).
std::string edited(const std::string& from, const std::string& to, size_t occurrence = 0) {
  std::string text = iiwa_text();
  size_t at = text.find(from);
  for (size_t k = 0; k < occurrence && at != std::string::npos; ++k) at = text.find(from, at + 1);
  if (at == std::string::npos) throw std::logic_error("'" + from + "' is not in iiwa14.urdf");
  return text.replace(at, from.size(), to);
}

// The message of the ModelError that loading `xml` raises, or "" when it loads.
std::string load_error(const std::string& xml, const std::string& tip = kTip) {
  try {
    load_urdf_string(xml, UrdfOptions{tip, {0.0, 0.0, -9.81}}, "iiwa14_edited.urdf");
  } catch (const ModelError& e) {
    return e.what();
  }
  return "";
}

TEST(Armature, TheUrdfsTransmissionsGiveTheReferencesArmature) {
  const testing::Reference ref = testing::load_reference("iiwa14");
  ASSERT_EQ(ref.armature.size(), 7);
  const RobotModel model = load_iiwa();
  ASSERT_EQ(model.armature().size(), 7);
  EXPECT_TRUE(matrices_near(model.armature(), ref.armature, 1e-12));
  // rotor_inertia × gear_ratio², by hand from the file: 1.321e-4 × 160², 8.2e-5 × ... as Drake's.
  EXPECT_NEAR(model.armature()[0], 0.0001321 * 160.0 * 160.0, 1e-12);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(model.description().armature[static_cast<size_t>(i)], model.armature()[i]);
}

// M, τ and q̈ with the armature, as Pinocchio's crba, rnea and aba with model.armature compute them.
// Each is held to 1e-12 × max(1, its reference's largest entry): the reference's M reaches 8.5 kg·m²,
// τ 98 N·m and q̈ 1.3 rad/s², so q̈'s bound is 1.3e-12 rad/s² absolute (measured worst: 5e-16
// relative for M and τ, 4e-15 rad/s² for q̈).
TEST(Armature, MassMatrixInverseAndForwardDynamicsMatchTheReference) {
  const testing::Reference ref = testing::load_reference("iiwa14");
  const RobotModel model = load_iiwa();
  Data data(model), tick(model);
  ASSERT_FALSE(ref.cases.empty());
  double worst_M = 0.0, worst_tau = 0.0, worst_qdd = 0.0, worst_qdd_abs = 0.0, worst_tick = 0.0, worst_p = 0.0;
  for (size_t k = 0; k < ref.cases.size(); ++k) {
    SCOPED_TRACE("case " + std::to_string(k));
    const testing::ReferenceCase& c = ref.cases[k];
    ASSERT_EQ(c.M_with_armature.rows(), 7);
    const Eigen::MatrixXd M = mass_matrix(model, data, c.q);
    EXPECT_TRUE(matrices_near_relative(M, c.M_with_armature, 1e-12));
    const Eigen::VectorXd tau = inverse_dynamics(model, data, c.q, c.qd, c.qdd);
    EXPECT_TRUE(matrices_near_relative(tau, c.tau_with_armature, 1e-12));
    const Eigen::VectorXd qdd = forward_dynamics(model, data, c.q, c.qd, c.tau);
    EXPECT_TRUE(matrices_near_relative(qdd, c.qdd_of_tau_with_armature, 1e-12));
    // The tick's one pass: the same M, and p = (M + diag(armature)) q̇.
    const Data& d = compute_tick_terms(model, tick, c.q, c.qd);
    EXPECT_TRUE(matrices_near_relative(d.M, c.M_with_armature, 1e-12));
    const Eigen::VectorXd p_expected = c.M_with_armature * c.qd;
    EXPECT_TRUE(matrices_near_relative(d.p, p_expected, 1e-12));
    EXPECT_TRUE(matrices_near_relative(Eigen::VectorXd(d.M * c.qdd + d.bias), c.tau_with_armature, 1e-12));
    worst_M = std::max(worst_M, relative_error(M, c.M_with_armature));
    worst_tau = std::max(worst_tau, relative_error(tau, c.tau_with_armature));
    worst_qdd = std::max(worst_qdd, relative_error(qdd, c.qdd_of_tau_with_armature));
    worst_qdd_abs = std::max(worst_qdd_abs, testing::max_abs_diff(qdd, c.qdd_of_tau_with_armature));
    worst_tick = std::max(worst_tick, relative_error(d.M, c.M_with_armature));
    worst_p = std::max(worst_p, relative_error(d.p, p_expected));
  }
  std::cout << std::setprecision(3) << "iiwa14 with armature, " << ref.cases.size()
            << " cases, max relative error: M " << worst_M << ", tau " << worst_tau << ", qdd " << worst_qdd << " (absolute " << worst_qdd_abs << " rad/s^2)"
            << ", tick M " << worst_tick << ", tick p " << worst_p << "\n";
}

// The rigid terms do not change: c, g and Cᵀq̇ are those of the model without armature, and M and
// τ differ from its by exactly diag(armature) and armature ∘ q̈.
TEST(Armature, OnlyTheDiagonalAndTheAccelerationTermChange) {
  const testing::Reference ref = testing::load_reference("iiwa14");
  const RobotModel model = load_iiwa();
  const RobotModel rigid = with_armature(model, Eigen::VectorXd::Zero(7));
  EXPECT_TRUE((rigid.armature().array() == 0.0).all());
  Data a(model), b(rigid);
  for (size_t k = 0; k < 10; ++k) {
    const testing::ReferenceCase& c = ref.cases[k];
    compute_tick_terms(model, a, c.q, c.qd);
    compute_tick_terms(rigid, b, c.q, c.qd);
    EXPECT_TRUE(matrices_near(a.bias, b.bias, 0.0));
    EXPECT_TRUE(matrices_near(a.g, b.g, 0.0));
    EXPECT_TRUE(matrices_near(a.ct_qd, b.ct_qd, 0.0));
    const Eigen::MatrixXd diagonal = model.armature().asDiagonal();
    EXPECT_TRUE(matrices_near(a.M - b.M, diagonal, 1e-14));
    const Eigen::VectorXd tau_a = inverse_dynamics(model, a, c.q, c.qd, c.qdd);
    const Eigen::VectorXd tau_b = inverse_dynamics(rigid, b, c.q, c.qd, c.qdd);
    EXPECT_TRUE(matrices_near(tau_a - tau_b, model.armature().cwiseProduct(c.qdd), 1e-12));
    const double ke = kinetic_energy(model, a, c.q, c.qd);
    EXPECT_NEAR(ke, 0.5 * c.qd.dot(c.M_with_armature * c.qd), 1e-12 * std::max(1.0, ke));
  }
}

TEST(Armature, WithArmatureReplacesTheUrdfsAndKeepsTheRest) {
  const RobotModel model = load_iiwa();
  Eigen::VectorXd armature(7);
  armature << 1.0, 2.0, 0.0, 0.5, 0.25, 0.125, 3.0;
  const RobotModel changed = with_armature(model, armature);
  EXPECT_TRUE(matrices_near(changed.armature(), armature, 0.0));
  EXPECT_EQ(changed.joints().size(), model.joints().size());
  EXPECT_TRUE(matrices_near(changed.space_axes(), model.space_axes(), 0.0));
  for (int i = 0; i < 7; ++i) EXPECT_TRUE(matrices_near(changed.inertia(i), model.inertia(i), 0.0));
  // A model without transmissions (the Panda's URDF) has none.
  const RobotModel panda = load_urdf_file(testing::data_path("panda.urdf"), UrdfOptions{"panda_hand", {0, 0, -9.81}});
  EXPECT_TRUE((panda.armature().array() == 0.0).all());
  EXPECT_EQ(panda.armature().size(), 7);
}

TEST(Armature, WithArmatureRefusesBadValuesNamingTheJoint) {
  const RobotModel model = load_iiwa();
  auto message = [&](const Eigen::VectorXd& armature) -> std::string {
    try {
      with_armature(model, armature);
    } catch (const ModelError& e) {
      return e.what();
    }
    return "";
  };
  Eigen::VectorXd armature = Eigen::VectorXd::Zero(7);
  armature[2] = -0.5;
  EXPECT_TRUE(contains(message(armature), "joint 'iiwa_joint_3': armature -0.5 is not a finite value >= 0"));
  armature[2] = std::nan("");
  EXPECT_TRUE(contains(message(armature), "joint 'iiwa_joint_3': armature nan is not a finite value >= 0"));
  armature[2] = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(contains(message(armature), "joint 'iiwa_joint_3'"));
  EXPECT_TRUE(contains(message(Eigen::VectorXd::Zero(6)), "armature has 6 values; the chain has 7 joints"));
  EXPECT_TRUE(contains(message(Eigen::VectorXd::Zero(6)), "iiwa14.urdf"));
}

// The programs' --armature (chasles_plant, chasles_controller): one value per joint, ≥ 0.
TEST(Armature, TheCommandLineListTakesOneValuePerJoint) {
  const Eigen::VectorXd a = parse_armature("3.38, 3.38,3.38,3.38,1.32,1.16,1.16", 7, "--armature");
  ASSERT_EQ(a.size(), 7);
  EXPECT_EQ(a[0], 3.38);
  EXPECT_EQ(a[6], 1.16);
  auto message = [](const std::string& text, int joints) -> std::string {
    try {
      parse_armature(text, joints, "--armature");
    } catch (const ArgumentError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message("1,2,3", 7),
            "--armature has 3 values; the arm has 7 joints: give one per joint, root to tip, kg*m^2 (kg for a "
            "prismatic joint)");
  EXPECT_EQ(message("1,2,3,4,5,6,7,8", 7).rfind("--armature has 8 values; the arm has 7 joints", 0), 0u);
  EXPECT_EQ(message("1,2,-3", 3), "--armature: entry 2 is negative; armature is >= 0");
  EXPECT_EQ(message("1,x,3", 3), "--armature: entry 1 ('x') is not a number");
  EXPECT_EQ(message("1,nan,3", 3), "--armature: entry 1 ('nan') is not finite");
}

// Joints off the chain keep no armature, and their transmissions are not read: with the tip at
// link 4, joints 5–7 are locked, a bad rotor inertia on joint 7 changes nothing.
TEST(Armature, TransmissionsOffTheChainAreIgnored) {
  const RobotModel short_chain = load_iiwa("iiwa_link_4");
  ASSERT_EQ(short_chain.dof(), 4);
  const testing::Reference ref = testing::load_reference("iiwa14");
  EXPECT_TRUE(matrices_near(short_chain.armature(), ref.armature.head(4), 1e-12));
  const std::string bad = edited("<drake:rotor_inertia value=\"0.0000454\" />", "<drake:rotor_inertia value=\"-1\" />", 1);
  EXPECT_EQ(load_error(bad, "iiwa_link_4"), "");
  EXPECT_TRUE(contains(load_error(bad), "iiwa_joint_7"));
}

TEST(Armature, AbsentGearRatioIsOneAndAbsentRotorInertiaIsZero) {
  const std::string no_ratio = edited("<drake:gear_ratio value=\"160.0\" />", "");
  const RobotModel a = load_urdf_string(no_ratio, UrdfOptions{kTip, {0, 0, -9.81}}, "no_ratio.urdf");
  EXPECT_NEAR(a.armature()[0], 0.0001321, 1e-18);
  EXPECT_NEAR(a.armature()[1], 0.0001321 * 160.0 * 160.0, 1e-12);
  const std::string no_rotor = edited("<drake:rotor_inertia value=\"0.0001321\" />", "");
  const RobotModel b = load_urdf_string(no_rotor, UrdfOptions{kTip, {0, 0, -9.81}}, "no_rotor.urdf");
  EXPECT_EQ(b.armature()[0], 0.0);
  EXPECT_NEAR(b.armature()[1], 0.0001321 * 160.0 * 160.0, 1e-12);
}

TEST(Armature, MalformedRotorValuesInTheUrdfNameTheJointAndTheFile) {
  const std::string rotor = "<drake:rotor_inertia value=\"0.0001321\" />";
  EXPECT_EQ(load_error(edited(rotor, "<drake:rotor_inertia value=\"-0.0001321\" />")),
            "iiwa14_edited.urdf: joint 'iiwa_joint_1': <drake:rotor_inertia> of transmission 'iiwa_tran_1' (line "
            "416): value -0.0001321 is negative; a rotor inertia is kg*m^2 (kg for a prismatic joint), >= 0");
  EXPECT_EQ(load_error(edited(rotor, "<drake:rotor_inertia value=\"NaN\" />")),
            "iiwa14_edited.urdf: joint 'iiwa_joint_1': <drake:rotor_inertia> of transmission 'iiwa_tran_1' (line "
            "416): value 'NaN' is not finite");
  EXPECT_EQ(load_error(edited(rotor, "<drake:rotor_inertia value=\"1e-4 kg m2\" />")),
            "iiwa14_edited.urdf: joint 'iiwa_joint_1': <drake:rotor_inertia> of transmission 'iiwa_tran_1' (line "
            "416): value '1e-4 kg m2' is not a number");
  EXPECT_EQ(load_error(edited(rotor, "<drake:rotor_inertia/>")),
            "iiwa14_edited.urdf: joint 'iiwa_joint_1': <drake:rotor_inertia> of transmission 'iiwa_tran_1' (line "
            "416) has no value attribute");
  const std::string ratio = "<drake:gear_ratio value=\"160.0\" />";
  EXPECT_TRUE(contains(load_error(edited(ratio, "<drake:gear_ratio value=\"inf\" />", 2)),
                       "joint 'iiwa_joint_3': <drake:gear_ratio> of transmission 'iiwa_tran_3'"));
  EXPECT_TRUE(contains(load_error(edited(ratio, "<drake:gear_ratio value=\"\" />", 2)), "is not a number"));
  // A negative gear ratio turns the motor the other way: ρ² is what enters.
  const RobotModel reversed = load_urdf_string(edited(ratio, "<drake:gear_ratio value=\"-160.0\" />"),
                                               UrdfOptions{kTip, {0, 0, -9.81}}, "reversed.urdf");
  EXPECT_NEAR(reversed.armature()[0], 0.0001321 * 160.0 * 160.0, 1e-12);
}

TEST(Armature, AMalformedValueInAUrdfFileNamesThatFile) {
  const std::string path = ::testing::TempDir() + "iiwa14_negative_rotor.urdf";
  {
    std::ofstream out(path);
    out << edited("<drake:rotor_inertia value=\"0.0000454\" />", "<drake:rotor_inertia value=\"-2e-5\" />");
  }
  try {
    load_urdf_file(path, UrdfOptions{kTip, {0, 0, -9.81}});
    ADD_FAILURE() << "a negative rotor inertia loaded";
  } catch (const ModelError& e) {
    EXPECT_TRUE(contains(e.what(), path + ": joint 'iiwa_joint_6': <drake:rotor_inertia>"));
    EXPECT_TRUE(contains(e.what(), "value -2e-5 is negative"));
  }
  std::remove(path.c_str());
}

TEST(Armature, TwoTransmissionsForOneJointAreRefused) {
  const std::string twice = edited("<joint name=\"iiwa_joint_2\">\n      <hardwareInterface>", "<joint name=\"iiwa_joint_1\">\n      <hardwareInterface>");
  EXPECT_EQ(load_error(twice),
            "iiwa14_edited.urdf: joint 'iiwa_joint_1': transmissions 'iiwa_tran_1' and 'iiwa_tran_2' both give it a "
            "rotor (drake:rotor_inertia, drake:gear_ratio): one per joint");
}

// The plant integrates the iiwa with its armature; the momentum observer of the same model sees no
// external torque in a free motion (τ̂_ext is the trapezoid rule's error on the smooth terms), and
// the observer of the rigid model sees the rotors' armature ∘ q̈ as a spurious external torque.
TEST(Armature, TheObserverOfTheSameModelSeesNoExternalTorqueInAFreeMotion) {
  const RobotModel model = load_iiwa();
  const RobotModel rigid = with_armature(model, Eigen::VectorXd::Zero(7));
  const double dt = 1e-3;
  Eigen::VectorXd q0(7);
  q0 << 0.2, 0.4, -0.3, -1.2, 0.5, 0.8, -0.4;
  plant::Plant plant(model, q0, Eigen::VectorXd::Zero(7), dt, 4);
  const Eigen::VectorXd gain = Eigen::VectorXd::Constant(7, 50.0);
  MomentumObserver with(model, gain), without(rigid, gain);
  Data data(model), rigid_data(rigid), control(model);
  momentum_terms(model, data, plant.q(), plant.qd());
  momentum_terms(rigid, rigid_data, plant.q(), plant.qd());
  with.reset(data, plant.qd());
  without.reset(rigid_data, plant.qd());
  // Computed torque toward a swinging goal: joints accelerate by up to a few rad/s².
  double worst_with = 0.0, worst_without = 0.0, peak_qdd = 0.0;
  Eigen::VectorXd qdd_goal(7), tau(7), q_goal(7);
  for (int k = 0; k < 2000; ++k) {
    const double t = k * dt;
    for (int i = 0; i < 7; ++i) q_goal[i] = q0[i] + 0.4 * std::sin(2.0 * t + 0.5 * i);
    qdd_goal = 100.0 * (q_goal - plant.q()) - 20.0 * plant.qd();
    tau = inverse_dynamics(model, control, plant.q(), plant.qd(), qdd_goal);
    plant.step(tau);
    peak_qdd = std::max(peak_qdd, qdd_goal.cwiseAbs().maxCoeff());
    momentum_terms(model, data, plant.q(), plant.qd());
    momentum_terms(rigid, rigid_data, plant.q(), plant.qd());
    with.update(data, plant.qd(), plant.effort(), dt);
    without.update(rigid_data, plant.qd(), plant.effort(), dt);
    if (k >= 100) {  // past the observer's lag (1/K_O = 20 ms) of the start
      worst_with = std::max(worst_with, with.external_torque().cwiseAbs().maxCoeff());
      worst_without = std::max(worst_without, without.external_torque().cwiseAbs().maxCoeff());
    }
  }
  std::cout << "free motion 2 s, peak commanded |qdd| " << peak_qdd << " rad/s^2: max |tau_ext_hat| with armature "
            << worst_with << " N*m, rigid model " << worst_without << " N*m\n";
  EXPECT_GT(peak_qdd, 1.0);
  EXPECT_LT(worst_with, 1e-3);
  EXPECT_GT(worst_without, 1.0);
}

}  // namespace
}  // namespace chasles
