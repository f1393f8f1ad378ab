// chasles_calibrate run as a real process: synth → fit round trips judged against the synthetic
// truth (its URDF and base/tool, loaded back with chasles's loader), the report's contract, and bad
// input as one "chasles_calibrate: ..." line with the documented exit code and nothing written.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include <chasles/robot_state_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/identification/dynamic_fit.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/payload.hpp"
#include "core/model/urdf.hpp"
#include "support/arm.hpp"
#include "support/identification_run.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;

RunResult run(const std::vector<std::string>& args) {
  return run_to_completion(concat({CHASLES_CALIBRATE}, args));
}

/// A fresh directory for one test's files, removed with everything in it.
struct ScratchDir {
  ScratchDir() {
    std::string pattern = ::testing::TempDir() + "chasles_calibrate_XXXXXX";
    path = ::mkdtemp(pattern.data());
  }
  ~ScratchDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return path + "/" + name; }
  std::string path;
};

bool exists(const std::string& path) { return std::filesystem::exists(path); }

Transform transform_from(const json& rows) {
  Matrix4d T;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) T(i, j) = rows.at(i).at(j).get<double>();
  return Transform(T.topLeftCorner<3, 3>(), T.topRightCorner<3, 1>());
}

RobotModel load_to(const std::string& urdf, const std::string& tip) {
  UrdfOptions options;
  options.tip_link = tip;
  return load_urdf_file(urdf, options);
}

/// RMS position and orientation distance, over fresh configurations, between the marker the
/// corrected URDF and report predict and the one the truth's URDF and JSON give — each loaded
/// with chasles's URDF loader to the marker link, the way any URDF user would.
std::pair<double, double> prediction_rms(const std::string& corrected_urdf, const json& report,
                                         const std::string& truth_urdf, const json& truth) {
  const RobotModel corrected = load_to(corrected_urdf, "marker");
  const RobotModel actual = load_to(truth_urdf, "marker");
  const Transform T_base = transform_from(report.at("T_tracker_base"));
  const Transform T_base_truth = transform_from(truth.at("T_tracker_base"));
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double sp = 0.0, sr = 0.0;
  const int n = 100;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd q(actual.dof());
    for (int i = 0; i < actual.dof(); ++i) {
      const JointLimits& l = actual.joint(i).limits;
      q[i] = l.lower + (0.05 + 0.9 * unit(rng)) * (l.upper - l.lower);
    }
    const Transform predicted = T_base * forward_kinematics_space(corrected, q);
    const Transform expected = T_base_truth * forward_kinematics_space(actual, q);
    sp += (predicted.translation() - expected.translation()).squaredNorm();
    sr += log3(Matrix3d(expected.linear().transpose() * predicted.linear())).squaredNorm();
  }
  return {std::sqrt(sp / n), std::sqrt(sr / n)};
}

struct Robot {
  std::string urdf, tip;
};
const Robot kUr5{data_path("ur5.urdf"), "tool0"};
const Robot kPanda{data_path("panda.urdf"), "panda_hand"};

/// synth then fit in `dir`; returns the fit's result. Extra arguments per step.
RunResult synth_and_fit(const ScratchDir& dir, const Robot& robot, const std::vector<std::string>& synth_extra,
                        const std::vector<std::string>& fit_extra = {}) {
  std::vector<std::string> synth{"synth", "--urdf", robot.urdf, "--tip", robot.tip, "--n", "200",
                                 "--out", dir / "data.csv", "--truth", dir / "truth.urdf",
                                 "--truth-report", dir / "truth.json"};
  synth.insert(synth.end(), synth_extra.begin(), synth_extra.end());
  const RunResult s = run(synth);
  EXPECT_EQ(s.exit_code, 0) << s.err;
  EXPECT_NE(s.out.find("wrote"), std::string::npos) << s.out;
  std::vector<std::string> fit{"fit", "--urdf", robot.urdf, "--tip", robot.tip, "--data", dir / "data.csv",
                               "--holdout", "0.2", "--out", dir / "corrected.urdf", "--report", dir / "report.json"};
  fit.insert(fit.end(), fit_extra.begin(), fit_extra.end());
  return run(fit);
}

json read_json(const std::string& path) { return json::parse(read_file(path)); }

