// The chasles CLI, run as a real process: its JSON must reproduce the independent reference data,
// and bad input must fail with one "chasles: ..." line on stderr, nothing on stdout.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;

using Result = testing::RunResult;

// Runs the chasles binary with `args`; stdin from `stdin_path` or /dev/null.
Result run_cli(const std::vector<std::string>& args, const std::string& stdin_path = "/dev/null") {
  return testing::run_to_completion(concat({CHASLES_CLI}, args), stdin_path);
}

// A list of rows (or a list of vectors) as a matrix; null (a non-finite value) becomes NaN.
Eigen::MatrixXd matrix_of(const json& rows) {
  const auto r = static_cast<Eigen::Index>(rows.size());
  const auto c = r == 0 ? Eigen::Index{0} : static_cast<Eigen::Index>(rows.at(0).size());
  Eigen::MatrixXd m(r, c);
  for (Eigen::Index i = 0; i < r; ++i) {
    const json& row = rows.at(static_cast<size_t>(i));
    EXPECT_EQ(static_cast<Eigen::Index>(row.size()), c) << "ragged matrix";
    for (Eigen::Index k = 0; k < c; ++k) {
      const json& x = row.at(static_cast<size_t>(k));
      m(i, k) = x.is_null() ? std::numeric_limits<double>::quiet_NaN() : x.get<double>();
    }
  }
  return m;
}

Eigen::VectorXd vector_of(const json& list) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(list.size()));
  for (size_t i = 0; i < list.size(); ++i) {
    v(static_cast<Eigen::Index>(i)) =
        list[i].is_null() ? std::numeric_limits<double>::infinity() : list[i].get<double>();
  }
  return v;
}

std::vector<std::string> model_args(const Reference& ref) { return {"--urdf", ref.urdf, "--tip", ref.tip_link}; }

