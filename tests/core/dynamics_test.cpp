// Dynamics: against the independent reference (tau, M, g, c), and by identities that tie the
// algorithms to each other and to energy: M from RNEA columns, τ = M q̈ + c + g, FD ∘ ID = id,
// c from the Christoffel symbols of M, ∂V/∂q = g, KE = ½ q̇ᵀMq̇, energy of a passive swing.
#include "core/dynamics/dynamics.hpp"

#include <gtest/gtest.h>

#include <random>
#include <sstream>
#include <string>

#include "core/kinematics/kinematics.hpp"
#include "core/model/payload.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/decompositions.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::matrices_near;
using testing::matrices_near_relative;

struct Robot {
  std::string name, tip;
};
void PrintTo(const Robot& robot, std::ostream* out) { *out << robot.name; }

class Dynamics : public ::testing::TestWithParam<Robot> {
 protected:
  void SetUp() override {
    UrdfOptions options;
    options.tip_link = GetParam().tip;
    model_ = std::make_unique<RobotModel>(load_urdf_file(testing::data_path(GetParam().name + ".urdf"), options));
    data_ = std::make_unique<Data>(*model_);
  }

  // Seeded random states: q within limits, q̇ and q̈ of order 1.
  struct State {
    Eigen::VectorXd q, qd, qdd;
  };
  std::vector<State> random_states(int count) const {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::normal_distribution<double> normal;
    std::vector<State> states;
    const int n = model_->dof();
    for (int k = 0; k < count; ++k) {
      State s{Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n)};
      for (int i = 0; i < n; ++i) {
        const auto& l = model_->joint(i).limits;
        s.q(i) = l.lower + (l.upper - l.lower) * unit(rng);
        s.qd(i) = normal(rng);
        s.qdd(i) = normal(rng);
      }
      states.push_back(s);
    }
    return states;
  }

  std::unique_ptr<RobotModel> model_;
  std::unique_ptr<Data> data_;
};

// ur5 and panda have reference values; the test arm (prismatic and continuous joints) is checked
// by the identities below. The reference's tau, M, g and c are the rigid bodies' alone: the iiwa's
// armature, which its URDF gives, is set to zero here (armature_test.cpp checks it).
class ReferenceDynamics : public Dynamics {
 protected:
  void SetUp() override {
    Dynamics::SetUp();
    model_ = std::make_unique<RobotModel>(with_armature(*model_, Eigen::VectorXd::Zero(model_->dof())));
    data_ = std::make_unique<Data>(*model_);
  }
};

TEST_P(ReferenceDynamics, MatchesTheReference) {
  const auto ref = testing::load_reference(GetParam().name);
  double worst = 0.0;
  auto relative = [](const Eigen::MatrixXd& a, const Eigen::MatrixXd& e) {
    return testing::max_abs_diff(a, e) / std::max(1.0, e.cwiseAbs().maxCoeff());
  };
  for (size_t k = 0; k < ref.cases.size(); ++k) {
    SCOPED_TRACE("case " + std::to_string(k));
    const auto& c = ref.cases[k];
    const Eigen::VectorXd tau = inverse_dynamics(*model_, *data_, c.q, c.qd, c.qdd);
    const Eigen::MatrixXd M = mass_matrix(*model_, *data_, c.q);
    const Eigen::VectorXd g = gravity_torques(*model_, *data_, c.q);
    const Eigen::VectorXd cq = velocity_product(*model_, *data_, c.q, c.qd);
    EXPECT_TRUE(matrices_near_relative(tau, c.tau, 1e-9));
    EXPECT_TRUE(matrices_near_relative(M, c.M, 1e-9));
    EXPECT_TRUE(matrices_near_relative(g, c.g, 1e-9));
    EXPECT_TRUE(matrices_near_relative(cq, c.c, 1e-9));
    worst = std::max({worst, relative(tau, c.tau), relative(M, c.M), relative(g, c.g), relative(cq, c.c)});
  }
  RecordProperty("max_rel_error", std::to_string(worst));
  std::cout << GetParam().name << ": max relative error over tau, M, g, c = " << worst << "\n";
}

