// chasles_plant: a simulated arm on LCM. It integrates the arm's forward dynamics under the latest
// joint_torque_command_t (zero-order hold) and publishes robot_state_t after every step, either
// in real time or in lockstep with its controller; or, with --protocol, speaks a Drake driver's
// messages as the driver does (lcmt_iiwa_status / lcmt_iiwa_command, lcmt_panda_status /
// lcmt_panda_command), so a controller can drive it as it would a KUKA iiwa or a Franka Panda. It
// keeps itself safe: without a valid command for --timeout-ms it brakes to rest against gravity.
// The arm can be pushed (--push), meet walls (--wall) and carry what its controller does not know
// (--payload, --friction, inertias off the URDF's with --perturb-inertia); the plant then publishes
// the truth (sim_truth_t) after every state. --effort-noise makes the reported effort a noisy
// sensor's.
//
// Errors: one line "chasles_plant: ..." on stderr; exit 2 for a usage error, 1 for bad input
// (URDF, --q0, --damping, the environment's specs) or when LCM cannot start. SIGINT and SIGTERM
// end it cleanly (exit 0).
#include <poll.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "controller/transport/realtime/realtime.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "core/number_list.hpp"
#include "tools/error_line.hpp"
#include "tools/run_main.hpp"
#include "tools/simulation/environment_forms.hpp"
#include "tools/simulation/simulation.hpp"
#ifdef CHASLES_WITH_MUJOCO
#include "core/geometry/collision_model.hpp"
#include "core/geometry/scene_file.hpp"
#include "tools/mujoco/mujoco_plant.hpp"
#endif

