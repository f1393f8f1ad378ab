// chasles_ruckig_bench: chasles's online trajectory generator (core/motion) beside Ruckig's C++
// (the sources of the PyPI package ruckig, at the version tools/ruckig.sh fetches, compiled into
// this binary with chasles's flags), on the same seeded random 7-axis problems, in one run:
//
// (a) quality, on kProblems problems (--problems=N to change): each library plans every problem
//     once; the ratio of chasles's duration to Ruckig's (max, mean, and how many above 1.02 and
//     1.0001), the failures of each (a plan refused or an error result), and the limit violations
//     of each, sampled every kSampleStep over the whole motion (|v|, |a| above the limit by more
//     than 1e-9 relative; |jerk| between samples by more than that, by the difference of a over
//     the step) with the end state against the target (1e-8). Printed on stdout. Then the same on
//     as many edge cases (make_edge_problems below: wide limits, values snapped to 0 and to the
//     limits), where a motion longer than 5 s is sampled 5000 times instead: chasles alone, as
//     Ruckig 0.19.4 writes out of bounds on some of them (see main()).
// (b) time per update: Google Benchmark times one plan of each (chasles's plan(), Ruckig's
//     calculate(input, trajectory)) cycling through the first kTimed problems, so that both see
//     the same mix; tools/bench.sh prints the ratio.
//
// The problems: 90 % with the Panda's limits (libfranka's: velocity, acceleration and jerk per
// joint below), 10 % with each limit scaled by its own random factor in [0.05, 1]. Current state:
// p in [−π, π], a in [−A, A], v uniform where |v| ≤ V and |v + a|a|/(2J)| ≤ V (a state within the
// limits that is not bound to leave them: neither library can keep one that is within them).
// Target: p in [−π, π], a = 0 for half of them and in [−A, A] for the others, v uniform where
// |v| ≤ V and |v − a|a|/(2J)| ≤ V (Ruckig's own check on a target state).
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <ruckig/ruckig.hpp>
#include <string>
#include <vector>

#include "core/motion/online_generator.hpp"

