// chasles ik: inverse kinematics (chasles::ik, Ceres) for a file of target poses or for one pose.
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "core/ik/ik.hpp"
#include "core/lie/so3.hpp"
#include "tools/cli/cases.hpp"
#include "command.hpp"

namespace chasles::cli {
namespace {

struct IkCommandOptions {
  ModelOptions model;
  std::string targets;
  std::string pose;
  std::string seed;
  double budget_ms = 5.0;
  std::uint64_t rng_seed = 1;
  int max_restarts = IkOptions().max_restarts;
  bool position_only = false;
};

IkTarget parse_pose_input(const RobotModel& model, const IkCommandOptions& options) {
  const Eigen::VectorXd numbers = parse_list(options.pose, 7, "--pose");
  Eigen::Vector4d wxyz = numbers.tail<4>();
  const double norm = wxyz.norm();
  if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance)) {
    throw InputError("--pose: the quaternion (w,x,y,z) has norm " + std::to_string(norm) +
                     "; give a unit quaternion (norm within 1e-3 of 1)");
  }
  wxyz /= norm;
  const Eigen::Quaterniond rotation(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  IkTarget input;
  input.T_sd = Matrix4d::Identity();
  input.T_sd.topLeftCorner<3, 3>() = rotation.toRotationMatrix();
  input.T_sd.topRightCorner<3, 1>() = numbers.head<3>();
  input.q_seed = options.seed.empty() ? middle_of_limits(model) : parse_list(options.seed, model.dof(), "--seed");
  return input;
}

/// The p-quantile of sorted values by the nearest-rank method; the median averages the middle two.
double median(const std::vector<double>& sorted) {
  const size_t n = sorted.size();
  return n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
}

double nearest_rank(const std::vector<double>& sorted, double p) {
  const size_t rank = static_cast<size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::min(sorted.size(), std::max<size_t>(rank, 1)) - 1];
}

Json run_ik(const IkCommandOptions& options) {
  const RobotModel model = load_model(options.model);
  const std::vector<IkTarget> inputs =
      options.targets.empty()
          ? std::vector<IkTarget>{parse_pose_input(model, options)}
          : parse_ik_targets(read_json_file(options.targets, "targets file"), model, options.targets);
  IkOptions ik_options;
  ik_options.position_only = options.position_only;
  ik_options.time_budget = std::chrono::microseconds(static_cast<std::int64_t>(std::llround(options.budget_ms * 1e3)));
  ik_options.rng_seed = options.rng_seed;
  ik_options.max_restarts = options.max_restarts;
  IkSolver solver(model, ik_options);

  Json cases = Json::array();
  std::vector<double> times;
  int converged = 0;
  for (const IkTarget& input : inputs) {
    const IkResult result = solver.solve(input.T_sd, input.q_seed);
    Json out;
    out["q"] = vector_json(result.q);
    out["converged"] = result.converged;
    out["pos_err"] = number(result.pos_err);
    out["rot_err"] = number(result.rot_err);
    out["iterations"] = result.iterations;
    out["restarts"] = result.restarts;
    out["time_us"] = number(result.time_us);
    cases.push_back(std::move(out));
    times.push_back(result.time_us);
    converged += result.converged ? 1 : 0;
  }
  Json summary;
  if (times.empty()) {
    summary["success_rate"] = nullptr;
    summary["median_us"] = nullptr;
    summary["p99_us"] = nullptr;
  } else {
    std::sort(times.begin(), times.end());
    summary["success_rate"] = static_cast<double>(converged) / static_cast<double>(times.size());
    summary["median_us"] = median(times);
    summary["p99_us"] = nearest_rank(times, 0.99);
  }
  Json document;
  document["cases"] = std::move(cases);
  document["summary"] = std::move(summary);
  return document;
}

}  // namespace

Command register_ik(CLI::App& app) {
  auto options = std::make_shared<IkCommandOptions>();
  CLI::App* command = app.add_subcommand("ik", "Inverse kinematics (Ceres): joint positions that put the tip at a pose");
  add_model_options(*command, options->model);
  CLI::Option* targets =
      command
          ->add_option("--targets", options->targets,
                       "JSON file {\"cases\": [{\"T_target\": 4x4 rows, \"q_seed\": [n numbers]}, ...]}; q_seed is "
                       "optional (default: the middle of the limits); other keys are ignored; - reads stdin")
          ->type_name("FILE");
  CLI::Option* pose = command
                          ->add_option("--pose", options->pose,
                                       "One target tip pose in the base frame: position x,y,z (m) and unit "
                                       "quaternion qw,qx,qy,qz")
                          ->type_name("X,Y,Z,QW,QX,QY,QZ");
  CLI::Option* seed =
      command->add_option("--seed", options->seed, "Start for --pose, one per joint (default: the middle of the limits)")
          ->type_name("Q,Q,...");
  command
      ->add_option("--budget-ms", options->budget_ms,
                   "Time budget per target, ms of the solving thread's CPU time: restarts stop when it is spent")
      ->check(CLI::Range(0.001, 3.6e6))
      ->capture_default_str();
  command->add_option("--seed-rng", options->rng_seed, "Seed of the random restarts")->capture_default_str();
  command->add_option("--max-restarts", options->max_restarts, "At most this many random restarts per target")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->add_flag("--position-only", options->position_only, "Reach the tip position only; the orientation is free");

  command->parse_complete_callback([=] {
    if ((targets->count() > 0) == (pose->count() > 0)) throw CLI::ValidationError("give exactly one of --targets and --pose");
    if (seed->count() > 0 && pose->count() == 0) throw CLI::ValidationError("--seed goes with --pose (a targets file has q_seed)");
  });
  command->footer(
      "Output: {\"cases\": [{\"q\": joint positions (the best found when not converged),\n"
      "                      \"converged\": pos_err <= 1e-6 m and rot_err <= 1e-6 rad,\n"
      "                      \"pos_err\": m, \"rot_err\": rad, \"iterations\", \"restarts\", \"time_us\"}, ...],\n"
      "         \"summary\": {\"success_rate\", \"median_us\", \"p99_us\" (nearest rank)}}\n"
      "The solution respects the joint limits; continuous joints are wrapped to (-pi, pi]. The answer is\n"
      "deterministic for a given --seed-rng unless the time budget, rather than --max-restarts, ends the\n"
      "search (a slower machine then tries fewer restarts). Refused (exit 1): a target that is not a finite\n"
      "rigid transform (rotation orthonormal and det 1 within 1e-6, bottom row 0 0 0 1), a seed of the wrong\n"
      "size, a quaternion whose norm is more than 1e-3 from 1.\n"
      "Examples:\n"
      "  chasles ik --urdf ur5.urdf --tip tool0 --targets ik_ur5.json\n"
      "  chasles ik --urdf ur5.urdf --tip tool0 --pose 0.4,0.1,0.3,0,1,0,0 --seed 0,-1.5,1.5,-1.5,-1.5,0");
  return {command, [options] { return run_ik(*options); }};
}

}  // namespace chasles::cli