namespace chasles::plant {

namespace {

struct Options {
  std::string robot;
  std::string tip;
  std::string damping = "0";
  std::string q0;
  std::vector<std::string> pushes, walls;
  std::string payload, friction, perturb_inertia, effort_noise, stalls;
  std::string armature;
  // --engine mujoco: the engine, its scene, its presses and where the URDF's meshes are.
  std::string engine = "chasles", scene;
  std::vector<std::string> presses, package_dirs;
  bool realtime = false;
  std::string protocol = "chasles", torque_semantics;
  std::string lcm_url;
  Bus::Receive receive = Bus::Receive::kDirect;
  double seconds = 0.0;
  SimulationOptions sim;
};

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", x);
  return text;
}

// CLI11's own range validators print the limits of double; these say what is wrong in words.
CLI::Validator at_least(double lower, bool inclusive, const char* words) {
  return CLI::Validator(
      [=](const std::string& text) {
        double x = 0.0;
        const bool ok = CLI::detail::lexical_cast(text, x) && std::isfinite(x) && (inclusive ? x >= lower : x > lower);
        return ok ? std::string() : "'" + text + "' is not " + words;
      },
      "");
}
const CLI::Validator kPositive = at_least(0.0, false, "a positive number");
const CLI::Validator kNonNegative = at_least(0.0, true, "a non-negative number");

// --q0, checked against the position limits; by default zero, moved into the limits for joints
// whose range excludes it (the Panda's fourth joint).
Eigen::VectorXd initial_position(const RobotModel& model, const std::string& text) {
  const int n = model.dof();
  Eigen::VectorXd q0(n);
  if (text.empty()) {
    for (int i = 0; i < n; ++i) q0[i] = std::clamp(0.0, model.joint(i).limits.lower, model.joint(i).limits.upper);
    return q0;
  }
  const std::vector<double> values = chasles::parse_number_list(text, "--q0");
  if (static_cast<int>(values.size()) != n) {
    throw ArgumentError("--q0 has " + std::to_string(values.size()) + " entries; the arm has " + std::to_string(n) +
                        " joints (one per joint, comma-separated)");
  }
  for (int i = 0; i < n; ++i) {
    const JointLimits& limits = model.joint(i).limits;
    q0[i] = values[static_cast<size_t>(i)];
    if (q0[i] < limits.lower || q0[i] > limits.upper) {
      throw ArgumentError("--q0: joint " + model.joint(i).name + " = " + number(q0[i]) + " is outside its limits [" +
                          number(limits.lower) + ", " + number(limits.upper) + "]");
    }
  }
  return q0;
}

Eigen::VectorXd joint_damping(const RobotModel& model, const std::string& text) {
  const int n = model.dof();
  const std::vector<double> values = chasles::parse_number_list(text, "--damping");
  if (values.size() != 1 && static_cast<int>(values.size()) != n) {
    throw ArgumentError("--damping has " + std::to_string(values.size()) + " entries; give one for every joint or " +
                        "one for all (the arm has " + std::to_string(n) + " joints)");
  }
  Eigen::VectorXd damping(n);
  for (int i = 0; i < n; ++i) {
    damping[i] = values.size() == 1 ? values[0] : values[static_cast<size_t>(i)];
    if (damping[i] < 0.0) throw ArgumentError("--damping: joint " + model.joint(i).name + " has negative damping");
  }
  return damping;
}

// --push, --wall, --payload, --friction and --perturb-inertia, each checked (environment_forms.hpp
// and core/simulation/environment.hpp say what is refused).
EnvironmentOptions environment(const RobotModel& model, const Options& o) {
  EnvironmentOptions env;
  for (const std::string& text : o.pushes) env.pushes.push_back(parse_push(text));
  for (const std::string& text : o.walls) env.walls.push_back(parse_wall(text));
  if (!o.payload.empty()) env.payload = parse_payload(o.payload);
  if (!o.friction.empty()) env.friction = parse_friction(o.friction, model);
  if (!o.perturb_inertia.empty()) env.perturbation = parse_perturbation(o.perturb_inertia);
  return env;
}

// --engine mujoco: MuJoCo's plant, its scene from --scene (the objects; planes and workspace boxes
// are the controller's safety zones, not things) and --press; chasles's plant's environment and
// substeps are refused by name. Without MuJoCo built in, says how to build it.
std::unique_ptr<Physics> mujoco_engine(const RobotModel& model, const Options& o, const Eigen::VectorXd& q0,
                                       const Eigen::VectorXd& damping) {
  for (const auto& [flag, given] : {std::pair{"--push", !o.pushes.empty()}, std::pair{"--wall", !o.walls.empty()},
                                    std::pair{"--payload", !o.payload.empty()}, std::pair{"--friction", !o.friction.empty()},
                                    std::pair{"--perturb-inertia", !o.perturb_inertia.empty()},
                                    std::pair{"--substeps", o.sim.substeps != 1}}) {
    if (given) {
      throw ArgumentError(std::string(flag) + " is chasles's own plant's: MuJoCo's has a scene (--scene) and presses "
                          "(--press) instead");
    }
  }
#ifdef CHASLES_WITH_MUJOCO
  const std::vector<std::string> dirs = geometry::with_ros_package_path(o.package_dirs);
  const geometry::CollisionModel geometry = geometry::load_collision_model(o.robot, model, {dirs, ""});
  if (geometry.objects.empty()) throw ArgumentError(o.robot + ": --engine mujoco needs the arm's collision geometry, and it has none");
  MujocoScene scene;
  if (!o.scene.empty()) scene.objects = geometry::read_scene_file(o.scene, {dirs}).objects;
  for (const std::string& text : o.presses) scene.presses.push_back(parse_press(text));
  return std::make_unique<MujocoPlant>(model, o.robot, geometry, scene, q0, damping, 1.0 / o.sim.rate_hz);
#else
  (void)model, (void)q0, (void)damping;
  throw ArgumentError("--engine mujoco: this chasles_plant was built without MuJoCo (configure with "
                      "-DCHASLES_MUJOCO_PREFIX=$(tools/mujoco.sh), as tools/test.sh and tools/demo.sh do)");
#endif
}

EffortNoise effort_noise(const Options& o) {
  return o.effort_noise.empty() ? EffortNoise{} : parse_effort_noise(o.effort_noise);
}

Stalls stalls(const Options& o) { return o.stalls.empty() ? Stalls{} : parse_stalls(o.stalls); }

// For the start line: what the plant simulates that its controller's model and sensors lack, as
// numbers to retake the run with (the seeds above all).
std::string model_errors(const SimulationOptions& sim) {
  std::string text;
  if (const auto& p = sim.environment.perturbation) {
    text += "; inertias perturbed by up to +-" + number(100.0 * p->fraction) + " % (seed " + std::to_string(p->seed) +
            "), not the URDF's";
  }
  if (const EffortNoise& noise = sim.faults.effort_noise; noise.sigma > 0.0) {
    text += "; effort reported with noise of sigma " + number(noise.sigma) + " N*m (seed " +
            std::to_string(noise.seed) + ")";
  }
  return text;
}

// Real time: one step per period on an absolute CLOCK_MONOTONIC schedule, with the latest command
// held. A wake-up more than a period late is an overrun; the schedule restarts from then rather
// than racing to catch up. A stall (--stall) holds the loop and counts as paused on `clock`, so the
// schedule goes on from where it stopped.
void run_real_time(Simulation& simulation, Bus& bus, PausableClock& clock, int64_t end_ns) {
  controller::minimise_timer_slack();  // the default 50 µs slack is most of the wake-up jitter
  const int64_t period_ns = simulation.period_ns();
  int64_t next_ns = clock.now_ns();
  const auto sleep_until = [&clock](int64_t t_ns) {  // clock's time; a stop signal interrupts it
    const int64_t at = t_ns + clock.paused();
    const timespec wake{static_cast<time_t>(at / 1'000'000'000), static_cast<long>(at % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
  };
  while (!g_stop) {
    next_ns += period_ns;
    sleep_until(next_ns);
    const int64_t now_ns = clock.now_ns();
    if (g_stop || now_ns >= end_ns) break;
    if (now_ns - next_ns > period_ns) {
      simulation.count_overrun();
      next_ns = now_ns;
    }
    bus.handle_pending();
    simulation.step();
    if (const int64_t stall_ns = simulation.stall_due(); stall_ns > 0) {
      sleep_until(clock.now_ns() + stall_ns);
      clock.pause(stall_ns);
    }
  }
}

// Lockstep: the steps happen as commands arrive (in the bus's handler); between them, the state is
// repeated and delayed states are sent when due.
void run_lockstep(Simulation& simulation, Bus& bus, const controller::Clock& clock, int64_t end_ns) {
  pollfd lcm_fd{bus.fileno(), POLLIN, 0};
  while (!g_stop) {
    const int64_t now_ns = clock.now_ns();
    if (now_ns >= end_ns) break;
    const int64_t wake_ns = std::min(simulation.serve_lockstep(), end_ns);
    const int timeout_ms = static_cast<int>(std::max<int64_t>(0, (wake_ns - now_ns + 999'999) / 1'000'000));
    if (poll(&lcm_fd, 1, timeout_ms) > 0) bus.handle_pending();
  }
}

int fail(const std::string& message, int code) { return chasles::tools::fail("chasles_plant", message, code); }

// LCM subscribes by regular expression: a channel or prefix has only characters that match themselves.
const CLI::Validator kPlainChannel(
    [](const std::string& text) {
      const bool plain = std::all_of(text.begin(), text.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '/';
      });
      return plain ? std::string() : "letters, digits, '_', '-' and '/' only";
    },
    "");

// --protocol and --torque-semantics take the names protocol.hpp gives (to_string / parse_*).
CLI::Validator named(bool (*parse)(std::string_view), const char* names) {
  return CLI::Validator(
      [=](const std::string& text) { return parse(text) ? std::string() : "'" + text + "' is not one of " + names; },
      "");
}
bool is_protocol(std::string_view text) {
  chasles::controller::Protocol protocol{};
  return chasles::controller::parse_protocol(text, protocol);
}
bool is_torque_semantics(std::string_view text) {
  chasles::controller::TorqueSemantics semantics{};
  return chasles::controller::parse_torque_semantics(text, semantics);
}

void add_options(CLI::App& app, Options& o) {
  app.add_option("--robot", o.robot, "Robot description (URDF file)")->required()->type_name("FILE");
  app.add_option("--tip", o.tip, "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
  app.add_option("--rate", o.sim.rate_hz,
                 "Steps per second; one status per step (default: the protocol's, 1000 for chasles and "
                 "drake-panda, 200 for drake-iiwa: FRI's 5 ms)")
      ->check(kPositive)
      ->type_name("HZ");
  app.add_option("--protocol", o.protocol,
                 "The messages spoken: 'chasles' (robot_state_t / joint_torque_command_t), 'drake-iiwa' "
                 "(lcmt_iiwa_status / lcmt_iiwa_command, as Drake's iiwa driver) or 'drake-panda' "
                 "(lcmt_panda_status / lcmt_panda_command, as drake-franka-driver in torque mode)")
      ->check(named(is_protocol, "chasles, drake-iiwa, drake-panda"))
      ->capture_default_str();
  app.add_option("--status-channel", o.sim.status_channel,
                 "Channel of the statuses (default: PREFIX STATE, IIWA_STATUS or PANDA_STATUS)")
      ->check(kPlainChannel)
      ->type_name("CHANNEL");
  app.add_option("--command-channel", o.sim.command_channel,
                 "Channel of the commands (default: PREFIX COMMAND, IIWA_COMMAND or PANDA_COMMAND)")
      ->check(kPlainChannel)
      ->type_name("CHANNEL");
  app.add_option("--torque-semantics", o.torque_semantics,
                 "'full': a command's torque is the whole joint torque; 'overlay': the plant adds g(q) of its "
                 "nominal model (the URDF's bare arm, not --payload), as Drake's drivers add gravity "
                 "compensation (default: full for chasles, overlay for drake-iiwa and drake-panda)")
      ->check(named(is_torque_semantics, "overlay, full"))
      ->type_name("SEMANTICS");
  app.add_option("--engine", o.engine,
                 "Who simulates the arm: 'chasles', its own rigid-body RK4 (exact; pushes and walls at the tip), or "
                 "'mujoco', MuJoCo 3.3.4 (contact on any link with --scene's objects and --press)")
      ->check(CLI::IsMember({"chasles", "mujoco"}))
      ->capture_default_str();
  app.add_option("--scene", o.scene,
                 "--engine mujoco: the scene file (docs/scene.md) whose objects the arm can touch; its planes and "
                 "workspace boxes are the controller's safety zones and are not simulated")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  app.add_option("--press", o.presses,
                 "--engine mujoco: a ball pressing LINK, repeatable (one at a time): from START s of simulated time for "
                 "DURATION s, ramped in and out over RAMP s each, along the line through (AX,AY,AZ) in the link's frame "
                 "(m) with direction (DX,DY,DZ) in the base frame, with FORCE N")
      ->type_name("LINK,START,DURATION,RAMP,AX,AY,AZ,DX,DY,DZ,FORCE");
  app.add_option("--package-dir", o.package_dirs,
                 "--engine mujoco: where the URDF's package://NAME/... meshes are looked for, as DIR/NAME/... "
                 "(repeatable; then $ROS_PACKAGE_PATH's folders)")
      ->type_name("DIR");
  app.add_option("--substeps", o.sim.substeps, "RK4 steps per step")->check(CLI::Range(1, 1000))->capture_default_str();
  app.add_option("--damping", o.damping, "Viscous joint damping, N*m*s/rad or N*s/m: one value, or one per joint")
      ->type_name("D[,D...]")
      ->capture_default_str();
  app.add_option("--q0", o.q0,
                 "Initial joint positions, rad or m, within the limits (default: zero, or the nearest limit "
                 "where zero is outside)")
      ->type_name("Q,Q,...");
  app.add_flag("--lockstep", o.sim.lockstep,
               "One step per command answering the latest state (deterministic); until then the state is "
               "sent again every 10 ms. Default: real time");
  app.add_flag("--realtime", o.realtime,
               "SCHED_FIFO 70 and mlockall for the simulation (warns if refused), so states leave on time");
  app.add_option("--timeout-ms", o.sim.timeout_ms, "Real time: brake after this long without a valid command")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--max-late", o.sim.max_late,
                 "Real time: brake after this many late cycles in a row (0: never). A step is late when no "
                 "command answering the previous state has arrived by then, as an arm counts a missed deadline")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-command-lag-ms", o.sim.max_lag_ms,
                 "Real time: ignore commands answering a state more than this much older than the newest "
                 "(or one not sent yet), as if none had come (default: --timeout-ms)")
      ->check(kNonNegative)
      ->type_name("MS");
  app.add_option("--channel-prefix", o.sim.prefix,
                 "Channels are PREFIX STATE and PREFIX COMMAND (chasles's protocol) and PREFIX TRUTH")
      ->check(kPlainChannel)
      ->type_name("PREFIX")
      ->capture_default_str();
  app.add_option("--push", o.pushes,
                 "A wrench on the tip, repeatable (pushes add): from START s of simulated time (steps x period) "
                 "for DURATION s, ramped linearly in and out over RAMP s each (RAMP <= DURATION/2); (m, f) in N*m "
                 "and N, the base frame's orientation at the tip frame's origin, what the environment applies")
      ->type_name("START,DURATION,RAMP,mx,my,mz,fx,fy,fz");
  app.add_option("--wall", o.walls,
                 "A one-sided plane on the tip frame's origin, repeatable: a point (m) and the normal to the free "
                 "side (base frame, normalised), stiffness K N/m (default 10000) and damping D N*s/m (default "
                 "100); force n*max(0, K*depth - D*v.n) while the origin is inside")
      ->type_name("PX,PY,PZ,NX,NY,NZ[,K,D]");
  app.add_option("--payload", o.payload,
                 "A point mass (kg) at (CX,CY,CZ) in the tip frame (m, default the origin), simulated but not in "
                 "the URDF the controller has")
      ->type_name("KG[,CX,CY,CZ]");
  app.add_option("--armature", o.armature,
                 "Each joint's reflected rotor inertia, kg*m^2 (kg for a prismatic joint), one per joint: replaces "
                 "the URDF's (drake:rotor_inertia * drake:gear_ratio^2, 0 where it gives none). Part of the nominal "
                 "model, like --damping: the truth does not count it as external; give the controller the same")
      ->type_name("A,A,...");
  app.add_option("--friction", o.friction,
                 "Hidden joint friction on top of --damping: tau_f = -b*qd - (fc + (fs - fc)*exp(-(qd/0.05)^2))*"
                 "tanh(qd/v_s), one pair (no stiction: fs = fc) or triple for every joint or one per joint (N*m*s/rad, "
                 "N*m, N*m); v_s is set for the RK4 step (see the docs)")
      ->type_name("B,FC[,FS][,B,FC...]");
  app.add_option("--perturb-inertia", o.perturb_inertia,
                 "Simulate inertias off the URDF's (which the controller keeps): every body's mass scaled by up to "
                 "+-FRACTION, its centre of mass moved by up to FRACTION times its radius of gyration per axis, its "
                 "spread along each principal axis scaled by up to +-FRACTION and the axes turned by up to FRACTION "
                 "rad, physically consistent; drawn from SEED (default 0). 0 <= FRACTION < 1, e.g. 0.2")
      ->type_name("FRACTION[,SEED]");
  app.add_option("--stall", o.stalls,
                 "Real time: the whole simulation pauses (no step, no state, its clock standing) for a time drawn "
                 "from [MIN_MS, MAX_MS] every EVERY_S s of simulated time, then goes on where it stopped, as a "
                 "simulator paced by a busy process (Drake's, in Python) does; drawn from SEED (default 0)")
      ->type_name("MIN_MS,MAX_MS,EVERY_S[,SEED]");
  app.add_option("--effort-noise", o.effort_noise,
                 "Gaussian noise of standard deviation SIGMA (N*m) on the effort each state reports (robot_state_t "
                 "effort, the Drake statuses' measured torque), independent per joint and state, drawn from SEED "
                 "(default 0); the torque applied to the arm stays the commanded one")
      ->type_name("SIGMA[,SEED]");
  app.add_flag("--truth", o.sim.truth,
               "Publish chasles.sim_truth_t on PREFIX TRUTH after every state even with none of --push, --wall, "
               "--payload, --friction, --perturb-inertia (with any of them it is always published)");
  app.add_option("--receive", o.receive,
                 "who reads the commands off the wire: 'direct', this process's step loop on its own multicast "
                 "socket (default), or 'lcm', LCM's receive thread and its hand-over")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, Bus::Receive>{{"direct", Bus::Receive::kDirect}, {"lcm", Bus::Receive::kLcm}}));
  app.add_option("--lcm-url", o.lcm_url, "LCM provider URL (default: $LCM_DEFAULT_URL, else LCM's default)")
      ->type_name("URL");
  app.add_option("--seed", o.sim.faults.seed, "Seed of the injected faults")->capture_default_str();
  app.add_option("--drop", o.sim.faults.drop, "Probability of not sending a state")
      ->check(CLI::Range(0.0, 1.0))
      ->type_name("P");
  app.add_option("--delay-ms", o.sim.faults.delay_ms, "Send every state this long after it is produced")
      ->check(kNonNegative)
      ->type_name("D");
  app.add_option("--delay-spike-ms", o.sim.faults.spike_ms,
                 "Every --delay-spike-every states, hold every state back for this long, then send them together")
      ->check(kNonNegative)
      ->type_name("D");
  app.add_option("--delay-spike-every", o.sim.faults.spike_every, "States between the starts of two delay spikes")
      ->check(at_least(1.0, true, "a whole number of states, 1 or more"))
      ->type_name("N");
  app.add_option("--noise", o.sim.faults.noise, "Std. deviation of gaussian noise on the sent position, rad or m")
      ->check(kNonNegative)
      ->type_name("SIGMA");
  app.add_option("--seconds", o.seconds, "Stop after this much wall-clock time (default: run until a signal)")
      ->check(kNonNegative)
      ->type_name("N");
}

}  // namespace
}  // namespace chasles::plant

