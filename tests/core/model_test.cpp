// Loading RobotModel from URDF: the shared robots against the reference, and one test per kind
// of bad input, each expecting an error that names the file and the joint or link.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <regex>
#include <sstream>

#include "core/dynamics/dynamics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/inertia.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::load_reference;
using testing::matrices_near;

RobotModel load_reference_model(const testing::Reference& ref) {
  UrdfOptions options;
  options.tip_link = ref.tip_link;
  return load_urdf_file(ref.urdf, options);
}

class ReferenceRobot : public ::testing::TestWithParam<std::string> {};

TEST_P(ReferenceRobot, StructureMatchesTheReference) {
  const auto ref = load_reference(GetParam());
  const RobotModel model = load_reference_model(ref);
  EXPECT_EQ(model.base_link(), ref.base_link);
  EXPECT_EQ(model.tip_link(), ref.tip_link);
  ASSERT_EQ(model.dof(), static_cast<int>(ref.joint_names.size()));
  for (int i = 0; i < model.dof(); ++i) {
    EXPECT_EQ(model.joint(i).name, ref.joint_names[static_cast<size_t>(i)]);
    EXPECT_EQ(to_string(model.joint(i).type), ref.joint_types[static_cast<size_t>(i)]);
    EXPECT_DOUBLE_EQ(model.joint(i).limits.lower, ref.lower(i));
    EXPECT_DOUBLE_EQ(model.joint(i).limits.upper, ref.upper(i));
  }
  EXPECT_TRUE(matrices_near(model.gravity(), ref.gravity, 0.0));
  std::vector<std::string> chain;
  for (const auto& link : model.links()) chain.push_back(link.name);
  std::vector<std::string> expected;
  for (const auto& [name, T] : ref.cases.front().link_T) expected.push_back(name);
  std::sort(chain.begin(), chain.end());
  EXPECT_EQ(chain, expected);
}

TEST_P(ReferenceRobot, HomePoseAndScrewAxesMatchTheReference) {
  const auto ref = load_reference(GetParam());
  const RobotModel model = load_reference_model(ref);
  EXPECT_TRUE(matrices_near(model.home_tip().matrix(), ref.home_T, 1e-10));
  EXPECT_TRUE(matrices_near(model.space_axes(), ref.home_S, 1e-10));
  // B_i = [Ad_{M⁻¹}] S_i.
  EXPECT_TRUE(matrices_near(model.body_axes(), adjoint(inverse(model.home_tip())) * model.space_axes(), 1e-14));
}

TEST_P(ReferenceRobot, SpatialInertiasArePhysical) {
  const auto ref = load_reference(GetParam());
  const RobotModel model = load_reference_model(ref);
  for (int i = 0; i < model.dof(); ++i) {
    const Matrix6d& G = model.inertia(i);
    EXPECT_TRUE(matrices_near(G, G.transpose(), 1e-15));
    // Positive semi-definite up to rounding: a point-mass body (TIAGo's, TALOS's) has G singular.
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(G);
    EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-15 * G.cwiseAbs().maxCoeff()) << "body of " << model.joint(i).name;
    EXPECT_TRUE(matrices_near(G.bottomRightCorner<3, 3>(), G(3, 3) * Matrix3d::Identity(), 1e-14));
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, ReferenceRobot, ::testing::Values("ur5", "panda", "tiago", "talos_left_arm", "finger_edu", "iiwa14"));

TEST(Model, PandaHandCarriesTheLockedFingers) {
  // Body 7 is panda_link7 + link8 + hand + tcp + both fingers (URDF masses, summed by hand).
  UrdfOptions options;
  options.tip_link = "panda_hand";
  const RobotModel model = load_urdf_file(testing::data_path("panda.urdf"), options);
  const double mass_link7 = 0.735522, mass_hand = 0.73, mass_finger = 0.015;
  EXPECT_NEAR(model.inertia(6)(3, 3), mass_link7 + mass_hand + 2 * mass_finger, 1e-12);
}