// One pass gives what the control tick needs, each term as the independent library computes it.
TEST_P(ReferenceDynamics, TickTermsMatchTheReference) {
  const auto ref = testing::load_reference(GetParam().name);
  for (size_t k = 0; k < ref.cases.size(); ++k) {
    SCOPED_TRACE("case " + std::to_string(k));
    const auto& c = ref.cases[k];
    const Data& d = compute_tick_terms(*model_, *data_, c.q, c.qd);
    EXPECT_TRUE(matrices_near_relative(d.M, c.M, 1e-9));
    EXPECT_TRUE(matrices_near_relative(d.g, c.g, 1e-9));
    EXPECT_TRUE(matrices_near_relative(d.c, c.c, 1e-9));
    EXPECT_TRUE(matrices_near_relative(d.bias, c.c + c.g, 1e-9));
    EXPECT_TRUE(matrices_near_relative(Eigen::VectorXd(d.M * c.qdd + d.bias), c.tau, 1e-9));
    EXPECT_TRUE(matrices_near_relative(d.J_b, c.J_b, 1e-9));
    EXPECT_TRUE(matrices_near_relative(d.p, c.M * c.qd, 1e-9));
  }
}

// compute_tick_terms against the algorithms one by one, and what it costs: one pass of the joint
// transforms and one body Jacobian, however many terms it fills.
TEST_P(Dynamics, APayloadsGravityIsWhatWithPayloadAddsToTheArms) {
  // An off-centre load with an inertia of its own (which gravity does not see).
  Payload payload;
  payload.mass = 2.5;
  payload.centre = Vector3d(0.03, -0.02, 0.08);
  payload.inertia = Vector3d(0.01, 0.02, 0.015).asDiagonal();
  const RobotModel loaded = with_payload(*model_, payload);
  Data loaded_data(loaded);
  for (const State& s : random_states(20)) {
    compute_tick_terms(loaded, loaded_data, s.q, s.qd);
    Eigen::VectorXd tau = gravity_torques(*model_, *data_, s.q);
    add_payload_gravity(loaded, loaded_data, payload, tau);
    EXPECT_TRUE(matrices_near(tau, gravity_torques(loaded, loaded_data, s.q), 1e-10));
  }
}

TEST_P(Dynamics, TickTermsAreTheSeparateAlgorithmsInOnePass) {
  Data separate(*model_);
  for (const auto& s : random_states(20)) {
    const Data::Passes before = data_->passes;
    const Data& d = compute_tick_terms(*model_, *data_, s.q, s.qd);
    EXPECT_EQ(d.passes.joint_transforms - before.joint_transforms, 1);
    EXPECT_EQ(d.passes.body_jacobians - before.body_jacobians, 1);
    const double scale = 1.0 + s.qd.squaredNorm();
    EXPECT_TRUE(matrices_near_relative(d.M, mass_matrix(*model_, separate, s.q), 1e-12));
    EXPECT_TRUE(matrices_near(d.M, d.M.transpose(), 0.0));
    EXPECT_TRUE(matrices_near_relative(d.g, gravity_torques(*model_, separate, s.q), 1e-12));
    EXPECT_TRUE(matrices_near_relative(d.c, velocity_product(*model_, separate, s.q, s.qd), 1e-12 * scale));
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model_->dof());
    EXPECT_TRUE(matrices_near_relative(d.bias, inverse_dynamics(*model_, separate, s.q, s.qd, zero), 1e-12 * scale));
    momentum_terms(*model_, separate, s.q, s.qd);
    EXPECT_TRUE(matrices_near_relative(d.p, separate.p, 1e-12));
    EXPECT_TRUE(matrices_near_relative(d.ct_qd, separate.ct_qd, 1e-12 * scale));
    EXPECT_TRUE(matrices_near_relative(d.J_b, body_jacobian(*model_, separate, s.q), 1e-12));
    EXPECT_TRUE(matrices_near(d.T_sb.matrix(), separate.T_sb.matrix(), 1e-12));
    for (size_t i = 0; i < d.T_body.size(); ++i) {
      EXPECT_TRUE(matrices_near(d.T_body[i].matrix(), separate.T_body[i].matrix(), 1e-12)) << "body " << i;
    }
  }
}

