// chasles_ik_bench: chasles's Ceres IK against Orocos KDL's ChainIkSolverPos_NR_JL, same URDFs,
// same targets and seeds (tests/data/ik_<robot>.json, 200 reachable targets each), same run.
//
// Each target is solved cold (from its q_seed) and warm (from its reference solution plus uniform
// noise of ±0.01 rad per joint, seeded). A solve succeeds when the answer's tip pose is within
// 1e-6 m and 1e-6 rad of the target, checked here with chasles's FK for both libraries, and within
// the joint limits. Both get the same 5 ms budget: chasles through its time budget (restarts
// included), KDL through an iteration cap measured to take about that long (NR_JL has no clock and
// no restarts; it stops at maxiter). Times are wall clock per solve; medians and p99 over targets.
//
// Prints a table, or with --json {"<robot>": {"<cold|warm>": {"<chasles|kdl>": {"success", "median_us",
// "p99_us"}}}}.
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_nr_jl.hpp>
#include <kdl/chainiksolvervel_pinv.hpp>
#include <kdl/frames.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/ik/ik.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/so3.hpp"
#include "core/model/urdf.hpp"

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kTolerance = 1e-6;
constexpr int kKdlMaxIterations = 350;  // a failing NR_JL solve then takes about 5 ms here

struct Case {
  chasles::Matrix4d T;
  Eigen::VectorXd seed, solution;
};

struct Figures {
  int success = 0, total = 0;
  std::vector<double> us;
};

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const size_t rank = static_cast<size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, rank > 0 ? rank - 1 : 0)];
}

bool solved(const chasles::RobotModel& model, chasles::Data& data, const Eigen::VectorXd& q, const chasles::Matrix4d& T) {
  for (int i = 0; i < model.dof(); ++i) {
    if (q[i] < model.joint(i).limits.lower - 1e-9 || q[i] > model.joint(i).limits.upper + 1e-9) return false;
  }
  const chasles::Transform& T_sb = chasles::forward_kinematics(model, data, q);
  const double pos = (T_sb.translation() - T.topRightCorner<3, 1>()).norm();
  const double rot = chasles::log3(chasles::Matrix3d(T.topLeftCorner<3, 3>().transpose() * T_sb.linear())).norm();
  return pos <= kTolerance && rot <= kTolerance;
}

nlohmann::json run(const std::string& robot, const std::string& data_dir) {
  std::ifstream in(data_dir + "/ik_" + robot + ".json");
  const nlohmann::json ref = nlohmann::json::parse(in);
  const std::string urdf = data_dir + "/" + robot + ".urdf";
  chasles::UrdfOptions options;
  options.tip_link = ref["tip_link"].get<std::string>();
  const chasles::RobotModel model = chasles::load_urdf_file(urdf, options);
  chasles::Data data(model);
  const int n = model.dof();

  std::vector<Case> cases;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> noise(-0.01, 0.01);
  for (const auto& c : ref["cases"]) {
    Case k;
    for (int r = 0; r < 4; ++r)
      for (int col = 0; col < 4; ++col) k.T(r, col) = c["T_target"][r][col].get<double>();
    k.seed = Eigen::Map<const Eigen::VectorXd>(c["q_seed"].get<std::vector<double>>().data(), n);
    k.solution = Eigen::Map<const Eigen::VectorXd>(c["q_solution"].get<std::vector<double>>().data(), n);
    cases.push_back(k);
  }

  KDL::Tree tree;
  if (!kdl_parser::treeFromFile(urdf, tree)) throw std::runtime_error("kdl_parser cannot read " + urdf);
  KDL::Chain chain;
  if (!tree.getChain(model.base_link(), model.tip_link(), chain)) throw std::runtime_error("no KDL chain");
  KDL::JntArray lower(n), upper(n);
  for (int i = 0; i < n; ++i) lower(i) = model.joint(i).limits.lower, upper(i) = model.joint(i).limits.upper;
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::ChainIkSolverVel_pinv vel(chain);
  KDL::ChainIkSolverPos_NR_JL kdl(chain, lower, upper, fk, vel, kKdlMaxIterations, kTolerance);

  chasles::IkSolver solver(model);
  nlohmann::json out;
  for (const bool warm : {false, true}) {
    std::vector<Eigen::VectorXd> seeds;
    std::mt19937_64 noise_rng(11);
    for (const Case& c : cases) {
      Eigen::VectorXd seed = c.seed;
      if (warm) {
        seed = c.solution;
        for (int i = 0; i < n; ++i) seed[i] = std::clamp(seed[i] + noise(noise_rng), lower(i), upper(i));
      }
      seeds.push_back(seed);
    }
    // One pass per solver, as an IK worker runs: interleaving the two would have each start every
    // solve with the other's code and data in the caches.
    Figures mine, theirs;
    for (size_t k = 0; k < cases.size(); ++k) {
      const chasles::IkResult result = solver.solve(cases[k].T, seeds[k]);
      mine.us.push_back(result.time_us);
      mine.success += solved(model, data, result.q, cases[k].T) ? 1 : 0;
    }
    for (size_t k = 0; k < cases.size(); ++k) {
      const Case& c = cases[k];
      KDL::JntArray q_in(n), q_out(n);
      for (int i = 0; i < n; ++i) q_in(i) = seeds[k][i];
      KDL::Frame goal;
      for (int r = 0; r < 3; ++r) {
        goal.p(r) = c.T(r, 3);
        for (int col = 0; col < 3; ++col) goal.M(r, col) = c.T(r, col);
      }
      const auto start = Clock::now();
      const int status = kdl.CartToJnt(q_in, goal, q_out);
      theirs.us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
      theirs.success += status >= 0 && solved(model, data, q_out.data, c.T) ? 1 : 0;
    }
    for (auto* f : {&mine, &theirs}) f->total = static_cast<int>(cases.size());
    auto figures = [](const Figures& f) {
      return nlohmann::json{{"success", static_cast<double>(f.success) / f.total},
                            {"median_us", percentile(f.us, 0.5)},
                            {"p99_us", percentile(f.us, 0.99)}};
    };
    out[warm ? "warm" : "cold"] = {{"chasles", figures(mine)}, {"kdl", figures(theirs)}};
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const bool json = argc > 1 && std::strcmp(argv[1], "--json") == 0;
  try {
    nlohmann::json all;
    for (const char* robot : {"ur5", "panda"}) all[robot] = run(robot, CHASLES_BENCH_DATA);
    if (json) {
      std::printf("%s\n", all.dump(2).c_str());
      return 0;
    }
    std::printf("robot  start  solver   success  median us   p99 us\n");
    std::printf("-----  -----  -------  -------  ---------  -------\n");
    for (const auto& [robot, by_start] : all.items()) {
      for (const char* start : {"cold", "warm"}) {
        for (const char* solver : {"chasles", "kdl"}) {
          const auto& f = by_start[start][solver];
          std::printf("%-5s  %-5s  %-7s  %6.1f%%  %9.1f  %7.1f\n", robot.c_str(), start, solver,
                      100.0 * f["success"].get<double>(), f["median_us"].get<double>(), f["p99_us"].get<double>());
        }
      }
    }
    std::printf("\nsuccess: tip within 1e-6 m and 1e-6 rad, within limits; chasles: Ceres LM with restarts in a 5 ms "
                "budget; kdl: ChainIkSolverPos_NR_JL, %d iterations at most.\n",
                kKdlMaxIterations);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chasles_ik_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
