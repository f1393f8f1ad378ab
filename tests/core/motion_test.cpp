// The online trajectory generator (core/motion) against independent checks: the textbook
// durations of rest-to-rest moves, the time-optimal velocity ramp (a lower bound on any motion to
// a target velocity and acceleration, reached exactly when the target position is where that ramp
// ends), fine sampling of thousands of seeded random 7-axis plans (start, end, continuity and every
// limit, by Taylor bounds between samples), min_duration, the brake from outside the limits, a
// replanning loop at 1 kHz toward a moving target, refusals, and no allocation per call.
#include "core/motion/online_generator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.hpp"
#include "support/allocation_counter.hpp"

namespace chasles::motion {
namespace {

struct Problem {
  KinematicState current, target;
  Limits limits;
};

Eigen::VectorXd vec(std::initializer_list<double> x) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(x.size()));
  Eigen::Index k = 0;
  for (double v : x) out[k++] = v;
  return out;
}

Problem single(double p0, double v0, double a0, double pf, double vf, double af, double V, double A, double J) {
  return {{vec({p0}), vec({v0}), vec({a0})}, {vec({pf}), vec({vf}), vec({af})}, {vec({V}), vec({A}), vec({J})}};
}

// Seeded random problems within the limits: current a in [−A, A], v where |v| ≤ V and
// |v + a|a|/(2J)| ≤ V (not bound to leave the limit); target a = 0 or in [−A, A], v where
// |v − a|a|/(2J)| ≤ V; positions in [−π, π]; the Panda's limits, or each scaled down at random.
Problem random_problem(std::mt19937_64& rng, int dof) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const double panda_v[7] = {2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
  const double panda_a[7] = {15, 7.5, 10, 12.5, 15, 20, 20};
  const double panda_j[7] = {7500, 3750, 5000, 6250, 7500, 10000, 10000};
  Problem pr;
  for (Eigen::VectorXd* x : {&pr.current.p, &pr.current.v, &pr.current.a, &pr.target.p, &pr.target.v, &pr.target.a,
                             &pr.limits.velocity, &pr.limits.acceleration, &pr.limits.jerk}) {
    x->resize(dof);
  }
  const bool scaled = unit(rng) < 0.3, zero_af = unit(rng) < 0.5;
  for (int i = 0; i < dof; ++i) {
    const double V = panda_v[i % 7] * (scaled ? uniform(0.05, 1.0) : 1.0);
    const double A = panda_a[i % 7] * (scaled ? uniform(0.05, 1.0) : 1.0);
    const double J = panda_j[i % 7] * (scaled ? uniform(0.02, 1.0) : 1.0);
    pr.limits.velocity[i] = V;
    pr.limits.acceleration[i] = A;
    pr.limits.jerk[i] = J;
    pr.current.p[i] = uniform(-M_PI, M_PI);
    pr.current.a[i] = uniform(-A, A);
    const double c0 = pr.current.a[i] * std::abs(pr.current.a[i]) / (2 * J);
    pr.current.v[i] = uniform(std::max(-V, -V - c0), std::min(V, V - c0));
    pr.target.p[i] = uniform(-M_PI, M_PI);
    pr.target.a[i] = zero_af ? 0.0 : uniform(-A, A);
    const double cf = pr.target.a[i] * std::abs(pr.target.a[i]) / (2 * J);
    pr.target.v[i] = uniform(std::max(-V, -V + cf), std::min(V, V + cf));
  }
  return pr;
}