TEST_P(Dynamics, ModelChecksTheSizesOfData) {
  EXPECT_TRUE(model_->check(*data_));
  const RobotModel other = load_urdf_file(testing::data_path(model_->dof() == 6 ? "panda.urdf" : "ur5.urdf"),
                                          UrdfOptions{model_->dof() == 6 ? "panda_hand" : "tool0"});
  EXPECT_FALSE(other.check(*data_)) << "a Data of " << model_->dof() << " joints passed for " << other.dof();
  EXPECT_TRUE(other.check(Data(other)));
}

TEST_P(Dynamics, MassMatrixIsSymmetricPositiveDefiniteAndEqualsRneaColumns) {
  const int n = model_->dof();
  for (const auto& s : random_states(20)) {
    const Eigen::MatrixXd M = mass_matrix(*model_, *data_, s.q);
    EXPECT_TRUE(matrices_near(M, M.transpose(), 0.0));
    EXPECT_GT(test::symmetric_eigenvalues(M).minCoeff(), 0.0);
    const Eigen::VectorXd g = gravity_torques(*model_, *data_, s.q);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      const Eigen::VectorXd e = Eigen::VectorXd::Unit(n, i);
      const Eigen::VectorXd column = inverse_dynamics(*model_, *data_, s.q, zero, e) - g;
      EXPECT_TRUE(matrices_near_relative(column, M.col(i), 1e-12)) << "column " << i;
    }
  }
}

TEST_P(Dynamics, InverseDynamicsIsTheSumOfItsParts) {
  for (const auto& s : random_states(20)) {
    const Eigen::MatrixXd M = mass_matrix(*model_, *data_, s.q);
    const Eigen::VectorXd expected =
        M * s.qdd + velocity_product(*model_, *data_, s.q, s.qd) + gravity_torques(*model_, *data_, s.q);
    EXPECT_TRUE(matrices_near_relative(inverse_dynamics(*model_, *data_, s.q, s.qd, s.qdd), expected, 1e-12));
  }
}

TEST_P(Dynamics, TipWrenchAddsTheBodyJacobianTranspose) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  for (const auto& s : random_states(20)) {
    Vector6d F_tip;
    for (int k = 0; k < 6; ++k) F_tip(k) = 10.0 * normal(rng);
    const Eigen::VectorXd free = inverse_dynamics(*model_, *data_, s.q, s.qd, s.qdd);
    const Eigen::VectorXd loaded = inverse_dynamics(*model_, *data_, s.q, s.qd, s.qdd, F_tip);
    const Eigen::MatrixXd J_b = body_jacobian(*model_, *data_, s.q);
    EXPECT_TRUE(matrices_near_relative(loaded - free, J_b.transpose() * F_tip, 1e-12));  // MR eq. 8.54
  }
}

TEST_P(Dynamics, ForwardDynamicsInvertsInverseDynamics) {
  Vector6d F_tip;
  F_tip << 0.5, -1.0, 0.2, 3.0, -4.0, 5.0;
  for (const auto& s : random_states(20)) {
    const Eigen::VectorXd tau = inverse_dynamics(*model_, *data_, s.q, s.qd, s.qdd, F_tip);
    EXPECT_TRUE(matrices_near(forward_dynamics(*model_, *data_, s.q, s.qd, tau, F_tip), s.qdd, 1e-9));
  }
}