int main(int argc, char** argv) {
  using namespace chasles::plant;

  CLI::App app("chasles_plant: a simulated robot arm on LCM: joint torques in, joint states out", "chasles_plant");
  Options options;
  add_options(app, options);
  app.footer(
      "Publishes chasles.robot_state_t on PREFIX STATE after every step; applies the latest valid\n"
      "chasles.joint_torque_command_t from PREFIX COMMAND (zero-order hold, clamped to the URDF effort\n"
      "limits). --protocol drake-iiwa or drake-panda speaks Drake's driver messages instead, on\n"
      "IIWA_STATUS / IIWA_COMMAND or PANDA_STATUS / PANDA_COMMAND, with the driver's signs and its\n"
      "gravity compensation (docs/protocols.md). Dynamics: M(q) qdd = tau - c - g - D qd, RK4.\n"
      "Real time: without a valid command for --timeout-ms the arm brakes to rest, tau = g(q) -\n"
      "M(q) qd / T. A command answering a state older than --max-command-lag-ms counts as none (and\n"
      "is reported). A step at which no command answering the previous state has arrived is a late\n"
      "cycle; after --max-late in a row the arm brakes the same way until a command is on time again.\n"
      "With --push, --wall, --payload, --friction, --perturb-inertia or --truth it publishes\n"
      "chasles.sim_truth_t on PREFIX TRUTH right after every state: the external joint torque and the\n"
      "contact wrench the nominal model (the URDF, --damping) does not contain; with --perturb-inertia\n"
      "the external torque includes the error of the nominal model's inertias.\n"
      "Examples:\n"
      "  tools/netns.sh chasles_plant --robot ur5.urdf --tip tool0 \\\n"
      "      --lcm-url 'udpm://239.255.76.67:7667?ttl=0'\n"
      "  chasles_plant --robot panda.urdf --tip panda_hand --lockstep --q0 0,0.5,0,-1.2,0,1,0\n"
      "  chasles_plant --robot iiwa14.urdf --tip iiwa_link_ee --protocol drake-iiwa --rate 200\n"
      "  chasles_plant --robot panda.urdf --tip panda_hand --seed 7 --drop 0.01 --delay-ms 2 --noise 1e-4\n"
      "  chasles_plant --robot panda.urdf --tip panda_hand --delay-spike-ms 5 --delay-spike-every 500\n"
      "  chasles_plant --robot panda.urdf --tip panda_hand --push 1,0.5,0.005,0,0,0,0,0,-30 \\\n"
      "      --wall 0.5,0,0.2,0,0,1 --payload 1.5,0,0,0.1 --friction 0.1,0.5\n"
      "  chasles_plant --robot panda.urdf --tip panda_hand --perturb-inertia 0.2,7 --effort-noise 0.05,3");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return fail(std::string(e.what()) + " (see 'chasles_plant --help')", 2);
  }

  chasles::controller::parse_protocol(options.protocol, options.sim.protocol);  // checked by its validator
  if (!options.torque_semantics.empty()) {
    chasles::controller::TorqueSemantics semantics{};
    chasles::controller::parse_torque_semantics(options.torque_semantics, semantics);
    options.sim.torque_semantics = semantics;
  }
  if (app.count("--rate") == 0) {
    const double period = chasles::controller::nominal_status_period(options.sim.protocol);
    options.sim.rate_hz = period > 0.0 ? 1.0 / period : 1000.0;
  }

  return chasles::tools::run_main("chasles_plant", [&] {
    chasles::UrdfOptions urdf_options;
    urdf_options.tip_link = options.tip;
    const chasles::RobotModel loaded = chasles::load_urdf_file(options.robot, urdf_options);
    const chasles::RobotModel model =
        options.armature.empty()
            ? loaded
            : chasles::with_armature(loaded, chasles::parse_armature(options.armature, loaded.dof(), "--armature"));
    chasles::tools::warn("chasles_plant", options.robot, model.warnings());
    if (const std::string defect = chasles::mass_matrix_defect(model); !defect.empty()) {
      throw chasles::ModelError(options.robot + ": cannot simulate this chain: " + defect);
    }
    const Eigen::VectorXd q0 = initial_position(model, options.q0);
    const Eigen::VectorXd damping = joint_damping(model, options.damping);
    const bool mujoco = options.engine == "mujoco";
    std::unique_ptr<Physics> engine = mujoco ? mujoco_engine(model, options, q0, damping) : nullptr;
    if (!mujoco) options.sim.environment = environment(model, options);
    options.sim.faults.effort_noise = effort_noise(options);
    options.sim.stalls = stalls(options);

    // SIGINT and SIGTERM stop the loop. They are blocked while LCM starts its receive thread, which
    // inherits the mask, so they always reach (and interrupt) the simulation thread.
    struct sigaction action {};
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    // Real time before LCM starts: with --receive lcm its receive thread, which every command
    // passes through, inherits SCHED_FIFO. Below the controller's default priority (80): on a shared machine the
    // controller's tick comes first.
    if (options.realtime) {
      for (const auto& warning : chasles::controller::make_realtime(70, -1)) {
        std::fprintf(stderr, "chasles_plant: warning: %s\n", warning.c_str());
      }
    }
    std::unique_ptr<Bus> bus;
    try {
      bus = std::make_unique<Bus>(options.lcm_url, options.receive);
    } catch (const chasles::Error&) {
      return fail("cannot start LCM" + (options.lcm_url.empty() ? std::string() : " on " + options.lcm_url) +
                      ": is there a multicast route? Run inside tools/netns.sh with "
                      "--lcm-url 'udpm://239.255.76.67:7667?ttl=0'",
                  1);
    }
    const chasles::controller::SystemClock system_clock;
    PausableClock clock(system_clock);
    Simulation simulation = engine ? Simulation(model, options.sim, std::move(engine), *bus, clock)
                                   : Simulation(model, options.sim, q0, damping, *bus, clock);
    pthread_sigmask(SIG_UNBLOCK, &stop_signals, nullptr);

    const std::string wire =
        options.sim.protocol == chasles::controller::Protocol::kChasles &&
                simulation.torque_semantics() == chasles::controller::TorqueSemantics::kFull
            ? "state on " + simulation.status_channel() + ", commands on " + simulation.command_channel()
            : std::string(chasles::controller::to_string(options.sim.protocol)) + ": status on " +
                  simulation.status_channel() + ", commands on " + simulation.command_channel() + " (torque " +
                  chasles::controller::to_string(simulation.torque_semantics()) + ")";
    std::fprintf(stderr, "chasles_plant: %s, %d joints to %s, %s, %g Hz %s; %s%s%s\n", model.name().c_str(), model.dof(),
                 model.tip_link().c_str(), mujoco ? "MuJoCo" : "chasles's RK4", options.sim.rate_hz,
                 options.sim.lockstep ? "lockstep" : "real time (braked until the first command)", wire.c_str(),
                 simulation.publishes_truth() ? (", truth on " + options.sim.prefix + "TRUTH").c_str() : "",
                 model_errors(options.sim).c_str());
    const int64_t end_ns = options.seconds > 0.0 ? clock.now_ns() + static_cast<int64_t>(options.seconds * 1e9)
                                                 : std::numeric_limits<int64_t>::max();
    simulation.start();
    if (options.sim.lockstep) {
      run_lockstep(simulation, *bus, clock, end_ns);
    } else {
      run_real_time(simulation, *bus, clock, end_ns);
    }
    simulation.print_summary();
    return 0;
  });
}