// Samples the plan every h and checks, independently of how it was made: the start is exactly the
// current state, the end (at duration()) the target within 1e-8, every axis's own profile ends at
// duration(), |v| and |a| within their limits (1e-9 relative) from `limits_from` on, and between
// consecutive samples the Taylor bounds of a motion whose jerk is at most J in magnitude:
// |Δa| ≤ J h, |Δv − a h| ≤ J h²/2, |Δp − v h − a h²/2| ≤ J h³/6 (continuity of p, v, a and the
// jerk limit at once).
void expect_valid(const OnlineGenerator& otg, const Problem& pr, double h, double limits_from = 0.0) {
  const int n = otg.dof();
  const double T = otg.duration();
  KinematicState s, next;
  otg.at_time(0.0, s);
  for (int i = 0; i < n; ++i) {
    ASSERT_EQ(s.p[i], pr.current.p[i]);
    ASSERT_EQ(s.v[i], pr.current.v[i]);
    ASSERT_EQ(s.a[i], pr.current.a[i]);
    ASSERT_NEAR(otg.axis(i).duration(), T, 1e-9) << "axis " << i;
  }
  const int steps = static_cast<int>(std::ceil(T / h));
  double t = 0.0;
  for (int k = 1; k <= steps; ++k) {
    const double t_next = std::min(k * h, T);
    const double dt = t_next - t;
    otg.at_time(t_next, next);
    for (int i = 0; i < n; ++i) {
      const double V = pr.limits.velocity[i], A = pr.limits.acceleration[i], J = pr.limits.jerk[i];
      if (t_next >= limits_from) {
        ASSERT_LE(std::abs(next.v[i]), V * (1 + 1e-9)) << "axis " << i << " at t = " << t_next;
        ASSERT_LE(std::abs(next.a[i]), A * (1 + 1e-9)) << "axis " << i << " at t = " << t_next;
      }
      ASSERT_LE(std::abs(next.a[i] - s.a[i]), J * dt * (1 + 1e-9) + 1e-9) << "axis " << i << " at t = " << t_next;
      ASSERT_LE(std::abs(next.v[i] - s.v[i] - s.a[i] * dt), J * dt * dt / 2 * (1 + 1e-9) + 1e-11)
          << "axis " << i << " at t = " << t_next;
      ASSERT_LE(std::abs(next.p[i] - s.p[i] - s.v[i] * dt - s.a[i] * dt * dt / 2), J * dt * dt * dt / 6 * (1 + 1e-9) + 1e-11)
          << "axis " << i << " at t = " << t_next;
    }
    s = next;
    t = t_next;
  }
  otg.at_time(T, s);
  for (int i = 0; i < n; ++i) {
    ASSERT_NEAR(s.p[i], pr.target.p[i], 1e-8) << "axis " << i;
    ASSERT_NEAR(s.v[i], pr.target.v[i], 1e-8) << "axis " << i;
    ASSERT_NEAR(s.a[i], pr.target.a[i], 1e-8) << "axis " << i;
  }
}

double plan_duration(const Problem& pr) {
  OnlineGenerator otg(static_cast<int>(pr.current.p.size()));
  EXPECT_TRUE(otg.plan(pr.current, pr.target, pr.limits)) << otg.reason();
  expect_valid(otg, pr, 1e-4);
  return otg.duration();
}

// Rest to rest, the four textbook shapes of the symmetric jerk-limited move over a distance D.
TEST(Motion, RestToRestAllPhasesTakesDistanceOverVPlusVOverAPlusAOverJ) {
  // Cruise and both acceleration plateaus: needs V ≥ A²/J and D ≥ V (V/A + A/J).
  const double V = 1.0, A = 2.0, J = 10.0, D = 3.0;
  EXPECT_NEAR(plan_duration(single(0.5, 0, 0, 0.5 + D, 0, 0, V, A, J)), D / V + V / A + A / J, 1e-12);
  EXPECT_NEAR(plan_duration(single(0.5, 0, 0, 0.5 - D, 0, 0, V, A, J)), D / V + V / A + A / J, 1e-12);
}

TEST(Motion, RestToRestWithoutCruiseTakesTauPlusRootOfTauSquaredPlus4DOverA) {
  // Acceleration plateaus, no cruise: T = τ + √(τ² + 4D/A), τ = A/J, while the peak velocity
  // A(T/2 − τ) stays under V.
  const double V = 10.0, A = 2.0, J = 10.0, D = 1.0, tau = A / J;
  const double T = tau + std::sqrt(tau * tau + 4 * D / A);
  ASSERT_LT(A * (T / 2 - tau), V);
  EXPECT_NEAR(plan_duration(single(0, 0, 0, D, 0, 0, V, A, J)), T, 1e-12);
}

