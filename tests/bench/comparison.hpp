// What chasles_bench (dynamics_bench.cpp, against KDL) and chasles_pinocchio_bench
// (pinocchio_bench.cpp, against Pinocchio) share, so that both time the same sample table, judge
// agreement the same way and report alike: the seeded table of (q, q̇, q̈, τ), chasles's side of
// each robot, the agreement check's bookkeeping, the "<library>/<robot>/<quantity>" registration
// and the whole main(). Each file keeps its library's side: the model it builds, what it compares
// and registers, its tolerance, its program name and what its agreement line lists.
#pragma once

#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/model/model.hpp"
#include "core/model/urdf.hpp"

namespace chasles::bench {

inline constexpr size_t kTableSize = 256;  // a power of two: the index wraps with a mask
inline constexpr unsigned kSeed = 20240611;
inline constexpr int kChecked = 8;  // table entries compared before timing

/// One table entry.
struct Sample {
  Eigen::VectorXd q, qd, qdd, tau;
};

/// The sample table, kTableSize entries drawn from kSeed: q uniform within the position limits, q̇
/// within the velocity limits, q̈ in ±5 rad/s², τ within half the effort limits.
inline std::vector<Sample> sample_table(const RobotModel& model) {
  std::mt19937_64 rng(kSeed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto finite_or = [](double x, double fallback) { return std::isfinite(x) ? x : fallback; };
  std::vector<Sample> table(kTableSize);
  for (Sample& s : table) {
    s.q.resize(model.dof());
    s.qd.resize(model.dof());
    s.qdd.resize(model.dof());
    s.tau.resize(model.dof());
    for (int i = 0; i < model.dof(); ++i) {
      const JointLimits& limits = model.joint(i).limits;
      s.q(i) = 0.5 * (limits.lower + limits.upper) + 0.5 * (limits.upper - limits.lower) * unit(rng);
      s.qd(i) = finite_or(limits.velocity, 2.0) * unit(rng);
      s.qdd(i) = 5.0 * unit(rng);
      s.tau(i) = 0.5 * finite_or(limits.effort, 20.0) * unit(rng);
    }
  }
  return table;
}

inline UrdfOptions tip_options(const std::string& tip) {
  UrdfOptions options;
  options.tip_link = tip;
  return options;
}

/// chasles's side of one robot, which each comparison's Robot adds its library's side to: the
/// model read from `urdf` down to `tip`, its workspace, and the name benchmarks and messages use.
/// Never copied or moved: the registered benchmarks keep a reference to the robot (see add()).
struct ChaslesRobot {
  ChaslesRobot(std::string robot_name, const std::string& urdf, const std::string& tip)
      : name(std::move(robot_name)), model(load_urdf_file(urdf, tip_options(tip))), data(model) {}
  ChaslesRobot(const ChaslesRobot&) = delete;
  ChaslesRobot& operator=(const ChaslesRobot&) = delete;

  const std::string name;
  const RobotModel model;
  Data data;
};

/// Keeps a result alive: its address escapes into an asm statement that clobbers memory.
template <class T>
void keep(const T& result) {
  const void* p = &result;
  benchmark::DoNotOptimize(p);
}

/// The agreement check's findings: the worst relative difference seen and, for each robot and
/// quantity off by more than `tolerance` (relative to the largest entry of the other library's
/// result, at least 1), the text saying so.
struct Check {
  Check(const char* other_library, double relative_tolerance)
      : library(other_library), tolerance(relative_tolerance) {}

  const char* library;  // the other side, in the failures' text
  double tolerance;
  std::string failures;
  std::set<std::string> reported;
  double worst = 0.0;

  void compare(const std::string& robot, const char* quantity, int k, const Eigen::MatrixXd& ours,
               const Eigen::MatrixXd& theirs) {
    const double scale = std::max(1.0, theirs.cwiseAbs().maxCoeff());
    const double error = (ours - theirs).cwiseAbs().maxCoeff() / scale;
    worst = std::max(worst, error);
    // Only the first disagreement of each robot and quantity is printed in full.
    if (!(error <= tolerance) && reported.insert(robot + " " + quantity).second) {
      std::ostringstream out;
      out << "  " << robot << " " << quantity << " at table entry " << k << ": max |chasles - " << library
          << "| = " << error * scale << " (scale " << scale << ")\n    chasles:\n"
          << ours << "\n    " << library << ":\n"
          << theirs << "\n";
      failures += out.str();
    }
  }
};

/// Registers "<library>/<robot>/<quantity>": each iteration runs `compute` on the next table entry.
template <class Robot, class Compute>
void add(const char* library, Robot& robot, const char* quantity, Compute compute) {
  const std::string name = std::string(library) + "/" + robot.name + "/" + quantity;
  benchmark::RegisterBenchmark(name.c_str(), [&robot, compute](benchmark::State& state) {
    size_t k = 0;
    for (auto _ : state) {
      compute(robot, robot.table[k++ & (kTableSize - 1)]);
    }
  });
}

/// What sets one comparison binary apart in main().
struct Comparison {
  const char* program;      // prefixes every message: "chasles_bench"
  const char* library;      // the other side, in messages: "KDL"
  double tolerance;         // relative, as Check takes it
  const char* context_key;  // the report context's key for the agreement line: "chasles_kdl_agreement"
  std::string what_agrees;  // the agreement line up to " on <kChecked> configurations …": "fk, … agree"
};

/// The whole main() of a comparison. `Robot`, built from its name, URDF and tip link, holds both
/// libraries' models of one robot, its `name` and its sample `table`; there are two, the UR5 to
/// tool0 and the Panda to panda_hand, read from CHASLES_BENCH_DATA (each target defines it).
/// Before timing, `check_agreement` compares the libraries on the first kChecked table entries of
/// each: if they disagree, nothing is timed, as the timings would compare different computations.
template <class Robot>
int run_comparison(int argc, char** argv, const Comparison& comparison, void (*check_agreement)(Robot&, Check&),
                   void (*register_benchmarks)(Robot&)) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  // Everything here goes to stderr: stdout is the benchmark report (JSON for tools/bench.sh).
  std::vector<std::unique_ptr<Robot>> robots;
  try {
    const std::string data = CHASLES_BENCH_DATA;
    robots.push_back(std::make_unique<Robot>("ur5", data + "/ur5.urdf", "tool0"));
    robots.push_back(std::make_unique<Robot>("panda", data + "/panda.urdf", "panda_hand"));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", comparison.program, e.what());
    return 1;
  }

  Check check(comparison.library, comparison.tolerance);
  for (auto& robot : robots) check_agreement(*robot, check);
  if (!check.failures.empty()) {
    std::fprintf(stderr,
                 "%s: chasles and %s disagree (relative tolerance %g), so the timings would compare "
                 "different computations; not running.\n%s",
                 comparison.program, comparison.library, comparison.tolerance, check.failures.c_str());
    return 1;
  }
  std::ostringstream agreed;
  agreed << comparison.what_agrees << " on " << kChecked << " configurations per robot; worst relative difference "
         << check.worst;
  std::fprintf(stderr, "%s: %s\n", comparison.program, agreed.str().c_str());
  benchmark::AddCustomContext(comparison.context_key, agreed.str());
  benchmark::AddCustomContext("sample_table", std::to_string(kTableSize) + " entries, seed " + std::to_string(kSeed));

  for (auto& robot : robots) register_benchmarks(*robot);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace chasles::bench
