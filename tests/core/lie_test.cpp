// Properties of the Lie-group layer over seeded random inputs, and a decade sweep of exp and log
// against an independent long-double evaluation.
#include "core/lie/lie.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::matrices_near;

constexpr int kSamples = 200;

struct Random {
  std::mt19937_64 rng{20261123};
  std::uniform_real_distribution<double> uniform{-1.0, 1.0};

  Vector3d vec3() { return Vector3d(uniform(rng), uniform(rng), uniform(rng)); }
  Vector3d unit3() { return vec3().normalized(); }
  double angle(double lo, double hi) { return lo + (hi - lo) * 0.5 * (1.0 + uniform(rng)); }
  // A twist whose rotation angle is below π, so log recovers it.
  Vector6d twist() {
    Vector6d V;
    V << unit3() * angle(0.0, 3.1), vec3();
    return V;
  }
  Transform transform() { return exp6(twist()); }
};

// --- long double reference: power series summed to convergence (no cut-offs, no closed forms
// whose cancellation would need them), so it is independent of the code under test.
using Matrix3ld = Eigen::Matrix<long double, 3, 3>;
using Vector3ld = Eigen::Matrix<long double, 3, 1>;

struct SeriesCoefficients {
  long double a, b, c;  // sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³
};

SeriesCoefficients series(long double theta) {
  const long double t2 = theta * theta;
  SeriesCoefficients k{0, 0, 0};
  long double term_a = 1, term_b = 0.5L, term_c = 1.0L / 6;  // θ^{2m}/(2m+1)!, /(2m+2)!, /(2m+3)!
  for (int m = 0; m < 60; ++m) {
    const long double sign = (m % 2 == 0) ? 1 : -1;
    k.a += sign * term_a;
    k.b += sign * term_b;
    k.c += sign * term_c;
    term_a *= t2 / ((2 * m + 2) * (2 * m + 3));
    term_b *= t2 / ((2 * m + 3) * (2 * m + 4));
    term_c *= t2 / ((2 * m + 4) * (2 * m + 5));
  }
  return k;
}

Matrix3ld hat_ld(const Vector3ld& w) {
  Matrix3ld W;
  W << 0, -w(2), w(1), w(2), 0, -w(0), -w(1), w(0), 0;
  return W;
}

Matrix4d exp6_long_double(const Vector6d& V) {
  const Vector3ld w = V.head<3>().cast<long double>();
  const Vector3ld v = V.tail<3>().cast<long double>();
  const auto k = series(std::sqrt(w.squaredNorm()));
  const Matrix3ld W = hat_ld(w);
  const Matrix3ld R = Matrix3ld::Identity() + k.a * W + k.b * W * W;
  const Vector3ld p = v + k.b * (W * v) + k.c * (W * (W * v));
  Eigen::Matrix<long double, 4, 4> T = Eigen::Matrix<long double, 4, 4>::Identity();
  T.topLeftCorner<3, 3>() = R;
  T.topRightCorner<3, 1>() = p;
  return T.cast<double>();
}

Transform to_transform(const Matrix4d& m) { return Transform(m.topLeftCorner<3, 3>(), m.topRightCorner<3, 1>()); }

// --- so(3) and se(3) basics ---------------------------------------------------------------

TEST(Lie, HatIsTheCrossProductAndVeeInvertsIt) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector3d w = r.vec3(), x = r.vec3();
    EXPECT_TRUE(matrices_near(hat3(w) * x, w.cross(x), 1e-15));
    EXPECT_TRUE(matrices_near(hat3(w) + hat3(w).transpose(), Matrix3d::Zero(), 0.0));
    EXPECT_EQ(vee3(hat3(w)), w);
    Vector6d V;
    V << w, x;
    EXPECT_EQ(vee6(hat6(V)), V);
  }
}