// The lines "chasles: warning: ..." on stderr: what a model loaded with but a user should know.
std::vector<std::string> warning_lines(const std::string& err) {
  std::vector<std::string> lines;
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

json parse_output(const Result& result) {
  EXPECT_EQ(result.exit_code, 0) << "stderr: " << result.err;
  for (const std::string& line : warning_lines(result.err)) {
    EXPECT_EQ(line.rfind("chasles: warning: ", 0), 0u) << "stderr holds more than warnings: " << line;
  }
  try {
    return json::parse(result.out);
  } catch (const json::exception& e) {
    ADD_FAILURE() << "stdout is not JSON: " << e.what();
    return json::object();
  }
}

// A failure as the CLI promises it: the exit code, one line "chasles: ..." on stderr that contains
// every one of `needles`, nothing on stdout.
void expect_failure(const Result& result, int exit_code, const std::vector<std::string>& needles) {
  EXPECT_EQ(result.exit_code, exit_code) << "stderr: " << result.err;
  EXPECT_EQ(result.out, "") << "stdout must stay empty on error";
  EXPECT_EQ(result.err.rfind("chasles: ", 0), 0u) << "stderr: " << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << "stderr: " << result.err;
  EXPECT_TRUE(!result.err.empty() && result.err.back() == '\n') << "stderr must end with a newline";
  for (const auto& needle : needles)
    EXPECT_NE(result.err.find(needle), std::string::npos) << "'" << needle << "' missing in: " << result.err;
}

class cliReference : public ::testing::TestWithParam<std::string> {};

TEST_P(cliReference, EvalReproducesReference) {
  const Reference ref = load_reference(GetParam());
  const json out =
      parse_output(run_cli(concat({"eval"}, concat(model_args(ref), {"--cases", data_path(GetParam() + ".json")}))));
  ASSERT_TRUE(out.contains("cases"));
  ASSERT_EQ(out["cases"].size(), ref.cases.size());
  const double tol = 1e-10;
  double max_T = 0.0, max_J_s = 0.0, max_J_b = 0.0, max_link = 0.0;
  for (size_t i = 0; i < ref.cases.size(); ++i) {
    SCOPED_TRACE("case " + std::to_string(i));
    const ReferenceCase& rc = ref.cases[i];
    const json& c = out["cases"][i];
    const Eigen::MatrixXd T = matrix_of(c.at("T")), J_s = matrix_of(c.at("J_s")), J_b = matrix_of(c.at("J_b"));
    EXPECT_TRUE(matrices_near(T, rc.T, tol)) << "T";
    EXPECT_TRUE(matrices_near(J_s, rc.J_s, tol)) << "J_s";
    EXPECT_TRUE(matrices_near(J_b, rc.J_b, tol)) << "J_b";
    if (T.rows() == 4 && T.cols() == 4) max_T = std::max(max_T, max_abs_diff(T, rc.T));
    if (J_s.rows() == 6 && J_s.cols() == rc.J_s.cols()) max_J_s = std::max(max_J_s, max_abs_diff(J_s, rc.J_s));
    if (J_b.rows() == 6 && J_b.cols() == rc.J_b.cols()) max_J_b = std::max(max_J_b, max_abs_diff(J_b, rc.J_b));

    const json& link_T = c.at("link_T");
    EXPECT_EQ(link_T.size(), rc.link_T.size())
        << "link_T: " << link_T.size() << " links, reference " << rc.link_T.size();
    for (const auto& [name, T_ref] : rc.link_T) {
      if (!link_T.contains(name)) {
        ADD_FAILURE() << "link_T has no '" << name << "'";
        continue;
      }
      const Eigen::MatrixXd T_link = matrix_of(link_T[name]);
      EXPECT_TRUE(matrices_near(T_link, T_ref, tol)) << "link_T " << name;
      if (T_link.rows() == 4 && T_link.cols() == 4) max_link = std::max(max_link, max_abs_diff(T_link, T_ref));
    }
  }
  const double max_all = std::max({max_T, max_J_s, max_J_b, max_link});
  std::ostringstream max_text;
  max_text << max_all;
  RecordProperty("max_abs_error", max_text.str());
  std::cout << "[ cli eval " << GetParam() << " ] " << ref.cases.size() << " cases, max abs error: T " << max_T
            << ", J_s " << max_J_s << ", J_b " << max_J_b << ", link_T " << max_link << std::endl;
}

TEST_P(cliReference, EvalReproducesReferenceDynamics) {
  const Reference ref = load_reference(GetParam());
  const json out =
      parse_output(run_cli(concat({"eval"}, concat(model_args(ref), {"--cases", data_path(GetParam() + ".json")}))));
  ASSERT_EQ(out.at("cases").size(), ref.cases.size());
  for (size_t i = 0; i < ref.cases.size(); ++i) {
    SCOPED_TRACE("case " + std::to_string(i));
    const ReferenceCase& rc = ref.cases[i];
    const json& c = out["cases"][i];
    EXPECT_TRUE(matrices_near_relative(vector_of(c.at("tau")), rc.tau, 1e-9)) << "tau";
    EXPECT_TRUE(matrices_near_relative(matrix_of(c.at("M")), rc.M, 1e-9)) << "M";
    EXPECT_TRUE(matrices_near_relative(vector_of(c.at("g")), rc.g, 1e-9)) << "g";
    EXPECT_TRUE(matrices_near_relative(vector_of(c.at("c")), rc.c, 1e-9)) << "c";
  }
}

std::string comma_list(const Eigen::VectorXd& v) {
  std::ostringstream text;
  text.precision(17);
  for (Eigen::Index i = 0; i < v.size(); ++i) text << (i ? "," : "") << v(i);
  return text.str();
}

TEST_P(cliReference, RneaAndFdSingleShots) {
  const Reference ref = load_reference(GetParam());
  for (size_t i = 0; i < 5; ++i) {
    const ReferenceCase& rc = ref.cases[i];
    const json tau = parse_output(run_cli(concat(
        {"rnea"},
        concat(model_args(ref), {"--q", comma_list(rc.q), "--qd", comma_list(rc.qd), "--qdd", comma_list(rc.qdd)}))));
    EXPECT_TRUE(matrices_near_relative(vector_of(tau.at("tau")), rc.tau, 1e-9));
    // The reference torque must produce the reference acceleration.
    const json qdd =
        parse_output(run_cli(concat({"fd"}, concat(model_args(ref), {"--q", comma_list(rc.q), "--qd", comma_list(rc.qd),
                                                                     "--tau", comma_list(rc.tau)}))));
    EXPECT_TRUE(matrices_near(vector_of(qdd.at("qdd")), rc.qdd, 1e-7));
  }
}

TEST_P(cliReference, RneaTipWrench) {
  // τ(F_tip) − τ(0) = J_bᵀ F_tip, with J_b from the reference.
  const Reference ref = load_reference(GetParam());
  const ReferenceCase& rc = ref.cases[0];
  Vector6d F_tip;
  F_tip << 0.5, -1.0, 2.0, 10.0, -20.0, 30.0;
  const std::vector<std::string> state = {"--q",   comma_list(rc.q),  "--qd", comma_list(rc.qd),
                                          "--qdd", comma_list(rc.qdd)};
  const json loaded =
      parse_output(run_cli(concat({"rnea"}, concat(model_args(ref), concat(state, {"--f-tip", comma_list(F_tip)})))));
  EXPECT_TRUE(matrices_near_relative(vector_of(loaded.at("tau")) - rc.tau, rc.J_b.transpose() * F_tip, 1e-9));
}

TEST_P(cliReference, InspectMatchesReference) {
  const Reference ref = load_reference(GetParam());
  const Result result = run_cli(concat({"inspect"}, model_args(ref)));
  const json out = parse_output(result);
  const auto n = static_cast<Eigen::Index>(ref.joint_names.size());
  // The warnings in the JSON are the ones on stderr, in order.
  const std::vector<std::string> lines = warning_lines(result.err);
  const auto warnings = out.at("warnings").get<std::vector<std::string>>();
  ASSERT_EQ(warnings.size(), lines.size());
  for (size_t i = 0; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i], "chasles: warning: " + ref.urdf + ": " + warnings[i]);
  }
  EXPECT_EQ(out.at("robot"), load_urdf_file(ref.urdf, UrdfOptions{ref.tip_link, {0.0, 0.0, -9.81}}).name());
  EXPECT_EQ(out.at("base_link"), ref.base_link);
  EXPECT_EQ(out.at("tip_link"), ref.tip_link);
  EXPECT_EQ(out.at("dof"), n);
  EXPECT_EQ(out.at("joint_names").get<std::vector<std::string>>(), ref.joint_names);
  EXPECT_EQ(out.at("joint_types").get<std::vector<std::string>>(), ref.joint_types);
  const json& limits = out.at("limits");
  EXPECT_TRUE(matrices_near(vector_of(limits.at("lower")), ref.lower, 1e-10)) << "lower limits";
  EXPECT_TRUE(matrices_near(vector_of(limits.at("upper")), ref.upper, 1e-10)) << "upper limits";

  // The reference has no velocity and effort limits: compare with the URDF as chasles reads it,
  // an absent limit (+∞) printed as null.
  const RobotModel model = load_urdf_file(ref.urdf, UrdfOptions{ref.tip_link, {0.0, 0.0, -9.81}});
  ASSERT_EQ(limits.at("velocity").size(), static_cast<size_t>(n));
  ASSERT_EQ(limits.at("effort").size(), static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    const JointLimits& l = model.joint(static_cast<int>(i)).limits;
    const json& velocity = limits["velocity"][static_cast<size_t>(i)];
    const json& effort = limits["effort"][static_cast<size_t>(i)];
    if (std::isfinite(l.velocity))
      EXPECT_EQ(velocity.get<double>(), l.velocity);
    else
      EXPECT_TRUE(velocity.is_null());
    if (std::isfinite(l.effort))
      EXPECT_EQ(effort.get<double>(), l.effort);
    else
      EXPECT_TRUE(effort.is_null());
  }

  const Eigen::MatrixXd home_T = matrix_of(out.at("home").at("T"));
  const Eigen::MatrixXd home_S = matrix_of(out.at("home").at("S")).transpose();  // n 6-vectors → 6×n
  EXPECT_TRUE(matrices_near(home_T, ref.home_T, 1e-10)) << "home T";
  EXPECT_TRUE(matrices_near(home_S, ref.home_S, 1e-10)) << "home S";
  if (home_T.rows() == 4 && home_T.cols() == 4 && home_S.rows() == 6 && home_S.cols() == n) {
    std::cout << "[ cli inspect " << GetParam() << " ] max abs error: home T " << max_abs_diff(home_T, ref.home_T)
              << ", home S " << max_abs_diff(home_S, ref.home_S) << std::endl;
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, cliReference, ::testing::Values("ur5", "panda", "tiago", "talos_left_arm", "finger_edu"),
                         [](const ::testing::TestParamInfo<std::string>& robot) { return robot.param; });