// The hand-written factorisation in data.M_llt (CholeskyFactor::factorize) is Eigen's LLT: the same
// factor, rcond and solve at every size the loop unrolls (6, 7) and at the others; and a matrix
// that is not positive definite fails as Eigen's does.
TEST(CholeskyFactor, IsEigensLlt) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int n : {1, 2, 5, 6, 7, 9}) {
    Eigen::MatrixXd A(n, n);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) A(i, j) = normal(rng);
    }
    const Eigen::MatrixXd M = A * A.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
    CholeskyFactor mine(n);
    mine.factorize(M);
    const Eigen::LLT<Eigen::MatrixXd> eigen(M);
    ASSERT_EQ(mine.info(), Eigen::Success) << n;
    const Eigen::MatrixXd L_mine = mine.matrixL(), L_eigen = eigen.matrixL();
    EXPECT_TRUE(matrices_near(L_mine, L_eigen, 1e-12)) << n;
    EXPECT_NEAR(mine.rcond(), eigen.rcond(), 1e-12 * eigen.rcond()) << n;
    const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
    EXPECT_TRUE(matrices_near(M * mine.solve(b), b, 1e-10)) << n;
    Eigen::MatrixXd indefinite = M;
    indefinite(n - 1, n - 1) = -1.0;
    mine.factorize(indefinite);
    EXPECT_EQ(mine.info(), Eigen::NumericalIssue) << n;
  }
}

TEST_P(Dynamics, VelocityProductComesFromTheChristoffelSymbolsOfM) {
  // C_ij = ½ Σ_k (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) q̇_k with ∂M by central differences; then
  // C q̇ must equal the RNEA's c, and Ṁ − 2C must be skew-symmetric (MR §8.1.3).
  const int n = model_->dof();
  const double h = 1e-6;
  for (const auto& s : random_states(5)) {
    std::vector<Eigen::MatrixXd> dM(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      const Eigen::VectorXd dq = h * Eigen::VectorXd::Unit(n, k);
      const Eigen::VectorXd q_plus = s.q + dq, q_minus = s.q - dq;
      const Eigen::MatrixXd M_plus = mass_matrix(*model_, *data_, q_plus);
      dM[static_cast<size_t>(k)] = (M_plus - mass_matrix(*model_, *data_, q_minus)) / (2 * h);
    }
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n), M_dot = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        for (int k = 0; k < n; ++k) {
          const auto K = static_cast<size_t>(k), J = static_cast<size_t>(j), I = static_cast<size_t>(i);
          C(i, j) += 0.5 * (dM[K](i, j) + dM[J](i, k) - dM[I](j, k)) * s.qd(k);
        }
      }
    }
    for (int k = 0; k < n; ++k) M_dot += dM[static_cast<size_t>(k)] * s.qd(k);
    EXPECT_TRUE(matrices_near_relative(C * s.qd, velocity_product(*model_, *data_, s.q, s.qd), 1e-7));
    const Eigen::MatrixXd N = M_dot - 2 * C;
    EXPECT_TRUE(matrices_near(N + N.transpose(), Eigen::MatrixXd::Zero(n, n), 1e-7));
  }
}

TEST_P(Dynamics, GravityTorquesAreTheGradientOfPotentialEnergy) {
  const int n = model_->dof();
  const double h = 1e-6;
  for (const auto& s : random_states(10)) {
    Eigen::VectorXd gradient(n);
    for (int k = 0; k < n; ++k) {
      const Eigen::VectorXd dq = h * Eigen::VectorXd::Unit(n, k);
      const Eigen::VectorXd q_plus = s.q + dq, q_minus = s.q - dq;
      gradient(k) = (potential_energy(*model_, *data_, q_plus) - potential_energy(*model_, *data_, q_minus)) / (2 * h);
    }
    EXPECT_TRUE(matrices_near_relative(gravity_torques(*model_, *data_, s.q), gradient, 1e-7));
  }
}

TEST_P(Dynamics, KineticEnergyIsTheMassMatrixQuadraticForm) {
  for (const auto& s : random_states(20)) {
    const double expected = 0.5 * s.qd.dot(mass_matrix(*model_, *data_, s.q) * s.qd);
    EXPECT_NEAR(kinetic_energy(*model_, *data_, s.q, s.qd), expected, 1e-12 * std::max(1.0, expected));
  }
}

