// chasles_tick_bench: the time of one control tick, Controller::tick, under each control law, on
// an arm moving in closed loop, as the daemon's loop calls it (a new state every tick: the model's
// terms, the contact observer and monitor, the reference, the law and the safety pipeline). The
// loop's own statistics in the demo say the same, with the machine's scheduling noise on top; this
// measures the computation alone, in one process, with nothing else between the ticks but the
// simulated arm.
//
// Each law runs the same programme: the arm starts at rest at a bent pose, and a JOINT target moves
// it back and forth between two poses (2 s each way), the Cartesian law following the same joint
// reference through its stiffness frame; free drive follows no target, so a torque that turns
// slowly pushes the arm around instead. The arm is the controller's own model integrated by
// semi-implicit Euler (four substeps per 1 ms tick) on its forward dynamics, the torque held over
// the tick as a plant holds it. The contact monitor runs every tick, with its thresholds at
// infinity (free drive's push would otherwise start a reflex and end the programme). Every tick is
// timed with CLOCK_MONOTONIC around tick() alone; the first second of each law is warm-up and not
// counted. Heap allocations during the counted ticks are counted too (they must be 0).
// --sleep-us N sleeps N µs before every tick, outside the timed region, as the daemon's loop waits
// for the next state: the tick then starts as it does there, from an idle core and cold caches.
//
// --clearance (the Panda): the controller keeps the arm clear of itself (its 44 SRDF pairs) and of a
// 6-object scene around the motion (controller/clearance.hpp): the distances at the state every
// tick and at the reference when it moves; the table's last column counts the ticks the
// reference was slowed.
//
//   chasles_tick_bench [--robot panda|ur5|FILE.urdf] [--tip LINK] [--seconds S] [--sleep-us N] [--clearance] [--json]
//
// Prints a table (law, ticks, p50, p99, max, mean µs, allocations) or, with --json, one object
// {"<law>": {"ticks", "p50_us", "p99_us", "max_us", "mean_us", "allocations"}}.
#include <time.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "controller/controller.hpp"
#include "controller/world.hpp"
#include "controller/transport/realtime/realtime.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/error.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"

namespace {

using chasles::controller::Controller;
using chasles::controller::JointState;
using chasles::controller::Law;
using chasles::controller::LawSettings;
using chasles::controller::Mode;
using chasles::controller::Target;
using Eigen::VectorXd;

constexpr int64_t kPeriodNs = 1'000'000;
constexpr int kSubsteps = 4;
constexpr double kLegSeconds = 2.0;
constexpr double kWarmUpSeconds = 1.0;

int64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

// A pose a fraction `s` of the way between the middle of each joint's range and its upper limit.
VectorXd pose(const chasles::RobotModel& model, double s) {
  VectorXd q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const auto& l = model.joint(i).limits;
    const double lower = std::max(l.lower, -3.0), upper = std::min(l.upper, 3.0);
    q(i) = 0.5 * (lower + upper) + s * 0.5 * (upper - lower);
  }
  return q;
}

LawSettings settings_of(Law law, int n) {
  LawSettings s(n);
  s.law = law;
  s.joint_stiffness.setConstant(300.0);
  return s;
}

struct Figures {
  int64_t ticks = 0;
  double p50 = 0, p99 = 0, max = 0, mean = 0;
  long allocations = 0;
  int64_t slowed = 0;  // ticks whose reference the clearance slowed
};

double percentile(std::vector<int64_t> sorted, double p) {
  const auto k = static_cast<size_t>(std::ceil(p * static_cast<double>(sorted.size()))) - 1;
  return 1e-3 * static_cast<double>(sorted[std::min(k, sorted.size() - 1)]);
}

// What drives the reference: JOINT targets back and forth, or a 30 Hz stream of setpoints (a
// smooth motion about the start, with its velocity) that the online generator follows every tick.
enum class Source { kTargets, kStream };