TEST(Motion, RestToRestShortTakesFourTimesCubeRootOfDOver2J) {
  // Neither plateau nor cruise: four jerk phases of t = (D/(2J))^(1/3) each, while J t ≤ A and
  // J t² ≤ V.
  const double V = 1.0, A = 2.0, J = 10.0, D = 0.05, t = std::cbrt(D / (2 * J));
  ASSERT_LT(J * t, A);
  ASSERT_LT(J * t * t, V);
  EXPECT_NEAR(plan_duration(single(-1, 0, 0, -1 + D, 0, 0, V, A, J)), 4 * t, 1e-12);
}

TEST(Motion, RestToRestVelocityLimitedWithoutAccelerationPlateauTakesDOverVPlus2RootVOverJ) {
  // V < A²/J: each ramp is +J, −J for √(V/J) each, covering V √(V/J); T = D/V + 2√(V/J).
  const double V = 0.2, A = 2.0, J = 10.0, D = 2.0;
  ASSERT_LT(V, A * A / J);
  EXPECT_NEAR(plan_duration(single(0, 0, 0, D, 0, 0, V, A, J)), D / V + 2 * std::sqrt(V / J), 1e-12);
}

// The time-optimal change of (v, a) alone, written here from its two possible shapes (jerk s·J up
// to a peak s·ap, held at A if ap reaches it, then −s·J to a1), the faster valid one: no motion to
// (v1, a1) can be faster, whatever its position. Returns the phases (jerk, duration).
std::vector<std::pair<double, double>> fastest_velocity_change(double v0, double a0, double v1, double a1, double A,
                                                               double J) {
  std::vector<std::pair<double, double>> best;
  double best_time = INFINITY;
  for (const double s : {1.0, -1.0}) {
    // s·(v1 − v0) = (2 ap² − a0² − a1²)/(2J) + ap·hold in the frame where the ramp goes up.
    const double b0 = s * a0, b1 = s * a1, dw = s * (v1 - v0);
    const double sq = J * dw + (b0 * b0 + b1 * b1) / 2;
    if (sq < 0) continue;
    double ap = std::sqrt(sq), hold = 0;
    if (ap > A) {
      ap = A;
      hold = (dw - (2 * A * A - b0 * b0 - b1 * b1) / (2 * J)) / A;
    }
    if (ap < b0 - 1e-12 || ap < b1 - 1e-12 || hold < 0) continue;
    const double time = (ap - b0) / J + hold + (ap - b1) / J;
    if (time < best_time) {
      best_time = time;
      best = {{s * J, (ap - b0) / J}, {0.0, hold}, {-s * J, (ap - b1) / J}};
    }
  }
  return best;
}

TEST(Motion, TargetWhereTheFastestVelocityChangeEndsTakesExactlyThatChange) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double V = 2.0, A = 5.0, J = 40.0;
  for (int k = 0; k < 500; ++k) {
    const double a0 = A * unit(rng), a1 = A * unit(rng);
    // Within the limits: the start not bound to leave V, the target not come from beyond it.
    const double c0 = a0 * std::abs(a0) / (2 * J), c1 = a1 * std::abs(a1) / (2 * J);
    const double v0 = std::max(-V, -V - c0) + (std::min(V, V - c0) - std::max(-V, -V - c0)) * (unit(rng) + 1) / 2;
    const double v1 = std::max(-V, -V + c1) + (std::min(V, V + c1) - std::max(-V, -V + c1)) * (unit(rng) + 1) / 2;
    const auto phases = fastest_velocity_change(v0, a0, v1, a1, A, J);
    ASSERT_FALSE(phases.empty());
    // Where it ends, by the exact cubic of each phase.
    double p = 0.3, v = v0, a = a0, T = 0;
    bool within = true;
    for (const auto& [j, t] : phases) {
      p += v * t + a * t * t / 2 + j * t * t * t / 6;
      v += a * t + j * t * t / 2;
      a += j * t;
      T += t;
      within = within && std::abs(v) <= V;
    }
    if (!within) continue;  // a ramp that passes the velocity limit is no lower bound within it
    const Problem pr = single(0.3, v0, a0, p, v1, a1, V, A, J);
    OnlineGenerator otg(1);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits)) << otg.reason();
    EXPECT_NEAR(otg.duration(), T, 1e-9) << "v0 " << v0 << " a0 " << a0 << " v1 " << v1 << " a1 " << a1;
    expect_valid(otg, pr, 1e-3);
  }
}