TEST(Lie, ExpIsTheMatrixExponential) {
  // exp([V]) against the matrix exponential summed as a power series of the 4×4 matrix [V].
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector6d V = r.twist();
    const Matrix4d X = hat6(V);
    Matrix4d sum = Matrix4d::Identity(), term = Matrix4d::Identity();
    for (int k = 1; k < 40; ++k) {
      term = term * X / k;
      sum += term;
    }
    EXPECT_TRUE(matrices_near(exp6(V).matrix(), sum, 1e-13));
  }
}

TEST(Lie, ExpOfLogIsIdentity) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Transform T = r.transform();
    EXPECT_TRUE(matrices_near(exp6(log6(T)).matrix(), T.matrix(), 1e-14));
    EXPECT_TRUE(matrices_near(exp3(log3(T.linear())), T.linear(), 1e-14));
  }
}

TEST(Lie, LogOfExpIsIdentityBelowPi) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector6d V = r.twist();
    EXPECT_TRUE(matrices_near(log6(exp6(V)), V, 1e-12));
  }
}

TEST(Lie, ExpAboutAUnitAxisIsExp) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector3d axis = r.unit3();
    const double theta = r.angle(-10.0, 10.0);
    EXPECT_TRUE(matrices_near(exp3_unit(axis, theta), exp3(axis * theta), 1e-14));
  }
}

TEST(Lie, ExpOfZeroIsIdentityAndLogOfIdentityIsZero) {
  EXPECT_EQ(exp6(Vector6d::Zero()).matrix(), Matrix4d::Identity());
  EXPECT_EQ(log6(Transform::Identity()), Vector6d::Zero());
  EXPECT_EQ(exp3(Vector3d::Zero()), Matrix3d::Identity());
  EXPECT_EQ(log3(Matrix3d::Identity()), Vector3d::Zero());
}

TEST(Lie, PureTranslation) {
  Vector6d V;
  V << 0, 0, 0, 1.5, -2.0, 0.25;
  const Transform T = exp6(V);
  EXPECT_EQ(T.linear(), Matrix3d::Identity());
  EXPECT_TRUE(matrices_near(T.translation(), V.tail<3>(), 0.0));
  EXPECT_TRUE(matrices_near(log6(T), V, 0.0));
}

TEST(Lie, InverseComposesToIdentity) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Transform T = r.transform();
    EXPECT_TRUE(matrices_near((inverse(T) * T).matrix(), Matrix4d::Identity(), 1e-14));
    EXPECT_TRUE(matrices_near(inverse(T).matrix(), T.matrix().inverse(), 1e-13));
  }
}

TEST(Lie, AdjointIsAHomomorphismAndConjugatesTwists) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Transform T1 = r.transform(), T2 = r.transform();
    const Vector6d V = r.twist();
    EXPECT_TRUE(matrices_near(adjoint(T1 * T2), adjoint(T1) * adjoint(T2), 1e-13));
    EXPECT_TRUE(matrices_near(adjoint(inverse(T1)), adjoint(T1).inverse(), 1e-12));
    // [Ad_T V] = T [V] T⁻¹ (MR eq. 3.83) and hence exp([Ad_T V]) = T exp([V]) T⁻¹.
    EXPECT_TRUE(matrices_near(hat6(adjoint(T1) * V), T1.matrix() * hat6(V) * T1.matrix().inverse(), 1e-13));
    EXPECT_TRUE(matrices_near(exp6(adjoint(T1) * V).matrix(), (T1 * exp6(V) * inverse(T1)).matrix(), 1e-12));
  }
}