// The Panda's geometry and a scene about the bench's motion: a floor under the outer links, a wall,
// a box, a ball, a post and a bar overhead, each 1 cm stop and 10 cm influence.
std::shared_ptr<chasles::controller::ClearanceWorld> panda_world(const chasles::RobotModel& model) {
  using namespace chasles::geometry;
  const std::string data = CHASLES_BENCH_DATA;
  chasles::controller::WorldOptions options;
  options.mode = chasles::controller::CollisionMode::kOn;
  options.urdf = data + "/panda.urdf";
  options.geometry = {{data + "/packages"}, data + "/packages/example-robot-data/robots/panda_description/srdf/panda.srdf"};
  std::vector<std::string> notes;
  const CollisionModel arm = chasles::controller::load_arm_geometry(model, options, notes);
  const auto at = [](double x, double y, double z) { return chasles::Transform(chasles::Matrix3d::Identity(), {x, y, z}); };
  const auto shape = [](ShapeKind kind, double radius, double half_length, const chasles::Vector3d& half) {
    Shape s;
    s.kind = kind, s.radius = radius, s.half_length = half_length, s.half_extents = half;
    return s;
  };
  Scene scene;
  scene.planes.push_back({"floor", chasles::Vector3d::UnitZ(), -0.05, {"panda_link5", "panda_link6", "panda_link7", "panda_hand"}, {}});
  scene.planes.push_back({"wall", -chasles::Vector3d::UnitY(), -0.75, {}, {}});
  scene.objects.push_back({"box", shape(ShapeKind::kBox, 0, 0, chasles::Vector3d(0.1, 0.1, 0.1)), at(0.65, -0.45, 0.2), {}});
  scene.objects.push_back({"ball", shape(ShapeKind::kSphere, 0.1, 0, chasles::Vector3d::Zero()), at(-0.45, 0.45, 0.6), {}});
  scene.objects.push_back({"post", shape(ShapeKind::kCylinder, 0.05, 0.5, chasles::Vector3d::Zero()), at(-0.3, -0.6, 0.5), {}});
  scene.objects.push_back({"bar", shape(ShapeKind::kCapsule, 0.04, 0.6, chasles::Vector3d::Zero()), at(0.2, 0.0, 1.4), {}});
  return chasles::controller::make_world(model, arm, scene, {});
}

