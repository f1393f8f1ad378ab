// chasles target: sends one arm_target_t to the controller on <prefix>TARGET, or one
// joint_trajectory_t on <prefix>TRAJECTORY. It refuses what is obviously wrong before anything is
// sent (a joint vector of the wrong size or outside the URDF's limits, a non-finite number, a
// quaternion that is not of unit norm, a duration that is not positive, waypoint times that do not
// increase); whether the motion fits the arm's limits is the controller's decision.
#include <unistd.h>

#include <charconv>
#include <chasles/arm_target_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <cmath>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>

#include "controller/transport/realtime/clock.hpp"
#include "core/lie/so3.hpp"
#include "command.hpp"

namespace chasles::cli {
namespace {

struct TargetOptions {
  enum class Mode { Hold, Joint, Pose, Trajectory } mode = Mode::Hold;  ///< which of the four was given
  bool hold = false;
  std::string joint, pose, duration, trajectory;
  ModelOptions model;
  WireOptions wire;
};

// Shortest round-trip form, so a value just past a limit does not print equal to it.
std::string text(double x) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), x);
  return std::string(buffer, result.ptr);
}

double parse_duration(const std::string& value) {
  size_t used = 0;
  double seconds = 0.0;
  try {
    seconds = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || value.find_first_not_of(" \t", used) != std::string::npos) {
    throw InputError("--duration: '" + value + "' is not a number");
  }
  if (!std::isfinite(seconds) || seconds <= 0.0) {
    throw InputError("--duration: " + value + " s; the time to reach the goal must be positive and finite");
  }
  return seconds;
}

// Each joint within [lower, upper]. Continuous joints turn without end (their ±π limits only
// describe one turn), so any finite goal is accepted for them.
void check_limits(const RobotModel& model, const Eigen::VectorXd& q) {
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    if (joint.type == JointType::Continuous) continue;
    if (q[i] < joint.limits.lower || q[i] > joint.limits.upper) {
      throw InputError("--joint: joint " + joint.name + " = " + text(q[i]) + " is outside its limits [" +
                       text(joint.limits.lower) + ", " + text(joint.limits.upper) + "] (entry " + std::to_string(i) +
                       ")");
    }
  }
}

// With a model, a tip position beyond any the chain can reach is refused: the distance from the
// first joint's origin is at most the sum of the fixed offsets along the chain plus the travel of
// its prismatic joints.
void check_reach(const RobotModel& model, const Vector3d& p_tip) {
  double reach = model.T_last_tip().translation().norm();
  for (int i = 0; i < model.dof(); ++i) {
    const Joint& joint = model.joint(i);
    if (i > 0) reach += joint.T_parent_joint.translation().norm();
    if (joint.type == JointType::Prismatic)
      reach += std::max(std::abs(joint.limits.lower), std::abs(joint.limits.upper));
  }
  const double distance = (p_tip - model.home_body(0).translation()).norm();
  if (distance > reach * (1.0 + 1e-9) + 1e-12) {
    throw InputError("--pose: the tip position is " + text(distance) + " m from the origin of joint " +
                     model.joint(0).name + ", beyond the arm's reach of " + text(reach) + " m");
  }
}

struct Pose {
  Vector3d p_sb;
  Eigen::Vector4d quaternion_wxyz;  ///< normalised
  double input_norm = 0.0;
};

Pose parse_pose(const std::string& value) {
  const Eigen::VectorXd numbers = parse_list(value, 7, "--pose");
  Pose pose;
  pose.p_sb = numbers.head<3>();
  pose.quaternion_wxyz = numbers.tail<4>();
  pose.input_norm = pose.quaternion_wxyz.norm();
  if (!(std::abs(pose.input_norm - 1.0) <= kQuaternionNormTolerance)) {
    throw InputError("--pose: the quaternion (w,x,y,z) = (" + text(numbers[3]) + ", " + text(numbers[4]) + ", " +
                     text(numbers[5]) + ", " + text(numbers[6]) + ") has norm " + text(pose.input_norm) +
                     "; give a unit quaternion (norms within " + text(kQuaternionNormTolerance) +
                     " of 1 are normalised)");
  }
  pose.quaternion_wxyz /= pose.input_norm;
  return pose;
}