// The URDF's Drake transmissions give the iiwa 14 its armature, which inspect lists (the reference's,
// rotor inertia × gear ratio²); a URDF without them has zeros.
TEST(cli, InspectListsTheArmature) {
  const Reference ref = load_reference("iiwa14");
  const json out = parse_output(run_cli(concat({"inspect"}, model_args(ref))));
  EXPECT_TRUE(matrices_near(vector_of(out.at("armature")), ref.armature, 1e-12));
  const json ur5 = parse_output(run_cli(concat({"inspect"}, model_args(load_reference("ur5")))));
  EXPECT_TRUE(matrices_near(vector_of(ur5.at("armature")), Eigen::VectorXd::Zero(6), 0.0));
}

// The printed numbers parse back to exactly the doubles the library computes.
TEST(cli, EvalPrintsExactDoubles) {
  const Reference ref = load_reference("ur5");
  const json out = parse_output(run_cli(concat({"eval"}, concat(model_args(ref), {"--cases", data_path("ur5.json")}))));
  const RobotModel model = load_urdf_file(ref.urdf, UrdfOptions{ref.tip_link, {0.0, 0.0, -9.81}});
  Data data(model);
  ASSERT_EQ(out["cases"].size(), ref.cases.size());
  for (size_t i = 0; i < ref.cases.size(); ++i) {
    const Eigen::VectorXd& q = ref.cases[i].q;
    const json& c = out["cases"][i];
    link_poses(model, data, q);
    EXPECT_EQ(max_abs_diff(matrix_of(c["T"]), data.T_sb.matrix()), 0.0) << "case " << i;
    for (size_t k = 0; k < model.links().size(); ++k) {
      EXPECT_EQ(max_abs_diff(matrix_of(c["link_T"][model.links()[k].name]), data.T_link[k].matrix()), 0.0);
    }
    EXPECT_EQ(max_abs_diff(matrix_of(c["J_s"]), space_jacobian(model, data, q)), 0.0) << "case " << i;
    EXPECT_EQ(max_abs_diff(matrix_of(c["J_b"]), body_jacobian(model, data, q)), 0.0) << "case " << i;
  }
}