TEST_P(Dynamics, AllocatesNothing) {
  const auto states = random_states(10);
  Vector6d F_tip = Vector6d::Ones();
  testing::AllocationCounter counter;
  for (const auto& s : states) {
    inverse_dynamics(*model_, *data_, s.q, s.qd, s.qdd);
    inverse_dynamics(*model_, *data_, s.q, s.qd, s.qdd, F_tip);
    gravity_torques(*model_, *data_, s.q);
    velocity_product(*model_, *data_, s.q, s.qd);
    mass_matrix(*model_, *data_, s.q);
    forward_dynamics(*model_, *data_, s.q, s.qd, s.qdd, F_tip);
    kinetic_energy(*model_, *data_, s.q, s.qd);
    potential_energy(*model_, *data_, s.q);
    compute_tick_terms(*model_, *data_, s.q, s.qd);
  }
  EXPECT_EQ(counter.count(), 0);
}

TEST_P(Dynamics, WrongSizesAreRejected) {
  const int n = model_->dof();
  const Eigen::VectorXd ok = Eigen::VectorXd::Zero(n), bad = Eigen::VectorXd::Zero(n + 1);
  EXPECT_THROW(inverse_dynamics(*model_, *data_, ok, bad, ok), ArgumentError);
  EXPECT_THROW(inverse_dynamics(*model_, *data_, ok, ok, bad), ArgumentError);
  EXPECT_THROW(forward_dynamics(*model_, *data_, ok, ok, bad), ArgumentError);
  EXPECT_THROW(mass_matrix(*model_, *data_, bad), ArgumentError);
}

INSTANTIATE_TEST_SUITE_P(Robots, ReferenceDynamics,
                         ::testing::Values(Robot{"ur5", "tool0"}, Robot{"panda", "panda_hand"}, Robot{"tiago", "hand_grasping_frame"}, Robot{"talos_left_arm", "gripper_left_motor_double_link"}, Robot{"finger_edu", "finger_tip_link"}, Robot{"iiwa14", "iiwa_link_ee"}),
                         [](const ::testing::TestParamInfo<Robot>& p) { return p.param.name; });
INSTANTIATE_TEST_SUITE_P(Robots, Dynamics,
                         ::testing::Values(Robot{"ur5", "tool0"}, Robot{"panda", "panda_hand"}, Robot{"arm", "tip"}, Robot{"tiago", "hand_grasping_frame"}, Robot{"talos_left_arm", "gripper_left_motor_double_link"}, Robot{"finger_edu", "finger_tip_link"}, Robot{"iiwa14", "iiwa_link_ee"}),
                         [](const ::testing::TestParamInfo<Robot>& p) { return p.param.name; });

