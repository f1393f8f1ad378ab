#include "support/identification_run.hpp"

#include <cmath>
#include <random>

#include "core/dynamics/dynamics.hpp"
#include "core/identification/log_cholesky.hpp"
#include "support/arm.hpp"

namespace chasles::testing {

namespace {

// In [0, 1) from the top 53 bits: the same numbers with every standard library.
double unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

double between(std::mt19937_64& rng, double low, double high) { return low + (high - low) * unit(rng); }

// One joint's trajectory: q = middle + Σ a_l sin(2π f_l t + φ_l) and its two derivatives.
struct Sines {
  double middle = 0.0;
  double a[5], f[5], phase[5];
  void at(double t, double& q, double& qd, double& qdd) const {
    q = middle, qd = 0.0, qdd = 0.0;
    for (int l = 0; l < 5; ++l) {
      const double w = 2.0 * kPi * f[l], angle = w * t + phase[l];
      q += a[l] * std::sin(angle);
      qd += a[l] * w * std::cos(angle);
      qdd -= a[l] * w * w * std::sin(angle);
    }
  }
};

}  // namespace

Eigen::VectorXd TrueArm::parameters() const {
  const int n = model.dof();
  Eigen::VectorXd pi(13 * n);
  for (int i = 0; i < n; ++i) {
    pi.segment<10>(10 * i) = body_parameters(model.body_inertia(i));
    pi[10 * n + i] = viscous[i];
    pi[11 * n + i] = coulomb[i];
    pi[12 * n + i] = model.armature()[i];
  }
  return pi;
}

TrueArm perturbed_panda(uint64_t seed) {
  const RobotModel& nominal = panda();
  const int n = nominal.dof();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd bodies = inertial_parameters(nominal);
  for (int i = 0; i < n; ++i) {
    Vector10d theta = log_cholesky_from_inertia(bodies.row(i).transpose());
    theta[0] += 0.05 * normal(rng);                                // m = e^{2α}: ±10 %
    for (int k = 1; k <= 3; ++k) theta[k] += 0.1 * normal(rng);   // radii of gyration ±10 %
    for (int k = 4; k < 10; ++k) theta[k] += 0.01 * normal(rng);  // shape and centre of mass, m
    bodies.row(i) = inertia_from_log_cholesky(theta).transpose();
  }
  Eigen::VectorXd armature(n), viscous(n), coulomb(n);
  for (int i = 0; i < n; ++i) {
    armature[i] = between(rng, 0.05, 0.3);
    viscous[i] = between(rng, 0.3, 0.6);
    coulomb[i] = between(rng, 0.8, 1.2);
  }
  return {with_armature(with_inertial_parameters(nominal, bodies), armature), viscous, coulomb};
}

JointSamples synthetic_run(const TrueArm& arm, double seconds, double rate_hz, double noise, uint64_t seed, int still) {
  const RobotModel& model = arm.model;
  const int n = model.dof();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double base[5] = {0.1, 0.23, 0.37, 0.55, 0.8};
  std::vector<Sines> joints(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    Sines& s = joints[static_cast<size_t>(i)];
    const JointLimits& l = model.joint(i).limits;
    s.middle = 0.5 * (l.lower + l.upper);
    double total = 0.0;
    for (int k = 0; k < 5; ++k) {
      s.a[k] = between(rng, 0.3, 1.0);
      s.f[k] = base[k] * (1.0 + 0.07 * i);
      s.phase[k] = between(rng, 0.0, 2.0 * kPi);
      total += s.a[k];
    }
    const double reach = i == still ? 0.0 : std::min(0.4 * (l.upper - l.lower), 1.0);
    for (double& a : s.a) a *= reach / total;
  }

  Data data(model);
  Eigen::VectorXd q(n), qd(n), qdd(n);
  // Everything but Coulomb friction, which jumps and is averaged apart.
  const auto smooth_torque = [&](double t) {
    for (int i = 0; i < n; ++i) joints[static_cast<size_t>(i)].at(t, q[i], qd[i], qdd[i]);
    Eigen::VectorXd tau = inverse_dynamics(model, data, q, qd, qdd);
    for (int i = 0; i < n; ++i) tau[i] += arm.viscous[i] * qd[i];
    return tau;
  };
  // The mean of sign q̇_i over [a, b], from its crossing found by bisection (one at most in a step).
  const auto velocity = [&](int i, double t) {
    double q_i, qd_i, qdd_i;
    joints[static_cast<size_t>(i)].at(t, q_i, qd_i, qdd_i);
    return qd_i;
  };
  const auto mean_sign = [&](int i, double a, double b) {
    const double va = velocity(i, a), vb = velocity(i, b);
    const double sa = (va > 0.0) - (va < 0.0), sb = (vb > 0.0) - (vb < 0.0);
    if (sa == sb) return sa;
    double low = a, high = b;
    for (int iteration = 0; iteration < 60; ++iteration) {
      const double middle = 0.5 * (low + high);
      (((velocity(i, middle) > 0.0) - (velocity(i, middle) < 0.0)) == sa ? low : high) = middle;
    }
    return (sa * (low - a) + sb * (b - low)) / (b - a);
  };
  const int N = static_cast<int>(std::lround(seconds * rate_hz));
  const double dt = 1.0 / rate_hz;
  JointSamples samples;
  samples.t.resize(N);
  samples.q.resize(n, N);
  samples.qd.resize(n, N);
  samples.tau.resize(n, N);
  Eigen::VectorXd left = smooth_torque(-dt);
  for (int k = 0; k < N; ++k) {
    const double t = k * dt;
    const Eigen::VectorXd middle = smooth_torque(t - 0.5 * dt);
    const Eigen::VectorXd right = smooth_torque(t);  // leaves q, qd at t
    samples.t[k] = t;
    samples.q.col(k) = q;
    samples.qd.col(k) = qd;
    for (int i = 0; i < n; ++i) {
      samples.tau(i, k) = (left[i] + 4.0 * middle[i] + right[i]) / 6.0 + arm.coulomb[i] * mean_sign(i, t - dt, t) +
                          noise * normal(rng);
    }
    left = right;
  }
  return samples;
}

}  // namespace chasles::testing
