// The joint-torque regressor: Y π against the model's own RNEA at random states, against the
// independent Pinocchio references (tests/data/<robot>.json), column by column against the change
// of τ when one parameter changes, and without allocating. The base parameters: their count against
// the grouping rules of Khalil and the literature, and Y_b β = Y π on states the QR never saw.
#include "core/identification/regressor.hpp"
#include "core/identification/base_parameters.hpp"

#include <gtest/gtest.h>

#include <iomanip>
#include <iostream>
#include <random>

#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::matrices_near_relative;
using testing::relative_error;

struct ArmFile {
  std::string name, tip;
};
void PrintTo(const ArmFile& arm, std::ostream* out) { *out << arm.name; }

struct State {
  Eigen::VectorXd q, qd, qdd;
};

// Seeded random states: q within limits, q̇ and q̈ of order 1 (some q̇ exactly 0, where sign is 0).
std::vector<State> random_states(const RobotModel& model, int count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal;
  std::vector<State> states;
  const int n = model.dof();
  for (int k = 0; k < count; ++k) {
    State s{Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n)};
    for (int i = 0; i < n; ++i) {
      const auto& l = model.joint(i).limits;
      s.q(i) = l.lower + (l.upper - l.lower) * unit(rng);
      s.qd(i) = k % 7 == 3 && i == k % n ? 0.0 : normal(rng);
      s.qdd(i) = normal(rng);
    }
    states.push_back(s);
  }
  return states;
}

class Regressor : public ::testing::TestWithParam<ArmFile> {
 protected:
  void SetUp() override {
    UrdfOptions options;
    options.tip_link = GetParam().tip;
    model_ = std::make_unique<RobotModel>(load_urdf_file(testing::data_path(GetParam().name + ".urdf"), options));
  }
  std::unique_ptr<RobotModel> model_;
};

TEST_P(Regressor, LayoutIsInertialThenViscousCoulombArmature) {
  const ParameterLayout layout = parameter_layout(*model_);
  const int n = model_->dof();
  EXPECT_EQ(layout.size(), 13 * n);
  EXPECT_EQ(layout.inertial(n - 1) + 9, 10 * n - 1);
  EXPECT_EQ(layout.viscous(0), 10 * n);
  EXPECT_EQ(layout.coulomb(0), 11 * n);
  EXPECT_EQ(layout.armature(n - 1), 13 * n - 1);
  // π_i is the model's SpatialInertia, entry by entry (its upper triangle of I), and goes back to
  // it: to rounding, since the model's I, turned into the body frame as R I Rᵀ, is symmetric only to
  // the last digit.
  const Eigen::VectorXd pi = model_parameters(*model_);
  for (int i = 0; i < n; ++i) {
    const SpatialInertia& G = model_->body_inertia(i);
    const int b = layout.inertial(i);
    EXPECT_EQ(pi(b), G.mass);
    EXPECT_EQ(pi(b + 2), G.h.y());
    EXPECT_EQ(pi(b + 5), G.I(0, 1));
    EXPECT_EQ(pi(b + 8), G.I(1, 2));
    EXPECT_EQ(pi(b + 9), G.I(2, 2));
    EXPECT_EQ(pi(layout.armature(i)), model_->armature()[i]);
    EXPECT_EQ(pi(layout.viscous(i)), 0.0);
    EXPECT_TRUE(matrices_near_relative(spatial_inertia(body_parameters(G)).matrix(), G.matrix(), 1e-15));
  }
  const RobotModel same = with_inertial_parameters(*model_, inertial_parameters(*model_));
  for (int i = 0; i < n; ++i) EXPECT_TRUE(matrices_near_relative(same.inertia(i), model_->inertia(i), 1e-15)) << i;
  EXPECT_THROW(with_inertial_parameters(*model_, Eigen::MatrixXd::Zero(n, 9)), ModelError);
}

