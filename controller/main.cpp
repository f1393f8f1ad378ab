// chasles_controller: the real-time control daemon. It loads the arm from URDF, then every period
// turns the latest robot_state_t into a joint_torque_command_t by computed torque, following the
// targets (arm_target_t) it receives, and reports controller_status_t for monitors.
//
// Errors: one line "chasles_controller: ..." on stderr; exit 2 for a usage error, 1 for bad input
// (URDF, gains, config file), when LCM cannot start, or when another controller is already
// commanding the arm (heard on the command channel before the loop starts). What main throws for
// bad input is a chasles::Error (ArgumentError, ModelError), as the libraries' errors are; an
// exception of any other kind is reported as "internal error: ..." (a bug), but for the system's
// refusals (std::system_error) and "out of memory". SIGINT and SIGTERM stop it cleanly (exit 0),
// after the summary is written.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <new>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <thread>

#include "controller/daemon.hpp"
#include "controller/node.hpp"
#include "controller/world.hpp"
#include "core/geometry/scene_file.hpp"
#include "core/atomic_file.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/error.hpp"
#include "core/model/model.hpp"
#include "core/model/payload.hpp"
#include "core/model/urdf.hpp"
#include "core/number_list.hpp"

namespace {

using chasles::controller::DaemonOptions;
using chasles::controller::Summary;
using Json = nlohmann::json;

/// Prints "chasles_controller: <message>" as one line on stderr and returns `code`, the exit status:
/// how the daemon reports every error, as the tools do theirs (tools/error_line.hpp).
int fail(const std::string& message, int code) {
  std::fprintf(stderr, "chasles_controller: %s\n", chasles::one_line(message).c_str());
  return code;
}

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop.store(true); }

// --simulator without --stale-ms: how long a silent simulator is waited for. Drake's simulated arms,
// paced by Python on a busy 2-core host, were seen silent for up to 110 ms.
constexpr int64_t kSimulatorStaleNs = 1'000'000'000;

/// A gain option: one number for every joint or a comma list of n; thresholds may be "inf" (none).
Eigen::VectorXd gains(const std::string& text, int n, const std::string& name, bool infinite_ok = false) {
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    size_t used = 0;
    double x = 0.0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || std::isnan(x) || (!infinite_ok && std::isinf(x))) {
      throw chasles::ArgumentError(name + ": '" + item + "' is not a " + (infinite_ok ? "number" : "finite number"));
    }
    values.push_back(x);
  }
  if (values.size() == 1) return Eigen::VectorXd::Constant(n, values[0]);
  if (static_cast<int>(values.size()) != n) {
    throw chasles::ArgumentError(name + " has " + std::to_string(values.size()) + " entries; give one or " +
                                 std::to_string(n));
  }
  return Eigen::Map<Eigen::VectorXd>(values.data(), n);
}

/// "a,b,c" with each entry as %g prints it.
std::string number_text(const Eigen::VectorXd& v) {
  std::string text;
  char entry[32];
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    std::snprintf(entry, sizeof entry, "%g", v[i]);
    text += (i ? "," : "") + std::string(entry);
  }
  return text;
}

std::string gains_text(const Json& value, const std::string& name) {
  if (value.is_number()) return std::to_string(value.get<double>());
  if (!value.is_array()) throw chasles::ArgumentError(name + ": expected a number or a list of numbers");
  std::string text;
  for (const auto& x : value) {
    if (!x.is_number()) throw chasles::ArgumentError(name + ": expected a number or a list of numbers");
    text += (text.empty() ? "" : ",") + std::to_string(x.get<double>());
  }
  return text;
}

// The settings the library gives its defaults for: each flag starts from them, so that a default is
// written once, in C++, and the help prints it from there.
const chasles::controller::Config kDefault{};
const chasles::controller::DaemonOptions::Locate kDefaultLocate{};
const chasles::geometry::ProximityOptions kDefaultProximity{};