// A 12-joint chain whose placements take every shape RobotModel::placement_rotation tells apart
// (the identity, one rpy angle about x, y or z, a quarter turn about each either way, and a general
// rotation) under joints about ±x, ±y, ±z, an oblique axis and a prismatic one; with `twin`, the
// first two zeros of each rpy and axis are 1e-200 and 2e-200 instead, so that every placement and
// axis is general and takes the full 3×3 path (T_local): the same chain to far below rounding.
std::string every_shape_chain(bool twin) {
  const char* const rpy[] = {"0 0 0",
                             "1.5707963267948966 0 0",
                             "0 -1.5707963267948966 0",
                             "0 0 1.5707963267948966",
                             "-1.5707963267948966 0 0",
                             "0 1.5707963267948966 0",
                             "0 0 -1.5707963267948966",
                             "0.4 0 0",
                             "0 -0.7 0",
                             "0 0 1.1",
                             "0.3 0.2 0.1",
                             "0 0 0"};
  const char* const axes[] = {"0 0 1", "0 1 0", "1 0 0", "0 0 -1", "0 -1 0", "-1 0 0",
                              "0.6 0 0.8", "0 0 1", "0 1 0", "1 0 0", "0 0 1", "0 1 0"};
  const auto perturbed = [&](const std::string& triple) {
    if (!twin) return triple;
    std::istringstream in(triple);
    std::string out, x;
    int moved = 0;  // 1e-200, then 2e-200: equal roll and yaw would cancel at a pitch of ±π/2
    while (in >> x) {
      out += out.empty() ? "" : " ";
      out += x == "0" && moved < 2 ? (++moved == 1 ? "1e-200" : "2e-200") : x;
    }
    return out;
  };
  std::ostringstream xml;
  xml << "<robot name='every_shape'>";
  for (int i = 0; i <= 12; ++i) {
    xml << "<link name='l" << i << "'><inertial><origin xyz='" << 0.01 * i << " -0.02 0.05' rpy='0.1 0.2 0.3'/>"
        << "<mass value='" << 1.0 + 0.1 * i << "'/><inertia ixx='0.02' iyy='0.03' izz='0.025' ixy='0.001' "
        << "ixz='-0.002' iyz='0.0015'/></inertial></link>";
  }
  for (int i = 0; i < 12; ++i) {
    xml << "<joint name='j" << i + 1 << "' type='" << (i == 11 ? "prismatic" : "revolute") << "'><parent link='l" << i
        << "'/><child link='l" << i + 1 << "'/><origin xyz='0.05 0.02 0.12' rpy='" << perturbed(rpy[i])
        << "'/><axis xyz='" << perturbed(axes[i]) << "'/><limit lower='-3' upper='3' effort='100' velocity='2'/></joint>";
  }
  xml << "</robot>";
  return xml.str();
}

// The fast paths (plane turns and quarter turns by the placement's and the axis's shape, no joint
// transform) against the general one, on every shape: FK, J_b, RNEA, M, forward dynamics and the
// tick's terms.
TEST(Dynamics, EveryShapedPathIsTheGeneralOne) {
  const UrdfOptions options{"l12", {0.0, 0.0, -9.81}};
  const RobotModel shaped = load_urdf_string(every_shape_chain(false), options, "every_shape.urdf");
  const RobotModel general = load_urdf_string(every_shape_chain(true), options, "every_shape_twin.urdf");
  ASSERT_EQ(shaped.dof(), 12);
  const PlacementKind placements[] = {PlacementKind::Identity,  PlacementKind::QuarterX,  PlacementKind::QuarterY,
                                      PlacementKind::QuarterZ,  PlacementKind::QuarterX,  PlacementKind::QuarterY,
                                      PlacementKind::QuarterZ,  PlacementKind::RotationX, PlacementKind::RotationY,
                                      PlacementKind::RotationZ, PlacementKind::General,   PlacementKind::Identity};
  const AxisKind axes[] = {AxisKind::RevoluteZ, AxisKind::RevoluteY, AxisKind::RevoluteX, AxisKind::RevoluteZ,
                           AxisKind::RevoluteY, AxisKind::RevoluteX, AxisKind::General,   AxisKind::RevoluteZ,
                           AxisKind::RevoluteY, AxisKind::RevoluteX, AxisKind::RevoluteZ, AxisKind::General};
  for (int i = 0; i < 12; ++i) {
    EXPECT_EQ(shaped.placement_rotation(i).kind, placements[i]) << i;
    EXPECT_EQ(shaped.joint_axis(i).kind, axes[i]) << i;
    EXPECT_EQ(general.placement_rotation(i).kind, PlacementKind::General) << i;
    EXPECT_EQ(general.joint_axis(i).kind, AxisKind::General) << i;
  }
  // The quarter turns either way, so that both signs of s are taken.
  EXPECT_EQ(shaped.placement_rotation(1).s, 1.0);
  EXPECT_EQ(shaped.placement_rotation(4).s, -1.0);

  Data a(shaped), b(general);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  for (int k = 0; k < 5; ++k) {
    Eigen::VectorXd q(12), qd(12), qdd(12), tau(12);
    for (int i = 0; i < 12; ++i) {
      q(i) = 2.5 * std::tanh(normal(rng));
      qd(i) = normal(rng);
      qdd(i) = normal(rng);
      tau(i) = 5.0 * normal(rng);
    }
    EXPECT_TRUE(matrices_near_relative(forward_kinematics(shaped, a, q).matrix(),
                                       forward_kinematics(general, b, q).matrix(), 1e-13));
    EXPECT_TRUE(matrices_near_relative(body_jacobian(shaped, a, q), body_jacobian(general, b, q), 1e-13));
    EXPECT_TRUE(matrices_near_relative(inverse_dynamics(shaped, a, q, qd, qdd), inverse_dynamics(general, b, q, qd, qdd),
                                       1e-12));
    EXPECT_TRUE(matrices_near_relative(mass_matrix(shaped, a, q), mass_matrix(general, b, q), 1e-12));
    EXPECT_TRUE(matrices_near_relative(forward_dynamics(shaped, a, q, qd, tau), forward_dynamics(general, b, q, qd, tau),
                                       1e-9));
    compute_tick_terms(shaped, a, q, qd);
    compute_tick_terms(general, b, q, qd);
    EXPECT_TRUE(matrices_near_relative(a.M, b.M, 1e-12));
    EXPECT_TRUE(matrices_near_relative(a.c, b.c, 1e-12));
    EXPECT_TRUE(matrices_near_relative(a.g, b.g, 1e-12));
    EXPECT_TRUE(matrices_near_relative(a.p, b.p, 1e-12));
    EXPECT_TRUE(matrices_near_relative(a.ct_qd, b.ct_qd, 1e-12));
    EXPECT_TRUE(matrices_near_relative(a.J_b, b.J_b, 1e-13));
    EXPECT_TRUE(matrices_near_relative(momentum_terms(shaped, a, q, qd), momentum_terms(general, b, q, qd), 1e-12));
    EXPECT_NEAR(kinetic_energy(shaped, a, q, qd), kinetic_energy(general, b, q, qd),
                1e-12 * kinetic_energy(general, b, q, qd));
  }
}