// Y π = RNEA(q, q̇, q̈) + armature ∘ q̈ with the model's own π, at 60 states.
TEST_P(Regressor, TimesTheModelsParametersIsInverseDynamics) {
  RegressorWorkspace workspace(*model_);
  Data data(*model_);
  const Eigen::VectorXd pi = model_parameters(*model_);
  double worst = 0.0;
  for (const State& s : random_states(*model_, 60, 11)) {
    const Eigen::VectorXd tau = joint_torque_regressor(*model_, workspace, s.q, s.qd, s.qdd) * pi;
    const Eigen::VectorXd& expected = inverse_dynamics(*model_, data, s.q, s.qd, s.qdd);
    EXPECT_TRUE(matrices_near_relative(tau, expected, 1e-12));
    worst = std::max(worst, relative_error(tau, expected));
  }
  std::cout << std::setprecision(3) << GetParam().name << ": Y pi vs rnea, 60 states, max relative error " << worst
            << "\n";
}

// Friction enters as f_v q̇ + f_c sign(q̇), joint by joint, with sign(0) = 0.
TEST_P(Regressor, FrictionColumnsAreVelocityAndItsSign) {
  RegressorWorkspace workspace(*model_);
  Data data(*model_);
  const ParameterLayout layout = parameter_layout(*model_);
  const int n = model_->dof();
  Eigen::VectorXd pi = model_parameters(*model_);
  for (int i = 0; i < n; ++i) {
    pi(layout.viscous(i)) = 0.5 + 0.25 * i;
    pi(layout.coulomb(i)) = 2.0 - 0.125 * i;
  }
  int zero_velocities = 0;
  for (const State& s : random_states(*model_, 60, 12)) {
    Eigen::VectorXd expected = inverse_dynamics(*model_, data, s.q, s.qd, s.qdd);
    for (int i = 0; i < n; ++i) {
      const double sign = s.qd(i) > 0.0 ? 1.0 : s.qd(i) < 0.0 ? -1.0 : 0.0;
      expected(i) += pi(layout.viscous(i)) * s.qd(i) + pi(layout.coulomb(i)) * sign;
      zero_velocities += s.qd(i) == 0.0;
    }
    const Eigen::VectorXd tau = joint_torque_regressor(*model_, workspace, s.q, s.qd, s.qdd) * pi;
    EXPECT_TRUE(matrices_near_relative(tau, expected, 1e-12));
  }
  EXPECT_GT(zero_velocities, 0);
}

// Each column is ∂τ/∂π_k, and τ is linear in π: the torque of a model with π_k moved by δ, less the
// torque of the model, is δ times column k. The base model is the arm with 10 kg·m² added to every
// body's rotational inertia (isotropic, so still physical), so that a step of δ = 0.1 in any one
// parameter leaves every body physical and the model accepts it; the difference loses ε |τ| / δ ≈
// 1e-13 to rounding. Four inertial parameters per body, in turn over the ten, and every armature
// column.
TEST_P(Regressor, EachColumnIsTheTorqueOfOneParametersChange) {
  const int n = model_->dof();
  const ParameterLayout layout = parameter_layout(*model_);
  Eigen::MatrixXd base = inertial_parameters(*model_);
  for (int i = 0; i < n; ++i) base(i, 4) += 10.0, base(i, 7) += 10.0, base(i, 9) += 10.0;
  const RobotModel model = with_inertial_parameters(*model_, base);
  RegressorWorkspace workspace(model);
  Data data(model);
  const double delta = 0.1;
  int columns = 0;
  for (const State& s : random_states(model, 3, 13)) {
    const Eigen::MatrixXd Y = joint_torque_regressor(model, workspace, s.q, s.qd, s.qdd);
    const Eigen::VectorXd tau = inverse_dynamics(model, data, s.q, s.qd, s.qdd);
    for (int i = 0; i < n; ++i) {
      for (int k = i % 10, count = 0; count < 4; k = (k + 3) % 10, ++count) {
        Eigen::MatrixXd moved = base;
        moved(i, k) += delta;
        const RobotModel other = with_inertial_parameters(model, moved);
        Data other_data(other);
        const Eigen::VectorXd change = (inverse_dynamics(other, other_data, s.q, s.qd, s.qdd) - tau) / delta;
        SCOPED_TRACE("body " + std::to_string(i) + ", parameter " + kInertialParameterNames[k]);
        EXPECT_TRUE(matrices_near_relative(Y.col(layout.inertial(i) + k), change, 1e-10));
        ++columns;
      }
      Eigen::VectorXd armature = model.armature();
      armature(i) += delta;
      const RobotModel rotor = with_armature(model, armature);
      Data rotor_data(rotor);
      const Eigen::VectorXd change = (inverse_dynamics(rotor, rotor_data, s.q, s.qd, s.qdd) - tau) / delta;
      EXPECT_TRUE(matrices_near_relative(Y.col(layout.armature(i)), change, 1e-10)) << "armature " << i;
      ++columns;
    }
  }
  EXPECT_EQ(columns, 3 * 5 * n);
}