// A brute-force search over a discretisation: jerk ∈ {−J, 0, +J} held over steps of h = 1 (units
// where J = 1), every sequence enumerated by iterative deepening. In these units a, 2v and 6p stay
// integers (a' = a + u, 2v' = 2v + 2a + u, 6p' = 6p + 3·2v + 3a + u), so a sequence reaches the
// target exactly or not at all, and since a changes by at most 1 per step it only crosses 0 at a
// step's end: the limits hold between samples when they hold at them. Every sequence found is a
// feasible jerk-limited motion, so the planner's minimal duration can be no longer than the
// shortest one.
struct Lattice {
  int a, v2, p6;
};

bool reaches_in(const Lattice& s, const Lattice& target, int steps, int A, int V2) {
  if (steps == 0) return s.a == target.a && s.v2 == target.v2 && s.p6 == target.p6;
  if (std::abs(s.a - target.a) > steps) return false;  // a moves by at most 1 per step
  for (int u = -1; u <= 1; ++u) {
    const Lattice next{s.a + u, s.v2 + 2 * s.a + u, s.p6 + 3 * s.v2 + 3 * s.a + u};
    if (std::abs(next.a) > A || std::abs(next.v2) > V2) continue;
    if (reaches_in(next, target, steps - 1, A, V2)) return true;
  }
  return false;
}

TEST(Motion, NoDiscreteJerkSequenceReachesTheTargetSoonerThanThePlan) {
  std::mt19937_64 rng(13);
  const int A = 3, V2 = 12;  // |a| ≤ 3, |v| ≤ 6 (2v ≤ 12), J = 1, h = 1
  int checked = 0;
  for (int k = 0; k < 1500; ++k) {
    // A start on the lattice within the limits, and a target made by a random feasible sequence.
    Lattice start{static_cast<int>(rng() % 5) - 2, static_cast<int>(rng() % 13) - 6, 0};
    Lattice s = start;
    const int length = 6 + static_cast<int>(rng() % 5);
    bool within = true;
    for (int step = 0; step < length && within; ++step) {
      const int u = static_cast<int>(rng() % 3) - 1;
      s = {s.a + u, s.v2 + 2 * s.a + u, s.p6 + 3 * s.v2 + 3 * s.a + u};
      within = std::abs(s.a) <= A && std::abs(s.v2) <= V2;
    }
    // The continuous plan needs the start not bound to pass V, and the target reachable within V.
    const double a0 = start.a, v0 = start.v2 / 2.0, af = s.a, vf = s.v2 / 2.0;
    if (!within || std::abs(v0 + a0 * std::abs(a0) / 2) > V2 / 2.0 || std::abs(vf - af * std::abs(af) / 2) > V2 / 2.0) {
      continue;
    }
    int shortest = 0;
    while (!reaches_in(start, s, shortest, A, V2)) ++shortest;
    ASSERT_LE(shortest, length);
    const Problem pr = single(0.0, v0, a0, s.p6 / 6.0, vf, af, V2 / 2.0, A, 1.0);
    OnlineGenerator otg(1);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits)) << otg.reason();
    EXPECT_LE(otg.duration(), shortest + 1e-9) << "start a " << start.a << " 2v " << start.v2 << " target a " << s.a
                                               << " 2v " << s.v2 << " 6p " << s.p6;
    expect_valid(otg, pr, 1e-3);
    ++checked;
  }
  EXPECT_GT(checked, 300);
}

