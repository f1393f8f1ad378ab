// chasles_mujoco_bench: the cost of one 1 kHz step of the MuJoCo plant (tools/mujoco), beside one
// of chasles's own RK4 plant (core/simulation) on the same arm, in one run. Each on the Panda held
// by gravity compensation at a bent pose: "free" with nothing touching it, "press" with MuJoCo's
// pusher on the elbow (20 N; one contact, the noslip pass and the contact truth). MuJoCo's step is
// mj_step followed by mj_forward (the new state's contacts, which the truth reports) and the truth.
// The ratio MuJoCo / chasles is what the docs quote: the price of the independent engine. And the
// contact locator's cost per update on that press.
#include <benchmark/benchmark.h>

#include "core/dynamics/dynamics.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/contact_locator.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "core/simulation/plant.hpp"
#include "tools/mujoco/mujoco_plant.hpp"

namespace chasles {
namespace {

const std::string kData = CHASLES_BENCH_DATA;

struct Panda {
  RobotModel model;
  geometry::CollisionModel geometry;
  Eigen::VectorXd q0 = (Eigen::VectorXd(7) << 0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8).finished();
};

const Panda& panda() {
  static const Panda arm = [] {
    UrdfOptions options;
    options.tip_link = "panda_hand";
    RobotModel model = load_urdf_file(kData + "/panda.urdf", options);
    geometry::CollisionModel geometry = geometry::load_collision_model(kData + "/panda.urdf", model, {{kData + "/packages"}, ""});
    return Panda{std::move(model), std::move(geometry)};
  }();
  return arm;
}

void BM_MujocoStep(benchmark::State& state, bool press) {
  const Panda& arm = panda();
  plant::MujocoPlant mujoco(arm.model, kData + "/panda.urdf", arm.geometry, {}, arm.q0,
                            Eigen::VectorXd::Constant(7, 0.1), 1e-3);
  if (press) mujoco.press("panda_link4", Vector3d::Zero(), Vector3d::UnitY(), 20.0);
  Data data(arm.model);
  const Eigen::VectorXd g = gravity_torques(arm.model, data, arm.q0);
  Eigen::VectorXd tau = g;
  for (auto _ : state) {
    // A stiff joint-space hold about q0 keeps the elbow on the pusher (a few vector operations).
    tau = g + 100.0 * (arm.q0 - mujoco.q()) - 5.0 * mujoco.qd();
    mujoco.step(tau);
    benchmark::DoNotOptimize(mujoco.tau_ext().data());
  }
  state.counters["contacts"] = static_cast<double>(mujoco.contacts().size());
}

void BM_ChaslesRk4Step(benchmark::State& state) {
  const Panda& arm = panda();
  plant::Plant rk4(arm.model, arm.q0, Eigen::VectorXd::Constant(7, 0.1), 1e-3);
  Data data(arm.model);
  const Eigen::VectorXd tau = gravity_torques(arm.model, data, arm.q0);
  for (auto _ : state) {
    rk4.step(tau);
    benchmark::DoNotOptimize(rk4.q().data());
  }
}

// One locate() of the contact locator (core/geometry) on the τ_ext of the MuJoCo press above.
void BM_Locate(benchmark::State& state) {
  const Panda& arm = panda();
  plant::MujocoPlant mujoco(arm.model, kData + "/panda.urdf", arm.geometry, {}, arm.q0,
                            Eigen::VectorXd::Constant(7, 0.1), 1e-3);
  mujoco.press("panda_link4", Vector3d::Zero(), Vector3d::UnitY(), 20.0);
  Data data(arm.model);
  const Eigen::VectorXd g = gravity_torques(arm.model, data, arm.q0);
  for (int k = 0; k < 500; ++k) mujoco.step(g + 100.0 * (arm.q0 - mujoco.q()) - 5.0 * mujoco.qd());
  geometry::ContactLocator locator(arm.model, arm.geometry);
  space_jacobian(arm.model, data, mujoco.q());
  for (auto _ : state) benchmark::DoNotOptimize(locator.locate(data, mujoco.tau_ext()).point.data());
  state.counters["candidates"] = locator.candidates();
}

BENCHMARK_CAPTURE(BM_MujocoStep, free, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_MujocoStep, press, true)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ChaslesRk4Step)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Locate)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace chasles

BENCHMARK_MAIN();
