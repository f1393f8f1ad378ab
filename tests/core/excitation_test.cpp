// The excitation trajectory: the series' derivatives against central differences of its positions,
// its positions against the textbook form of Swevers et al., rest at both ends, and an optimised
// Panda trajectory judged on its own: every limit on a 1 ms grid, its W_b rebuilt here and
// decomposed by an SVD (full column rank, the condition number reported), and better conditioned
// than the seeded start it came from.
#include "core/identification/excitation.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/model/urdf.hpp"
#include "support/decompositions.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

RobotModel panda_to_hand() {
  UrdfOptions options;
  options.tip_link = "panda_hand";
  return load_urdf_file(testing::data_path("panda.urdf"), options);
}

// A 7-joint, 5-harmonic series with seeded coefficients of order 0.3 rad/s, at rest at its ends.
FourierTrajectory random_series(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-0.3, 0.3);
  FourierTrajectory s;
  s.period = 8.0;
  s.periods = 3;
  s.start = Eigen::VectorXd(7);
  s.a = Eigen::MatrixXd(7, 5);
  s.b = Eigen::MatrixXd(7, 5);
  for (int i = 0; i < 7; ++i) {
    s.start(i) = unit(rng);
    for (int l = 0; l < 5; ++l) s.a(i, l) = unit(rng), s.b(i, l) = unit(rng);
  }
  make_rest_to_rest(s);
  return s;
}

Eigen::VectorXd position(const FourierTrajectory& s, double t) {
  Eigen::VectorXd q(s.dof()), qd(s.dof()), qdd(s.dof()), qddd(s.dof());
  sample_fourier(s, t, q, qd, qdd, qddd);
  return q;
}

// The ExcitationLimits of the Panda as chasles's controller derives them by default
// (controller/limits.cpp): the URDF's positions less 0.01 rad, its velocities, acceleration =
// velocity / 0.4 s and jerk = acceleration / 0.02 s.
ExcitationLimits panda_limits(const RobotModel& model) {
  const int n = model.dof();
  ExcitationLimits limits;
  limits.lower = limits.upper = limits.velocity = Eigen::VectorXd(n);
  for (int i = 0; i < n; ++i) {
    limits.lower(i) = model.joint(i).limits.lower + 0.01;
    limits.upper(i) = model.joint(i).limits.upper - 0.01;
    limits.velocity(i) = model.joint(i).limits.velocity;
  }
  limits.acceleration = limits.velocity / 0.4;
  limits.jerk = limits.acceleration / 0.02;
  return limits;
}