TEST(Motion, NoAxisAloneIsFasterThanItsFastestVelocityChange) {
  std::mt19937_64 rng(11);
  for (int k = 0; k < 2000; ++k) {
    const Problem pr = random_problem(rng, 1);
    OnlineGenerator otg(1);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits)) << otg.reason();
    const auto phases = fastest_velocity_change(pr.current.v[0], pr.current.a[0], pr.target.v[0], pr.target.a[0],
                                                pr.limits.acceleration[0], pr.limits.jerk[0]);
    double T = 0;
    for (const auto& phase : phases) T += phase.second;
    EXPECT_GE(otg.duration(), T - 1e-12);
  }
}

TEST(Motion, ThousandsOfRandomSevenAxisPlansStartEndAndStayWithinTheLimits) {
#ifdef CHASLES_SANITIZED
  constexpr int kPlans = 200;  // the first 200 under the sanitizers (tests/CMakeLists.txt)
#else
  constexpr int kPlans = 2000;
#endif
  std::mt19937_64 rng(2026);
  OnlineGenerator otg(7);
  for (int k = 0; k < kPlans; ++k) {
    const Problem pr = random_problem(rng, 7);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits)) << "problem " << k << ": " << otg.reason();
    // The slowest axis alone sets the duration (a blocked interval may raise it a little).
    double slowest = 0;
    for (int i = 0; i < 7; ++i) slowest = std::max(slowest, otg.minimal_duration(i));
    ASSERT_GE(otg.duration(), slowest - 1e-12);
    // 1e-4 s on the first 500, 1e-3 s on the others (the suite also runs under sanitizers).
    expect_valid(otg, pr, k < 500 ? 1e-4 : 1e-3);
    if (HasFatalFailure()) {
      ADD_FAILURE() << "problem " << k;
      return;
    }
  }
}

TEST(Motion, MinDurationIsHonoured) {
  std::mt19937_64 rng(3);
  OnlineGenerator otg(7);
  for (int k = 0; k < 200; ++k) {
    const Problem pr = random_problem(rng, 7);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits));
    const double T = otg.duration();
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits, T + 1.5)) << otg.reason();
    EXPECT_NEAR(otg.duration(), T + 1.5, 1e-9);
    expect_valid(otg, pr, 1e-3);
    // Shorter than the minimal duration: the minimal duration.
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits, 0.5 * T));
    EXPECT_EQ(otg.duration(), T);
  }
}

// Unsynchronised: each axis alone at its own minimal duration (the synchronised plan's step 1),
// reaching its target then and moving on with it; within every limit throughout.
TEST(Motion, UnsynchronisedEachAxisArrivesAtItsOwnMinimalDuration) {
  std::mt19937_64 rng(5);
  OnlineGenerator otg(7);
  KinematicState s;
  for (int k = 0; k < 200; ++k) {
    const Problem pr = random_problem(rng, 7);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits));
    double minimal[7], longest = 0.0;
    for (int i = 0; i < 7; ++i) minimal[i] = otg.minimal_duration(i), longest = std::max(longest, minimal[i]);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits, 0.0, Synchronization::kNone)) << otg.reason();
    EXPECT_EQ(otg.duration(), longest);
    for (int i = 0; i < 7; ++i) {
      EXPECT_EQ(otg.axis(i).duration(), minimal[i]) << "axis " << i;
      otg.at_time(minimal[i], s);
      EXPECT_NEAR(s.p[i], pr.target.p[i], 1e-8) << "axis " << i;
      EXPECT_NEAR(s.v[i], pr.target.v[i], 1e-8) << "axis " << i;
      // Sampled every 1 ms to its end, within its limits.
      for (double t = 0.0; t <= minimal[i]; t += 1e-3) {
        otg.at_time(t, s);
        ASSERT_LE(std::abs(s.v[i]), pr.limits.velocity[i] * (1 + 1e-9)) << "axis " << i << " t " << t;
        ASSERT_LE(std::abs(s.a[i]), pr.limits.acceleration[i] * (1 + 1e-9)) << "axis " << i << " t " << t;
      }
    }
  }
}