TEST(cli, PrettyAndStdinGiveTheSameDocument) {
  const Reference ref = load_reference("panda");
  const Result compact = run_cli(concat({"eval"}, concat(model_args(ref), {"--cases", data_path("panda.json")})));
  const Result pretty =
      run_cli(concat({"eval", "--pretty"}, concat(model_args(ref), {"--cases", "-"})), data_path("panda.json"));
  EXPECT_EQ(std::count(compact.out.begin(), compact.out.end(), '\n'), 1);
  EXPECT_GT(std::count(pretty.out.begin(), pretty.out.end(), '\n'), 100);
  EXPECT_EQ(parse_output(compact), parse_output(pretty));
}

TEST(cli, HelpAndVersion) {
  const Result help = run_cli({"--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_EQ(help.err, "");
  for (const char* word : {"inspect", "eval", "--pretty", "--version", "Example"}) {
    EXPECT_NE(help.out.find(word), std::string::npos) << word << " missing in --help:\n" << help.out;
  }
  for (const char* command : {"inspect", "eval"}) {
    const Result sub = run_cli({command, "--help"});
    EXPECT_EQ(sub.exit_code, 0);
    EXPECT_NE(sub.out.find("--urdf"), std::string::npos) << sub.out;
    EXPECT_NE(sub.out.find("Example:\n"), std::string::npos) << sub.out;
    EXPECT_NE(sub.out.find(std::string("  chasles ") + command + " --urdf"), std::string::npos) << sub.out;
  }
  const Result version = run_cli({"--version"});
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out.rfind("chasles ", 0), 0u) << version.out;
}

// `chasles view` becomes the interpreter running chasles.view with every argument after it, --help
// and the global flags' look-alikes included: /bin/echo standing in for the interpreter prints the
// command line it was given. An interpreter that is not there is said in one line.
TEST(cli, ViewHandsEveryArgumentToThePythonModule) {
  const testing::RunResult echoed = testing::run_to_completion(
      {CHASLES_CLI, "view", "run.lcmlog", "--urdf", "ur5.urdf", "--pretty", "--help"}, "/dev/null",
      {"CHASLES_PYTHON=/bin/echo"});
  EXPECT_EQ(echoed.exit_code, 0) << echoed.err;
  EXPECT_EQ(echoed.out, "-m chasles.view run.lcmlog --urdf ur5.urdf --pretty --help\n");
  const testing::RunResult missing =
      testing::run_to_completion({CHASLES_CLI, "view"}, "/dev/null", {"CHASLES_PYTHON=/nonexistent/python"});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_EQ(missing.err.rfind("chasles: cannot run /nonexistent/python -m chasles.view: No such file or directory", 0),
            0u)
      << missing.err;
}

// --- errors (suite names start with "cli" so that `ctest -R cli` selects them all)
// --------------------------------------------------------------------------------

TEST(cliErrors, MissingUrdfFile) {
  expect_failure(run_cli({"inspect", "--urdf", "/nonexistent/arm.urdf", "--tip", "tool0"}), 1,
                 {"/nonexistent/arm.urdf", "cannot open"});
}

TEST(cliErrors, MalformedUrdf) {
  const TempFile input("malformed.urdf", "<robot name=\"x\"><link name=\"a\">\n");
  expect_failure(run_cli({"inspect", "--urdf", input.path}), 1, {input.path, "XML"});
}

TEST(cliErrors, MissingTipListsLeaves) {
  expect_failure(run_cli({"inspect", "--urdf", data_path("ur5.urdf")}), 1,
                 {"ur5.urdf", "leaves", "'tool0'", "'ee_link'", "--tip"});
}

TEST(cliErrors, UnknownTip) {
  expect_failure(
      run_cli({"eval", "--urdf", data_path("panda.urdf"), "--tip", "no_such_link", "--cases", data_path("panda.json")}),
      1, {"panda.urdf", "'no_such_link'"});
}

TEST(cliErrors, CasesFileMissing) {
  expect_failure(
      run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", "/nonexistent/cases.json"}), 1,
      {"/nonexistent/cases.json", "cannot open"});
}

TEST(cliErrors, CasesNotJson) {
  const TempFile input("not_json.json", "{\"cases\": [{\"q\": [0, 0, 0, 0, 0, 0]},\n nope]}");
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", input.path}), 1,
                 {input.path, "not valid JSON", "(byte ", "line 2"});
}