// Known errors of a few mm and mrad on every origin and zero, base and tool, noise σ: on fresh
// configurations the corrected URDF predicts the truth's noise-free marker far better than σ.
TEST(calibrateCli, PoseRoundTripPredictsTheTruth) {
  const ScratchDir dir;
  const double sigma_p = 1e-4, sigma_r = 1e-3;
  const RunResult fit = synth_and_fit(dir, kUr5, {"--seed", "5", "--noise-pos", "1e-4", "--noise-rot", "1e-3"},
                                      {"--sigma-pos", "1e-4", "--sigma-rot", "1e-3"});
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_EQ(fit.err, "");
  for (const char* line : {"identifiable parameters: 30 of 54", "held-out after", "solver: converged"}) {
    EXPECT_NE(fit.out.find(line), std::string::npos) << fit.out;
  }
  const json report = read_json(dir / "report.json");
  const json truth = read_json(dir / "truth.json");
  EXPECT_EQ(report.at("measurements"), "pose");
  EXPECT_EQ(report.at("identifiability").at("rank"), 30);
  EXPECT_EQ(report.at("identifiability").at("theoretical"), 30);
  EXPECT_EQ(report.at("identifiability").at("fixed").size(), 24u);
  EXPECT_EQ(report.at("split").at("holdout_rows"), 40);
  EXPECT_EQ(report.at("split").at("holdout_lines").size(), 40u);
  const json& holdout = report.at("residuals").at("holdout");
  EXPECT_LT(holdout.at("after").at("rms_position_m").get<double>(), 2.0 * std::sqrt(3.0) * sigma_p);
  EXPECT_GT(holdout.at("before").at("rms_position_m").get<double>(), 10.0 * sigma_p);
  EXPECT_LT(holdout.at("after").at("rms_rotation_rad").get<double>(), 2.0 * std::sqrt(3.0) * sigma_r);
  const auto [position, rotation] = prediction_rms(dir / "corrected.urdf", report, dir / "truth.urdf", truth);
  EXPECT_LT(position, 0.5 * sigma_p);
  EXPECT_LT(rotation, 0.5 * sigma_r);
  for (const json& p : report.at("parameters")) {
    if (p.at("free").get<bool>()) {
      EXPECT_GT(p.at("stddev").get<double>(), 0.0) << p;
    } else {
      EXPECT_EQ(p.at("estimate").get<double>(), 0.0) << p;
    }
  }
  std::printf("ur5 pose: held-out RMS %.3g m before, %.3g m after; truth prediction RMS %.3g m, %.3g rad\n",
              holdout.at("before").at("rms_position_m").get<double>(),
              holdout.at("after").at("rms_position_m").get<double>(), position, rotation);
}

// A laser tracker: positions only. The tool's orientation is not identifiable (3 fewer), and the
// predicted marker positions still match the truth far below σ.
TEST(calibrateCli, PositionOnlyRoundTrip) {
  const ScratchDir dir;
  const double sigma_p = 1e-4;
  const RunResult fit = synth_and_fit(dir, kPanda, {"--seed", "6", "--position-only"});
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const json report = read_json(dir / "report.json");
  EXPECT_EQ(report.at("measurements"), "position");
  EXPECT_EQ(report.at("identifiability").at("rank"), 31);
  EXPECT_EQ(report.at("identifiability").at("theoretical"), 31);
  EXPECT_TRUE(report.at("residuals").at("fit").at("after").at("rms_rotation_rad").is_null());
  int no_effect = 0;
  for (const json& f : report.at("identifiability").at("fixed")) no_effect += f.at("reason") == "no effect" ? 1 : 0;
  EXPECT_EQ(no_effect, 3);  // tool.wx, tool.wy, tool.wz
  const auto [position, rotation] = prediction_rms(dir / "corrected.urdf", report, dir / "truth.urdf", read_json(dir / "truth.json"));
  (void)rotation;
  EXPECT_LT(position, 0.5 * sigma_p);
}

TEST(calibrateCli, NoiseFreeDataFitToRoundOff) {
  const ScratchDir dir;
  const RunResult fit = synth_and_fit(dir, kPanda, {"--seed", "7", "--noise-pos", "0", "--noise-rot", "0"});
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const json report = read_json(dir / "report.json");
  const json& after = report.at("residuals").at("fit").at("after");
  EXPECT_LT(after.at("max_position_m").get<double>(), 1e-9);
  EXPECT_LT(after.at("max_rotation_rad").get<double>(), 1e-9);
  EXPECT_LT(report.at("residuals").at("holdout").at("after").at("max_position_m").get<double>(), 1e-9);
  const auto [position, rotation] = prediction_rms(dir / "corrected.urdf", report, dir / "truth.urdf", read_json(dir / "truth.json"));
  EXPECT_LT(position, 1e-9);
  EXPECT_LT(rotation, 1e-9);
}