TEST(Motion, AStateOutsideTheLimitsIsBroughtBackFirst) {
  // The limits were lowered under a moving arm: |v| > V, |a| > A, or a velocity bound to pass V.
  const double V = 1.0, A = 4.0, J = 50.0;
  const double starts[][2] = {{1.6, 0.0}, {-1.4, 2.0}, {0.9, 3.9}, {0.5, 6.0}, {-1.2, -7.0}, {1.3, 5.0}};
  for (const auto& [v0, a0] : starts) {
    const Problem pr = single(0.0, v0, a0, 0.5, 0.0, 0.0, V, A, J);
    OnlineGenerator otg(1);
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits)) << otg.reason();
    // The brake (full jerk toward the inside, then −A held) is over once v and a are within their
    // limits and v + a|a|/(2J) too; from then on, the limits hold.
    double t_in = 0;
    KinematicState s;
    for (double t = 0; t < otg.duration(); t += 1e-5) {
      otg.at_time(t, s);
      const double v = s.v[0], a = s.a[0];
      if (std::abs(v) <= V && std::abs(a) <= A && std::abs(v + a * std::abs(a) / (2 * J)) <= V * (1 + 1e-9)) {
        t_in = t;
        break;
      }
    }
    // No longer than reaching −A at full jerk and holding it until v is within the limit.
    EXPECT_LE(t_in, (std::abs(a0) + A) / J + (std::abs(v0) + std::abs(a0) * std::abs(a0) / (2 * J)) / A + 1e-4);
    expect_valid(otg, pr, 1e-4, t_in + 1e-5);
  }
}

TEST(Motion, ReplanningEveryMillisecondTowardAMovingTargetStaysSmoothAndArrives) {
  // As the controller uses it: each tick plans from the reference the last plan gave 1 ms later,
  // toward a target that moves for the first second and then stops.
  const Problem base = [] {
    std::mt19937_64 rng(5);
    return random_problem(rng, 7);
  }();
  OnlineGenerator otg(7);
  KinematicState reference = base.current, next;
  KinematicState target = base.target;
  target.v.setZero();
  target.a.setZero();
  const double h = 1e-3;
  bool arrived = false;
  for (int tick = 0; tick < 20000 && !arrived; ++tick) {
    const double t = tick * h;
    for (int i = 0; i < 7; ++i) target.p[i] = base.target.p[i] + (t < 1.0 ? 0.3 * std::sin(3 * t + i) : 0.3 * std::sin(3 + i));
    ASSERT_TRUE(otg.plan(reference, target, base.limits)) << otg.reason();
    otg.at_time(h, next);
    for (int i = 0; i < 7; ++i) {
      const double J = base.limits.jerk[i];
      ASSERT_LE(std::abs(next.v[i]), base.limits.velocity[i] * (1 + 1e-9));
      ASSERT_LE(std::abs(next.a[i]), base.limits.acceleration[i] * (1 + 1e-9));
      ASSERT_LE(std::abs(next.a[i] - reference.a[i]), J * h * (1 + 1e-9) + 1e-9);
    }
    reference = next;
    arrived = t > 1.0 && otg.duration() <= h;
  }
  EXPECT_TRUE(arrived);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(reference.p[i], target.p[i], 1e-8);
}

TEST(Motion, AlreadyThereIsAPlanOfZeroDuration) {
  const Problem pr = single(0.25, 0, 0, 0.25, 0, 0, 1, 1, 1);
  OnlineGenerator otg(1);
  ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits));
  EXPECT_EQ(otg.duration(), 0.0);
  KinematicState s;
  otg.at_time(1.0, s);
  EXPECT_EQ(s.p[0], 0.25);
}