TEST(Excitation, DerivativesMatchCentralDifferencesOfThePositions) {
  const FourierTrajectory s = random_series(7);
  const int n = s.dof();
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  double worst[3] = {0.0, 0.0, 0.0}, largest[3] = {0.0, 0.0, 0.0};
  for (double t : {0.37, 1.9, 4.0, 6.55, 11.3, 23.99}) {
    sample_fourier(s, t, q, qd, qdd, qddd);
    // Steps balancing truncation (h² times the next derivatives, ≤ (2π L / T_f)² ≈ 15 times the
    // one sought) and rounding (ε |q| / h^d).
    const double h1 = 1e-5, h2 = 1e-4, h3 = 2e-3;
    const Eigen::VectorXd v = (position(s, t + h1) - position(s, t - h1)) / (2 * h1);
    const Eigen::VectorXd a = (position(s, t + h2) - 2 * position(s, t) + position(s, t - h2)) / (h2 * h2);
    const Eigen::VectorXd j = (position(s, t + 2 * h3) - 2 * position(s, t + h3) + 2 * position(s, t - h3) -
                               position(s, t - 2 * h3)) /
                              (2 * h3 * h3 * h3);
    worst[0] = std::max(worst[0], (v - qd).cwiseAbs().maxCoeff());
    worst[1] = std::max(worst[1], (a - qdd).cwiseAbs().maxCoeff());
    worst[2] = std::max(worst[2], (j - qddd).cwiseAbs().maxCoeff());
    largest[0] = std::max(largest[0], qd.cwiseAbs().maxCoeff());
    largest[1] = std::max(largest[1], qdd.cwiseAbs().maxCoeff());
    largest[2] = std::max(largest[2], qddd.cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst[0], 1e-9 * largest[0]);
  EXPECT_LT(worst[1], 1e-6 * largest[1]);
  EXPECT_LT(worst[2], 1e-4 * largest[2]);
}

// The positions are Swevers's series, q0 + Σ [a/(ω l) sin(ω l t) − b/(ω l) cos(ω l t)], with the
// constant q0 = start + Σ b/(ω l) that puts q(0) at the start.
TEST(Excitation, PositionsAreTheFourierSeriesOfSwevers) {
  const FourierTrajectory s = random_series(11);
  const double w = 2.0 * kPi / s.period;
  EXPECT_EQ(s.omega(), w);
  for (double t : {0.0, 0.8, 5.1, 17.25}) {
    Eigen::VectorXd expected = s.start;
    for (int l = 1; l <= 5; ++l) {
      expected += s.b.col(l - 1) / (w * l);
      expected += s.a.col(l - 1) / (w * l) * std::sin(w * l * t) - s.b.col(l - 1) / (w * l) * std::cos(w * l * t);
    }
    EXPECT_LT((position(s, t) - expected).cwiseAbs().maxCoeff(), 1e-14) << "t = " << t;
  }
}

TEST(Excitation, AtRestAtTheStartAndAtTheEndOfEveryPeriod) {
  const FourierTrajectory s = random_series(3);
  const int n = s.dof();
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  sample_fourier(s, 0.0, q, qd, qdd, qddd);
  EXPECT_EQ(q, s.start);
  EXPECT_LT(qd.cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT(qdd.cwiseAbs().maxCoeff(), 1e-15);
  for (int k = 1; k <= s.periods; ++k) {
    sample_fourier(s, k * s.period, q, qd, qdd, qddd);
    EXPECT_LT((q - s.start).cwiseAbs().maxCoeff(), 1e-13) << "period " << k;
    EXPECT_LT(qd.cwiseAbs().maxCoeff(), 1e-13) << "period " << k;
    EXPECT_LT(qdd.cwiseAbs().maxCoeff(), 1e-12) << "period " << k;
  }
  // Not by accident: without a_i1 and b_i1 set so, the series moves at t = 0.
  FourierTrajectory moving = s;
  moving.a(0, 0) += 0.1;
  moving.b(1, 0) += 0.1;
  sample_fourier(moving, 0.0, q, qd, qdd, qddd);
  EXPECT_NEAR(qd(0), 0.1, 1e-15);
  EXPECT_NEAR(qdd(1), 0.1 * moving.omega(), 1e-15);
}

// A short optimisation (20 states a period, 3 harmonics, 15 iterations: what CI affords), judged
// by what it must deliver rather than by its figures.
TEST(Excitation, OptimisedPandaKeepsItsLimitsAndIsBetterConditionedThanItsStart) {
  const RobotModel model = panda_to_hand();
  const int n = model.dof();
  const BaseParameters base = base_parameters(model, 30, 1);
  ASSERT_EQ(base.count, 62);  // regressor_test: 43 inertial + 2 n friction + n − 2 rotors
  const ExcitationLimits limits = panda_limits(model);
  const Eigen::VectorXd start = 0.5 * (limits.lower + limits.upper);
  ExcitationOptions options;
  options.harmonics = 3;
  options.period = 6.0;
  options.periods = 2;
  options.samples = 20;
#ifdef CHASLES_SANITIZED
  options.iterations = 6;  // the sanitizers run the fit 10 times slower; every check holds after 6
#else
  options.iterations = 15;
#endif
  const ExcitationResult result = optimize_excitation(model, base, limits, start, options);
  const FourierTrajectory& s = result.trajectory;
  EXPECT_EQ(s.start, start);
  EXPECT_EQ(s.duration(), 12.0);

  // Every limit, every millisecond of the whole run, and at rest at both ends.
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  double worst = 0.0;  // the largest fraction of a limit used
  for (int k = 0; k <= 12000; ++k) {
    sample_fourier(s, 1e-3 * k, q, qd, qdd, qddd);
    for (int i = 0; i < n; ++i) {
      ASSERT_GE(q(i), limits.lower(i)) << "joint " << i << " at " << 1e-3 * k << " s";
      ASSERT_LE(q(i), limits.upper(i)) << "joint " << i << " at " << 1e-3 * k << " s";
      worst = std::max({worst, std::abs(qd(i)) / limits.velocity(i), std::abs(qdd(i)) / limits.acceleration(i),
                        std::abs(qddd(i)) / limits.jerk(i)});
    }
    if (k == 12000) {
      EXPECT_LT((q - start).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_LT(qd.cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_LT(qdd.cwiseAbs().maxCoeff(), 1e-12);
    }
  }
  EXPECT_LE(worst, 1.0);
  EXPECT_LE(result.peaks.velocity.cwiseQuotient(limits.velocity).maxCoeff(), 1.0);
  EXPECT_EQ(excitation_limit_problem(model, s, limits, 1e-3), "");

  // W_b rebuilt here, at the states the optimiser stacked, and decomposed by an SVD: full column
  // rank r, and the condition number of its unit-norm columns is the one reported.
  RegressorWorkspace workspace(model);
  Eigen::MatrixXd W(options.samples * n, base.count), Y_b(n, base.count);
  for (int k = 0; k < options.samples; ++k) {
    sample_fourier(s, (k + 0.5) * s.period / options.samples, q, qd, qdd, qddd);
    base_regressor(base, joint_torque_regressor(model, workspace, q, qd, qdd), Y_b);
    W.middleRows(k * n, n) = Y_b;
  }
  const Eigen::VectorXd norms = W.colwise().norm();
  const Eigen::MatrixXd W_unit = W * norms.cwiseInverse().asDiagonal();
  const Eigen::VectorXd sigma = Eigen::JacobiSVD<Eigen::MatrixXd>(W_unit).singularValues();
  EXPECT_GT(sigma(base.count - 1), 1e-6 * sigma(0)) << "rank below " << base.count;
  EXPECT_NEAR(result.condition_number, sigma(0) / sigma(base.count - 1), 1e-8 * result.condition_number);
  EXPECT_EQ(result.condition_number, result.scaled_condition_number);
  const Eigen::VectorXd raw = Eigen::JacobiSVD<Eigen::MatrixXd>(W).singularValues();
  EXPECT_NEAR(result.raw_condition_number, raw(0) / raw(base.count - 1), 1e-6 * result.raw_condition_number);

  EXPECT_LT(result.condition_number, result.start_condition_number);
  EXPECT_GT(result.iterations, 0);
  // Deterministic: the same seed, the same coefficients.
  EXPECT_EQ(optimize_excitation(model, base, limits, start, options).trajectory.a, s.a);
  std::cout << "cond(W_b) " << result.start_condition_number << " -> " << result.condition_number << " (raw "
            << result.raw_condition_number << ") in " << result.iterations << " iterations, " << result.seconds
            << " s\n";
}

TEST(Excitation, RefusesWhatItCannotDo) {
  const RobotModel model = panda_to_hand();
  const BaseParameters base = base_parameters(model, 30, 1);
  const ExcitationLimits limits = panda_limits(model);
  ExcitationOptions options;
  options.samples = 20;
  options.iterations = 0;
  const auto message = [&](const Eigen::VectorXd& start, const ExcitationOptions& o, const ExcitationLimits& l) {
    try {
      optimize_excitation(model, base, l, start, o);
    } catch (const ArgumentError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const auto contains = [](const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
  };
  Eigen::VectorXd start = 0.5 * (limits.lower + limits.upper);
  // Joint 4 of the Panda bends only one way: its middle less nothing is fine, its upper limit is not.
  Eigen::VectorXd at_limit = start;
  at_limit(3) = limits.upper(3);
  EXPECT_TRUE(contains(message(at_limit, options, limits), "joint panda_joint4 at")) << message(at_limit, options, limits);
  EXPECT_TRUE(contains(message(start.head(6), options, limits), "6 values where the arm has 7"));
  ExcitationOptions one = options;
  one.harmonics = 1;
  EXPECT_TRUE(contains(message(start, one, limits), "harmonics"));
  ExcitationOptions few = options;
  few.samples = 8;  // 56 torques for 62 parameters
  EXPECT_TRUE(contains(message(start, few, limits), "cannot determine 62"));
  ExcitationLimits negative = limits;
  negative.jerk(2) = 0.0;
  EXPECT_TRUE(contains(message(start, options, negative), "must be positive"));
  // A trajectory ten times too fast is caught, naming the joint and the quantity.
  FourierTrajectory fast = optimize_excitation(model, base, limits, start, options).trajectory;
  fast.a *= 10.0;
  fast.b *= 10.0;
  EXPECT_TRUE(contains(excitation_limit_problem(model, fast, limits, 1e-3), "joint panda_joint"));
}

}  // namespace
}  // namespace chasles
