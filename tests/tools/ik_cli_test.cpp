// `chasles ik` run as a real process: the documented output for a targets file in the reference
// format and for one --pose, and bad input as one "chasles: ..." line with the documented exit code.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;

using Result = testing::RunResult;

// Runs the chasles binary with `args`.
Result run_cli(const std::vector<std::string>& args) {
  return testing::run_to_completion(concat({CHASLES_CLI}, args));
}

const std::vector<std::string> kUr5 = {"ik", "--urdf", data_path("ur5.urdf"), "--tip", "tool0"};

std::vector<std::string> ur5_args(const std::vector<std::string>& more) { return concat(kUr5, more); }

RobotModel ur5() {
  UrdfOptions options;
  options.tip_link = "tool0";
  return load_urdf_file(data_path("ur5.urdf"), options);
}

void expect_one_error_line(const Result& result, int exit_code, const std::string& fragment) {
  EXPECT_EQ(result.exit_code, exit_code) << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_EQ(result.err.rfind("chasles: ", 0), 0u) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_NE(result.err.find(fragment), std::string::npos) << result.err;
}

// The first reference targets, with their extra keys, as a targets file: every case answered with
// the documented keys, the answers reach their targets (checked by FK here) and the summary adds up.
TEST(ikCli, TargetsFileGivesTheDocumentedAnswer) {
  std::ifstream file(data_path("ik_ur5.json"));
  json document = json::parse(file);
  document["cases"].erase(document["cases"].begin() + 10, document["cases"].end());
  const TempFile targets("targets.json", document.dump());
  const Result result = run_cli(ur5_args({"--targets", targets.path, "--budget-ms", "1000", "--max-restarts", "100"}));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  const auto out = nlohmann::ordered_json::parse(result.out);  // keeps the printed key order
  const RobotModel model = ur5();
  ASSERT_EQ(out.at("cases").size(), 10u);
  std::vector<double> times;
  for (size_t k = 0; k < 10; ++k) {
    const auto& c = out["cases"][k];
    std::vector<std::string> keys;
    for (const auto& item : c.items()) keys.push_back(item.key());
    EXPECT_EQ(keys, (std::vector<std::string>{"q", "converged", "pos_err", "rot_err", "iterations", "restarts",
                                              "time_us"}));
    EXPECT_TRUE(c.at("converged").get<bool>());
    Eigen::VectorXd q(model.dof());
    for (int i = 0; i < model.dof(); ++i) q[i] = c.at("q").at(static_cast<size_t>(i)).get<double>();
    Matrix4d T_target;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) T_target(i, j) = document["cases"][k]["T_target"][i][j].get<double>();
    const Transform T_sb = forward_kinematics_space(model, q);
    EXPECT_LE((T_sb.translation() - T_target.topRightCorner<3, 1>()).norm(), 1e-6);
    EXPECT_LE(log3(Matrix3d(T_target.topLeftCorner<3, 3>().transpose() * T_sb.linear())).norm(), 1e-6);
    EXPECT_LE(c.at("pos_err").get<double>(), 1e-6);
    times.push_back(c.at("time_us").get<double>());
    EXPECT_GT(times.back(), 0.0) << "a solve that ran took time";
  }
  // The summary is of the cases printed: the median of ten averages the 5th and 6th fastest, and
  // the nearest-rank p99 of ten is the slowest.
  std::sort(times.begin(), times.end());
  const auto& summary = out.at("summary");
  EXPECT_EQ(summary.at("success_rate").get<double>(), 1.0);
  EXPECT_EQ(summary.at("median_us").get<double>(), 0.5 * (times[4] + times[5]));
  EXPECT_EQ(summary.at("p99_us").get<double>(), times[9]);
}

TEST(ikCli, OnePose) {
  // FK at q = 0.3 (all joints), as position and quaternion (w, x, y, z).
  const RobotModel model = ur5();
  const Transform T = forward_kinematics_space(model, Eigen::VectorXd::Constant(6, 0.3));
  const Eigen::Quaterniond r(T.linear());
  std::ostringstream pose;
  pose.precision(17);
  pose << T.translation().x() << ',' << T.translation().y() << ',' << T.translation().z() << ',' << r.w() << ','
       << r.x() << ',' << r.y() << ',' << r.z();
  const Result result = run_cli(ur5_args({"--pose", pose.str(), "--seed", "0,0,0,0,0,0", "--seed-rng", "7"}));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const json out = json::parse(result.out);
  ASSERT_EQ(out.at("cases").size(), 1u);
  EXPECT_TRUE(out["cases"][0].at("converged").get<bool>());
  EXPECT_EQ(out.at("summary").at("success_rate").get<double>(), 1.0);
}

TEST(ikCli, BadInputIsOneLine) {
  const TempFile non_rigid("non_rigid.json",
                           R"({"cases": [{"T_target": [[1,0,0,0],[0,1,0,0],[0,0,2,0],[0,0,0,1]], "q_seed": [0,0,0,0,0,0]}]})");
  expect_one_error_line(run_cli(ur5_args({"--targets", non_rigid.path})), 1, "cases[0].T_target");
  const TempFile non_finite("non_finite.json", R"({"cases": [{"T_target": [[1,0,0,0],[0,1,0,0],[0,0,1,null],[0,0,0,1]]}]})");
  expect_one_error_line(run_cli(ur5_args({"--targets", non_finite.path})), 1, "cases[0].T_target");
  const TempFile short_seed("short_seed.json",
                            R"({"cases": [{"T_target": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "q_seed": [0,0]}]})");
  expect_one_error_line(run_cli(ur5_args({"--targets", short_seed.path})), 1, "q_seed");
  expect_one_error_line(run_cli(ur5_args({"--pose", "0.4,0,0.3,2,0,0,0"})), 1, "quaternion");
  expect_one_error_line(run_cli(ur5_args({"--pose", "0.4,0,0.3,1,0,0,0", "--seed", "0,0"})), 1, "--seed");
  // Usage errors: exit 2.
  expect_one_error_line(run_cli(ur5_args({})), 2, "--targets");
  expect_one_error_line(run_cli(ur5_args({"--targets", non_rigid.path, "--pose", "0,0,0,1,0,0,0"})), 2, "--targets");
  expect_one_error_line(run_cli(ur5_args({"--targets", non_rigid.path, "--seed", "0,0,0,0,0,0"})), 2, "--seed");
  expect_one_error_line(run_cli(ur5_args({"--pose", "0,0,0,1,0,0,0", "--budget-ms", "-1"})), 2, "--budget-ms");
}

}  // namespace
}  // namespace chasles::testing
