// chasles::ik against the independent IK targets in tests/data/ik_<robot>.json (FK of a random
// configuration by Pinocchio; any solution within the limits counts), and its properties: limits,
// determinism, an honest failure, bad targets, position-only mode, the analytic Jacobian.
#include "core/ik/ik.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"
#include "support/statistics.hpp"

namespace chasles {
namespace {

using testing::percentile;

struct IkCase {
  Matrix4d T_target;
  Eigen::VectorXd q_seed;
};

struct IkReference {
  std::string robot, tip_link;
  std::vector<IkCase> cases;
};

Eigen::VectorXd to_vector(const nlohmann::json& list) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(list.size()));
  for (size_t i = 0; i < list.size(); ++i) v[static_cast<Eigen::Index>(i)] = list[i].get<double>();
  return v;
}

IkReference load_ik_reference(const std::string& robot) {
  std::ifstream file(testing::data_path("ik_" + robot + ".json"));
  const nlohmann::json document = nlohmann::json::parse(file);
  IkReference ref;
  ref.robot = robot;
  ref.tip_link = document.at("tip_link").get<std::string>();
  for (const auto& item : document.at("cases")) {
    IkCase c;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) c.T_target(i, j) = item.at("T_target").at(i).at(j).get<double>();
    c.q_seed = to_vector(item.at("q_seed"));
    ref.cases.push_back(std::move(c));
  }
  return ref;
}

// Position and orientation error of FK(q) against T, computed here from FK, not by the solver.
void pose_errors(const RobotModel& model, const Eigen::VectorXd& q, const Matrix4d& T, double& pos_err,
                 double& rot_err) {
  const Transform T_sb = forward_kinematics_space(model, q);
  pos_err = (T_sb.translation() - T.topRightCorner<3, 1>()).norm();
  rot_err = log3(Matrix3d(T.topLeftCorner<3, 3>().transpose() * T_sb.linear())).norm();
}

::testing::AssertionResult within_limits(const RobotModel& model, const Eigen::VectorXd& q) {
  for (int i = 0; i < model.dof(); ++i) {
    const JointLimits& limits = model.joint(i).limits;
    const bool ok = model.joint(i).type == JointType::Continuous ? (q[i] > -kPi && q[i] <= kPi)
                                                                 : (q[i] >= limits.lower && q[i] <= limits.upper);
    if (!ok || !std::isfinite(q[i])) {
      return ::testing::AssertionFailure() << "joint " << model.joint(i).name << " at " << q[i] << " outside ["
                                           << limits.lower << ", " << limits.upper << "]";
    }
  }
  return ::testing::AssertionSuccess();
}

class Ik : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ref_ = load_ik_reference(GetParam());
    UrdfOptions options;
    options.tip_link = ref_.tip_link;
    model_ = std::make_unique<RobotModel>(load_urdf_file(testing::data_path(GetParam() + ".urdf"), options));
  }
  IkReference ref_;
  std::unique_ptr<RobotModel> model_;
};