TEST(Motion, BadInputIsRefusedWithAReason) {
  OnlineGenerator otg(1);
  const Problem good = single(0, 0, 0, 1, 0, 0, 1, 1, 1);
  ASSERT_TRUE(otg.plan(good.current, good.target, good.limits));
  const double kept = otg.duration();
  const auto refused = [&](Problem pr, double min_duration, const char* words) {
    EXPECT_FALSE(otg.plan(pr.current, pr.target, pr.limits, min_duration));
    EXPECT_NE(std::string(otg.reason()).find(words), std::string::npos) << otg.reason();
    EXPECT_EQ(otg.duration(), kept);  // the previous plan stays
  };
  Problem pr = good;
  pr.current.p = vec({0, 0});
  refused(pr, 0, "one entry per axis");
  pr = good;
  pr.limits.jerk[0] = 0;
  refused(pr, 0, "limit must be finite and > 0");
  pr = good;
  pr.limits.velocity[0] = INFINITY;
  refused(pr, 0, "limit must be finite and > 0");
  pr = good;
  pr.current.v[0] = NAN;
  refused(pr, 0, "current state is not finite");
  pr = good;
  pr.target.p[0] = INFINITY;
  refused(pr, 0, "target state is not finite");
  pr = good;
  pr.target.v[0] = 1.5;
  refused(pr, 0, "target velocity 1.5 exceeds its limit");
  pr = good;
  pr.target.a[0] = -1.5;
  refused(pr, 0, "target acceleration -1.5 exceeds its limit");
  pr = good;
  pr.target.v[0] = 0.9;
  pr.target.a[0] = -0.9;  // came from v = 0.9 + 0.81/2 > 1
  refused(pr, 0, "cannot be held within the velocity limit");
  refused(good, -1, "min_duration");
  refused(good, NAN, "min_duration");
  EXPECT_THROW(OnlineGenerator(0), ArgumentError);
}

// The velocity interface: each axis reaches its target velocity at a = 0 exactly as fast as the
// fastest velocity change allows (written independently above), along a valid jerk-limited motion,
// and moves on at that velocity past its end.
TEST(Motion, VelocityInterfaceReachesEachVelocityInTheFastestVelocityChange) {
  std::mt19937_64 rng(31);
  OnlineGenerator otg(7);
  for (int k = 0; k < 1000; ++k) {
    Problem pr = random_problem(rng, 7);
    pr.target.a.setZero();
    for (int i = 0; i < 7; ++i) {
      pr.target.v[i] = std::uniform_real_distribution<double>(-1.0, 1.0)(rng) * pr.limits.velocity[i];
    }
    ASSERT_TRUE(otg.plan_velocity(pr.current, pr.target.v, pr.limits)) << otg.reason();
    double slowest = 0;
    for (int i = 0; i < 7; ++i) {
      double T = 0;
      for (const auto& phase : fastest_velocity_change(pr.current.v[i], pr.current.a[i], pr.target.v[i], 0.0,
                                                       pr.limits.acceleration[i], pr.limits.jerk[i])) {
        T += phase.second;
      }
      ASSERT_NEAR(otg.axis(i).duration(), T, 1e-12) << "problem " << k << " axis " << i;
      slowest = std::max(slowest, T);
    }
    ASSERT_NEAR(otg.duration(), slowest, 1e-12);
    // Each axis ends where its own motion takes it: sampled at the plan's end, then moving on.
    KinematicState end, later;
    otg.at_time(otg.duration(), end);
    pr.target.p = end.p;
    otg.at_time(otg.duration() + 0.5, later);
    for (int i = 0; i < 7; ++i) {
      ASSERT_NEAR(later.p[i], end.p[i] + 0.5 * pr.target.v[i], 1e-12);
      ASSERT_NEAR(later.a[i], 0.0, 1e-12);
    }
    // expect_valid wants every axis to end at the plan's duration: one axis at a time.
    for (int i = 0; i < 7 && k < 200; ++i) {
      const Problem axis = single(pr.current.p[i], pr.current.v[i], pr.current.a[i], 0.0, pr.target.v[i], 0.0,
                                  pr.limits.velocity[i], pr.limits.acceleration[i], pr.limits.jerk[i]);
      OnlineGenerator one(1);
      ASSERT_TRUE(one.plan_velocity(axis.current, axis.target.v, axis.limits));
      Problem reached = axis;
      KinematicState s;
      one.at_time(one.duration(), s);
      reached.target.p[0] = s.p[0];
      expect_valid(one, reached, 1e-4);
      if (HasFatalFailure()) {
        ADD_FAILURE() << "problem " << k << " axis " << i;
        return;
      }
    }
  }
}