// The placement rotations the fast paths take (RobotModel::placement_rotation) are exactly the
// model's matrices: the identity, about one axis (c, s as stored), a quarter turn (c = 0), or
// general.
TEST_P(ReferenceRobot, PlacementRotationsAreExactlyTheirMatrices) {
  const RobotModel model = load_reference_model(load_reference(GetParam()));
  for (int i = 0; i < model.dof(); ++i) {
    const PlacementRotation& p = model.placement_rotation(i);
    const Matrix3d& R = model.joint(i).T_parent_joint.linear();
    if (p.kind == PlacementKind::General) continue;
    Matrix3d expected = Matrix3d::Identity();
    if (p.kind != PlacementKind::Identity) {
      const int kind = static_cast<int>(p.kind), quarter = static_cast<int>(PlacementKind::QuarterX);
      const int k = kind >= quarter ? kind - quarter : kind, a = (k + 1) % 3, b = (k + 2) % 3;
      if (kind >= quarter) {
        EXPECT_EQ(p.c, 0.0) << model.joint(i).name;
      }
      expected(a, a) = expected(b, b) = p.c;
      expected(b, a) = p.s;
      expected(a, b) = -p.s;
    }
    EXPECT_TRUE(matrices_near(R, expected, 0.0)) << model.joint(i).name;
  }
}

TEST(Model, PlacementRotationsOfTheUr5AndThePanda) {
  UrdfOptions options;
  options.tip_link = "tool0";
  const RobotModel ur5 = load_urdf_file(testing::data_path("ur5.urdf"), options);
  for (int i = 0; i < ur5.dof(); ++i) {
    const PlacementKind expected = (i == 1 || i == 3) ? PlacementKind::RotationY : PlacementKind::Identity;
    EXPECT_EQ(ur5.placement_rotation(i).kind, expected) << i;
  }
  // The UR5's rpy of 1.57079632679 is 5e-12 short of a quarter turn: its cosine stays as it is.
  EXPECT_EQ(ur5.placement_rotation(1).c, ur5.joint(1).T_parent_joint.linear()(2, 2));
  EXPECT_NEAR(ur5.placement_rotation(1).c, std::cos(1.57079632679), 1e-16);
  options.tip_link = "panda_hand";
  const RobotModel panda = load_urdf_file(testing::data_path("panda.urdf"), options);
  EXPECT_EQ(panda.placement_rotation(0).kind, PlacementKind::Identity);
  // The Panda's rpy of ±π/2 (to the last digit) are quarter turns, made exact: within 4ε of the
  // rotation by the angle as written, and with entries of exactly 0 and ±1.
  const double angle[] = {-M_PI / 2, M_PI / 2, M_PI / 2, -M_PI / 2, M_PI / 2, M_PI / 2};
  for (int i = 1; i < panda.dof(); ++i) {
    EXPECT_EQ(panda.placement_rotation(i).kind, PlacementKind::QuarterX) << i;
    const Matrix3d& R = panda.joint(i).T_parent_joint.linear();
    const Matrix3d exact = Eigen::AngleAxisd(angle[i - 1], Vector3d::UnitX()).toRotationMatrix();
    EXPECT_TRUE(matrices_near(R, exact, 4.0 * std::numeric_limits<double>::epsilon())) << i;
    EXPECT_TRUE(matrices_near(R, exact.array().round().matrix(), 0.0)) << i;
  }
}

TEST(Model, SeveralLeavesNeedATip) {
  try {
    load_urdf_file(testing::data_path("panda.urdf"));
    FAIL() << "expected an error";
  } catch (const ModelError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("panda.urdf"), std::string::npos) << what;
    for (const char* leaf : {"panda_hand_tcp", "panda_leftfinger", "panda_rightfinger"}) {
      EXPECT_NE(what.find(leaf), std::string::npos) << what;
    }
    EXPECT_NE(what.find("name the tip link"), std::string::npos) << what;
    EXPECT_EQ(what.find("--"), std::string::npos) << "the library knows no command-line flag: " << what;
  }
}

// --- a small arm and its mutations ----------------------------------------------------------

// tests/data/arm.urdf: base → (revolute j1) → l1 → (fixed f) → l1b → (prismatic j2) → l2 →
// (continuous j3) → tip, and a gripper finger off the chain on l2.
std::string arm_urdf() {
  std::ifstream file(testing::data_path("arm.urdf"));
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("test bug: '" + from + "' not in URDF");
  return text.replace(at, from.size(), to);
}

RobotModel load_arm(const std::string& xml, const std::string& tip = "tip") {
  UrdfOptions options;
  options.tip_link = tip;
  return load_urdf_string(xml, options, "arm.urdf");
}