struct Flags {
  std::string robot, tip, config, summary;
  // rate and stale_ms 0: the protocol's status rate, and 10 ms or three of its periods.
  double rate = 0.0, stale_ms = 0.0, torque_ramp_ms = 1e3 * kDefault.torque_ramp, omega = 20.0;
  std::string kp, kd;
  std::string damping;
  std::string coulomb;
  bool friction_from_urdf = false;
  // Contact: per-joint lists as text until the joint count is known; empty: the defaults.
  std::string observer_gain, contact_torque, collision_torque;
  chasles::controller::ContactConfig contact;
  std::vector<std::string> link_policies;  // LINK,FORCE,REFLEX,guided|strict each
  double retract_mm = 1e3 * kDefault.contact.retract_distance;
  std::string payload;
  std::string armature;
  // Motion limits beyond the URDF's: per-joint lists as text until the joint count is known.
  std::string acceleration_limit, jerk_limit;
  double stream_timeout_ms = 1e3 * kDefault.stream_timeout;
  chasles::motion::LimitConfig limits;
  chasles::controller::JogConfig jog;
  double pose_time_constant_ms = 1e3 * kDefault.jog.pose_time_constant;
  bool semantics_check = kDefault.check_torque_semantics;
  // Clearance: the collision geometry, where its meshes are, and the distances kept.
  std::string collision = "auto", srdf, scene;
  std::vector<std::string> package_dirs;
  // Contact localisation (DaemonOptions::locate).
  std::string locate = "on";
  double locate_hz = kDefaultLocate.rate_hz, locate_floor = kDefaultLocate.floor;
  double self_stop_mm = 1e3 * kDefaultProximity.self.stop, self_influence_mm = 1e3 * kDefaultProximity.self.influence;
  double clearance_margin_mm = 1e3 * kDefault.clearance.reference_margin;
  double clearance_time_constant_ms = 1e3 * kDefault.clearance.time_constant;
  double clearance_deceleration = kDefault.clearance.deceleration, repulsion = kDefault.clearance.repulsion;
};

// The collision geometry and the scene from the flags into `options`, each step said on stderr.
void load_clearance(const chasles::RobotModel& model, const Flags& flags, DaemonOptions& options) {
  chasles::controller::WorldOptions world;
  chasles::controller::parse_collision_mode(flags.collision, world.mode);  // checked by CLI11
  world.urdf = flags.robot;
  world.geometry.package_dirs = chasles::geometry::with_ros_package_path(flags.package_dirs);
  world.geometry.srdf_path = flags.srdf;
  world.proximity.self = {flags.self_stop_mm * 1e-3, flags.self_influence_mm * 1e-3};
  std::vector<std::string> notes;
  options.arm = chasles::controller::load_arm_geometry(model, world, notes);
  options.proximity = world.proximity;
  for (const std::string& note : notes) std::fprintf(stderr, "chasles_controller: %s\n", chasles::one_line(note).c_str());
  chasles::geometry::Scene scene;
  if (!flags.scene.empty()) {
    if (options.arm.objects.empty()) throw chasles::ArgumentError("--scene " + flags.scene + ": the arm has no collision geometry");
    scene = chasles::geometry::read_scene_file(flags.scene, {world.geometry.package_dirs});
    std::fprintf(stderr, "chasles_controller: scene %s: %zu objects, %zu planes\n", flags.scene.c_str(),
                 scene.objects.size(), scene.planes.size());
  }
  options.clearance = chasles::controller::make_world(model, options.arm, scene, world.proximity);
}

// A contact or collision threshold: a positive number, or inf for none (as the per-joint torque
// thresholds take it).
const CLI::Validator kThreshold(
    [](std::string& text) {
      char* end = nullptr;
      const double value = std::strtod(text.c_str(), &end);
      return end != text.c_str() && *end == '\0' && value > 0.0 ? std::string()
                                                                 : "'" + text + "' is not a positive number or inf";
    },
    "POSITIVE|inf");