TEST(cliErrors, NoCasesArray) {
  const TempFile input("no_cases.json", "{\"q\": [0, 0, 0, 0, 0, 0]}");
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", input.path}), 1,
                 {input.path, "\"cases\""});
}

TEST(cliErrors, QWrongLength) {
  const TempFile input("short_q.json", "{\"cases\": [{\"q\": [0, 0, 0, 0, 0, 0]}, {\"q\": [1, 2, 3, 4, 5]}]}");
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", input.path}), 1,
                 {input.path, "cases[1].q", "5 entries", "expected 6"});
}

TEST(cliErrors, CaseWithoutQ) {
  const TempFile input("no_q.json", "{\"cases\": [{\"q\": [0, 0, 0, 0, 0, 0]}, {\"qd\": [0]}]}");
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", input.path}), 1,
                 {input.path, "cases[1]", "\"q\""});
}

TEST(cliErrors, QNotNumeric) {
  const TempFile input("string_q.json", "{\"cases\": [{\"q\": [0, 0, \"0.5\", 0, 0, 0]}]}");
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", input.path}), 1,
                 {"cases[0].q[2]", "string"});
}

TEST(cliErrors, QNotFinite) {
  const TempFile input("huge_q.json", "{\"cases\": [{\"q\": [0, 0, 1e999, 0, 0, 0]}]}");
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0", "--cases", input.path}), 1,
                 {input.path, "1e999"});
}

TEST(cliErrors, DynamicsListsAreChecked) {
  const std::vector<std::string> model = {"--urdf", data_path("ur5.urdf"), "--tip", "tool0"};
  const std::string zeros = "0,0,0,0,0,0";
  expect_failure(run_cli(concat({"rnea"}, concat(model, {"--q", "0,0,0,0,0", "--qd", zeros, "--qdd", zeros}))), 1,
                 {"--q has 5 entries", "expected 6"});
  expect_failure(run_cli(concat({"rnea"}, concat(model, {"--q", zeros, "--qd", "0,0,x,0,0,0", "--qdd", zeros}))), 1,
                 {"--qd", "entry 2", "'x'", "not a number"});
  expect_failure(run_cli(concat({"fd"}, concat(model, {"--q", zeros, "--qd", zeros, "--tau", "0,0,nan,0,0,0"}))), 1,
                 {"--tau", "entry 2", "not finite"});
  expect_failure(
      run_cli(concat({"fd"}, concat(model, {"--q", zeros, "--qd", zeros, "--tau", zeros, "--f-tip", "1,2"}))), 1,
      {"--f-tip has 2 entries", "expected 6"});
  expect_failure(run_cli(concat({"fd"}, concat(model, {"--q", zeros, "--qd", zeros}))), 2, {"--tau"});
}

TEST(cliErrors, UsageErrorsExitTwo) {
  expect_failure(run_cli({}), 2, {"--help"});
  expect_failure(run_cli({"fk"}), 2, {"'fk'"});
  expect_failure(run_cli({"inspect"}), 2, {"--urdf"});
  expect_failure(run_cli({"eval", "--urdf", data_path("ur5.urdf"), "--tip", "tool0"}), 2, {"--cases"});
  expect_failure(run_cli({"inspect", "--urdf", data_path("ur5.urdf"), "--bogus"}), 2, {"--bogus"});
}

}  // namespace
}  // namespace chasles::testing