// LCM explains a failure to start on stderr, over a dozen lines. While it starts, stderr goes to
// a temporary file; on failure the first line of what it said becomes part of the one-line error,
// otherwise anything it said is passed on.
class StderrCapture {
 public:
  StderrCapture() : file_(std::tmpfile()), saved_(file_ ? ::dup(STDERR_FILENO) : -1) {
    if (saved_ >= 0) {
      std::fflush(stderr);
      ::dup2(::fileno(file_), STDERR_FILENO);
    }
  }
  ~StderrCapture() { release(); }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

  /// Restores stderr and returns what was written to it meanwhile.
  std::string release() {
    if (saved_ < 0) return {};
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    saved_ = -1;
    std::string captured;
    std::rewind(file_);
    char buffer[512];
    size_t read = 0;
    while ((read = std::fread(buffer, 1, sizeof(buffer), file_)) > 0) captured.append(buffer, read);
    std::fclose(file_);
    return captured;
  }

 private:
  std::FILE* file_;
  int saved_;
};

std::string first_line(const std::string& text) {
  size_t start = text.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return {};
  return text.substr(start, text.find('\n', start) - start);
}

template <typename Message>
void send(const TargetOptions& options, const std::string& channel, const Message& target) {
  StderrCapture capture;
  lcm::LCM lcm(options.wire.lcm_url);
  const std::string said = capture.release();
  const std::string where = options.wire.lcm_url.empty() ? std::string() : " on " + options.wire.lcm_url;
  if (!lcm.good()) {
    const std::string reason = first_line(said);
    const bool multicast = options.wire.lcm_url.empty() || options.wire.lcm_url.rfind("udpm://", 0) == 0;
    throw InputError("cannot start LCM" + where + (reason.empty() ? "" : " (" + reason + ")") +
                     (multicast ? ": is there a multicast route? (inside tools/netns.sh use --lcm-url "
                                  "'udpm://239.255.76.67:7667?ttl=0')"
                                : ""));
  }
  std::fputs(said.c_str(), stderr);
  if (lcm.publish(channel, &target) != 0) throw InputError("cannot publish on " + channel + where);
}

// A number, or a list of `n` numbers, of `where`'s member `key` (absent: `fallback` for each).
std::vector<double> per_joint(const Json& where, const char* key, size_t n, double fallback, const std::string& file) {
  if (!where.contains(key)) return std::vector<double>(n, fallback);
  const Json& value = where[key];
  if (value.is_number()) return std::vector<double>(n, value.get<double>());
  if (!value.is_array() || value.size() != n) {
    throw InputError(file + ": \"" + key + "\" must be a number or a list of " + std::to_string(n) + " numbers");
  }
  std::vector<double> values;
  for (const Json& x : value) {
    if (!x.is_number()) throw InputError(file + ": \"" + key + "\" must hold numbers");
    values.push_back(x.get<double>());
  }
  return values;
}