Figures run(const chasles::RobotModel& model, Law law, double seconds, int64_t sleep_ns,
            Source source = Source::kTargets, chasles::controller::ClearanceWorld* world = nullptr) {
  const int n = model.dof();
  // The monitor runs and classifies as always, with no threshold to cross: free drive's push is
  // an external force by design, and a reflex would end the programme.
  chasles::controller::Config config = chasles::controller::Config::critically_damped(n, 20.0);
  const double inf = std::numeric_limits<double>::infinity();
  config.contact.contact_torque = config.contact.collision_torque = VectorXd::Constant(n, inf);
  config.contact.contact_force = config.contact.collision_force = inf;
  config.contact.contact_moment = config.contact.collision_moment = inf;
  Controller controller(model, config);
  controller.set_clearance_world(world);
  chasles::Data plant(model);
  JointState state(n);
  state.q = pose(model, 0.1);
  const VectorXd q_start = state.q;
  VectorXd tau = VectorXd::Zero(n), push = VectorXd::Zero(n);
  const VectorXd poses[2] = {pose(model, 0.3), pose(model, -0.1)};

  const auto total_ticks = static_cast<int64_t>((seconds + kWarmUpSeconds) * 1e9 / kPeriodNs);
  const auto warm_up = static_cast<int64_t>(kWarmUpSeconds * 1e9 / kPeriodNs);
  std::vector<int64_t> times;
  times.reserve(static_cast<size_t>(total_ticks - warm_up));
  Target target(n);
  target.mode = Target::kJoint;
  target.num_joints = n;
  target.duration = kLegSeconds;
  const auto leg_ticks = static_cast<int64_t>(kLegSeconds * 1e9 / kPeriodNs);
  chasles::controller::Setpoint setpoint(n);
  long allocations = 0;
  int64_t slowed = 0;
  for (int64_t k = 0; k < total_ticks; ++k) {
    const int64_t t = k * kPeriodNs;
    state.seq = k;
    state.utime = t / 1000;
    state.arrival_ns = t;
    state.effort = tau;
    if (k == 1 && !controller.set_law(settings_of(law, n), t)) {
      std::fprintf(stderr, "chasles_tick_bench: %s refused: %s\n", to_string(law), controller.mode_rejection());
      std::exit(1);
    }
    if (source == Source::kTargets && law != Law::kFreeDrive && k >= 1 && k % leg_ticks == 1) {
      target.q = poses[(k / leg_ticks) % 2];
      controller.set_target(target, t);
    }
    if (source == Source::kStream && k >= 1 && k % 33 == 1) {
      const double time = 1e-9 * static_cast<double>(t);
      for (int i = 0; i < n; ++i) {
        setpoint.q(i) = q_start(i) + 0.2 * std::sin(1.5 * time + i);
        setpoint.qd(i) = 0.3 * std::cos(1.5 * time + i);
      }
      setpoint.utime = t / 1000;
      controller.set_setpoint(setpoint, t);
    }
    const bool counted = k >= warm_up;
    if (sleep_ns > 0) {
      const timespec pause{0, static_cast<long>(sleep_ns)};
      nanosleep(&pause, nullptr);
    }
    const chasles::testing::AllocationCounter counter;
    const int64_t start = now_ns();
    const bool command = controller.tick(t, &state);
    const int64_t end = now_ns();
    if (counted) {
      times.push_back(end - start);
      allocations += counter.count();
      slowed += controller.clearance().kept < 1.0 ? 1 : 0;
    }
    if (controller.mode() == Mode::kFault || controller.mode() == Mode::kReflex) {
      std::fprintf(stderr, "chasles_tick_bench: %s: the arm went to %s (%s%s)\n", to_string(law),
                   to_string(controller.mode()), controller.fault_reason(), controller.reflex_reason());
      std::exit(1);
    }
    if (command) tau = controller.torque();
    // Free drive: a push that turns slowly through the joints, a few percent of their effort, by
    // a hand that also keeps each joint near the start (inside its limits, whose crossing would
    // stop the arm).
    for (int i = 0; i < n && law == Law::kFreeDrive; ++i) {
      const double effort = std::min(model.joint(i).limits.effort, 50.0);
      push(i) = 0.03 * effort * std::sin(0.5 * 1e-9 * double(t) + i) - 0.1 * effort * (state.q(i) - q_start(i));
    }
    const double h = 1e-9 * kPeriodNs / kSubsteps;
    for (int s = 0; s < kSubsteps; ++s) {
      state.qd += h * chasles::forward_dynamics(model, plant, state.q, state.qd, tau + push);
      state.q += h * state.qd;
    }
  }
  Figures f;
  f.ticks = static_cast<int64_t>(times.size());
  std::sort(times.begin(), times.end());
  f.p50 = percentile(times, 0.50);
  f.p99 = percentile(times, 0.99);
  f.max = 1e-3 * static_cast<double>(times.back());
  double sum = 0;
  for (int64_t x : times) sum += static_cast<double>(x);
  f.mean = 1e-3 * sum / static_cast<double>(times.size());
  f.allocations = allocations;
  f.slowed = slowed;
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"chasles_tick_bench: the time of Controller::tick under each control law, on an arm in closed loop"};
  std::string robot = "panda", tip;
  double seconds = 20.0;
  bool json = false;
  app.add_option("--robot", robot, "panda or ur5 (tests/data), or a URDF file (default panda)");
  app.add_option("--tip", tip, "the chain's tip (default: panda_hand for panda, tool0 for ur5)");
  app.add_option("--seconds", seconds, "simulated seconds timed per law, after 1 s of warm-up (default 20)")
      ->check(CLI::PositiveNumber);
  int64_t sleep_us = 0;
  app.add_option("--sleep-us", sleep_us, "sleep this long before every tick, untimed, as the daemon waits for a state")
      ->check(CLI::Range(0, 999'999));
  int wake_latency_us = -1;
  app.add_option("--cpu-wake-latency-us", wake_latency_us,
                 "hold /dev/cpu_dma_latency at this many us while timing, as chasles_controller --realtime does "
                 "(-1: ask nothing, the default)")
      ->check(CLI::Range(-1, 1'000'000));
  bool clearance = false;
  app.add_flag("--clearance", clearance, "the Panda kept clear of itself and a 6-object scene");
  app.add_flag("--json", json, "one JSON object on stdout instead of the table");
  CLI11_PARSE(app, argc, argv);
  std::optional<chasles::controller::CpuWakeLatency> wake_latency;
  if (wake_latency_us >= 0) {
    wake_latency.emplace(wake_latency_us);
    if (!wake_latency->warning().empty()) std::fprintf(stderr, "warning: %s\n", wake_latency->warning().c_str());
  }
  std::string path = robot;
  if (robot == "panda" || robot == "ur5") {
    path = std::string(CHASLES_BENCH_DATA) + "/" + robot + ".urdf";
    if (tip.empty()) tip = robot == "panda" ? "panda_hand" : "tool0";
  }
  try {
    chasles::UrdfOptions options;
    options.tip_link = tip;
    const chasles::RobotModel model = chasles::load_urdf_file(path, options);
    std::shared_ptr<chasles::controller::ClearanceWorld> world;
    if (clearance) {
      if (robot != "panda") throw chasles::ArgumentError("--clearance is the Panda's");
      world = panda_world(model);
    }
    const Law laws[] = {Law::kComputedTorque, Law::kJointImpedance, Law::kCartesianImpedance, Law::kFreeDrive};
    if (!json) {
      std::printf("%s: %d joints to %s; %.0f s per law at 1 kHz after %.0f s of warm-up\n\n", model.name().c_str(),
                  model.dof(), model.tip_link().c_str(), seconds, kWarmUpSeconds);
      std::printf("%-26s %8s %8s %8s %8s %8s %12s%s\n", "law", "ticks", "p50 us", "p99 us", "max us", "mean us",
                  "allocations", clearance ? "       slowed" : "");
    } else {
      std::printf("{");
    }
    const char* separator = "";
    const auto print = [&](const std::string& name, const Figures& f) {
      if (json) {
        std::printf("%s\"%s\": {\"ticks\": %lld, \"p50_us\": %.3f, \"p99_us\": %.3f, \"max_us\": %.3f, "
                    "\"mean_us\": %.3f, \"allocations\": %ld, \"slowed\": %lld}",
                    separator, name.c_str(), static_cast<long long>(f.ticks), f.p50, f.p99, f.max, f.mean,
                    f.allocations, static_cast<long long>(f.slowed));
        separator = ", ";
      } else {
        std::printf("%-26s %8lld %8.2f %8.2f %8.2f %8.2f %12ld", name.c_str(), static_cast<long long>(f.ticks),
                    f.p50, f.p99, f.max, f.mean, f.allocations);
        if (clearance) std::printf(" %12lld", static_cast<long long>(f.slowed));
        std::printf("\n");
      }
    };
    for (Law law : laws) print(to_string(law), run(model, law, seconds, 1000 * sleep_us, Source::kTargets, world.get()));
    // The same computed-torque law with its reference from a stream through the online generator.
    print("computed-torque-stream",
          run(model, Law::kComputedTorque, seconds, 1000 * sleep_us, Source::kStream, world.get()));
    std::printf(json ? "}\n" : "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chasles_tick_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