// The config file's keys are the flags' names with '_' for '-'.
std::string flag_of(const std::string& key) {
  std::string flag = "--" + key;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

/// Settings from a JSON config file ({"kp": .., "kd": .., "rate": .., "stale_ms": ..,
/// "torque_ramp_ms": .., the contact settings ..}); flags given on the command line win.
void apply_config(const std::string& path, Flags& flags, const CLI::App& app) {
  std::ifstream in(path);
  if (!in) throw chasles::ArgumentError("cannot read config file " + path);
  Json config;
  try {
    config = Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw chasles::ArgumentError("config file " + path + " is not valid JSON: " + e.what());
  }
  if (!config.is_object()) throw chasles::ArgumentError("config file " + path + ": expected a JSON object");
  static const char* const kKnown =
      "kp, kd, rate, stale_ms, torque_ramp_ms, observer_gain, contact_torque, collision_torque, contact_force, "
      "collision_force, contact_moment, collision_moment, reflex, link_policy, retract_mm";
  for (const auto& [key, value] : config.items()) {
    // A key that names no flag is no setting either: said below (App::count would throw).
    if (const CLI::Option* given = app.get_option_no_throw(flag_of(key)); given != nullptr && given->count() > 0) {
      continue;
    }
    const std::string where = "config file " + path + ": " + key;
    auto positive = [&]() {
      if (!value.is_number() || !(value.get<double>() > 0.0)) {
        throw chasles::ArgumentError(where + ": expected a positive number");
      }
      return value.get<double>();
    };
    if (key == "kp") {
      flags.kp = gains_text(value, where);
    } else if (key == "kd") {
      flags.kd = gains_text(value, where);
    } else if (key == "observer_gain" || key == "contact_torque" || key == "collision_torque") {
      (key == "observer_gain" ? flags.observer_gain : key == "contact_torque" ? flags.contact_torque
                                                                              : flags.collision_torque) =
          gains_text(value, where);
    } else if (key == "rate" || key == "stale_ms" || key == "torque_ramp_ms" || key == "retract_mm") {
      (key == "rate"       ? flags.rate
       : key == "stale_ms" ? flags.stale_ms
       : key == "retract_mm" ? flags.retract_mm
                             : flags.torque_ramp_ms) = positive();
    } else if (key == "contact_force") {
      flags.contact.contact_force = positive();
    } else if (key == "collision_force") {
      flags.contact.collision_force = positive();
    } else if (key == "contact_moment") {
      flags.contact.contact_moment = positive();
    } else if (key == "collision_moment") {
      flags.contact.collision_moment = positive();
    } else if (key == "reflex") {
      if (!value.is_string() || !chasles::controller::parse_reflex(value.get<std::string>(), flags.contact.reflex)) {
        throw chasles::ArgumentError(where + ": expected \"stop\", \"compliant\" or \"retract\"");
      }
    } else if (key == "link_policy") {
      if (!value.is_array()) throw chasles::ArgumentError(where + ": expected a list of \"LINK,FORCE,REFLEX,guided|strict\"");
      for (const auto& entry : value) {
        if (!entry.is_string()) throw chasles::ArgumentError(where + ": expected strings \"LINK,FORCE,REFLEX,guided|strict\"");
        flags.link_policies.push_back(entry.get<std::string>());
      }
    } else {
      throw chasles::ArgumentError(where + ": unknown setting (known: " + kKnown + ")");
    }
  }
}

Json to_json(const chasles::controller::Percentiles& p) { return {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}}; }