TEST(Lie, MatrixFreeFormsMatchTheMatrices) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Transform T = r.transform();
    const Vector6d V1 = r.twist(), V2 = r.twist();
    EXPECT_TRUE(matrices_near(adjoint_times(T, V1), adjoint(T) * V1, 1e-14));
    EXPECT_TRUE(matrices_near(adjoint_inverse_times(T, V1), adjoint(inverse(T)) * V1, 1e-14));
    EXPECT_TRUE(matrices_near(adjoint_transpose_times(T, V1), adjoint(T).transpose() * V1, 1e-14));
    EXPECT_TRUE(matrices_near(adjoint_inverse_transpose_times(T, V1), adjoint(inverse(T)).transpose() * V1, 1e-14));
    EXPECT_TRUE(matrices_near(ad_times(V1, V2), ad(V1) * V2, 1e-14));
    EXPECT_TRUE(matrices_near(ad_transpose_times(V1, V2), ad(V1).transpose() * V2, 1e-14));
  }
}

TEST(Lie, AdIsTheLieBracket) {
  // [ad_V1 V2] = [V1][V2] − [V2][V1] (MR §8.2.2).
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector6d V1 = r.twist(), V2 = r.twist();
    EXPECT_TRUE(matrices_near(hat6(ad(V1) * V2), hat6(V1) * hat6(V2) - hat6(V2) * hat6(V1), 1e-14));
  }
}

TEST(Lie, AdjointIsTheDerivativeOfConjugation) {
  // d/dt T exp([V]t) T⁻¹ at t = 0 is [Ad_T V], by central differences.
  Random r;
  const double h = 1e-6;
  for (int i = 0; i < 20; ++i) {
    const Transform T = r.transform();
    const Vector6d V = r.twist();
    const Matrix4d d = ((T * exp6(V * h) * inverse(T)).matrix() - (T * exp6(-V * h) * inverse(T)).matrix()) / (2 * h);
    EXPECT_TRUE(matrices_near(d, hat6(adjoint(T) * V), 1e-8));
  }
}

// --- screws ---------------------------------------------------------------------------------

TEST(Screw, TwistOfAScrewAxis) {
  // A screw through q = (0, 2, 0) along ẑ with pitch 2: S = (0, 0, 1, 2, 0, 2) (MR example 3.26).
  const ScrewAxis screw{Vector3d(0, 2, 0), Vector3d::UnitZ(), 2.0};
  Vector6d expected;
  expected << 0, 0, 1, 2, 0, 2;
  EXPECT_TRUE(matrices_near(twist_from_screw(screw), expected, 1e-15));
  EXPECT_TRUE(matrices_near(twist_from_screw(screw, 3.0), 3.0 * expected, 1e-15));
}

TEST(Screw, ScrewFromTwistRoundTrip) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector6d V = r.twist();
    const ScrewAxis screw = screw_from_twist(V);
    const double theta_dot = exponential_coordinates(V).theta;
    EXPECT_NEAR(screw.s.norm(), 1.0, 1e-15);
    EXPECT_NEAR(screw.q.dot(screw.s), 0.0, 1e-14);  // the point nearest the origin
    EXPECT_TRUE(matrices_near(twist_from_screw(screw, theta_dot), V, 1e-14));
  }
}

TEST(Screw, PureTranslationHasInfinitePitch) {
  Vector6d V;
  V << 0, 0, 0, 0, 3, 4;
  const ScrewAxis screw = screw_from_twist(V);
  EXPECT_TRUE(screw.is_translation());
  EXPECT_TRUE(matrices_near(screw.s, Vector3d(0, 0.6, 0.8), 1e-15));
  EXPECT_DOUBLE_EQ(exponential_coordinates(V).theta, 5.0);
  EXPECT_TRUE(matrices_near(twist_from_screw(screw, 5.0), V, 1e-15));
}

TEST(Screw, ExponentialCoordinatesOfATransform) {
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Transform T = r.transform();
    const ExponentialCoordinates e = exponential_coordinates(T);
    EXPECT_NEAR(e.S.head<3>().norm(), 1.0, 1e-14);
    EXPECT_TRUE(matrices_near(exp6(e.S * e.theta).matrix(), T.matrix(), 1e-14));
  }
  Transform shift = Transform::Identity();
  shift.translation() << 0, 0, -2;
  const ExponentialCoordinates e = exponential_coordinates(shift);
  EXPECT_DOUBLE_EQ(e.theta, 2.0);
  EXPECT_TRUE(matrices_near(e.S, (Vector6d() << 0, 0, 0, 0, 0, -1).finished(), 0.0));
  EXPECT_EQ(exponential_coordinates(Transform::Identity()).theta, 0.0);
}