// {"id", "joint_names" (default: the URDF's, root to tip), "points": [{"time_from_start",
// "positions", "velocities"?, "accelerations"?}], "path_tolerance"?, "goal_tolerance"? (a number
// or one per joint, 0: none), "goal_time_tolerance"?, "time_scaling"?} → joint_trajectory_t.
joint_trajectory_t read_trajectory(const std::string& path, const std::optional<RobotModel>& model) {
  const Json document = read_json_file(path, "trajectory file");
  if (!document.is_object() || !document.contains("points") || !document["points"].is_array()) {
    throw InputError(path + ": a trajectory is an object with a list \"points\"");
  }
  joint_trajectory_t t{};
  t.id = document.value("id", int64_t{0});
  if (document.contains("joint_names")) {
    for (const Json& name : document["joint_names"]) {
      if (!name.is_string()) throw InputError(path + ": \"joint_names\" must hold strings");
      t.joint_names.push_back(name.get<std::string>());
    }
  } else if (model) {
    for (const Joint& joint : model->joints()) t.joint_names.push_back(joint.name);
  } else {
    throw InputError(path + ": no \"joint_names\"; give them, or --robot for the URDF's");
  }
  const size_t n = t.joint_names.size();
  t.num_joints = static_cast<int32_t>(n);
  const Json& points = document["points"];
  t.num_points = static_cast<int32_t>(points.size());
  if (points.empty()) throw InputError(path + ": no waypoints");
  const bool velocities = points[0].contains("velocities"), accelerations = points[0].contains("accelerations");
  double before = 0.0;
  for (size_t k = 0; k < points.size(); ++k) {
    const Json& point = points[k];
    const std::string where = path + ": waypoint " + std::to_string(k);
    const auto row = [&](const char* key) {
      if (!point.contains(key)) throw InputError(where + " has no \"" + key + "\" (the first one has)");
      const std::vector<double> values = per_joint(point, key, n, 0.0, where);
      for (double x : values) {
        if (!std::isfinite(x)) throw InputError(where + ": \"" + key + "\" holds a number that is not finite");
      }
      return values;
    };
    const double time = point.value("time_from_start", std::nan(""));
    if (!std::isfinite(time) || !(time > before)) {
      throw InputError(where + ": time_from_start " + text(time) + " s is not after " + text(before) +
                       " s (times increase from > 0)");
    }
    before = time;
    t.time_from_start.push_back(time);
    t.positions.push_back(row("positions"));
    if (velocities) t.velocities.push_back(row("velocities"));
    if (accelerations) t.accelerations.push_back(row("accelerations"));
    if (model) {
      for (size_t c = 0; c < n; ++c) {
        const int i = model->joint_index(t.joint_names[c]);
        if (i < 0) throw InputError(path + ": joint '" + t.joint_names[c] + "' is not one of the arm's");
        const Joint& joint = model->joint(i);
        const double q = t.positions.back()[c];
        if (joint.type != JointType::Continuous && (q < joint.limits.lower || q > joint.limits.upper)) {
          throw InputError(where + ": joint " + joint.name + " = " + text(q) + " is outside its limits [" +
                           text(joint.limits.lower) + ", " + text(joint.limits.upper) + "]");
        }
      }
    }
  }
  if (model && n != size_t(model->dof())) {
    throw InputError(path + ": " + std::to_string(n) + " joints named; the arm has " + std::to_string(model->dof()));
  }
  t.num_velocities = velocities ? t.num_points : 0;
  t.num_accelerations = accelerations ? t.num_points : 0;
  t.path_tolerance = per_joint(document, "path_tolerance", n, 0.0, path);
  t.goal_tolerance = per_joint(document, "goal_tolerance", n, 0.0, path);
  t.goal_time_tolerance = document.value("goal_time_tolerance", 0.0);
  t.time_scaling = document.value("time_scaling", false);
  for (const auto* tolerance : {&t.path_tolerance, &t.goal_tolerance}) {
    for (double x : *tolerance) {
      if (!std::isfinite(x) || x < 0.0) throw InputError(path + ": tolerances must be finite and non-negative");
    }
  }
  if (!std::isfinite(t.goal_time_tolerance) || t.goal_time_tolerance < 0.0) {
    throw InputError(path + ": goal_time_tolerance must be finite and non-negative");
  }
  return t;
}

Json run_trajectory(const TargetOptions& options) {
  std::optional<RobotModel> model;
  if (!options.model.urdf.empty()) model.emplace(load_model(options.model));
  joint_trajectory_t trajectory = read_trajectory(options.trajectory, model);
  const std::string channel = options.wire.prefix + "TRAJECTORY";
  trajectory.utime = controller::realtime_us();
  send(options, channel, trajectory);
  Json out;
  out["channel"] = channel;
  out["utime"] = trajectory.utime;
  out["id"] = trajectory.id;
  out["joint_names"] = trajectory.joint_names;
  out["points"] = trajectory.num_points;
  out["duration"] = trajectory.time_from_start.back();
  out["velocities"] = trajectory.num_velocities > 0;
  out["accelerations"] = trajectory.num_accelerations > 0;
  out["time_scaling"] = trajectory.time_scaling;
  return out;
}