TEST(Model, SmallArmStructure) {
  const RobotModel model = load_arm(arm_urdf());
  ASSERT_EQ(model.dof(), 3);
  EXPECT_EQ(model.joint(2).type, JointType::Continuous);
  EXPECT_TRUE(matrices_near(model.joint(2).axis, Vector3d::UnitY(), 0.0));  // normalised
  EXPECT_DOUBLE_EQ(model.joint(2).limits.lower, -kPi);
  EXPECT_EQ(model.joint(2).limits.effort, std::numeric_limits<double>::infinity());
  // The fixed joint f is merged: M_{1,2} = origin(f) · origin(j2).
  const Transform expected = make_transform(exp3(Vector3d(kPi / 2, 0, 0)), Vector3d(0, 0, 0.2)) *
                             make_transform(Matrix3d::Identity(), Vector3d(0.1, 0, 0));
  EXPECT_TRUE(matrices_near(model.joint(1).T_parent_joint.matrix(), expected.matrix(), 1e-15));
  // Links on the chain, with l1b riding on body 1.
  ASSERT_EQ(model.links().size(), 5u);
  EXPECT_EQ(model.links()[2].name, "l1b");
  EXPECT_EQ(model.links()[2].body, 1);
  // Space screw axis of the prismatic joint: (0, R_{0,2} x̂).
  EXPECT_TRUE(matrices_near(model.space_axes().col(1), (Vector6d() << 0, 0, 0, 1, 0, 0).finished(), 1e-15));
}

TEST(Model, InertialOriginXyzAndRpyApply) {
  const RobotModel model = load_arm(arm_urdf());
  // Body 2 = l2 (mass 1, CoM (0.1, 0, 0), principal axes turned 90° about z: Ixx ↔ Iyy) plus the
  // finger (mass 0.5 at (0, 0.05, 0)).
  const Matrix6d& G = model.inertia(1);
  EXPECT_NEAR(G(3, 3), 1.5, 1e-15);
  const Vector3d first_moment = 1.0 * Vector3d(0.1, 0, 0) + 0.5 * Vector3d(0, 0.05, 0);
  EXPECT_TRUE(matrices_near(vee3(G.topRightCorner<3, 3>()), first_moment, 1e-15));
  // Rotational inertia at the body origin: I_c turned, plus m(|c|²I − ccᵀ) per part.
  Matrix3d I_o = Vector3d(0.002, 0.001, 0.003).asDiagonal();
  I_o += 1.0 * (0.01 * Matrix3d::Identity() - Vector3d(0.1, 0, 0) * Vector3d(0.1, 0, 0).transpose());
  I_o += 1e-4 * Matrix3d::Identity() +
         0.5 * (0.0025 * Matrix3d::Identity() - Vector3d(0, 0.05, 0) * Vector3d(0, 0.05, 0).transpose());
  EXPECT_TRUE(matrices_near(G.topLeftCorner<3, 3>(), I_o, 1e-15));
}

TEST(Model, TheSingleLeafIsTheDefaultTip) {
  std::string xml = std::regex_replace(arm_urdf(), std::regex(R"(<joint name="finger_joint"[\s\S]*?</joint>)"), "");
  xml = std::regex_replace(xml, std::regex(R"(<link name="finger">[\s\S]*?</link>)"), "");
  const RobotModel model = load_urdf_string(xml, {}, "arm.urdf");
  EXPECT_EQ(model.tip_link(), "tip");
}

TEST(Model, OffChainMimicJointIsLocked) {
  const std::string xml =
      replace(arm_urdf(), R"(<limit lower="0" upper="0.04" effort="10" velocity="0.1"/></joint>)",
              R"(<limit lower="0" upper="0.04" effort="10" velocity="0.1"/><mimic joint="j2"/></joint>)");
  EXPECT_EQ(load_arm(xml).dof(), 3);
}

// Every bad input: the mutation, and the words the message must contain besides the file name.
struct BadInput {
  std::string name;
  std::function<std::string(const std::string&)> mutate;
  std::vector<std::string> expected_words;
  std::string tip = "tip";
};

void PrintTo(const BadInput& bad, std::ostream* out) { *out << bad.name; }