// 5 % of the rows 10 cm off: the robust loss leaves them out, the report names exactly those
// lines, and the predictions are as good as without them.
TEST(calibrateCli, OutliersAreRejectedAndNamed) {
  const ScratchDir dir;
  const RunResult fit = synth_and_fit(dir, kUr5, {"--seed", "8", "--outliers", "0.05", "--position-only"});
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const json report = read_json(dir / "report.json");
  const json truth = read_json(dir / "truth.json");
  std::vector<int> flagged = report.at("outliers").at("fit_lines").get<std::vector<int>>();
  for (int line : report.at("outliers").at("holdout_lines").get<std::vector<int>>()) flagged.push_back(line);
  std::sort(flagged.begin(), flagged.end());
  EXPECT_EQ(flagged, truth.at("outlier_lines").get<std::vector<int>>());
  EXPECT_EQ(flagged.size(), 10u);
  const auto [position, rotation] = prediction_rms(dir / "corrected.urdf", report, dir / "truth.urdf", truth);
  (void)rotation;
  EXPECT_LT(position, 0.5e-4);
}

// Explicit errors: only the ones given are in the truth.
TEST(calibrateCli, ExplicitErrorSpec) {
  const ScratchDir dir;
  const RunResult s = run({"synth", "--urdf", kUr5.urdf, "--tip", kUr5.tip, "--n", "50", "--out", dir / "d.csv",
                           "--truth-report", dir / "t.json", "--errors",
                           R"({"offsets": {"elbow_joint": 0.002}, "origins": {"wrist_1_joint": [0, 0.001, 0, 0.002, 0, 0]}})"});
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const json truth = read_json(dir / "t.json");
  EXPECT_EQ(truth.at("offsets").at("elbow_joint"), 0.002);
  EXPECT_EQ(truth.at("offsets").at("shoulder_pan_joint"), 0.0);
  EXPECT_EQ(truth.at("origins").at("wrist_1_joint").at(3), 0.002);
  EXPECT_EQ(transform_from(truth.at("T_tracker_base")).matrix(), Matrix4d::Identity());
  const RunResult bad = run({"synth", "--urdf", kUr5.urdf, "--tip", kUr5.tip, "--out", dir / "e.csv", "--errors",
                             R"({"offsets": {"no_such_joint": 1}})"});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("'no_such_joint' is not a joint of the chain"), std::string::npos) << bad.err;
  EXPECT_FALSE(exists(dir / "e.csv"));
}

void expect_one_error_line(const RunResult& result, int exit_code, const std::string& fragment) {
  EXPECT_EQ(result.exit_code, exit_code) << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_EQ(result.err.rfind("chasles_calibrate: ", 0), 0u) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_NE(result.err.find(fragment), std::string::npos) << result.err;
}

// Bad datasets: exit 1, the file and line in the message, and no output written — an existing
// output file is left as it was.
TEST(calibrateCli, BadInputWritesNothing) {
  const ScratchDir dir;
  const std::string header =
      "shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,wrist_3_joint,x,y,z\n";
  std::string rows;
  for (int k = 0; k < 30; ++k) rows += "0.1,-1," + std::to_string(0.05 * k) + ",0.2,0.3,0.4,1,2,3\n";
  struct Case {
    std::string content, fragment;
  };
  const std::vector<Case> cases = {
      {header + rows + "0,0,0,0,0,nan,1,2,3\n", "bad.csv:32: column 'wrist_3_joint': 'nan' is not a finite number"},
      {header + rows + "0,0,0,0,0,1,2,3\n", "bad.csv:32: 8 fields, expected 9"},
      {"shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,wrist_7_joint,x,y,z\n" + rows,
       "bad.csv:1: unknown column 'wrist_7_joint'"},
      {header + "0.1,-1,0.1,0.2,0.3,0.4,1,2,3\n0.2,-1,0.1,0.2,0.3,0.4,1,2,3\n", "lines 2-3"},
  };
  const std::string report = dir / "report.json";
  const TempFile existing("existing_report.json", "keep me");
  for (const Case& c : cases) {
    const TempFile data("bad.csv", c.content);
    const RunResult result = run({"fit", "--urdf", kUr5.urdf, "--tip", kUr5.tip, "--data", data.path, "--out",
                                  dir / "out.urdf", "--report", existing.path, "--holdout", "0"});
    expect_one_error_line(result, 1, c.fragment);
    EXPECT_FALSE(exists(dir / "out.urdf"));
    EXPECT_EQ(read_file(existing.path), "keep me");
  }
  // No stray temporary files either.
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
  expect_one_error_line(run({"fit", "--urdf", dir / "missing.urdf", "--data", "x.csv", "--out", dir / "o.urdf",
                             "--report", report}),
                        1, "missing.urdf");
}