Json run_target(const TargetOptions& options) {
  if (options.mode == TargetOptions::Mode::Trajectory) return run_trajectory(options);
  const std::string channel = options.wire.prefix + "TARGET";
  arm_target_t target{};
  target.num_joints = 0;
  target.duration = 0.0;
  Json out;
  out["channel"] = channel;
  out["utime"] = 0;  // set when it is sent; keys keep their insertion order

  // Everything is checked before LCM starts: a refused target is never sent.
  std::optional<RobotModel> model;
  if (!options.model.urdf.empty()) model.emplace(load_model(options.model));
  if (options.mode == TargetOptions::Mode::Hold) {
    target.mode = arm_target_t::HOLD;
    out["mode"] = "HOLD";
  } else if (options.mode == TargetOptions::Mode::Joint) {
    const Eigen::VectorXd q = parse_list(options.joint, model->dof(), "--joint");
    check_limits(*model, q);
    target.mode = arm_target_t::JOINT;
    target.num_joints = model->dof();
    target.joint_position.assign(q.data(), q.data() + q.size());
    target.duration = parse_duration(options.duration);
    Json names = Json::array();
    for (const Joint& joint : model->joints()) names.push_back(joint.name);
    out["mode"] = "JOINT";
    out["joint_names"] = std::move(names);
    out["joint_position"] = vector_json(q);
    out["duration"] = target.duration;
  } else {
    const Pose pose = parse_pose(options.pose);
    if (model) check_reach(*model, pose.p_sb);
    target.mode = arm_target_t::CARTESIAN;
    for (int i = 0; i < 3; ++i) target.tip_position[i] = pose.p_sb[i];
    for (int i = 0; i < 4; ++i) target.tip_quaternion[i] = pose.quaternion_wxyz[i];
    target.duration = parse_duration(options.duration);
    out["mode"] = "CARTESIAN";
    out["tip_position"] = vector_json(pose.p_sb);
    out["tip_quaternion"] = vector_json(pose.quaternion_wxyz);
    out["quaternion_input_norm"] = pose.input_norm;
    out["duration"] = target.duration;
  }

  target.utime = controller::realtime_us();
  send(options, channel, target);
  out["utime"] = target.utime;
  return out;
}

}  // namespace