TEST_P(Regressor, AllocatesNothing) {
  RegressorWorkspace workspace(*model_);
  const auto states = random_states(*model_, 10, 14);
  testing::AllocationCounter counter;
  for (const State& s : states) joint_torque_regressor(*model_, workspace, s.q, s.qd, s.qdd);
  EXPECT_EQ(counter.count(), 0);
}

TEST_P(Regressor, WrongSizesAreRejected) {
  RegressorWorkspace workspace(*model_);
  const int n = model_->dof();
  const Eigen::VectorXd ok = Eigen::VectorXd::Zero(n), bad = Eigen::VectorXd::Zero(n + 1);
  EXPECT_THROW(joint_torque_regressor(*model_, workspace, bad, ok, ok), ArgumentError);
  EXPECT_THROW(joint_torque_regressor(*model_, workspace, ok, bad, ok), ArgumentError);
  EXPECT_THROW(joint_torque_regressor(*model_, workspace, ok, ok, bad), ArgumentError);
}

INSTANTIATE_TEST_SUITE_P(Arms, Regressor,
                         ::testing::Values(ArmFile{"ur5", "tool0"}, ArmFile{"panda", "panda_hand"},
                                           ArmFile{"iiwa14", "iiwa_link_ee"}, ArmFile{"arm", "tip"}),
                         [](const ::testing::TestParamInfo<ArmFile>& p) { return p.param.name; });

// Y π with the URDF's π against Pinocchio's rnea (tests/data/<robot>.json, 50 cases each): the
// rigid bodies' τ with the armature's entries of π at zero, and the iiwa's τ with its armature.
TEST(RegressorReference, MatchesPinocchiosInverseDynamics) {
  for (const ArmFile& arm : {ArmFile{"ur5", "tool0"}, ArmFile{"panda", "panda_hand"}, ArmFile{"iiwa14", "iiwa_link_ee"}}) {
    SCOPED_TRACE(arm.name);
    const testing::Reference ref = testing::load_reference(arm.name);
    UrdfOptions options;
    options.tip_link = arm.tip;
    const RobotModel model = load_urdf_file(testing::data_path(arm.name + ".urdf"), options);
    const ParameterLayout layout = parameter_layout(model);
    RegressorWorkspace workspace(model);
    const Eigen::VectorXd pi = model_parameters(model);
    Eigen::VectorXd rigid = pi;
    rigid.tail(model.dof()).setZero();
    ASSERT_EQ(ref.cases.size(), 50u);
    double worst = 0.0;
    for (const testing::ReferenceCase& c : ref.cases) {
      const Eigen::MatrixXd& Y = joint_torque_regressor(model, workspace, c.q, c.qd, c.qdd);
      const Eigen::VectorXd tau = Y * rigid;
      EXPECT_TRUE(matrices_near_relative(tau, c.tau, 1e-12));
      worst = std::max(worst, relative_error(tau, c.tau));
      if (c.tau_with_armature.size() > 0) {
        ASSERT_GT(pi(layout.armature(0)), 0.0);
        const Eigen::VectorXd tau_armature = Y * pi;
        EXPECT_TRUE(matrices_near_relative(tau_armature, c.tau_with_armature, 1e-12));
        worst = std::max(worst, relative_error(tau_armature, c.tau_with_armature));
      }
    }
    std::cout << std::setprecision(3) << arm.name << ": Y pi vs Pinocchio, 50 cases, max relative error " << worst
              << "\n";
  }
}

