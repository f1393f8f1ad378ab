// What both plant test files hold the plant against: the arms they drive — the Panda to panda_hand,
// as the tests start chasles_plant with it (support/arm.hpp's panda() ends at the TCP, the
// controller's tests' tip), the iiwa's start pose — the plant's step, and an integrator written
// independently of the plant's. plant_test.cpp runs chasles_plant as a process;
// plant_drake_test.cpp its Drake protocols in process. In a namespace of their own, which each file
// brings into its anonymous namespace, so that panda() there means this one.
#pragma once

#include <Eigen/Core>

#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace chasles::testing::plant_reference {

inline constexpr double kDt = 1e-3;  // the plant's default 1000 Hz

inline RobotModel panda() {
  UrdfOptions options;
  options.tip_link = "panda_hand";
  return load_urdf_file(data_path("panda.urdf"), options);
}

inline Eigen::VectorXd iiwa_pose() {
  Eigen::VectorXd q(7);
  q << 0.2, 0.6, -0.3, -1.2, 0.4, 0.8, 0.1;
  return q;
}

// Classic RK4 on (q, q̇) with constant τ, written here independently of the plant's, for
// reference integrations at a much smaller step.
inline void rk4_reference(const RobotModel& model, Eigen::VectorXd& q, Eigen::VectorXd& qd, const Eigen::VectorXd& tau,
                   double h, int steps) {
  Data data(model);
  const auto qdd = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return forward_dynamics(model, data, x, v, tau);
  };
  for (int i = 0; i < steps; ++i) {
    const Eigen::VectorXd v1 = qd, a1 = qdd(q, v1);
    const Eigen::VectorXd v2 = qd + 0.5 * h * a1, a2 = qdd(q + 0.5 * h * v1, v2);
    const Eigen::VectorXd v3 = qd + 0.5 * h * a2, a3 = qdd(q + 0.5 * h * v2, v3);
    const Eigen::VectorXd v4 = qd + h * a3, a4 = qdd(q + h * v3, v4);
    q += h / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4);
    qd += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
  }
}

}  // namespace chasles::testing::plant_reference