class BadUrdf : public ::testing::TestWithParam<BadInput> {};

TEST_P(BadUrdf, IsRejectedWithAClearMessage) {
  const BadInput& bad = GetParam();
  try {
    load_arm(bad.mutate(arm_urdf()), bad.tip);
    FAIL() << "expected a ModelError";
  } catch (const ModelError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("arm.urdf: ", 0), 0u) << what;
    for (const auto& word : bad.expected_words) EXPECT_NE(what.find(word), std::string::npos) << what;
  }
}

auto swap(const std::string& from, const std::string& to) {
  return [from, to](const std::string& xml) { return replace(xml, from, to); };
}

const std::string kJ1Limit = R"(<limit lower="-2" upper="2" effort="50" velocity="2"/>)";

INSTANTIATE_TEST_SUITE_P(
    Cases, BadUrdf,
    ::testing::Values(
        BadInput{"Malformed", swap("</robot>", "<robot>"), {"malformed XML", "line"}},
        BadInput{"NotARobot", [](const std::string&) { return std::string("<model/>"); }, {"<robot>"}},
        BadInput{"UnknownTip", [](const std::string& x) { return x; }, {"unknown tip link 'hand'"}, "hand"},
        BadInput{"SeveralLeaves", [](const std::string& x) { return x; }, {"leaves", "'tip'", "'finger'"}, ""},
        BadInput{"FloatingOnChain",
                 swap(R"(name="j2" type="prismatic")", R"(name="j2" type="floating")"),
                 {"joint 'j2'", "floating"}},
        BadInput{"PlanarOnChain",
                 swap(R"(name="j2" type="prismatic")", R"(name="j2" type="planar")"),
                 {"joint 'j2'", "planar"}},
        BadInput{"MimicOnChain", swap(kJ1Limit, kJ1Limit + R"(<mimic joint="j3"/>)"), {"joint 'j1'", "mimic"}},
        BadInput{"ZeroAxis", swap(R"(<axis xyz="0 2 0"/>)", R"(<axis xyz="0 0 0"/>)"), {"joint 'j3'", "axis is zero"}},
        BadInput{"NegativeMass", swap(R"(<mass value="2"/>)", R"(<mass value="-2"/>)"), {"link 'l1'", "negative"}},
        BadInput{"NanMass", swap(R"(<mass value="2"/>)", R"(<mass value="nan"/>)"), {"l1"}},
        BadInput{"NegativePrincipalMoment",
                 swap(R"(ixx="0.02")", R"(ixx="-0.02")"),
                 {"joint 'j1'", "link 'l1'", "(-0.02, 0.01, 0.02) kg·m²", "negative", "tolerance of 4e-05 kg·m²"}},
        BadInput{"TriangleInequalityBroken",
                 swap(R"(ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.01")",
                      R"(ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.0302")"),
                 {"joint 'j1'", "link 'l1'", "triangle inequality", "0.01 + 0.02 < 0.0302"}},
        BadInput{"NanOrigin",
                 swap(R"(<origin xyz="0 0 0.3" rpy="0 0 0"/>)", R"(<origin xyz="0 nan 0.3" rpy="0 0 0"/>)"),
                 {"joint [j1]"}},
        BadInput{
            "InfiniteLimit", swap(kJ1Limit, R"(<limit lower="-inf" upper="2" effort="50" velocity="2"/>)"), {"j1"}},
        BadInput{"HugeNumber", swap(R"(<mass value="1"/>)", R"(<mass value="1e999"/>)"), {"l2"}},
        BadInput{"MissingLimits", swap(kJ1Limit, ""), {"j1", "limits"}},
        BadInput{"NegativeDrakeAcceleration",
                 swap(kJ1Limit, R"(<limit drake:acceleration="-3" lower="-2" upper="2" effort="50" velocity="2"/>)"),
                 {"joint 'j1'", "drake:acceleration=\"-3\"", "not a positive number"}},
        BadInput{"DrakeAccelerationNotANumber",
                 swap(kJ1Limit, R"(<limit drake:acceleration="8 rad" lower="-2" upper="2" effort="50" velocity="2"/>)"),
                 {"joint 'j1'", "drake:acceleration=\"8 rad\""}},
        BadInput{"LowerAboveUpper",
                 swap(kJ1Limit, R"(<limit lower="2" upper="-2" effort="50" velocity="2"/>)"),
                 {"joint 'j1'", "lower limit 2", "above upper limit -2"}},
        BadInput{"UnknownChildLink",
                 swap(R"(<child link="l2"/>)", R"(<child link="l9"/>)"),
                 {"joint 'j2'", "child link 'l9'", "does not exist"}},
        BadInput{"UnknownParentLink",
                 swap(R"(<parent link="l1b"/>)", R"(<parent link="nowhere"/>)"),
                 {"joint 'j2'", "parent link 'nowhere'"}},
        BadInput{"Cycle",
                 swap("</robot>",
                      R"(<joint name="back" type="fixed"><parent link="tip"/><child link="base"/></joint></robot>)"),
                 {"cycle", "'back'", "'j1'"}},
        BadInput{"TwoParents",
                 swap("</robot>",
                      R"(<joint name="extra" type="fixed"><parent link="base"/><child link="l2"/></joint></robot>)"),
                 {"link 'l2'", "two parent joints", "'j2'", "'extra'"}},
        BadInput{"NoMovableJoint", [](const std::string& x) { return x; }, {"no movable joint"}, "base"}),
    [](const ::testing::TestParamInfo<BadInput>& p) { return p.param.name; });