// FK(IK(T)) = T for every reachable reference target, within the limits. Asserted with a restart
// cap and a generous clock (the same answer on any machine); then measured with the default 5 ms
// budget, cold from q_seed and warm from the solution plus 0.01 rad of noise, and printed, not
// asserted: within a CPU-time budget the rate and the times depend on the machine (and on a
// sanitizer build).
TEST_P(Ik, ReachesTheReferenceTargets) {
  {
    IkOptions options;
    options.time_budget = std::chrono::seconds(1);
    options.max_restarts = 200;
    IkSolver solver(*model_, options);
    int converged = 0, restarts = 0;
    for (const IkCase& c : ref_.cases) {
      const IkResult result = solver.solve(c.T_target, c.q_seed);
      EXPECT_TRUE(within_limits(*model_, result.q));
      double pos_err, rot_err;
      pose_errors(*model_, result.q, c.T_target, pos_err, rot_err);
      EXPECT_NEAR(pos_err, result.pos_err, 1e-9);
      EXPECT_NEAR(rot_err, result.rot_err, 1e-9);
      if (result.converged) {
        EXPECT_LE(pos_err, 1e-6);
        EXPECT_LE(rot_err, 1e-6);
        ++converged;
      }
      restarts += result.restarts;
    }
    std::printf("[ ik %s ] up to 200 restarts: %d/%zu converged (%.2f %%), %d restarts in all\n", GetParam().c_str(),
                converged, ref_.cases.size(), 100.0 * converged / static_cast<double>(ref_.cases.size()), restarts);
    EXPECT_EQ(converged, static_cast<int>(ref_.cases.size()));  // the issue asks ≥ 99.9 %: all 200
  }

  IkSolver solver(*model_);
  std::vector<double> cold_us, warm_us;
  std::vector<Eigen::VectorXd> solutions;
  std::vector<bool> solved;
  int cold_ok = 0, warm_ok = 0, restarts = 0, iterations = 0;
  for (const IkCase& c : ref_.cases) {
    const IkResult result = solver.solve(c.T_target, c.q_seed);
    EXPECT_TRUE(within_limits(*model_, result.q));
    cold_us.push_back(result.time_us);
    restarts += result.restarts;
    iterations += result.iterations;
    cold_ok += result.converged ? 1 : 0;
    solutions.push_back(result.q);
    solved.push_back(result.converged);
  }
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> noise(-0.01, 0.01);
  for (size_t k = 0; k < ref_.cases.size(); ++k) {
    Eigen::VectorXd seed = solutions[k];
    for (Eigen::Index i = 0; i < seed.size(); ++i) seed[i] += noise(rng);
    const IkResult result = solver.solve(ref_.cases[k].T_target, seed);
    EXPECT_TRUE(within_limits(*model_, result.q));
    warm_us.push_back(result.time_us);
    warm_ok += result.converged ? 1 : 0;
    // A warm start near a solution stays by it (the panda's regularisation holds the null space).
    if (solved[k] && result.converged) {
      EXPECT_LT((result.q - seed).cwiseAbs().maxCoeff(), 0.1) << "case " << k;
    }
  }
  const double n = static_cast<double>(ref_.cases.size());
  std::printf("[ ik %s ] 5 ms budget, cold: %d/%zu converged (%.2f %%), median %.1f us, p99 %.1f us, max %.1f us, "
              "%d restarts, %.1f iterations/case\n",
              GetParam().c_str(), cold_ok, ref_.cases.size(), 100.0 * cold_ok / n, percentile(cold_us, 0.5),
              percentile(cold_us, 0.99), percentile(cold_us, 1.0), restarts, iterations / n);
  std::printf("[ ik %s ] 5 ms budget, warm: %d/%zu converged (%.2f %%), median %.1f us, p99 %.1f us\n",
              GetParam().c_str(), warm_ok, ref_.cases.size(), 100.0 * warm_ok / n, percentile(warm_us, 0.5),
              percentile(warm_us, 0.99));
}

// Same inputs, same answer, to the bit, when the restart cap (not the clock) ends the search.
TEST_P(Ik, IsDeterministicWithASeed) {
  IkOptions options;
  options.time_budget = std::chrono::seconds(10);
  options.max_restarts = 3;
  options.rng_seed = 42;
  IkSolver solver(*model_, options);
  Matrix4d far = ref_.cases[0].T_target;
  far(0, 3) += 10.0;  // unreachable: every restart runs
  for (const Matrix4d& T : {Matrix4d(ref_.cases[1].T_target), far}) {
    const IkResult a = solver.solve(T, ref_.cases[1].q_seed);
    const IkResult b = solver.solve(T, ref_.cases[1].q_seed);
    EXPECT_EQ(a.q, b.q);
    EXPECT_EQ(a.restarts, b.restarts);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.converged, b.converged);
  }
  EXPECT_EQ(solver.solve(far, ref_.cases[1].q_seed).restarts, 3);
}

// A target 10 m away: not converged, the best pose found, finite and within the limits, after
// every restart the budget allows.
TEST_P(Ik, ReportsAnUnreachableTarget) {
  IkOptions options;
  options.max_restarts = 20;
  IkSolver solver(*model_, options);
  Matrix4d T = ref_.cases[2].T_target;
  T(2, 3) += 10.0;
  const IkResult result = solver.solve(T, ref_.cases[2].q_seed);
  EXPECT_FALSE(result.converged);
  EXPECT_TRUE(within_limits(*model_, result.q));
  double seed_pos_err, seed_rot_err;
  pose_errors(*model_, ref_.cases[2].q_seed, T, seed_pos_err, seed_rot_err);
  EXPECT_GT(result.pos_err, 8.0);
  EXPECT_LT(result.pos_err, seed_pos_err - 0.1);  // it reached out towards the target
  EXPECT_GT(result.restarts, 0);
  EXPECT_LE(result.restarts, 20);
  double pos_err, rot_err;
  pose_errors(*model_, result.q, T, pos_err, rot_err);
  EXPECT_NEAR(pos_err, result.pos_err, 1e-9);
  EXPECT_NEAR(rot_err, result.rot_err, 1e-9);
}