// From constant velocity v (a = 0) the fastest stop covers v²/(2A) + vA/(2J) when it reaches the
// acceleration limit (v ≥ A²/J), else v·√(v/J); from any state, it is where braking ends.
TEST(Motion, StopPositionIsWhereTheFastestBrakeEnds) {
  const double V = 2.0, A = 5.0, J = 50.0;
  for (const double v : {0.0, 0.1, 0.4, 0.5, 0.9, 2.0, -0.3, -1.7}) {
    const double speed = std::abs(v);
    const double d = speed >= A * A / J ? speed * speed / (2 * A) + speed * A / (2 * J) : speed * std::sqrt(speed / J);
    EXPECT_NEAR(stop_position(1.0, v, 0.0, V, A, J), 1.0 + std::copysign(d, v), 1e-14) << "v = " << v;
  }
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  OnlineGenerator otg(1);
  for (int k = 0; k < 500; ++k) {
    const double a = A * unit(rng), v = V * unit(rng) * 0.9;
    const Problem pr = single(0.2, v, a, 0.0, 0.0, 0.0, V, A, J);
    ASSERT_TRUE(otg.plan_velocity(pr.current, pr.target.v, pr.limits));
    KinematicState s;
    otg.at_time(otg.duration() + 1.0, s);
    EXPECT_NEAR(stop_position(0.2, v, a, V, A, J), s.p[0], 1e-12);
    EXPECT_NEAR(s.v[0], 0.0, 1e-12);
  }
}

TEST(Motion, VelocityInterfaceRefusesBadInputWithAReason) {
  OnlineGenerator otg(1);
  const Problem good = single(0, 0, 0, 0, 0.5, 0, 1, 1, 1);
  ASSERT_TRUE(otg.plan_velocity(good.current, good.target.v, good.limits));
  const auto refused = [&](const Problem& pr, const Eigen::VectorXd& velocity, const char* words) {
    EXPECT_FALSE(otg.plan_velocity(pr.current, velocity, pr.limits));
    EXPECT_NE(std::string(otg.reason()).find(words), std::string::npos) << otg.reason();
  };
  refused(good, vec({1.5}), "target velocity 1.5 is not finite or exceeds its limit");
  refused(good, vec({NAN}), "is not finite or exceeds its limit");
  refused(good, vec({0.1, 0.1}), "one entry per axis");
  Problem pr = good;
  pr.current.a[0] = INFINITY;
  refused(pr, good.target.v, "current state is not finite");
  pr = good;
  pr.limits.acceleration[0] = -1;
  refused(pr, good.target.v, "limit must be finite and > 0");
}

TEST(Motion, PlanAndSamplingAllocateNothing) {
  std::mt19937_64 rng(9);
  std::vector<Problem> problems;
  for (int k = 0; k < 200; ++k) problems.push_back(random_problem(rng, 7));
  OnlineGenerator otg(7);
  KinematicState s{Eigen::VectorXd(7), Eigen::VectorXd(7), Eigen::VectorXd(7)};
  Problem bad = problems[0];
  bad.target.v[0] = 100;
  testing::AllocationCounter counter;
  for (const Problem& pr : problems) {
    ASSERT_TRUE(otg.plan(pr.current, pr.target, pr.limits));
    otg.at_time(0.5 * otg.duration(), s);
    otg.at_time(2 * otg.duration(), s);
    ASSERT_TRUE(otg.plan_velocity(pr.current, pr.target.v, pr.limits));
    otg.at_time(0.5 * otg.duration(), s);
  }
  EXPECT_FALSE(otg.plan(bad.current, bad.target, bad.limits));
  EXPECT_EQ(counter.count(), 0);
}

}  // namespace
}  // namespace chasles::motion