// One base for every exception the libraries throw (calibration's is checked in its own test).
static_assert(std::is_base_of_v<Error, ModelError> && std::is_base_of_v<Error, ArgumentError> &&
              std::is_base_of_v<Error, DynamicsError> && std::is_base_of_v<std::runtime_error, Error>);

TEST(Model, MissingFile) {
  try {
    load_urdf_file("/nonexistent/robot.urdf");
    FAIL() << "expected an error";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/robot.urdf: cannot open"), std::string::npos) << e.what();
  }
}

TEST(Model, AZeroVelocityOrEffortLimitMeansNone) {
  // What CAD exporters write when they do not know the limit (URDF requires both attributes).
  const RobotModel model = load_arm(replace(arm_urdf(), R"(effort="50" velocity="2")", R"(effort="0" velocity="0")"));
  EXPECT_EQ(model.joint(0).limits.velocity, std::numeric_limits<double>::infinity());
  EXPECT_EQ(model.joint(0).limits.effort, std::numeric_limits<double>::infinity());
  EXPECT_EQ(model.joint(1).limits.effort, 100.0);
}

// Drake's <limit drake:acceleration="..."/>, as its iiwa14.urdf gives them (the file's numbers,
// joint by joint); a URDF without them has none.
TEST(Model, DrakesAccelerationLimitsAreRead) {
  UrdfOptions options;
  options.tip_link = "iiwa_link_ee";
  const RobotModel iiwa = load_urdf_file(chasles::testing::data_path("iiwa14.urdf"), options);
  const double file[] = {8.57, 8.57, 8.74, 11.36, 12.23, 15.72, 15.72};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(iiwa.joint(i).limits.acceleration, file[i]) << iiwa.joint(i).name;
  const RobotModel arm = load_arm(arm_urdf());
  for (int i = 0; i < arm.dof(); ++i) EXPECT_EQ(arm.joint(i).limits.acceleration, std::numeric_limits<double>::infinity());
}

// --- inertias: physical within the tolerance of rounding (core/model/inertia.hpp) ---------------

std::string with_l1_inertia(const std::string& inertia) {
  return replace(arm_urdf(), R"(ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.01")", inertia);
}

bool any_warning_has(const RobotModel& model, const std::vector<std::string>& words) {
  for (const std::string& warning : model.warnings()) {
    bool all = true;
    for (const auto& word : words) all = all && warning.find(word) != std::string::npos;
    if (all) return true;
  }
  return false;
}