// The brief's Fourier series, evaluated here from the report's q0, a and b: q, q̇, q̈, q⃛ of joint i.
std::array<double, 4> swevers_series(const json& report, int i, double t) {
  const double w = 2.0 * kPi / report.at("period").get<double>();
  std::array<double, 4> x{report.at("q0").at(i).get<double>(), 0.0, 0.0, 0.0};
  const json& a = report.at("a").at(i);
  const json& b = report.at("b").at(i);
  for (size_t l = 1; l <= a.size(); ++l) {
    const double al = a.at(l - 1).get<double>(), bl = b.at(l - 1).get<double>(), wl = w * l;
    const double s = std::sin(wl * t), c = std::cos(wl * t);
    x[0] += al / wl * s - bl / wl * c;
    x[1] += al * c + bl * s;
    x[2] += wl * (-al * s + bl * c);
    x[3] += wl * wl * (-al * c - bl * s);
  }
  return x;
}

// excite writes the series as waypoints — the first the start at rest after a 1 s lead-in, each
// other one the series' q, q̇, q̈ at its time, the last exactly at rest at the start — within the controller's default limits every millisecond: the
// URDF's positions less 0.01 rad, its velocities, velocity / 0.4 s and that / 0.02 s
// (docs/controller.md, "Limits"). A short optimisation, as CI affords.
TEST(calibrateCli, ExciteWritesTheSeriesAsWaypointsWithinTheLimits) {
  const ScratchDir dir;
  const RunResult result = run({"excite", "--urdf", kPanda.urdf, "--tip", kPanda.tip, "--out", dir / "excitation.json",
                                "--report", dir / "report.json", "--period", "4", "--harmonics", "3", "--duration", "8",
                                "--samples", "20", "--iterations", "10", "--waypoints", "400"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("62 base parameters"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("chasles target --joint 0,0,0,-1.5708"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("--collision-torque inf --collision-force inf --collision-moment inf"), std::string::npos)
      << result.out;
  const json report = read_json(dir / "report.json");
  const json trajectory = read_json(dir / "excitation.json");
  const RobotModel model = load_to(kPanda.urdf, kPanda.tip);
  const int n = model.dof();
  EXPECT_EQ(report.at("base_parameters"), 62);
  EXPECT_LT(report.at("condition_number").get<double>(), report.at("start_condition_number").get<double>());
  EXPECT_EQ(report.at("periods"), 2);

  // The file as `chasles target --trajectory` reads it (tools/chasles/target.cpp, read_trajectory).
  ASSERT_EQ(trajectory.at("joint_names").size(), 7u);
  for (int i = 0; i < n; ++i) EXPECT_EQ(trajectory.at("joint_names").at(i), model.joint(i).name);
  // An arm that sags at the start would have the first waypoint refused without it.
  EXPECT_EQ(trajectory.at("time_scaling"), true);
  const json& points = trajectory.at("points");
  ASSERT_EQ(points.size(), 400u);
  double before = 0.0, worst = 0.0;
  for (size_t k = 0; k < points.size(); ++k) {
    const json& point = points[k];
    const double t = point.at("time_from_start").get<double>();
    ASSERT_GT(t, before) << "waypoint " << k;
    before = t;
    for (const char* key : {"positions", "velocities", "accelerations"}) ASSERT_EQ(point.at(key).size(), 7u) << key;
    for (int i = 0; i < n; ++i) {
      // The first holds the start for the lead-in (1 s), at rest: the series' value at its t = 0.
      const std::array<double, 4> x = swevers_series(report, i, k == 0 ? 0.0 : t - 1.0);
      for (int d = 0; d < 3; ++d) {
        const char* key = d == 0 ? "positions" : d == 1 ? "velocities" : "accelerations";
        worst = std::max(worst, std::abs(point.at(key).at(i).get<double>() - x[d]));
      }
    }
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(points[0].at("time_from_start"), 1.0);
  EXPECT_EQ(report.at("lead_in"), 1.0);
  EXPECT_EQ(before, 9.0);
  const json& last = points.back();
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(last.at("positions").at(i), report.at("start").at(i));
    EXPECT_EQ(last.at("velocities").at(i), 0.0);
    EXPECT_EQ(last.at("accelerations").at(i), 0.0);
  }

  // Every millisecond from the start at rest to the end.
  for (int i = 0; i < n; ++i) {
    const JointLimits& l = model.joint(i).limits;
    const double v = l.velocity, a = v / 0.4, j = a / 0.02;
    double peak[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k <= 8000; ++k) {
      const std::array<double, 4> x = swevers_series(report, i, 1e-3 * k);
      ASSERT_GE(x[0], l.lower + 0.01) << model.joint(i).name << " at " << 1e-3 * k << " s";
      ASSERT_LE(x[0], l.upper - 0.01) << model.joint(i).name << " at " << 1e-3 * k << " s";
      for (int d = 0; d < 3; ++d) peak[d] = std::max(peak[d], std::abs(x[d + 1]));
    }
    EXPECT_LE(peak[0], v) << model.joint(i).name;
    EXPECT_LE(peak[1], a) << model.joint(i).name;
    EXPECT_LE(peak[2], j) << model.joint(i).name;
    const json& reported = report.at("joints").at(i);
    EXPECT_NEAR(reported.at("velocity_fraction").get<double>(), peak[0] / v, 1e-9);
    EXPECT_NEAR(reported.at("jerk_fraction").get<double>(), peak[2] / j, 1e-9);
    const std::array<double, 4> at_start = swevers_series(report, i, 0.0);
    EXPECT_NEAR(at_start[0], report.at("start").at(i).get<double>(), 1e-14);
    EXPECT_NEAR(at_start[1], 0.0, 1e-14);
    EXPECT_NEAR(at_start[2], 0.0, 1e-13);
  }
#ifdef CHASLES_CLI
  // And chasles target itself takes it (on an in-process bus: nothing leaves the machine).
  const RunResult sent = run_to_completion({CHASLES_CLI, "target", "--robot", kPanda.urdf, "--tip", kPanda.tip,
                                            "--trajectory", dir / "excitation.json", "--lcm-url", "memq://"});
  EXPECT_EQ(sent.exit_code, 0) << sent.err;
  EXPECT_EQ(json::parse(sent.out).at("points"), 400) << sent.out;
#endif
}

// Refused before anything is optimised or written: a duration shorter than a period or not a whole
// number of them, a start of the wrong size or outside the limits, a limit list of the wrong size.
TEST(calibrateCli, ExciteRefusesBadInputAndWritesNothing) {
  const ScratchDir dir;
  const std::vector<std::string> common{"excite", "--urdf", kPanda.urdf, "--tip", kPanda.tip, "--out",
                                        dir / "excitation.json", "--report", dir / "report.json"};
  struct Case {
    std::vector<std::string> args;
    std::string fragment;
  };
  const std::vector<Case> cases = {
      {{"--duration", "5"}, "--duration 5 s is shorter than one period (--period 10 s)"},
      {{"--duration", "15"}, "--duration 15 s is not a whole number of 10 s periods"},
      {{"--start", "0,0,0,-1.5,0,1.8"}, "--start has 6 values; the arm has 7 joints (panda_joint1, "},
      {{"--start", "0,0,0,0,0,1.8,0"}, "joint panda_joint4 at 0 is not within"},
      {{"--start", "0,0,x,-1.5,0,1.8,0"}, "--start: entry 2 ('x') is not a number"},
      {{"--acceleration-limit", "1,2"}, "--acceleration-limit has 2 entries; give one or 7"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = common;
    args.insert(args.end(), c.args.begin(), c.args.end());
    expect_one_error_line(run(args), 1, c.fragment);
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
  std::vector<std::string> one = common;
  one.insert(one.end(), {"--harmonics", "1"});
  expect_one_error_line(run(one), 2, "--harmonics");
}

TEST(calibrateCli, UsageErrorsExitTwo) {
  const ScratchDir dir;
  expect_one_error_line(run({"fit", "--urdf", kUr5.urdf, "--out", dir / "o", "--report", dir / "r"}), 2, "--data");
  expect_one_error_line(run({"fit", "--urdf", kUr5.urdf, "--data", "d.csv", "--out", dir / "o", "--report", dir / "r",
                             "--loss", "tukey"}),
                        2, "--loss");
  expect_one_error_line(run({"fit", "--urdf", kUr5.urdf, "--data", "d.csv", "--out", dir / "o", "--report", dir / "r",
                             "--holdout", "1.5"}),
                        2, "--holdout");
  expect_one_error_line(run({"calibrate"}), 2, "unknown command 'calibrate'");
  expect_one_error_line(run({}), 2, "subcommand");
}

TEST(calibrateCli, HelpDescribesTheOutput) {
  const RunResult fit = run({"fit", "--help"});
  EXPECT_EQ(fit.exit_code, 0);
  for (const char* text : {"marker_joint", "T_tracker_base", "Example", "atomically", "--position-only", "--loss"}) {
    EXPECT_NE(fit.out.find(text), std::string::npos) << text;
  }
  const RunResult excite = run({"excite", "--help"});
  EXPECT_EQ(excite.exit_code, 0);
  for (const char* text : {"--start", "chasles target", "atomically", "Example"}) {
    EXPECT_NE(excite.out.find(text), std::string::npos) << text;
  }
  const RunResult synth = run({"synth", "--help"});
  EXPECT_EQ(synth.exit_code, 0);
  EXPECT_NE(synth.out.find("--truth"), std::string::npos);
}

// --- dynamics ----------------------------------------------------------------------------------

/// The samples as the arm's driver would have sent them: robot_state_t on `channel`, encoded by
/// lcm-gen's code, in a log written by LCM's own LogFile, stamped from an epoch time; every
/// `repeat_every`-th state sent twice, as a sender repeats a state it has nothing newer than.
void write_state_log(const std::string& path, const JointSamples& samples, const std::string& channel,
                     int repeat_every = 0) {
  lcm::LogFile log(path, "w");
  ASSERT_TRUE(log.good()) << path;
  const int n = static_cast<int>(samples.q.rows());
  const int64_t start = 1'800'000'000'000'000;  // µs since the epoch, in 2027
  std::vector<uint8_t> bytes;
  int64_t events = 0;
  for (Eigen::Index k = 0; k < samples.t.size(); ++k) {
    robot_state_t state;
    state.utime = start + std::llround(samples.t[k] * 1e6);
    state.seq = k;
    state.num_joints = n;
    for (const auto& [field, values] : {std::pair{&state.position, &samples.q}, std::pair{&state.velocity, &samples.qd},
                                        std::pair{&state.effort, &samples.tau}}) {
      field->assign(values->col(k).data(), values->col(k).data() + n);
    }
    bytes.resize(static_cast<size_t>(state.getEncodedSize()));
    ASSERT_EQ(state.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
    const bool twice = repeat_every > 0 && k % repeat_every == repeat_every - 1;
    for (int copy = 0; copy < (twice ? 2 : 1); ++copy) {
      lcm::LogEvent event;
      event.eventnum = events++;
      event.timestamp = state.utime + 150 + copy;  // received a little after it was stamped
      event.channel = channel;
      event.datalen = static_cast<int32_t>(bytes.size());
      event.data = bytes.data();
      ASSERT_EQ(log.writeEvent(&event), 0);
    }
  }
}

constexpr double kEffortNoise = 0.05;  // N·m

const Robot kPandaTcp{data_path("panda.urdf"), "panda_hand_tcp"};  // testing::panda()'s chain

// The perturbed Panda of tests/support/identification_run, 12 s at 500 Hz, logged as its driver
// would: the command identifies it, the report's base parameters match the truth's within their
// standard errors, the held-out torques shrink to the noise, and the URDF carries the report.
TEST(calibrateCli, DynamicsIdentifiesTheArmFromItsLog) {
  const ScratchDir dir;
  const TrueArm truth = perturbed_panda(7);
  write_state_log(dir / "run.lcmlog", synthetic_run(truth, 12.0, 500.0, kEffortNoise, 11), "CHASLES_STATE", 100);
  const RunResult result = run({"dynamics", "--urdf", kPandaTcp.urdf, "--tip", kPandaTcp.tip, "--log",
                                dir / "run.lcmlog", "--out", dir / "identified.urdf", "--report",
                                dir / "identified.json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  EXPECT_NE(result.out.find("base parameters: 62 of 62 (theory)"), std::string::npos) << result.out;
  const json report = read_json(dir / "identified.json");

  const json& base = report.at("base_parameters");
  EXPECT_EQ(base.at("count"), 62);
  EXPECT_EQ(base.at("data_rank"), 62);
  EXPECT_EQ(base.at("inertial"), 43);
  const BaseParameters structure = base_parameters(panda(), 100, 1);
  const Eigen::VectorXd beta_true = base_parameter_values(structure, truth.parameters());
  Eigen::VectorXd beta(62);
  for (int k = 0; k < 62; ++k) {
    const json& c = base.at("combinations").at(k);
    EXPECT_EQ(c.at("expression"), base_parameter_expression(panda(), structure, k));
    beta[k] = c.at("identified").get<double>();
    EXPECT_LT(std::abs(beta[k] - beta_true[k]), 4.0 * c.at("standard_error").get<double>()) << c.at("expression");
  }
  for (const json& joint : report.at("held_out_torque_rms")) {
    const double before = joint.at("nominal").get<double>(), after = joint.at("identified").get<double>();
    EXPECT_LE(after, 1.5 * kEffortNoise) << joint.at("joint");
    EXPECT_GE(before, 10.0 * after) << joint.at("joint");
    // No stiction here: the slow samples the fit leaves out are explained as well as the rest.
    EXPECT_LE(joint.at("identified_every_sample").get<double>(), 1.5 * kEffortNoise) << joint.at("joint");
  }
  const json& samples = report.at("samples");
  EXPECT_EQ(samples.at("rest_s"), 0.0);  // the five sines never stop every joint at once
  ASSERT_EQ(samples.at("moving_share").size(), 7u);
  for (const auto& [joint, share] : samples.at("moving_share").items()) {
    EXPECT_GT(share.get<double>(), 0.5) << joint;
    EXPECT_LT(share.get<double>(), 0.8) << joint;
  }
  EXPECT_EQ(samples.at("states"), 6000);
  EXPECT_EQ(samples.at("repeated_states_left_out"), 60);
  EXPECT_EQ(samples.at("decimation"), 20);
  EXPECT_EQ(samples.at("held_out_blocks"), json::array({8, 9}));
  EXPECT_GT(report.at("solver").at("fit_seconds").get<double>(), 0.0);

  // The identified URDF, loaded by chasles's loader, is the report's model: its bodies and rotors
  // with the report's friction give the report's base parameters.
  const RobotModel loaded = load_to(dir / "identified.urdf", kPandaTcp.tip);
  Eigen::VectorXd pi = model_parameters(loaded);
  const json& parameters = report.at("parameters");
  ASSERT_EQ(parameters.size(), 91u);
  const ParameterLayout layout = parameter_layout(loaded);
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(parameters.at(layout.viscous(i)).at("name"), panda().joint(i).name + ".viscous");
    pi[layout.viscous(i)] = parameters.at(layout.viscous(i)).at("identified").get<double>();
    pi[layout.coulomb(i)] = parameters.at(layout.coulomb(i)).at("identified").get<double>();
  }
  EXPECT_TRUE(matrices_near_relative(base_parameter_values(structure, pi), beta, 1e-9));
}

// The arm identified from one log, then a 1.2 kg load on it from another, on the identified URDF:
// the payload is what `chasles payload` would send, found to within grams and millimetres.
TEST(calibrateCli, PayloadOnTheIdentifiedArm) {
  const ScratchDir dir;
  const TrueArm truth = perturbed_panda(7);
  write_state_log(dir / "run.lcmlog", synthetic_run(truth, 12.0, 500.0, kEffortNoise, 11), "CHASLES_STATE");
  ASSERT_EQ(run({"dynamics", "--urdf", kPandaTcp.urdf, "--tip", kPandaTcp.tip, "--log", dir / "run.lcmlog", "--out",
                 dir / "identified.urdf", "--report", dir / "identified.json"})
                .exit_code,
            0);
  Payload box;
  box.mass = 1.2;
  box.centre = Vector3d(0.02, -0.01, 0.08);
  box.inertia = Vector3d(0.0023, 0.0026, 0.001).asDiagonal();
  const TrueArm carrying{with_payload(truth.model, box), truth.viscous, truth.coulomb};
  write_state_log(dir / "box.lcmlog", synthetic_run(carrying, 6.0, 500.0, kEffortNoise, 13), "CHASLES_STATE");
  const RunResult result = run({"payload", "--urdf", dir / "identified.urdf", "--tip", kPandaTcp.tip, "--log",
                                dir / "box.lcmlog", "--out", dir / "box.json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("send it: chasles payload --mass "), std::string::npos) << result.out;
  const json out = read_json(dir / "box.json");
  EXPECT_NEAR(out.at("mass").get<double>(), box.mass, 0.01);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(out.at("centre_of_mass").at(k).get<double>(), box.centre[k], 2e-3);
  EXPECT_EQ(out.at("command").get<std::string>().rfind("chasles payload --mass ", 0), 0u);
  // The identified URDF's friction came back from its <dynamics>.
  const json report = read_json(dir / "identified.json");
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(out.at("arm").at("viscous").at(i), report.at("parameters").at(70 + i).at("identified"));
  }
  for (const json& joint : out.at("held_out_torque_rms")) {
    EXPECT_LE(joint.at("with_payload").get<double>(), 1.5 * kEffortNoise) << joint.at("joint");
  }
}

// "over the joints: X" of check's output.
double rms_over_joints(const std::string& out) {
  const size_t at = out.find("over the joints: ");
  return at == std::string::npos ? -1.0 : std::stod(out.substr(at + 17));
}

// What the report's held-out RMS claims, against what the identified URDF does on another motion
// of the same arm (other sines, other noise): within 20 %, and the URDF as given far worse there.
TEST(calibrateCli, CheckMeasuresTheIdentifiedUrdfOnAnotherMotion) {
  const ScratchDir dir;
  const TrueArm truth = perturbed_panda(7);
  write_state_log(dir / "run.lcmlog", synthetic_run(truth, 12.0, 500.0, kEffortNoise, 11), "CHASLES_STATE");
  write_state_log(dir / "other.lcmlog", synthetic_run(truth, 12.0, 500.0, kEffortNoise, 17), "CHASLES_STATE");
  ASSERT_EQ(run({"dynamics", "--urdf", kPandaTcp.urdf, "--tip", kPandaTcp.tip, "--log", dir / "run.lcmlog", "--out",
                 dir / "identified.urdf", "--report", dir / "identified.json"})
                .exit_code,
            0);
  double claimed = 0.0;
  const json report = read_json(dir / "identified.json");
  for (const json& joint : report.at("held_out_torque_rms")) {
    claimed += std::pow(joint.at("identified").get<double>(), 2);
  }
  claimed = std::sqrt(claimed / 7.0);
  const RunResult identified =
      run({"check", "--urdf", dir / "identified.urdf", "--tip", kPandaTcp.tip, "--log", dir / "other.lcmlog"});
  ASSERT_EQ(identified.exit_code, 0) << identified.err;
  const RunResult as_given =
      run({"check", "--urdf", kPandaTcp.urdf, "--tip", kPandaTcp.tip, "--log", dir / "other.lcmlog"});
  ASSERT_EQ(as_given.exit_code, 0) << as_given.err;
  const double measured = rms_over_joints(identified.out), nominal = rms_over_joints(as_given.out);
  EXPECT_NEAR(claimed, measured, 0.2 * measured) << identified.out;
  EXPECT_LE(measured, 1.5 * kEffortNoise) << identified.out;
  EXPECT_GE(nominal, 10.0 * measured) << as_given.out;
  std::printf("held-out RMS claimed %.4f, on another motion %.4f (the URDF as given %.3f) N*m\n", claimed, measured,
              nominal);
}

// A log the fit cannot use: exit 1, one line naming what, and nothing written.
TEST(calibrateCli, DynamicsRefusesALogItCannotUse) {
  const ScratchDir dir;
  const TrueArm truth = perturbed_panda(7);
  write_state_log(dir / "other.lcmlog", synthetic_run(truth, 3.0, 500.0, kEffortNoise, 11), "PANDA_STATE");
  write_state_log(dir / "short.lcmlog", synthetic_run(truth, 1.0, 500.0, kEffortNoise, 11), "CHASLES_STATE");
  write_state_log(dir / "still.lcmlog", synthetic_run(truth, 12.0, 500.0, kEffortNoise, 11, 4), "CHASLES_STATE");
  struct Case {
    Robot robot;
    std::string log, fragment;
  };
  const std::vector<Case> cases = {
      {kPandaTcp, "other.lcmlog", "other.lcmlog: no messages on CHASLES_STATE (channels in the log: PANDA_STATE 1500)"},
      {kUr5, "short.lcmlog", "the states on CHASLES_STATE carry 7 joints; the chain of " + kUr5.urdf +
                                 " from 'world' to 'tool0' has 6"},
      {kPandaTcp, "short.lcmlog", "the log is too short: 0.998 s at 500 Hz hold 0.598 s of motion"},
      {kPandaTcp, "still.lcmlog", "the log does not excite the arm: joints that barely move: 'panda_joint5'"},
      {Robot{data_path("iiwa14.urdf"), "iiwa_link_ee"}, "still.lcmlog",
       "the log's joints leave the URDF's limits: 'iiwa_joint_6' spans [1.19, 2.63] against [-2.09, 2.09]"},
      {kPandaTcp, "missing.lcmlog", "missing.lcmlog: cannot open the log"},
  };
  for (const Case& c : cases) {
    expect_one_error_line(run({"dynamics", "--urdf", c.robot.urdf, "--tip", c.robot.tip, "--log", dir / c.log, "--out",
                               dir / "identified.urdf", "--report", dir / "identified.json"}),
                          1, c.fragment);
    EXPECT_FALSE(exists(dir / "identified.urdf"));
    EXPECT_FALSE(exists(dir / "identified.json"));
  }
  const RunResult help = run({"dynamics", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const char* text :
       {"--state-channel", "--cutoff", "--holdout", "drake:rotor_inertia", "Example", "atomically"}) {
    EXPECT_NE(help.out.find(text), std::string::npos) << text;
  }
}

}  // namespace
}  // namespace chasles::testing