// --- decade sweep against long double ---------------------------------------------------------

class DecadeSweep : public ::testing::TestWithParam<double> {};

TEST_P(DecadeSweep, ExpMatchesLongDouble) {
  Random r;
  const double theta = GetParam();
  for (int i = 0; i < 50; ++i) {
    Vector6d V;
    V << r.unit3() * theta, r.vec3();
    EXPECT_TRUE(matrices_near(exp6(V).matrix(), exp6_long_double(V), 1e-14)) << "theta " << theta;
  }
}

TEST_P(DecadeSweep, LogRecoversTheTwist) {
  // Up to π − 1e-6 the logarithm is unique and must come back within 1e-12; at π it has two
  // values (see LogAtPi), so there the test asks for exp(log(T)) = T instead.
  Random r;
  const double theta = GetParam();
  for (int i = 0; i < 50; ++i) {
    Vector6d V;
    V << r.unit3() * theta, r.vec3();
    const Transform T = to_transform(exp6_long_double(V));
    if (theta <= kPi - 1e-6) {
      EXPECT_TRUE(matrices_near(log6(T), V, 1e-12)) << "theta " << theta;
    } else {
      EXPECT_TRUE(matrices_near(exp6(log6(T)).matrix(), T.matrix(), 1e-14)) << "theta " << theta;
    }
  }
}

std::vector<double> sweep_angles() {
  std::vector<double> angles;
  for (int k = -12; k <= 0; ++k) angles.push_back(std::pow(10.0, k));
  for (double t : {2.0, 3.0, 3.1, 3.14}) angles.push_back(t);
  for (int k = 1; k <= 6; ++k) angles.push_back(kPi - std::pow(10.0, -k));
  angles.push_back(kPi);
  return angles;
}

INSTANTIATE_TEST_SUITE_P(Angles, DecadeSweep, ::testing::ValuesIn(sweep_angles()));

TEST(Lie, LogAtPi) {
  // Rotations by exactly π have two logarithms, ±π ω̂: either axis sign is right.
  Random r;
  for (int i = 0; i < kSamples; ++i) {
    const Vector3d axis = r.unit3();
    const Matrix3d R = 2.0 * axis * axis.transpose() - Matrix3d::Identity();  // exactly π about axis
    const Vector3d w = log3(R);
    EXPECT_NEAR(w.norm(), kPi, 1e-12);
    EXPECT_NEAR(std::abs(w.normalized().dot(axis)), 1.0, 1e-12);
    EXPECT_TRUE(matrices_near(exp3(w), R, 1e-14));
  }
  // Axis-aligned half-turns, where R − Rᵀ is exactly zero.
  for (int k = 0; k < 3; ++k) {
    Matrix3d R = -Matrix3d::Identity();
    R(k, k) = 1.0;
    const Vector3d w = log3(R);
    EXPECT_TRUE(matrices_near(w.cwiseAbs(), kPi * Vector3d::Unit(k), 1e-15));
  }
}

TEST(Lie, LogNearPiKeepsTheSign) {
  // Just below π the skew part is tiny but still decides the sign of the axis.
  Random r;
  for (int k = 3; k <= 9; ++k) {
    for (int i = 0; i < 20; ++i) {
      const Vector3d w = r.unit3() * (kPi - std::pow(10.0, -k));
      EXPECT_TRUE(matrices_near(log3(exp3(w)), w, 1e-12)) << "π − 1e-" << k;
    }
  }
}