TEST(Inertia, EveryCloudOfPointMassesIsPhysicalAndItsMirrorImagesAreNot) {
  // Any mass distribution is physical, including degenerate ones (a rod, a plate): clouds of 1–4
  // point masses cover them. Taking the largest principal moment past the sum of the other two,
  // or one moment below zero, by 1 % of the largest, is beyond rounding.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coordinate(-0.2, 0.2), mass(0.01, 3.0);
  for (int trial = 0; trial < 400; ++trial) {
    const int points = 1 + trial % 4;
    double m = 0.0;
    Vector3d h = Vector3d::Zero();
    Matrix3d I_origin = Matrix3d::Zero();
    for (int k = 0; k < points; ++k) {
      const double m_k = mass(rng);
      const Vector3d r(coordinate(rng), coordinate(rng), trial % 7 == 0 ? 0.0 : coordinate(rng));
      m += m_k;
      h += m_k * r;
      I_origin += m_k * (r.squaredNorm() * Matrix3d::Identity() - r * r.transpose());
    }
    const InertiaCheck check = check_inertia(m, inertia_about_centre_of_mass(m, h, I_origin));
    EXPECT_TRUE(check.physical()) << check.problem;
    EXPECT_EQ(check.point_mass, points == 1);
    const Vector3d& lambda = check.principal_moments;
    if (points > 1) {
      const double beyond = 0.01 * lambda(2);
      const Vector3d too_long(lambda(0), lambda(1), lambda(0) + lambda(1) + beyond);
      const Vector3d negative(-beyond, lambda(1), lambda(2));
      EXPECT_NE(check_inertia(m, too_long.asDiagonal().toDenseMatrix()).problem.find("triangle inequality"),
                std::string::npos);
      EXPECT_NE(check_inertia(m, negative.asDiagonal().toDenseMatrix()).problem.find("negative"), std::string::npos);
    }
  }
  EXPECT_NE(check_inertia(-1.0, Matrix3d::Zero()).problem.find("negative"), std::string::npos);
  EXPECT_NE(check_inertia(std::nan(""), Matrix3d::Zero()).problem.find("not finite"), std::string::npos);
  EXPECT_NE(check_inertia(0.0, Matrix3d::Identity()).problem.find("mass 0"), std::string::npos);
  EXPECT_TRUE(check_inertia(0.0, Matrix3d::Zero()).physical());
}

