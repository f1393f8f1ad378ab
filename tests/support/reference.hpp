// Reading the independent reference data in tests/data/ (see its README), and comparing
// matrices with a message that names the first element that differs.
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace chasles::testing {

/// Path of a file in tests/data.
std::string data_path(const std::string& name);

struct ReferenceCase {
  Eigen::VectorXd q, qd, qdd;
  Matrix4d T;
  Eigen::MatrixXd J_s, J_b;
  std::map<std::string, Matrix4d> link_T;
  Eigen::VectorXd tau, g, c;
  Eigen::MatrixXd M;
  /// With the reference's armature (iiwa14.json; empty in the files without one): RNEA with it, M +
  /// diag(armature), and forward dynamics of the rigid `tau` with it.
  Eigen::VectorXd tau_with_armature, qdd_of_tau_with_armature;
  Eigen::MatrixXd M_with_armature;
};

struct Reference {
  std::string robot, urdf, base_link, tip_link;
  std::vector<std::string> joint_names, joint_types;
  Eigen::VectorXd lower, upper;
  Vector3d gravity;
  Matrix4d home_T;
  Eigen::MatrixXd home_S;  ///< 6×n, one column per joint
  Eigen::VectorXd armature;  ///< reflected rotor inertia per joint; empty when the file gives none
  std::vector<ReferenceCase> cases;
};

/// tests/data/<robot>.json, with `urdf` pointing at tests/data/<robot>.urdf.
Reference load_reference(const std::string& robot);

/// Largest absolute difference; also usable outside assertions.
double max_abs_diff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b);
/// max |a − e| / max(1, max |e|): the reference's own magnitude sets the scale where it exceeds 1
/// (torques reach 10² N·m), the absolute error below it.
double relative_error(const Eigen::MatrixXd& a, const Eigen::MatrixXd& e);

/// Passes when every |actual − expected| ≤ tolerance; otherwise names the first offending
/// element, with both values.
::testing::AssertionResult matrices_near(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected,
                                         double tolerance);

/// The same with a relative tolerance: |a − e| ≤ tolerance · max(1, |e|_max).
::testing::AssertionResult matrices_near_relative(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected,
                                                  double tolerance);

/// A binary STL's vertices as the floats it stores (80-byte header, triangle count, 50 bytes per
/// triangle), three per triangle; a size that disagrees with the count fails the test.
std::vector<Eigen::Vector3d> read_binary_stl(const std::string& path);

}  // namespace chasles::testing