// exp(ξ + h e_j) ≈ exp(ξ) exp(h Jr e_j): Jr by finite differences of the body-frame twist, from
// tiny to large angles; and Jr⁻¹ is its inverse.
TEST(Jacobians, RightJacobianOfSe3AndItsInverse) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (double scale : {1e-9, 1e-3, 0.05, 0.5, 2.0}) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = scale * normal(rng);
    const Matrix6d J = se3_right_jacobian(xi);
    for (int j = 0; j < 6; ++j) {
      const double h = 1e-6;
      Vector6d plus = xi, minus = xi;
      plus[j] += h;
      minus[j] -= h;
      const Vector6d d = (log6(inverse(exp6(xi)) * exp6(plus)) - log6(inverse(exp6(xi)) * exp6(minus))) / (2.0 * h);
      EXPECT_TRUE(matrices_near(J.col(j), d, 1e-8)) << "scale " << scale << " column " << j;
    }
    EXPECT_TRUE(matrices_near(se3_right_jacobian_inverse(xi) * J, Matrix6d::Identity(), 1e-9)) << scale;
    const Vector3d phi = xi.head<3>();
    EXPECT_TRUE(matrices_near(so3_right_jacobian_inverse(phi) * so3_left_jacobian(-phi), Matrix3d::Identity(), 1e-9));
  }
}

// The batched sin and cos (lie/sincos.hpp) against long double, within 1 ulp: joint-range angles,
// angles within 1e-6 of a multiple of π/2 (where the reduction cancels), tiny ones, and ones up to
// the reduction's limit; beyond it, and at ±∞ and NaN, the same as glibc's, which it hands them to.
TEST(SinCos, BatchedWithinOneUlpOfLongDouble) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto ulp_error = [](double got, long double truth) {
    const double rounded = static_cast<double>(truth);
    const double ulp = std::nextafter(std::abs(rounded), INFINITY) - std::abs(rounded);
    return static_cast<double>(std::abs(static_cast<long double>(got) - truth) / ulp);
  };
  constexpr int kAngles = 200001;  // odd: the last one goes through the unpaired lane
  std::vector<double> theta(kAngles), s(kAngles), c(kAngles);
  for (int k = 0; k < kAngles; ++k) {
    switch (k % 4) {
      case 0: theta[k] = 7.0 * unit(rng); break;
      case 1: theta[k] = std::round(20.0 * unit(rng)) * (kPi / 2.0) + 1e-6 * unit(rng); break;
      case 2: theta[k] = std::ldexp(unit(rng), -static_cast<int>(rng() % 60)); break;
      default: theta[k] = 5e5 * unit(rng); break;
    }
  }
  sin_cos(theta.data(), kAngles, s.data(), c.data());
  double worst = 0.0;
  for (int k = 0; k < kAngles; ++k) {
    worst = std::max({worst, ulp_error(s[k], std::sin(static_cast<long double>(theta[k]))),
                      ulp_error(c[k], std::cos(static_cast<long double>(theta[k])))});
  }
  EXPECT_LT(worst, 1.0);
  std::vector<double> outside = {6e5, -1e9, 1e300, INFINITY, -INFINITY, NAN, 0.0, -0.0};
  std::vector<double> so(outside.size()), co(outside.size());
  sin_cos(outside.data(), static_cast<int>(outside.size()), so.data(), co.data());
  for (size_t k = 0; k < outside.size(); ++k) {
    double gs = 0.0, gc = 0.0;
    sin_cos(outside[k], gs, gc);
    EXPECT_EQ(std::isnan(so[k]), std::isnan(gs)) << outside[k];
    if (!std::isnan(gs)) {
      EXPECT_EQ(so[k], gs) << outside[k];
      EXPECT_EQ(co[k], gc) << outside[k];
      EXPECT_EQ(std::signbit(so[k]), std::signbit(gs)) << outside[k];
    }
  }
}

}  // namespace
}  // namespace chasles