// A passive swing: τ = 0, no damping, so kinetic + potential energy is conserved. Integrated with
// classical Runge-Kutta at 4 kHz for 10 s (the light wrist spins up past 100 rad/s); RK4's energy
// error scales as h⁴.
TEST(Energy, PassivePandaSwingConservesEnergy) {
  UrdfOptions options;
  options.tip_link = "panda_hand";
  const RobotModel model = load_urdf_file(testing::data_path("panda.urdf"), options);
  Data data(model);
  const int n = model.dof();
  Eigen::VectorXd q(n), qd = Eigen::VectorXd::Zero(n);
  q << 0.3, -0.5, 0.2, -2.0, 0.1, 1.5, 0.4;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  auto energy = [&] { return kinetic_energy(model, data, q, qd) + potential_energy(model, data, q); };
  auto accel = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return forward_dynamics(model, data, x, v, zero);
  };
  const double dt = 2.5e-4, E0 = energy();
  double worst = 0.0, max_speed = 0.0;
  for (int step = 0; step < 40000; ++step) {
    const Eigen::VectorXd k1q = qd, k1v = accel(q, qd);
    const Eigen::VectorXd k2q = qd + 0.5 * dt * k1v, k2v = accel(q + 0.5 * dt * k1q, k2q);
    const Eigen::VectorXd k3q = qd + 0.5 * dt * k2v, k3v = accel(q + 0.5 * dt * k2q, k3q);
    const Eigen::VectorXd k4q = qd + dt * k3v, k4v = accel(q + dt * k3q, k4q);
    q += dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q);
    qd += dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    worst = std::max(worst, std::abs(energy() - E0));
    max_speed = std::max(max_speed, qd.cwiseAbs().maxCoeff());
  }
  std::cout << "passive swing 10 s: max |E − E0| = " << worst << " J, peak joint speed " << max_speed << " rad/s\n";
  EXPECT_GT(max_speed, 1.0);  // the arm really swung
  EXPECT_LT(worst, 1e-6);     // documented tolerance: 1 µJ over 10 s
}

}  // namespace
}  // namespace chasles
