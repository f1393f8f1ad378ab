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

#include "chasles/core/kinematics/kinematics.hpp"
#include "chasles/core/lie/se3.hpp"
#include "chasles/core/model/urdf.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;

RunResult run(const std::vector<std::string>& args) {
  std::vector<std::string> argv{CHASLES_CALIBRATE};
  argv.insert(argv.end(), args.begin(), args.end());
  return run_to_completion(argv);
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

// excite writes the series as waypoints — each one the series' q, q̇, q̈ at its time, the last
// exactly at rest at the start — within the controller's default limits every millisecond: the
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
      const std::array<double, 4> x = swevers_series(report, i, t);
      for (int d = 0; d < 3; ++d) {
        const char* key = d == 0 ? "positions" : d == 1 ? "velocities" : "accelerations";
        worst = std::max(worst, std::abs(point.at(key).at(i).get<double>() - x[d]));
      }
    }
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(before, 8.0);
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

}  // namespace
}  // namespace chasles::testing