Command register_target(CLI::App& app) {
  auto options = std::make_shared<TargetOptions>();
  CLI::App* command =
      app.add_subcommand("target", "Send the controller one goal (arm_target_t): hold, a joint position or a tip pose");
  CLI::Option* hold = command->add_flag("--hold", options->hold, "Hold the position the arm is at");
  CLI::Option* joint =
      command->add_option("--joint", options->joint, "Goal joint positions, rad or m, comma-separated, root to tip")
          ->type_name("Q,Q,...");
  CLI::Option* pose = command
                          ->add_option("--pose", options->pose,
                                       "Goal tip pose in the base frame: position x,y,z (m) and unit "
                                       "quaternion qw,qx,qy,qz")
                          ->type_name("X,Y,Z,QW,QX,QY,QZ");
  CLI::Option* trajectory =
      command
          ->add_option("--trajectory", options->trajectory,
                       "A waypoint trajectory (JSON, '-' for standard input), sent as joint_trajectory_t on PREFIX "
                       "TRAJECTORY")
          ->type_name("FILE.json");
  CLI::Option* duration =
      command->add_option("--duration", options->duration, "Time to reach the goal, s (with --joint or --pose)")
          ->type_name("T");
  CLI::Option* urdf = command
                          ->add_option("--robot,--urdf", options->model.urdf,
                                       "Robot description (URDF file): needed for --joint, whose size and "
                                       "limits it checks; with --pose it checks the reach")
                          ->type_name("FILE");
  command
      ->add_option("--tip", options->model.tip,
                   "Link that ends the chain; needed when the URDF tree has several leaves")
      ->type_name("LINK");
  add_wire_options(*command, options->wire, "target", "TARGET");

  // The combinations are usage errors (exit 2); the values are checked when the command runs (exit 1).
  command->parse_complete_callback([=] {
    const int modes = static_cast<int>(hold->count() > 0) + static_cast<int>(joint->count() > 0) +
                      static_cast<int>(pose->count() > 0) + static_cast<int>(trajectory->count() > 0);
    if (modes != 1) throw CLI::ValidationError("give exactly one of --hold, --joint, --pose and --trajectory");
    options->mode = hold->count() > 0       ? TargetOptions::Mode::Hold
                    : joint->count() > 0    ? TargetOptions::Mode::Joint
                    : trajectory->count() > 0 ? TargetOptions::Mode::Trajectory
                                            : TargetOptions::Mode::Pose;
    if (hold->count() > 0 && duration->count() > 0) throw CLI::ValidationError("--hold takes no --duration");
    if (trajectory->count() > 0 && duration->count() > 0) {
      throw CLI::ValidationError("--trajectory takes no --duration (its waypoints carry their times)");
    }
    if (hold->count() == 0 && trajectory->count() == 0 && duration->count() == 0) {
      throw CLI::ValidationError(std::string(joint->count() > 0 ? "--joint" : "--pose") + " needs --duration");
    }
    if (joint->count() > 0 && urdf->count() == 0) {
      throw CLI::ValidationError("--joint needs --robot (the URDF, to check the joint count and limits)");
    }
  });
  command->footer(
      "Sends one chasles.arm_target_t on PREFIX TARGET and prints what was sent:\n"
      "  {\"channel\", \"utime\", \"mode\": \"HOLD\" | \"JOINT\" | \"CARTESIAN\",\n"
      "   JOINT: \"joint_names\", \"joint_position\", \"duration\";\n"
      "   CARTESIAN: \"tip_position\", \"tip_quaternion\" (normalised), \"quaternion_input_norm\", \"duration\"}\n"
      "Refused, with nothing sent: a wrong number of joints, a non-finite number, a joint outside its URDF\n"
      "limits (continuous joints excepted), a quaternion whose norm is more than 1e-3 from 1, a tip position\n"
      "beyond the arm's reach (with --robot), a duration that is not positive and finite.\n"
      "--trajectory FILE.json sends one chasles.joint_trajectory_t on PREFIX TRAJECTORY instead:\n"
      "  {\"id\": 7, \"joint_names\": [..] (default with --robot: the URDF's, root to tip),\n"
      "   \"points\": [{\"time_from_start\": 1.0, \"positions\": [..], \"velocities\": [..]?, \"accelerations\": [..]?}, ..],\n"
      "   \"path_tolerance\": 0.05, \"goal_tolerance\": [..], \"goal_time_tolerance\": 0.5, \"time_scaling\": true}\n"
      "  and prints {\"channel\", \"utime\", \"id\", \"joint_names\", \"points\", \"duration\", \"velocities\",\n"
      "  \"accelerations\", \"time_scaling\"}. Refused before sending: times that do not increase from > 0, a\n"
      "  row of the wrong size, a non-finite number, a waypoint outside the URDF's limits (with --robot).\n"
      "Examples:\n"
      "  chasles target --hold\n"
      "  chasles target --robot panda.urdf --tip panda_hand --joint 0,-0.3,0,-2,0,1.7,0.8 --duration 2\n"
      "  chasles target --pose 0.4,0,0.5,0,1,0,0 --duration 3 --lcm-url 'udpm://239.255.76.67:7667?ttl=0'\n"
      "  chasles target --robot panda.urdf --tip panda_hand --trajectory pick.json");
  return {command, [options] { return run_target(*options); }};
}

}  // namespace chasles::cli