// An unreachable target with an unlimited restart cap: the budget, in the thread's CPU time, ends
// the search, overrun by at most one iteration.
TEST_P(Ik, StopsWhenTheBudgetIsSpent) {
  IkOptions options;
  options.time_budget = std::chrono::milliseconds(20);
  options.max_restarts = 1'000'000;
  IkSolver solver(*model_, options);
  Matrix4d T = ref_.cases[3].T_target;
  T(0, 3) += 10.0;
  const auto cpu_ms = [] {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
  };
  const double start = cpu_ms();
  const IkResult result = solver.solve(T, ref_.cases[3].q_seed);
  const double spent = cpu_ms() - start;
  EXPECT_FALSE(result.converged);
  EXPECT_GT(result.restarts, 0);
  EXPECT_LT(result.restarts, options.max_restarts);
  EXPECT_GE(spent, 20.0);
  EXPECT_LT(spent, 30.0);  // one iteration is ~5 µs (~50 µs under sanitizers)
}

// The tip reaches the position; the orientation is free.
TEST_P(Ik, PositionOnlyReachesThePosition) {
  IkOptions options;
  options.position_only = true;
  options.time_budget = std::chrono::seconds(1);  // the restart cap binds, not the machine's load
  options.max_restarts = 200;
  IkSolver solver(*model_, options);
  int converged = 0;
  for (size_t k = 0; k < 20; ++k) {
    const IkCase& c = ref_.cases[k];
    const IkResult result = solver.solve(c.T_target, c.q_seed);
    EXPECT_TRUE(within_limits(*model_, result.q));
    double pos_err, rot_err;
    pose_errors(*model_, result.q, c.T_target, pos_err, rot_err);
    if (result.converged) {
      ++converged;
      EXPECT_LE(pos_err, 1e-6);
    }
  }
  EXPECT_EQ(converged, 20);
}