// The count of base parameters, against theory. For a chain of revolute joints whose first axis is
// vertical (parallel to gravity), the ten parameters of body 1 enter τ only through its moment about
// that axis, a₁ᵀ I₁ a₁ (9 lost), and for each later body the mass, the first moment along its joint
// axis and one diagonal moment fold into its parent's (Khalil's general grouping rule for revolute
// joints: 3 lost per body). The rules that remove more need axes parallel to the first (a planar
// arm); the UR5's parallel axes 2–4 are turned out of their plane by joint 1, so none applies here:
// 10 n − 9 − 3 (n − 1) inertial combinations, 36 for the UR5 and 43 for the Panda and
// the iiwa (Gaz et al., RA-L 2019, identify the Panda's 43). Friction adds 2 n, always separable (q̇
// and sign q̇ in one row); the rotors add n − 2, since a₁ᵀ I₁ a₁ and a₂ᵀ I₂ a₂ for an axis 2 ⟂ axis 1
// turn with q̇₁ and q̇₂ alone (½ (aᵀ I a) q̇² of kinetic energy, the armature's own form), which
// RotorsOfTheFirstTwoJointsFoldIntoTheirBodies checks directly.
struct BaseCount {
  ArmFile arm;
  int inertial, total;
  int zero_columns;  ///< parameters that move no torque at all
};
void PrintTo(const BaseCount& c, std::ostream* out) { *out << c.arm.name; }

class BaseCountTest : public ::testing::TestWithParam<BaseCount> {};

TEST_P(BaseCountTest, MatchesKhalilsRulesWhateverTheSeedOrSampleCount) {
  UrdfOptions options;
  options.tip_link = GetParam().arm.tip;
  const RobotModel model = load_urdf_file(testing::data_path(GetParam().arm.name + ".urdf"), options);
  const int n = model.dof();
  // The premises: revolute joints, the first axis along gravity.
  for (int i = 0; i < n; ++i) ASSERT_EQ(model.joint(i).type, JointType::Revolute);
  ASSERT_LT(model.space_axes().col(0).head<3>().cross(model.gravity()).norm(), 1e-12);
  ASSERT_EQ(GetParam().inertial, 10 * n - 9 - 3 * (n - 1));
  ASSERT_EQ(GetParam().total, GetParam().inertial + 2 * n + (n - 2));
  for (const auto& [samples, seed] : {std::pair<int, uint64_t>{20, 1}, {20, 2}, {200, 3}}) {
    const BaseParameters base = base_parameters(model, samples, seed);
    SCOPED_TRACE(std::to_string(samples) + " samples, seed " + std::to_string(seed));
    EXPECT_EQ(base.inertial_count, GetParam().inertial);
    EXPECT_EQ(base.count, GetParam().total);
    EXPECT_EQ(base.independent.size() + base.dependent.size(), static_cast<size_t>(13 * n));
    // A clear-cut rank: the kept pivots stay above 1e-3 of the largest, the dropped are rounding.
    EXPECT_GT(base.smallest_kept, 1e-3);
    EXPECT_LT(base.largest_dropped, 1e-13);
    std::cout << GetParam().arm.name << ", " << samples << " samples: " << base.count << " base parameters ("
              << base.inertial_count << " inertial), pivots kept >= " << base.smallest_kept << ", dropped <= "
              << base.largest_dropped << "\n";
  }
  // The parameters that move nothing: body 1's nine besides a₁ᵀ I₁ a₁ and, where axis 2 meets axis 1
  // (Panda, iiwa; the UR5's shoulder is offset), body 2's mass and its first moment along axis 2 —
  // the frame's origin is then a fixed point, and gravity's moment h × g has no share along a₂ ∥ h
  // or a₁ ∥ g. These are the ones Khalil's rule folds from body 2 into body 1, where they are lost.
  const BaseParameters base = base_parameters(model, 30, 4);
  int zero_columns = 0;
  for (size_t k = 0; k < base.dependent.size(); ++k) {
    if (base.K.col(static_cast<Eigen::Index>(k)).isZero(1e-12)) {
      EXPECT_LT(base.dependent[k], GetParam().zero_columns == 9 ? 10 : 20) << "π_" << base.dependent[k];
      ++zero_columns;
    }
  }
  EXPECT_EQ(zero_columns, GetParam().zero_columns);
}