TEST(Model, ATriangleInequalityMissedByRoundingLoads) {
  // Principal moments 0.01, 0.02, izz: izz ≤ 0.03 is physical; the tolerance on λ0 + λ1 − λ2 is
  // 2 × (2e-3 × izz + m·(1 µm)²) = 1.2044e-4 at izz = 0.03011, so 0.03011 loads (it misses by
  // 1.1e-4) and 0.0302 (2e-4) is refused in BadUrdf.TriangleInequalityBroken.
  const RobotModel model = load_arm(with_l1_inertia(R"(ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03011")"));
  EXPECT_TRUE(model.warnings().empty());
}

TEST(Model, ANegativeMomentOfRoundingSizeLoads) {
  // A thin rod along z written by an exporter: one moment a rounding error below zero.
  const RobotModel model = load_arm(with_l1_inertia(R"(ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="-1e-19")"));
  EXPECT_TRUE(model.warnings().empty());
  EXPECT_EQ(model.dof(), 3);
}

TEST(Model, APointMassLoadsWithAWarning) {
  // so101's gripper_frame_link and baxter's right_gripper: mass, every moment 0.
  const RobotModel model = load_arm(with_l1_inertia(R"(ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0")"));
  ASSERT_EQ(model.warnings().size(), 1u);
  EXPECT_TRUE(any_warning_has(model, {"link 'l1'", "point mass", "2 kg"})) << model.warnings().front();
  EXPECT_DOUBLE_EQ(model.inertia(0)(3, 3), 2.0);
}

TEST(Model, AnOddLinkOnAPhysicalBodyLoadsWithAWarning) {
  // The finger (off the chain, riding on l2's body) breaks the triangle inequality; l2 and the
  // finger together do not (both lie flat in l2's x-y plane, and a larger Ixx only adds slack to
  // the plate's Izz ≤ Ixx + Iyy).
  const RobotModel model = load_arm(replace(arm_urdf(), R"(<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/>)",
                                            R"(<inertia ixx="5e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/>)"));
  ASSERT_EQ(model.warnings().size(), 1u);
  EXPECT_TRUE(any_warning_has(model, {"link 'finger'", "triangle inequality", "joint 'j2'", "physical as a whole"}))
      << model.warnings().front();
}

TEST(Model, AnOddLinkOnTheFixedBaseOnlyWarns) {
  // A link of another arm, fixed to the base, cannot stop this chain from loading.
  const RobotModel model = load_arm(replace(arm_urdf(), R"(<link name="base"/>)",
                                            R"(<link name="base"><inertial><mass value="1"/>)"
                                            R"(<inertia ixx="-1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>)"));
  ASSERT_EQ(model.warnings().size(), 1u);
  EXPECT_TRUE(any_warning_has(model, {"link 'base'", "negative", "never enters the dynamics"})) << model.warnings().front();
}

TEST(Model, AMasslessLastBodyLoadsButForwardDynamicsSaysWhy) {
  // Without the tip's inertial, joint j3 moves nothing: M's last row and column are zero.
  const RobotModel model =
      load_arm(std::regex_replace(arm_urdf(), std::regex(R"(<link name="tip"><inertial>[\s\S]*?</inertial></link>)"),
                                  R"(<link name="tip"/>)"));
  Data data(model);
  const Eigen::VectorXd q = Eigen::Vector3d(0.3, 0.2, 0.1), zero = Eigen::VectorXd::Zero(3);
  EXPECT_NE(mass_matrix_defect(model).find("joint 'j3' moves no inertia"), std::string::npos) << mass_matrix_defect(model);
  try {
    forward_dynamics(model, data, q, zero, zero);
    FAIL() << "expected a DynamicsError";
  } catch (const DynamicsError& e) {
    EXPECT_NE(std::string(e.what()).find("joint 'j3' moves no inertia"), std::string::npos) << e.what();
  }
  // The full arm is fine.
  EXPECT_EQ(mass_matrix_defect(load_arm(arm_urdf())), "");
}

TEST(Model, MassZeroFramesLoad) {
  // ur5's base, ee_link and tool0 carry mass 0 and zero inertia: valid.
  UrdfOptions options;
  options.tip_link = "tool0";
  EXPECT_EQ(load_urdf_file(testing::data_path("ur5.urdf"), options).dof(), 6);
}

// The Panda's URDF states damping="0.003" friction="0.0" on each of its joints (franka_description's
// values), the fingers' included; the arm's seven are the chain's.
TEST(JointFriction, ReadFromEachChainJointsDynamics) {
  std::ifstream file(testing::data_path("panda.urdf"));
  const std::string xml((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  UrdfOptions options;
  options.tip_link = "panda_hand";
  const RobotModel model = load_urdf_string(xml, options, "panda.urdf");
  const JointFriction friction = joint_friction_from_urdf(xml, model);
  EXPECT_EQ(friction.viscous, Eigen::VectorXd::Constant(7, 0.003));
  EXPECT_EQ(friction.coulomb, Eigen::VectorXd::Zero(7));

  // A joint that states none has none; a value that is no friction is refused, naming the joint.
  const std::string tag = "damping=\"0.003\" friction=\"0.0\"";
  std::string edited = xml;
  const size_t third = [&] {
    size_t at = edited.find("name=\"panda_joint3\"");
    return edited.find(tag, at);
  }();
  ASSERT_NE(third, std::string::npos);
  EXPECT_EQ(joint_friction_from_urdf(edited.replace(third, tag.size(), "damping=\"0.5\""), model).viscous[2], 0.5);
  EXPECT_EQ(joint_friction_from_urdf(edited, model).coulomb[2], 0.0);
  for (const auto& [bad, value] : {std::pair{"damping=\"-0.1\"", "-0.1"}, std::pair{"damping=\"nan\"", "nan"},
                                   std::pair{"damping=\"2 N\"", "2 N"}}) {
    std::string refused = xml;
    refused.replace(third, tag.size(), bad);
    try {
      joint_friction_from_urdf(refused, model);
      ADD_FAILURE() << bad << " was taken";
    } catch (const ModelError& e) {
      EXPECT_EQ(std::string(e.what()), std::string("panda.urdf: joint 'panda_joint3': <dynamics damping=\"") + value +
                                           "\"> is not a finite number >= 0");
    }
  }
  EXPECT_THROW(joint_friction_from_urdf("<robot><joint", model), ModelError);

  // From the file, read as the loader reads it.
  EXPECT_EQ(joint_friction_from_urdf_file(testing::data_path("panda.urdf"), model).viscous, friction.viscous);
  EXPECT_THROW(joint_friction_from_urdf_file(testing::data_path("no_such.urdf"), model), ModelError);
}

}  // namespace
}  // namespace chasles