// ∂r/∂q of the cost function against central differences, near and far from the target (far, the
// inverse right Jacobian of the log differs from the identity), full pose and position only.
TEST_P(Ik, AnalyticJacobianMatchesFiniteDifferences) {
  for (bool position_only : {false, true}) {
    IkOptions options;
    options.position_only = position_only;
    options.weights << 1.0, 2.0, 0.5, 3.0, 1.0, 0.25;
    IkSolver solver(*model_, options);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (size_t k = 0; k < 10; ++k) {
      solver.set_target(ref_.cases[k].T_target);
      Eigen::VectorXd q(model_->dof());
      for (int i = 0; i < model_->dof(); ++i) {
        const JointLimits& l = model_->joint(i).limits;
        q[i] = l.lower + (l.upper - l.lower) * unit(rng);
      }
      Vector6d r;
      Matrix6Xd J(6, model_->dof());
      solver.evaluate(q, r, J);
      // Keep away from θ = π, where log jumps.
      if (r.head<3>().cwiseQuotient(options.weights.head<3>()).norm() > 2.8) continue;
      Matrix6Xd J_fd(6, model_->dof());
      const double h = 1e-6;
      for (int i = 0; i < model_->dof(); ++i) {
        Eigen::VectorXd qp = q, qm = q;
        qp[i] += h;
        qm[i] -= h;
        Vector6d rp, rm;
        Matrix6Xd unused(6, model_->dof());
        solver.evaluate(qp, rp, unused);
        solver.evaluate(qm, rm, unused);
        J_fd.col(i) = (rp - rm) / (2.0 * h);
      }
      EXPECT_TRUE(testing::matrices_near(J, J_fd, 1e-6 * std::max(1.0, J.cwiseAbs().maxCoeff())))
          << "case " << k << (position_only ? " position only" : " full pose");
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, Ik, ::testing::Values("ur5", "panda"));

// Arms no solver setting was tuned on (tests/data/lbr7.urdf, a 7-DOF arm laid out like the KUKA
// LBR iiwa; skew6.urdf, six tilted, offset axes and a continuous wrist; arm.urdf, a prismatic and a
// continuous joint): 200 targets each, FK of configurations drawn 5 % inside the limits (FK is
// checked against Pinocchio in kinematics_test), seeds drawn independently. Every one is reached
// within the limits under the restart cap; the 5 ms budget's figures are printed.
struct HeldOutArm {
  const char* urdf;
  const char* tip;
};

class IkHeldOut : public ::testing::TestWithParam<HeldOutArm> {};

TEST_P(IkHeldOut, ReachesTargetsOnAnArmNotTunedFor) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = GetParam().tip;
  const RobotModel model = load_urdf_file(testing::data_path(GetParam().urdf), urdf_options);
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto draw = [&](double margin) {
    Eigen::VectorXd q(model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      const JointLimits& l = model.joint(i).limits;
      q[i] = l.lower + (l.upper - l.lower) * (margin + (1.0 - 2.0 * margin) * unit(rng));
    }
    return q;
  };
  std::vector<IkCase> cases(200);
  for (IkCase& c : cases) {
    c.T_target = forward_kinematics_space(model, draw(0.05)).matrix();
    c.q_seed = draw(0.0);
  }
  // Asserted where the restart cap ends the search (the same on any machine); printed for the
  // default 5 ms budget.
  struct Pass {
    const char* name;
    IkOptions options;
    bool asserted;
  };
  Pass capped{"up to 200 restarts", {}, true};
  capped.options.time_budget = std::chrono::seconds(1);
  capped.options.max_restarts = 200;
  for (const Pass& pass : {capped, Pass{"5 ms budget, cold", {}, false}}) {
    IkSolver solver(model, pass.options);
    int converged = 0;
    std::vector<double> us;
    for (const IkCase& c : cases) {
      const IkResult result = solver.solve(c.T_target, c.q_seed);
      EXPECT_TRUE(within_limits(model, result.q));
      double pos_err, rot_err;
      pose_errors(model, result.q, c.T_target, pos_err, rot_err);
      if (result.converged) {
        EXPECT_LE(pos_err, 1e-6);
        EXPECT_LE(rot_err, 1e-6);
        ++converged;
      }
      us.push_back(result.time_us);
    }
    std::printf("[ ik %s ] %s: %d/%zu converged, median %.1f us, p99 %.1f us\n", GetParam().urdf, pass.name, converged,
                cases.size(), percentile(us, 0.5), percentile(us, 0.99));
    if (pass.asserted) {
      EXPECT_EQ(converged, static_cast<int>(cases.size()));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Arms, IkHeldOut,
                         ::testing::Values(HeldOutArm{"lbr7.urdf", "flange"}, HeldOutArm{"skew6.urdf", "tool"},
                                           HeldOutArm{"arm.urdf", "tip"}),
                         [](const ::testing::TestParamInfo<HeldOutArm>& arm) {
                           std::string name = arm.param.urdf;
                           return name.substr(0, name.find('.'));
                         });

class IkTargets : public ::testing::Test {
 protected:
  void SetUp() override {
    UrdfOptions options;
    options.tip_link = "tool0";
    model_ = std::make_unique<RobotModel>(load_urdf_file(testing::data_path("ur5.urdf"), options));
  }
  std::unique_ptr<RobotModel> model_;
};

TEST_F(IkTargets, RejectsANonRigidOrNonFiniteTarget) {
  IkSolver solver(*model_);
  const Eigen::VectorXd seed = Eigen::VectorXd::Zero(6);
  const Matrix4d good = forward_kinematics_space(*model_, Eigen::VectorXd::Constant(6, 0.3)).matrix();
  auto expect_rejected = [&](const Matrix4d& T, const std::string& fragment) {
    try {
      solver.solve(T, seed);
      ADD_FAILURE() << "accepted a bad target; expected a message with '" << fragment << "'";
    } catch (const ArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  Matrix4d T = good;
  T(1, 2) = std::numeric_limits<double>::quiet_NaN();
  expect_rejected(T, "not finite");
  T = good;
  T(0, 3) = std::numeric_limits<double>::infinity();
  expect_rejected(T, "not finite");
  T = good;
  T.topLeftCorner<3, 3>() *= 1.01;
  expect_rejected(T, "not orthonormal");
  T = good;
  T.col(0) = -T.col(0);  // a reflection
  T(3, 0) = 0.0;
  expect_rejected(T, "det R");
  T = good;
  T(3, 1) = 0.5;
  expect_rejected(T, "bottom row");
  // Off by less than 1e-6 is accepted (and projected onto SO(3)).
  T = good;
  T(0, 0) += 5e-7;
  EXPECT_TRUE(solver.solve(T, seed).converged);
  // The seed is checked too.
  EXPECT_THROW(solver.solve(good, Eigen::VectorXd::Zero(5)), ArgumentError);
  EXPECT_THROW(solver.solve(good, Eigen::VectorXd::Constant(6, std::nan(""))), ArgumentError);
}

// Continuous joints come back wrapped to (−π, π]; a seed outside the limits is clamped into them.
TEST(IkContinuous, WrapsContinuousJointsAndClampsTheSeed) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = "tip";
  const RobotModel model = load_urdf_file(testing::data_path("arm.urdf"), urdf_options);
  IkOptions options;
  options.position_only = true;
  IkSolver solver(model, options);
  Eigen::VectorXd q_true(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const JointLimits& l = model.joint(i).limits;
    q_true[i] = l.lower + 0.7 * (l.upper - l.lower);
  }
  const Matrix4d T = forward_kinematics_space(model, q_true).matrix();
  Eigen::VectorXd seed(model.dof());
  for (int i = 0; i < model.dof(); ++i) seed[i] = model.joint(i).type == JointType::Continuous ? 20.0 : 50.0;
  const IkResult result = solver.solve(T, seed);
  EXPECT_TRUE(result.converged) << result.pos_err;
  EXPECT_TRUE(within_limits(model, result.q));
}

}  // namespace
}  // namespace chasles
