// The torque-semantics check on torques made up to its cases: the arm applies the command (with
// noise, a step's lag, friction), the command + g(q), the command − g(q); too little gravity to
// tell; a verdict at the end of each window and none before.
#include <gtest/gtest.h>

#include <random>

#include "controller/semantics_check.hpp"

namespace chasles::controller {
namespace {

using Verdict = TorqueSemanticsCheck::Verdict;
using Eigen::VectorXd;

// A window of 1 ms steps: g(q) of a Panda-like size swinging with the pose, the command a moving
// torque around it, the arm applying command + share · g + what `extra` adds; the verdict at the
// window's end, and that none came before it.
Verdict window(TorqueSemanticsCheck& check, double share, double gravity_scale, double noise, bool lag = false) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, noise);
  const double dt = 1e-3;
  const int steps = static_cast<int>(std::lround(TorqueSemanticsCheck::kWindow / dt));
  VectorXd g(7), commanded(7), previous = VectorXd::Zero(7), applied(7);
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    for (int i = 0; i < 7; ++i) {
      g(i) = gravity_scale * (i % 2 == 0 ? 0.5 : 20.0) * std::cos(0.8 * t + i);
      commanded(i) = g(i) + 5.0 * std::sin(6.0 * t + 0.3 * i);  // a move's torque on top
    }
    applied = (lag && k > 0 ? previous : commanded) + share * g;
    for (int i = 0; i < 7; ++i) applied(i) += normal(rng) - 0.3 * std::tanh(std::sin(6.0 * t + i) / 0.01);  // friction
    previous = commanded;
    const Verdict v = check.update(applied, commanded, g, dt);
    if (k + 1 < steps) {
      EXPECT_EQ(v, Verdict::kUndecided) << "step " << k;
    } else {
      return v;
    }
  }
  return Verdict::kUndecided;
}

TEST(TorqueSemanticsCheck, TheArmApplyingTheCommandAgrees) {
  TorqueSemanticsCheck check;
  EXPECT_EQ(window(check, 0.0, 1.0, 0.05), Verdict::kAgreed);
  EXPECT_NEAR(check.share(), 0.0, 0.05);
  EXPECT_EQ(window(check, 0.0, 1.0, 0.5, true), Verdict::kAgreed);  // a step late, noisier
  EXPECT_NEAR(check.share(), 0.0, 0.05);
}

TEST(TorqueSemanticsCheck, ADriversGravityAddedOrMissingIsFoundWithItsSign) {
  TorqueSemanticsCheck check;
  EXPECT_EQ(window(check, 1.0, 1.0, 0.05), Verdict::kDriverAddsGravity);
  EXPECT_NEAR(check.share(), 1.0, 0.05);
  EXPECT_EQ(window(check, -1.0, 1.0, 0.05), Verdict::kDriverAddsNothing);
  EXPECT_NEAR(check.share(), -1.0, 0.05);
  // A driver's model of gravity off by a fifth is still its gravity.
  EXPECT_EQ(window(check, 0.8, 1.0, 0.05), Verdict::kDriverAddsGravity);
}

TEST(TorqueSemanticsCheck, TooLittleGravityOrAnAmbiguousShareDecidesNothing) {
  TorqueSemanticsCheck check;
  // An arm near upright: g(q) of 0.5 N·m RMS, under kMinGravity.
  EXPECT_EQ(window(check, 1.0, 0.05, 0.0), Verdict::kUndecided);
  // Between the bounds: the next window decides.
  EXPECT_EQ(window(check, 0.4, 1.0, 0.0), Verdict::kUndecided);
  EXPECT_EQ(window(check, 0.0, 1.0, 0.0), Verdict::kAgreed);
  // No time, no evidence.
  const VectorXd g = VectorXd::Constant(7, 10.0);
  EXPECT_EQ(check.update(g, VectorXd::Zero(7), g, 0.0), Verdict::kUndecided);
}

}  // namespace
}  // namespace chasles::controller