// Y_b β = Y π for any π, at states the factorisation never saw: β carries all the torques can say.
TEST_P(BaseCountTest, BaseRegressorTimesBaseParametersIsTheFullProduct) {
  UrdfOptions options;
  options.tip_link = GetParam().arm.tip;
  const RobotModel model = load_urdf_file(testing::data_path(GetParam().arm.name + ".urdf"), options);
  const int n = model.dof();
  EXPECT_THROW(base_parameters(model, 12, 5), ArgumentError);  // 12 n rows for 13 n unknowns
  const BaseParameters base = base_parameters(model, 40, 5);
  RegressorWorkspace workspace(model);
  Eigen::MatrixXd Y_b(n, base.count);
  std::mt19937_64 rng(6);
  std::normal_distribution<double> normal;
  Eigen::VectorXd pi = model_parameters(model);
  for (int k = 0; k < 10 * n; ++k) pi(k) += 0.1 * normal(rng);  // need not be physical
  for (int k = 10 * n; k < 13 * n; ++k) pi(k) = std::abs(normal(rng));
  const Eigen::VectorXd beta = base_parameter_values(base, pi);
  ASSERT_EQ(beta.size(), base.count);
  double worst = 0.0;
  for (const State& s : random_states(model, 50, 7)) {
    const Eigen::MatrixXd& Y = joint_torque_regressor(model, workspace, s.q, s.qd, s.qdd);
    base_regressor(base, Y, Y_b);
    const Eigen::VectorXd tau = Y * pi, tau_b = Y_b * beta;
    EXPECT_TRUE(matrices_near_relative(tau_b, tau, 1e-10));
    worst = std::max(worst, relative_error(tau_b, tau));
  }
  std::cout << GetParam().arm.name << ": Y_b beta vs Y pi on 50 held-out states, max relative error " << worst << "\n";
}

INSTANTIATE_TEST_SUITE_P(Arms, BaseCountTest,
                         ::testing::Values(BaseCount{{"ur5", "tool0"}, 36, 52, 9},
                                           BaseCount{{"panda", "panda_hand"}, 43, 62, 11},
                                           BaseCount{{"iiwa14", "iiwa_link_ee"}, 43, 62, 11}),
                         [](const ::testing::TestParamInfo<BaseCount>& p) { return p.param.arm.name; });

// The reason two rotors are not separable: with I = a aᵀ for joint j's axis a (in body j's frame)
// and every other parameter zero, Y π = q̈_j e_j, the armature's column, when j = 1 (a fixed axis)
// and when j = 2 with axis 2 ⟂ axis 1 (ω₂ · a₂ = q̇₂); not so for joint 3.
// On the arms whose first joints are revolute (the test arm's are prismatic).
class RevoluteRegressor : public Regressor {};

TEST_P(RevoluteRegressor, RotorsOfTheFirstTwoJointsFoldIntoTheirBodies) {
  const ParameterLayout layout = parameter_layout(*model_);
  RegressorWorkspace workspace(*model_);
  for (const State& s : random_states(*model_, 10, 15)) {
    const Eigen::MatrixXd& Y = joint_torque_regressor(*model_, workspace, s.q, s.qd, s.qdd);
    for (int j = 0; j < 3; ++j) {
      const Vector3d a = model_->local_axis(j).head<3>();
      Eigen::VectorXd pi = Eigen::VectorXd::Zero(layout.size());
      pi.segment<6>(layout.inertial(j) + 4) << a.x() * a.x(), a.x() * a.y(), a.x() * a.z(), a.y() * a.y(),
          a.y() * a.z(), a.z() * a.z();
      const Eigen::VectorXd tau = Y * pi;
      const Eigen::VectorXd rotor = Y.col(layout.armature(j));
      if (j < 2) {
        EXPECT_TRUE(matrices_near_relative(tau, rotor, 1e-13)) << "joint " << j + 1;
      } else {
        EXPECT_GT(testing::max_abs_diff(tau, rotor), 1e-3) << "joint 3";
      }
    }
  }
  EXPECT_NEAR(std::abs(model_->local_axis(0).head<3>().dot(model_->joint(1).T_parent_joint.linear() *
                                                           model_->local_axis(1).head<3>())),
              0.0, 1e-12)
      << "axis 2 is not perpendicular to axis 1";
}

INSTANTIATE_TEST_SUITE_P(Arms, RevoluteRegressor,
                         ::testing::Values(ArmFile{"ur5", "tool0"}, ArmFile{"panda", "panda_hand"},
                                           ArmFile{"iiwa14", "iiwa_link_ee"}),
                         [](const ::testing::TestParamInfo<ArmFile>& p) { return p.param.name; });

}  // namespace
}  // namespace chasles