/// Written to a temporary file beside the target and renamed over it, so a reader never sees half.
void write_summary(const std::string& path, const Summary& s) {
  const Json json = {{"ticks", s.ticks},
                     {"rate_hz", s.rate_hz},
                     {"seconds", s.seconds},
                     {"tick", s.state_driven ? "state" : "clock"},
                     {"overruns", s.overruns},
                     {"jitter_us", to_json(s.jitter_us)},
                     {"compute_us", to_json(s.compute_us)},
                     {"publish_us", to_json(s.publish_us)},
                     {"latency_us", to_json(s.latency_us)},
                     {"tracking_error", {{"rms", s.tracking_rms}, {"max", s.tracking_max}}},
                     {"commands", s.commands},
                     {"send_failures", s.send_failures},
                     {"lost_timing_records", s.lost_timing_records},
                     {"stale_states", s.stale_states},
                     {"rejected_messages", s.rejected_messages},
                     {"faults", s.faults},
                     {"foreign_commands", s.foreign_commands},
                     {"contacts", s.contacts},
                     {"reflexes", s.reflexes},
                     {"peak_tip_force_n", s.peak_tip_force},
                     {"realtime", s.realtime_granted}};
  chasles::write_file_atomically(path, json.dump(2) + "\n");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"chasles_controller: computed-torque control of an arm over LCM, at a fixed rate"};
  app.footer(
      "Example (in a private network namespace, with chasles_plant running):\n"
      "  chasles_controller --robot tests/data/panda.urdf --realtime --seconds 10 --summary run.json");
  Flags flags;
  DaemonOptions options;
  app.add_option("--robot", flags.robot, "URDF of the arm")->required()->check(CLI::ExistingFile);
  app.add_option("--tip", flags.tip, "tip link (default: the URDF's single leaf)");
  app.add_option("--rate", flags.rate,
                 "control rate, Hz: the rate the arm's status comes at (default: the protocol's, 200 for drake-iiwa, "
                 "else 1000)")
      ->check(CLI::PositiveNumber);
  app.add_option("--kp", flags.kp, "position gains K_p, 1/s²: one number or one per joint (default ω²)");
  app.add_option("--kd", flags.kd, "velocity gains K_d, 1/s: one number or one per joint (default 2ω)");
  app.add_option("--damping", flags.damping,
                 "the joints' viscous damping, N·m·s/rad: one number or one per joint; fed forward as D q̇_d");
  app.add_option("--coulomb", flags.coulomb,
                 "the joints' Coulomb friction f_c, N·m (chasles_calibrate dynamics identifies it): one number or "
                 "one per joint; fed forward as f_c tanh(q̇_d / 0.05 rad/s), and the contact observer counts it");
  app.add_flag("--friction-from-urdf", flags.friction_from_urdf,
               "the joints' viscous damping and Coulomb friction from the URDF's <dynamics damping friction> (what "
               "chasles_calibrate dynamics writes into an identified URDF); --damping and --coulomb override them");
  app.add_option("--omega", flags.omega, "natural frequency ω of the default gains, rad/s (default 20)")
      ->check(CLI::PositiveNumber);
  app.add_option("--config", flags.config,
                 "JSON file with any of the settings below, named with '_' for '-' (kp, stale_ms, reflex, ...); "
                 "flags win")
      ->check(CLI::ExistingFile);
  app.add_option("--stale-ms", flags.stale_ms,
                 "a robot state older than this is a FAULT (default 10, or three periods where that is longer; "
                 "with --simulator, 1000)")
      ->check(CLI::PositiveNumber);
  app.add_option("--torque-ramp-ms", flags.torque_ramp_ms,
                 "torque-rate limit: time to ramp through a joint's effort range, ms")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--observer-gain", flags.observer_gain,
                 "contact observer bandwidth K_O, 1/s: one number or one per joint; the estimate lags the external "
                 "torque by 1/K_O (default 200)");
  app.add_option("--contact-torque", flags.contact_torque,
                 "contact threshold on each joint's external torque, N·m: one or one per joint, inf for none "
                 "(default 5 % of the effort limit)");
  app.add_option("--collision-torque", flags.collision_torque,
                 "collision threshold on each joint's external torque, N·m (default 15 % of the effort limit)");
  app.add_option("--contact-force", flags.contact.contact_force, "contact threshold on the tip force, N (inf: none)")
      ->check(kThreshold)
      ->capture_default_str();
  app.add_option("--collision-force", flags.contact.collision_force,
                 "collision threshold on the tip force, N (inf: none)")
      ->check(kThreshold)
      ->capture_default_str();
  app.add_option("--contact-moment", flags.contact.contact_moment,
                 "contact threshold on the tip moment, N·m (inf: none)")
      ->check(kThreshold)
      ->capture_default_str();
  app.add_option("--collision-moment", flags.contact.collision_moment,
                 "collision threshold on the tip moment, N·m (inf: none)")
      ->check(kThreshold)
      ->capture_default_str();
  app.add_option("--reflex", flags.contact.reflex,
                 "on a collision: 'stop' (hold where the arm is), 'compliant' (gravity compensation and damping: "
                 "the arm yields) or 'retract' (back along the tip's path by --retract-mm over 0.3 s); until a "
                 "new target (default stop)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, chasles::controller::Reflex>{
          {"stop", chasles::controller::Reflex::kStop},
          {"compliant", chasles::controller::Reflex::kCompliant},
          {"retract", chasles::controller::Reflex::kRetract}}));
  app.add_option("--link-policy", flags.link_policies,
                 "what a contact on one link means, LINK,FORCE,REFLEX,guided|strict (repeat per link): a force of "
                 "FORCE N (inf: none) located on LINK is a collision even under the joint thresholds; a collision "
                 "isolated on LINK starts REFLEX; guided: under free drive a push on it is a person's, never a "
                 "reflex; strict: a collision there too. Other links: --collision-force, --reflex, guided")
      ->take_all();
  app.add_option("--payload", flags.payload,
                 "a known load at the tip, KG[,CX,CY,CZ] (kg; its centre in the tip frame, m): the model carries it, "
                 "so gravity, dynamics and the contact estimate account for it; a payload_t on PREFIX PAYLOAD "
                 "(chasles payload) replaces it at run time");
  app.add_option("--armature", flags.armature,
                 "each joint's reflected rotor inertia, A1,A2,... one per joint (kg·m², kg for a prismatic joint): "
                 "replaces the URDF's (Drake's drake:rotor_inertia × drake:gear_ratio²; 0 where it gives none)");
  app.add_option("--acceleration-limit", flags.acceleration_limit,
                 "joint acceleration limits, rad/s²: one number or one per joint (default: the URDF velocity limit / "
                 "0.4 s; the Panda's own: 15,7.5,10,12.5,15,20,20)");
  app.add_option("--jerk-limit", flags.jerk_limit,
                 "joint jerk limits, rad/s³: one number or one per joint (default: the acceleration limit / 0.02 s; "
                 "the Panda's own: 7500,3750,5000,6250,7500,10000,10000)");
  app.add_option("--position-margin", flags.limits.position_margin,
                 "how far inside the URDF position limits every reference keeps, rad")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--velocity-tolerance", flags.limits.velocity_tolerance,
                 "a measured joint velocity over its limit by more than this fraction stops the arm (REFLEX)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--stream-timeout-ms", flags.stream_timeout_ms,
                 "a stream of setpoints or jog commands silent this long is over: the arm decelerates to rest")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--pose-time-constant-ms", flags.pose_time_constant_ms,
                 "a Cartesian stream (tip_setpoint_t) closes the gap to its pose in about this time")
      ->check(CLI::Range(1.0, 10000.0))
      ->capture_default_str();
  app.add_option("--jog-slow-condition", flags.jog.slow_condition,
                 "a twist jog heading toward a singularity slows from this condition number of J_b")
      ->check(CLI::Range(1.0, 1e12))
      ->capture_default_str();
  app.add_option("--jog-stop-condition", flags.jog.stop_condition,
                 "...and stops before this one (above --jog-slow-condition)")
      ->check(CLI::Range(1.0, 1e12))
      ->capture_default_str();
  app.add_option("--retract-mm", flags.retract_mm, "how far the retract reflex backs off, mm")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--collision", flags.collision,
                 "keep the arm clear of itself and the scene with its URDF's collision geometry: auto (if it "
                 "loads, else say why and run without), on (it must), off")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  app.add_option("--scene", flags.scene,
                 "the scene kept clear of from the start: obstacles, safety planes and workspace boxes "
                 "(docs/scene.md); a scene_t on <prefix>SCENE replaces it")
      ->check(CLI::ExistingFile);
  app.add_option("--srdf", flags.srdf, "SRDF whose <disable_collisions> pairs are not checked")->check(CLI::ExistingFile);
  app.add_option("--package-dir", flags.package_dirs,
                 "where package://NAME/... meshes are looked for, as DIR/NAME/... (repeatable; then "
                 "$ROS_PACKAGE_PATH's folders)");
  app.add_option("--self-stop-mm", flags.self_stop_mm, "the least distance between two parts of the arm, mm")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--self-influence-mm", flags.self_influence_mm,
                 "two parts of the arm closer than this slow their approach, mm")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--clearance-margin-mm", flags.clearance_margin_mm,
                 "the reference stops this much short of each stop distance, the room the arm lags it by, mm")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--clearance-time-constant-ms", flags.clearance_time_constant_ms,
                 "a pair closes at most at its room to the stop distance over this time, ms")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--clearance-deceleration", flags.clearance_deceleration,
                 "a closing pair is stopped within this deceleration, m/s^2")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--locate", flags.locate,
                 "find where on the arm a contact is, from the external torque and the collision geometry, on a "
                 "thread of its own; published as contact_estimate_t on <prefix>CONTACT: on (with the geometry) or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--locate-hz", flags.locate_hz, "at most this many searches a second (each takes milliseconds)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--locate-floor", flags.locate_floor,
                 "search only while |tau_ext| is at least this, N*m (the observer's noise on a real arm lies under it)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--repulsion", flags.repulsion,
                 "under free drive and impedance, the force pushing a pair apart at its stop distance, N")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--realtime", options.realtime,
               "SCHED_FIFO, mlockall, --cpu and --cpu-wake-latency-us for the loop (warns if refused)");
  app.add_option("--priority", options.priority, "SCHED_FIFO priority with --realtime")
      ->check(CLI::Range(1, 99))
      ->capture_default_str();
  app.add_option("--cpu", options.cpu, "pin the loop to this CPU with --realtime (default: the last one; -1: none)")
      ->check(CLI::Range(-1, 1023));
  app.add_option("--cpu-wake-latency-us", options.cpu_wake_latency_us,
                 "with --realtime, hold /dev/cpu_dma_latency at this many us while the loop runs, so that idle "
                 "cores do not halt deeply and the tick after a wait does not start cold (0: idle cores poll; "
                 "-1: ask nothing)")
      ->check(CLI::Range(-1, 1'000'000))
      ->capture_default_str();
  app.add_option("--tick", options.tick,
                 "what starts a tick: 'state', as each state arrives, with the clock as the watchdog "
                 "(default); 'clock', every period, with the latest state (for a plant that does not "
                 "stream, such as chasles_plant --lockstep)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, chasles::controller::TickSource>{{"state", chasles::controller::TickSource::kState},
                                                                 {"clock", chasles::controller::TickSource::kClock}}));
  app.add_option("--receive", options.direct_receive,
                 "who reads states and targets off the wire: 'direct', the loop on its own multicast socket "
                 "(default), or 'lcm', LCM's receive thread, which hands each message over through a pipe")
      ->transform(CLI::CheckedTransformer(std::map<std::string, bool>{{"direct", true}, {"lcm", false}}));
  app.add_option("--channel-prefix", options.channel_prefix, "prefix of the LCM channels (default CHASLES_)");
  app.add_option("--protocol", options.protocol,
                 "the arm driver's messages (docs/protocols.md): 'chasles' (robot_state_t / joint_torque_command_t on "
                 "PREFIX STATE / COMMAND, default), 'drake-iiwa' (lcmt_iiwa_status / lcmt_iiwa_command on IIWA_STATUS / "
                 "IIWA_COMMAND) or 'drake-panda' (lcmt_panda_status / lcmt_panda_command on PANDA_STATUS / "
                 "PANDA_COMMAND); every other channel stays chasles's")
      ->transform(CLI::CheckedTransformer(std::map<std::string, chasles::controller::Protocol>{
          {"chasles", chasles::controller::Protocol::kChasles},
          {"drake-iiwa", chasles::controller::Protocol::kDrakeIiwa},
          {"drake-panda", chasles::controller::Protocol::kDrakePanda}}));
  app.add_option("--status-channel", options.status_channel, "the arm's status channel (default: the protocol's)");
  app.add_option("--command-channel", options.command_channel, "the arm's command channel (default: the protocol's)");
  app.add_option("--torque-semantics", options.torque_semantics,
                 "'full': the command carries the whole joint torque (chasles's plant; the default for chasles); "
                 "'overlay': the torque less g(q) of the bare arm, for a driver that adds its own gravity "
                 "compensation (the default for Drake's iiwa and Panda drivers)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, chasles::controller::TorqueSemantics>{
          {"full", chasles::controller::TorqueSemantics::kFull},
          {"overlay", chasles::controller::TorqueSemantics::kOverlay}}));
  app.add_flag("--simulator", options.simulator,
               "The plant is a simulator that may pause (Drake's, paced by Python on a busy host): keep the "
               "plant's time, its states' utime, for the motion, the observer and the stale rule, so that a "
               "pause is waited for rather than a FAULT; --stale-ms is then how long a silent simulator is "
               "waited for (default 1000). Never for a real arm, whose time does not stop");
  app.add_flag("!--no-semantics-check", flags.semantics_check,
               "Do not FAULT when the arm applies the torque commanded +- g(q) over a quarter second of states (a driver's "
               "gravity compensation added to a whole torque, or missing from an overlay); for a driver whose "
               "reported torque is not the torque it applies");
  app.add_option("--iiwa-positions", options.iiwa_positions,
                 "drake-iiwa: what a torque command carries in joint_position: 'none' (num_joints 0: Drake's "
                 "torque-only mode, drake-iiwa-driver --torque_only; default) or 'measured' (the measured position "
                 "of the status answered: drake-iiwa-driver's default torque mode, overlaying KUKA's joint "
                 "impedance)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, chasles::controller::IiwaPositions>{
          {"none", chasles::controller::IiwaPositions::kNone},
          {"measured", chasles::controller::IiwaPositions::kMeasured}}));
  app.add_option("--lcm-url", options.lcm_url, "LCM URL (default: LCM's, or $LCM_DEFAULT_URL)");
  app.add_option("--seconds", options.seconds, "stop after this long (default: run until SIGINT/SIGTERM)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--summary", flags.summary, "on exit, write the run's figures here as JSON");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    return fail(e.what(), 2);
  }

  try {
    if (!flags.config.empty()) apply_config(flags.config, flags, app);
    chasles::UrdfOptions urdf;
    urdf.tip_link = flags.tip;
    // The daemon is given the model as loaded and the payload apart, so that a payload_t received
    // at run time replaces the payload rather than adds to it.
    const chasles::RobotModel loaded = chasles::load_urdf_file(flags.robot, urdf);
    const chasles::RobotModel model =
        flags.armature.empty()
            ? loaded
            : chasles::with_armature(loaded, chasles::parse_armature(flags.armature, loaded.dof(), "--armature"));
    if (!flags.payload.empty()) options.payload = chasles::parse_payload(flags.payload, "--payload");
    const chasles::RobotModel carried = options.payload ? chasles::with_payload(model, *options.payload) : model;
    for (const std::string& warning : model.warnings()) {
      std::fprintf(stderr, "chasles_controller: warning: %s: %s\n", flags.robot.c_str(),
                   chasles::one_line(warning).c_str());
    }
    // The computed-torque law needs no M⁻¹, but the arm it drives does: a model whose M is singular
    // cannot describe a real arm's motion, and every model-based estimate built on it would be wrong.
    if (const std::string defect = chasles::mass_matrix_defect(carried); !defect.empty()) {
      throw chasles::ModelError(flags.robot + ": cannot control this chain: " + defect);
    }
    const int n = model.dof();
    for (const chasles::Joint& joint : model.joints()) {
      // Said once at start, where whoever runs the arm reads it: nothing but the arm's own
      // driver bounds this joint's torque (or, without a velocity limit, its planned speed).
      if (std::isinf(joint.limits.effort) || std::isinf(joint.limits.velocity)) {
        std::fprintf(stderr, "chasles_controller: warning: joint '%s' has no %s limit in the URDF (absent or 0)\n",
                     joint.name.c_str(),
                     std::isinf(joint.limits.effort) && std::isinf(joint.limits.velocity) ? "effort or velocity"
                     : std::isinf(joint.limits.effort)                                     ? "effort"
                                                                                            : "velocity");
      }
    }
    options.control = chasles::controller::Config::critically_damped(n, flags.omega);
    if (!flags.kp.empty()) options.control.kp = gains(flags.kp, n, "--kp");
    if (!flags.kd.empty()) options.control.kd = gains(flags.kd, n, "--kd");
    if (flags.friction_from_urdf) {
      const chasles::JointFriction friction = chasles::joint_friction_from_urdf_file(flags.robot, model);
      options.control.damping = friction.viscous;
      options.control.coulomb = friction.coulomb;
      std::fprintf(stderr, "chasles_controller: joint friction from %s: damping %s N·m·s/rad, Coulomb %s N·m\n",
                   flags.robot.c_str(), number_text(friction.viscous).c_str(), number_text(friction.coulomb).c_str());
    }
    if (!flags.damping.empty()) options.control.damping = gains(flags.damping, n, "--damping");
    if (!flags.coulomb.empty()) options.control.coulomb = gains(flags.coulomb, n, "--coulomb");
    const double status_period = chasles::controller::nominal_status_period(options.protocol);
    options.control.period = flags.rate > 0.0 ? 1.0 / flags.rate : status_period > 0.0 ? status_period : 1e-3;
    options.control.stale_ns = flags.stale_ms > 0.0  ? static_cast<int64_t>(flags.stale_ms * 1e6)
                               : options.simulator ? kSimulatorStaleNs
                                                   : chasles::controller::default_stale_ns(options.control.period);
    options.control.torque_ramp = flags.torque_ramp_ms * 1e-3;
    options.control.contact = flags.contact;
    options.control.contact.retract_distance = flags.retract_mm * 1e-3;
    options.control.limits = flags.limits;
    options.control.stream_timeout = flags.stream_timeout_ms * 1e-3;
    options.control.jog = flags.jog;
    options.control.check_torque_semantics = flags.semantics_check;
    options.control.jog.pose_time_constant = flags.pose_time_constant_ms * 1e-3;
    if (!flags.acceleration_limit.empty()) {
      options.control.limits.acceleration = gains(flags.acceleration_limit, n, "--acceleration-limit");
    }
    if (!flags.jerk_limit.empty()) options.control.limits.jerk = gains(flags.jerk_limit, n, "--jerk-limit");
    for (const std::string& text : flags.link_policies) {
      chasles::controller::LinkPolicy policy;
      std::string why;
      if (!chasles::controller::parse_link_policy(text, policy, why)) throw chasles::ArgumentError("--link-policy " + why);
      options.control.contact.links.push_back(policy);
    }
    if (!flags.observer_gain.empty()) options.control.contact.observer_gain = gains(flags.observer_gain, n, "--observer-gain");
    if (!flags.contact_torque.empty()) {
      options.control.contact.contact_torque = gains(flags.contact_torque, n, "--contact-torque", true);
    }
    if (!flags.collision_torque.empty()) {
      options.control.contact.collision_torque = gains(flags.collision_torque, n, "--collision-torque", true);
    }

    options.control.clearance.reference_margin = flags.clearance_margin_mm * 1e-3;
    options.control.clearance.time_constant = flags.clearance_time_constant_ms * 1e-3;
    options.control.clearance.deceleration = flags.clearance_deceleration;
    options.control.clearance.repulsion = flags.repulsion;
    load_clearance(model, flags, options);
    options.locate.enabled = flags.locate == "on";
    options.locate.rate_hz = flags.locate_hz;
    options.locate.floor = flags.locate_floor;

    // CPU 0 usually takes most interrupts and housekeeping; the last CPU is the conventional one
    // to set aside. Users with an isolated core (isolcpus) name it.
    if (options.realtime && app.count("--cpu") == 0) options.cpu = static_cast<int>(std::thread::hardware_concurrency()) - 1;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    chasles::controller::Daemon daemon(model, options);
    const chasles::controller::Channels channels = chasles::controller::channels_of(options);
    std::fprintf(stderr, "chasles_controller: %s, %d joints, %g Hz on %s -> %s (%s)%s\n", model.name().c_str(), n,
                 1.0 / options.control.period, channels.state.c_str(), channels.command.c_str(),
                 chasles::controller::to_string(options.protocol),
                 options.simulator ? "; a simulator: its time, waited for while it pauses" : "");
    const Summary summary = daemon.run(g_stop);
    std::fprintf(stderr,
                 "chasles_controller: %lld ticks at %.1f Hz, %lld overruns, jitter p99 %.0f us, compute p99 %.0f us, "
                 "latency p99 %.0f us, %lld faults\n",
                 static_cast<long long>(summary.ticks), summary.rate_hz, static_cast<long long>(summary.overruns),
                 summary.jitter_us.p99, summary.compute_us.p99, summary.latency_us.p99,
                 static_cast<long long>(summary.faults));
    if (!flags.summary.empty()) write_summary(flags.summary, summary);
  } catch (const chasles::TipNotChosenError& e) {
    return fail(std::string(e.what()) + " with --tip", 1);
  } catch (const chasles::Error& e) {
    return fail(e.what(), 1);
  } catch (const std::bad_alloc&) {
    return fail("out of memory", 1);
  } catch (const std::system_error& e) {
    return fail(e.what(), 1);
  } catch (const std::exception& e) {
    return fail(std::string("internal error: ") + e.what(), 1);
  }
  return 0;
}
