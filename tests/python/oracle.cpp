// chasles_python_oracle: what the C++ library computes, for the Python bindings to be compared
// with bit for bit (tests/python/test_bindings.py).
//
//   chasles_python_oracle                 every reference robot of tests/data, every case, as JSON
//   chasles_python_oracle --time ROBOT    µs of a C++ loop of 1000 fk and of 1000 rnea (best of 50)
//
// The JSON holds, per robot (tests/data/<robot>.json's cases, loaded with its tip link), every
// quantity chasles._core's Model binds at each case's q, q̇, q̈ and τ, plus the momentum observer run
// through the cases in order and the tip wrench of each case's τ. Doubles are printed with %.17g,
// which reads back to the same double.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <iterator>
#include <vector>

#include "core/contact/observer.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "support/reference.hpp"

namespace {

using namespace chasles;

const char* const kRobots[] = {"ur5", "panda", "tiago", "talos_left_arm", "finger_edu", "iiwa14"};

void print_number(double x) { std::printf("%.17g", x); }

void print_matrix(const Eigen::MatrixXd& m) {
  std::printf("[");
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    std::printf(i ? ",[" : "[");
    for (Eigen::Index k = 0; k < m.cols(); ++k) {
      if (k) std::printf(",");
      print_number(m(i, k));
    }
    std::printf("]");
  }
  std::printf("]");
}

void print_vector(const Eigen::VectorXd& v) {
  std::printf("[");
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (i) std::printf(",");
    print_number(v(i));
  }
  std::printf("]");
}

void print_field(const char* name, const Eigen::MatrixXd& m) {
  std::printf(",\"%s\":", name);
  if (m.cols() == 1) {
    print_vector(m);
  } else {
    print_matrix(m);
  }
}

// The observer's gain and step in the oracle and in the test: every case is one sample, 1 ms apart.
constexpr double kObserverGain = 50.0, kObserverStep = 1e-3;

void print_robot(const std::string& robot) {
  const chasles::testing::Reference ref = chasles::testing::load_reference(robot);
  UrdfOptions options;
  options.tip_link = ref.tip_link;
  const RobotModel model = load_urdf_file(ref.urdf, options);
  Data data(model);
  const int n = model.dof();
  MomentumObserver observer(model, Eigen::VectorXd::Constant(n, kObserverGain));
  Data observer_data(model);
  std::printf("\"%s\":{\"urdf\":\"%s\",\"tip\":\"%s\",\"cases\":[", robot.c_str(), ref.urdf.c_str(), ref.tip_link.c_str());
  for (size_t k = 0; k < ref.cases.size(); ++k) {
    const chasles::testing::ReferenceCase& c = ref.cases[k];
    std::printf(k ? ",{" : "{");
    std::printf("\"q\":");
    print_vector(c.q);
    print_field("qd", c.qd);
    print_field("qdd", c.qdd);
    print_field("tau_in", c.tau);
    print_field("fk", forward_kinematics(model, data, c.q).matrix());
    std::printf(",\"link_poses\":[");
    const auto& poses = link_poses(model, data, c.q);
    for (size_t l = 0; l < poses.size(); ++l) {
      if (l) std::printf(",");
      print_matrix(poses[l].matrix());
    }
    std::printf("]");
    print_field("space_jacobian", space_jacobian(model, data, c.q));
    print_field("body_jacobian", body_jacobian(model, data, c.q));
    print_field("rnea", inverse_dynamics(model, data, c.q, c.qd, c.qdd));
    print_field("gravity", gravity_torques(model, data, c.q));
    print_field("coriolis", velocity_product(model, data, c.q, c.qd));
    print_field("mass_matrix", mass_matrix(model, data, c.q));
    print_field("forward_dynamics", forward_dynamics(model, data, c.q, c.qd, c.tau));
    std::printf(",\"kinetic_energy\":");
    print_number(kinetic_energy(model, data, c.q, c.qd));
    std::printf(",\"potential_energy\":");
    print_number(potential_energy(model, data, c.q));
    print_field("tip_wrench", tip_wrench_from_torque(body_jacobian(model, data, c.q), c.tau));
    momentum_terms(model, observer_data, c.q, c.qd);
    if (k == 0) observer.reset(observer_data, c.qd);
    print_field("observer", k == 0 ? Eigen::VectorXd(observer.external_torque())
                                   : Eigen::VectorXd(observer.update(observer_data, c.qd, c.tau, kObserverStep)));
    std::printf("}");
  }
  std::printf("]}");
}

// The C++ loops the bindings' batches are measured against: 1000 random configurations within the
// limits, each result written into one preallocated array as a batch writes its numpy array.
void time_loops(const std::string& robot) {
  const chasles::testing::Reference ref = chasles::testing::load_reference(robot);
  UrdfOptions options;
  options.tip_link = ref.tip_link;
  const RobotModel model = load_urdf_file(ref.urdf, options);
  const int n = model.dof(), rows = 1000;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::MatrixXd Q(n, rows);
  for (int r = 0; r < rows; ++r) {
    for (int i = 0; i < n; ++i) Q(i, r) = model.joint(i).limits.lower + unit(rng) * (model.joint(i).limits.upper - model.joint(i).limits.lower);
  }
  std::vector<double> out(static_cast<size_t>(rows) * 16);
  auto best_of = [&](auto&& loop) {
    double best = 1e300;
    for (int trial = 0; trial < 50; ++trial) {
      const auto start = std::chrono::steady_clock::now();
      loop();
      const std::chrono::duration<double, std::micro> us = std::chrono::steady_clock::now() - start;
      best = std::min(best, us.count());
    }
    return best;
  };
  Data data(model);
  const double fk_us = best_of([&] {
    for (int r = 0; r < rows; ++r) {
      const Transform& T = forward_kinematics(model, data, Q.col(r));
      Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> M(out.data() + 16 * r);
      M.topLeftCorner<3, 3>() = T.linear();
      M.topRightCorner<3, 1>() = T.translation();
      M.row(3) << 0.0, 0.0, 0.0, 1.0;
    }
  });
  const double rnea_us = best_of([&] {
    for (int r = 0; r < rows; ++r) {
      Eigen::Map<Eigen::VectorXd>(out.data() + n * r, n) = inverse_dynamics(model, data, Q.col(r), Q.col(r), Q.col(r));
    }
  });
  std::printf("{\"robot\":\"%s\",\"rows\":%d,\"fk_us\":%.3f,\"rnea_us\":%.3f}\n", robot.c_str(), rows, fk_us, rnea_us);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::string(argv[1]) == "--time") {
      time_loops(argv[2]);
      return 0;
    }
    if (argc != 1) {
      std::fprintf(stderr, "usage: chasles_python_oracle [--time ROBOT]\n");
      return 2;
    }
    std::printf("{");
    for (size_t r = 0; r < std::size(kRobots); ++r) {
      if (r) std::printf(",");
      print_robot(kRobots[r]);
    }
    std::printf("}\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chasles_python_oracle: %s\n", e.what());
    return 1;
  }
  return 0;
}
