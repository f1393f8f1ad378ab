#include "support/reference.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "support/process.hpp"

namespace chasles::testing {
namespace {

using nlohmann::json;

Eigen::VectorXd vector_from(const json& j) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(j.size()));
  for (size_t i = 0; i < j.size(); ++i) v(static_cast<Eigen::Index>(i)) = j[i].get<double>();
  return v;
}

Eigen::MatrixXd matrix_from(const json& rows) {
  const auto r = static_cast<Eigen::Index>(rows.size());
  const auto c = static_cast<Eigen::Index>(rows.at(0).size());
  Eigen::MatrixXd m(r, c);
  for (Eigen::Index i = 0; i < r; ++i) {
    for (Eigen::Index k = 0; k < c; ++k) m(i, k) = rows[static_cast<size_t>(i)][static_cast<size_t>(k)].get<double>();
  }
  return m;
}

}  // namespace

std::string data_path(const std::string& name) { return std::string(CHASLES_TEST_DATA) + "/" + name; }

Reference load_reference(const std::string& robot) {
  std::ifstream file(data_path(robot + ".json"));
  if (!file) throw std::runtime_error("missing reference file " + data_path(robot + ".json"));
  const json j = json::parse(file);
  Reference ref;
  ref.robot = j.at("robot");
  ref.urdf = data_path(robot + ".urdf");
  ref.base_link = j.at("base_link");
  ref.tip_link = j.at("tip_link");
  ref.joint_names = j.at("joint_names").get<std::vector<std::string>>();
  ref.joint_types = j.at("joint_types").get<std::vector<std::string>>();
  ref.lower = vector_from(j.at("limits").at("lower"));
  ref.upper = vector_from(j.at("limits").at("upper"));
  ref.gravity = vector_from(j.at("gravity"));
  ref.home_T = matrix_from(j.at("home").at("T"));
  ref.home_S = matrix_from(j.at("home").at("S")).transpose();
  if (j.contains("armature")) ref.armature = vector_from(j.at("armature").at("values"));
  for (const json& c : j.at("cases")) {
    ReferenceCase rc;
    rc.q = vector_from(c.at("q"));
    rc.qd = vector_from(c.at("qd"));
    rc.qdd = vector_from(c.at("qdd"));
    rc.T = matrix_from(c.at("T"));
    rc.J_s = matrix_from(c.at("J_s"));
    rc.J_b = matrix_from(c.at("J_b"));
    for (const auto& [name, T] : c.at("link_T").items()) rc.link_T[name] = matrix_from(T);
    rc.tau = vector_from(c.at("tau"));
    rc.g = vector_from(c.at("g"));
    rc.c = vector_from(c.at("c"));
    rc.M = matrix_from(c.at("M"));
    if (c.contains("tau_with_armature")) {
      rc.tau_with_armature = vector_from(c.at("tau_with_armature"));
      rc.M_with_armature = matrix_from(c.at("M_with_armature"));
      rc.qdd_of_tau_with_armature = vector_from(c.at("qdd_of_tau_with_armature"));
    }
    ref.cases.push_back(std::move(rc));
  }
  return ref;
}

double max_abs_diff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).cwiseAbs().maxCoeff(); }

double relative_error(const Eigen::MatrixXd& a, const Eigen::MatrixXd& e) {
  return max_abs_diff(a, e) / std::max(1.0, e.cwiseAbs().maxCoeff());
}

namespace {
::testing::AssertionResult compare(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double bound) {
  if (actual.rows() != expected.rows() || actual.cols() != expected.cols()) {
    return ::testing::AssertionFailure() << "shape " << actual.rows() << "x" << actual.cols() << " != expected "
                                         << expected.rows() << "x" << expected.cols();
  }
  for (Eigen::Index i = 0; i < actual.rows(); ++i) {
    for (Eigen::Index k = 0; k < actual.cols(); ++k) {
      const double a = actual(i, k), e = expected(i, k);
      if (!(std::abs(a - e) <= bound)) {
        return ::testing::AssertionFailure()
               << std::setprecision(17) << "element (" << i << ", " << k << "): " << a << " vs expected " << e
               << ", difference " << std::abs(a - e) << " > " << bound;
      }
    }
  }
  return ::testing::AssertionSuccess();
}
}  // namespace

::testing::AssertionResult matrices_near(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected,
                                         double tolerance) {
  return compare(actual, expected, tolerance);
}

::testing::AssertionResult matrices_near_relative(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected,
                                                  double tolerance) {
  return compare(actual, expected, tolerance * std::max(1.0, expected.cwiseAbs().maxCoeff()));
}

std::vector<Eigen::Vector3d> read_binary_stl(const std::string& path) {
  const std::string bytes = read_file(path);
  uint32_t count = 0;
  if (bytes.size() >= 84) std::memcpy(&count, bytes.data() + 80, 4);
  EXPECT_EQ(bytes.size(), 84 + 50 * static_cast<size_t>(count)) << path;
  std::vector<Eigen::Vector3d> out;
  if (bytes.size() != 84 + 50 * static_cast<size_t>(count)) return out;
  for (uint32_t t = 0; t < count; ++t) {
    for (int v = 0; v < 3; ++v) {
      float xyz[3];
      std::memcpy(xyz, bytes.data() + 84 + 50 * t + 12 + 12 * v, 12);
      out.emplace_back(xyz[0], xyz[1], xyz[2]);
    }
  }
  return out;
}

}  // namespace chasles::testing