namespace {

constexpr int kDof = 7;
constexpr int kProblems = 100000;
constexpr int kTimed = 4096;
constexpr double kSampleStep = 1e-3;

using Array = std::array<double, kDof>;
struct Problem {
  Array p0, v0, a0, pf, vf, af, V, A, J;
};

constexpr Array kPandaV{2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
constexpr Array kPandaA{15, 7.5, 10, 12.5, 15, 20, 20};
constexpr Array kPandaJ{7500, 3750, 5000, 6250, 7500, 10000, 10000};

std::vector<Problem> make_problems(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  std::vector<Problem> problems(static_cast<std::size_t>(count));
  for (Problem& pr : problems) {
    const bool scaled = unit(rng) < 0.1;
    const bool zero_af = unit(rng) < 0.5;
    for (int i = 0; i < kDof; ++i) {
      const double V = kPandaV[i] * (scaled ? uniform(0.05, 1.0) : 1.0);
      const double A = kPandaA[i] * (scaled ? uniform(0.05, 1.0) : 1.0);
      const double J = kPandaJ[i] * (scaled ? uniform(0.05, 1.0) : 1.0);
      pr.V[i] = V;
      pr.A[i] = A;
      pr.J[i] = J;
      pr.p0[i] = uniform(-M_PI, M_PI);
      pr.a0[i] = uniform(-A, A);
      const double c0 = pr.a0[i] * std::abs(pr.a0[i]) / (2.0 * J);
      pr.v0[i] = uniform(std::max(-V, -V - c0), std::min(V, V - c0));
      pr.pf[i] = uniform(-M_PI, M_PI);
      pr.af[i] = zero_af ? 0.0 : uniform(-A, A);
      const double cf = pr.af[i] * std::abs(pr.af[i]) / (2.0 * J);
      pr.vf[i] = uniform(std::max(-V, -V + cf), std::min(V, V + cf));
    }
  }
  return problems;
}

// Harder problems, for robustness: each axis's limits drawn log-uniformly over wide ranges
// (V in [e⁻³, e²], A in [e⁻², e⁴], J in [1, e⁹]), and each of a0, v0, af, vf snapped to 0 (15 %),
// to the top or the bottom of its range (10 % each) or uniform in it; the target position the
// current one for 10 % of the axes, within 1e-6 of it for another 10 %. The states are within the
// limits as above (|a| reduced to at most √(2JV) first, so that the velocity range is not empty).
std::vector<Problem> make_edge_problems(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const auto snap = [&](double x, double lo, double hi) {
    const double q = unit(rng);
    return q < 0.15 ? 0.0 : q < 0.25 ? hi : q < 0.35 ? lo : x;
  };
  std::vector<Problem> problems(static_cast<std::size_t>(count));
  for (Problem& pr : problems) {
    for (int i = 0; i < kDof; ++i) {
      const double V = std::exp(uniform(-3, 2)), A = std::exp(uniform(-2, 4)), J = std::exp(uniform(0, 9));
      pr.V[i] = V;
      pr.A[i] = A;
      pr.J[i] = J;
      double a0 = snap(uniform(-A, A), -A, A);
      if (a0 * a0 / (2 * J) > V) a0 = std::copysign(std::sqrt(2 * J * V) * unit(rng), a0);
      const double c0 = a0 * std::abs(a0) / (2 * J);
      const double lo0 = std::max(-V, -V - c0), hi0 = std::min(V, V - c0);
      pr.a0[i] = a0;
      pr.v0[i] = std::clamp(snap(uniform(lo0, hi0), lo0, hi0), lo0, hi0);
      double af = snap(uniform(-A, A), -A, A);
      if (af * af / (2 * J) > V) af = std::copysign(std::sqrt(2 * J * V) * unit(rng), af);
      const double cf = af * std::abs(af) / (2 * J);
      const double lof = std::max(-V, -V + cf), hif = std::min(V, V + cf);
      pr.af[i] = af;
      pr.vf[i] = std::clamp(snap(uniform(lof, hif), lof, hif), lof, hif);
      pr.p0[i] = uniform(-1, 1);
      const double q = unit(rng);
      pr.pf[i] = q < 0.1 ? pr.p0[i] : q < 0.2 ? pr.p0[i] + uniform(-1e-6, 1e-6) : uniform(-2, 2);
    }
  }
  return problems;
}

Eigen::VectorXd to_eigen(const Array& x) { return Eigen::Map<const Eigen::VectorXd>(x.data(), kDof); }

struct ChaslesSide {
  chasles::motion::OnlineGenerator otg{kDof};
  chasles::motion::KinematicState current{Eigen::VectorXd(kDof), Eigen::VectorXd(kDof), Eigen::VectorXd(kDof)};
  chasles::motion::KinematicState target = current;
  chasles::motion::Limits limits{Eigen::VectorXd(kDof), Eigen::VectorXd(kDof), Eigen::VectorXd(kDof)};
  void load(const Problem& pr) {
    current.p = to_eigen(pr.p0);
    current.v = to_eigen(pr.v0);
    current.a = to_eigen(pr.a0);
    target.p = to_eigen(pr.pf);
    target.v = to_eigen(pr.vf);
    target.a = to_eigen(pr.af);
    limits.velocity = to_eigen(pr.V);
    limits.acceleration = to_eigen(pr.A);
    limits.jerk = to_eigen(pr.J);
  }
  bool plan() { return otg.plan(current, target, limits); }
};

struct RuckigSide {
  ruckig::Ruckig<kDof> otg;
  ruckig::InputParameter<kDof> input;
  ruckig::Trajectory<kDof> trajectory;
  void load(const Problem& pr) {
    input.current_position = pr.p0;
    input.current_velocity = pr.v0;
    input.current_acceleration = pr.a0;
    input.target_position = pr.pf;
    input.target_velocity = pr.vf;
    input.target_acceleration = pr.af;
    input.max_velocity = pr.V;
    input.max_acceleration = pr.A;
    input.max_jerk = pr.J;
  }
  bool plan() {
    const ruckig::Result result = otg.calculate(input, trajectory);
    return result == ruckig::Result::Working || result == ruckig::Result::Finished;
  }
};

// Samples a plan every kSampleStep (and at its end) through `state(t, p, v, a)` and counts it as
// violating when a limit is exceeded by more than 1e-9 relative, or the end misses the target by
// more than 1e-8. Jerk is checked as the change of a between samples.
template <typename State>
bool violates(const Problem& pr, double duration, State state) {
  constexpr double tol = 1e-9;
  Array p{}, v{}, a{}, a_prev{};
  state(0.0, p, v, a);
  for (int i = 0; i < kDof; ++i) {
    if (std::abs(p[i] - pr.p0[i]) > 1e-8 || std::abs(v[i] - pr.v0[i]) > 1e-8 || std::abs(a[i] - pr.a0[i]) > 1e-8) {
      return true;
    }
  }
  a_prev = a;
  double t_prev = 0.0;
  // Every kSampleStep, or 5000 samples over a longer motion (the edge cases' run to minutes).
  const double step = std::max(kSampleStep, duration / 5000.0);
  const int steps = static_cast<int>(std::ceil(duration / step));
  for (int k = 1; k <= steps; ++k) {
    const double t = std::min(k * step, duration);
    state(t, p, v, a);
    for (int i = 0; i < kDof; ++i) {
      if (std::abs(v[i]) > pr.V[i] * (1.0 + tol) || std::abs(a[i]) > pr.A[i] * (1.0 + tol)) return true;
      if (t > t_prev && std::abs(a[i] - a_prev[i]) > pr.J[i] * (t - t_prev) * (1.0 + tol) + 1e-9) return true;
    }
    a_prev = a;
    t_prev = t;
  }
  state(duration, p, v, a);
  for (int i = 0; i < kDof; ++i) {
    if (std::abs(p[i] - pr.pf[i]) > 1e-8 || std::abs(v[i] - pr.vf[i]) > 1e-8 || std::abs(a[i] - pr.af[i]) > 1e-8) {
      return true;
    }
  }
  return false;
}

int problems_wanted(int argc, char** argv) {
  for (int k = 1; k < argc; ++k) {
    if (std::strncmp(argv[k], "--problems=", 11) == 0) return std::atoi(argv[k] + 11);
  }
  return kProblems;
}

void quality(const char* title, const std::vector<Problem>& problems, bool with_ruckig = true) {
  ChaslesSide chasles;
  RuckigSide ruckig;
  chasles::motion::KinematicState sample{Eigen::VectorXd(kDof), Eigen::VectorXd(kDof), Eigen::VectorXd(kDof)};
  int chasles_failed = 0, ruckig_failed = 0, chasles_violations = 0, ruckig_violations = 0;
  int above_2pc = 0, above_tiny = 0, below = 0, compared = 0;
  double ratio_max = 0.0, ratio_sum = 0.0, ratio_min = 1e300;
  int worst = -1;
  for (std::size_t n = 0; n < problems.size(); ++n) {
    const Problem& pr = problems[n];
    chasles.load(pr);
    ruckig.load(pr);
    const bool c_ok = chasles.plan();
    const bool r_ok = with_ruckig && ruckig.plan();
    if (!c_ok) {
      ++chasles_failed;
      if (chasles_failed <= 5) {
        std::fprintf(stderr, "chasles failed on problem %zu: %s\n", n, chasles.otg.reason());
        for (int i = 0; i < kDof; ++i) {
          std::fprintf(stderr, "  axis %d: %.17g %.17g %.17g -> %.17g %.17g %.17g limits %.17g %.17g %.17g\n", i,
                       pr.p0[i], pr.v0[i], pr.a0[i], pr.pf[i], pr.vf[i], pr.af[i], pr.V[i], pr.A[i], pr.J[i]);
        }
      }
    }
    if (with_ruckig && !r_ok) ++ruckig_failed;
    if (c_ok && violates(pr, chasles.otg.duration(), [&](double t, Array& p, Array& v, Array& a) {
          chasles.otg.at_time(t, sample);
          for (int i = 0; i < kDof; ++i) {
            p[i] = sample.p[i];
            v[i] = sample.v[i];
            a[i] = sample.a[i];
          }
        })) {
      ++chasles_violations;
      if (chasles_violations <= 5) std::fprintf(stderr, "chasles violates on problem %zu\n", n);
    }
    if (r_ok && violates(pr, ruckig.trajectory.get_duration(),
                         [&](double t, Array& p, Array& v, Array& a) { ruckig.trajectory.at_time(t, p, v, a); })) {
      ++ruckig_violations;
    }
    if (c_ok && r_ok && ruckig.trajectory.get_duration() > 0.0) {
      const double ratio = chasles.otg.duration() / ruckig.trajectory.get_duration();
      ++compared;
      ratio_sum += ratio;
      if (ratio > ratio_max) {
        ratio_max = ratio;
        worst = static_cast<int>(n);
      }
      ratio_min = std::min(ratio_min, ratio);
      if (ratio > 1.02) ++above_2pc;
      if (ratio > 1.0001) ++above_tiny;
      if (ratio < 0.9999) ++below;
    }
  }
  std::printf("%s\n", title);
  std::printf("problems                       %zu (7 axes each)\n", problems.size());
  if (!with_ruckig) {
    std::printf("failures                       chasles %d (Ruckig not run)\n", chasles_failed);
    std::printf("limit or target violations     chasles %d (sampled every %g s or 5000 times)\n\n", chasles_violations,
                kSampleStep);
    std::fflush(stdout);
    return;
  }
  std::printf("failures                       chasles %d, Ruckig %d\n", chasles_failed, ruckig_failed);
  std::printf("limit or target violations     chasles %d, Ruckig %d (sampled every %g s or 5000 times)\n",
              chasles_violations, ruckig_violations, kSampleStep);
  std::printf("duration chasles / Ruckig      max %.9f (problem %d), mean %.9f, min %.9f over %d\n", ratio_max, worst,
              compared ? ratio_sum / compared : 0.0, ratio_min, compared);
  std::printf("                               %d above 1.02, %d above 1.0001, %d below 0.9999\n", above_2pc, above_tiny,
              below);
  std::printf("\n");
  std::fflush(stdout);
}

const std::vector<Problem>& timed_problems() {
  static const std::vector<Problem> problems = make_problems(kTimed, 20260302);
  return problems;
}

void BM_chasles(benchmark::State& state) {
  ChaslesSide side;

  const auto& problems = timed_problems();
  std::vector<chasles::motion::KinematicState> current, target;
  std::vector<chasles::motion::Limits> limits;
  for (const Problem& pr : problems) {
    side.load(pr);
    current.push_back(side.current);
    target.push_back(side.target);
    limits.push_back(side.limits);
  }
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(side.otg.plan(current[k], target[k], limits[k]));
    benchmark::DoNotOptimize(side.otg.duration());
    k = (k + 1) % problems.size();
  }
}

void BM_ruckig(benchmark::State& state) {
  RuckigSide side;
  const auto& problems = timed_problems();
  std::vector<ruckig::InputParameter<kDof>> inputs;
  for (const Problem& pr : problems) {
    side.load(pr);
    inputs.push_back(side.input);
  }
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(side.otg.calculate(inputs[k], side.trajectory));
    benchmark::DoNotOptimize(side.trajectory.get_duration());
    k = (k + 1) % problems.size();
  }
}

BENCHMARK(BM_chasles)->Name("chasles/plan");
BENCHMARK(BM_ruckig)->Name("ruckig/calculate");

}  // namespace

int main(int argc, char** argv) {
  const int count = problems_wanted(argc, argv);
  // --problems=N is ours; Google Benchmark must not see it.
  std::vector<char*> args;
  for (int k = 0; k < argc; ++k) {
    if (std::strncmp(argv[k], "--problems=", 11) != 0) args.push_back(argv[k]);
  }
  int bench_argc = static_cast<int>(args.size());
  if (count > 0) {
    quality("The Panda's limits (10 % scaled down), random states within them:", make_problems(count, 20260301));
    // chasles alone: Ruckig 0.19.4 writes out of bounds on some of these (AddressSanitizer: a
    // stack-buffer-underflow in Profile::set_boundary, from PositionThirdOrderStep1::add_profile)
    // and crashes this binary at -O3.
    quality("Edge cases (wide limits, values snapped to 0 and to the limits, targets at or near the start), chasles alone:",
            make_edge_problems(count, 20260303), false);
  }
  benchmark::Initialize(&bench_argc, args.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
