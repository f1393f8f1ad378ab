// chasles target: sends one arm_target_t to the controller on <prefix>TARGET. It refuses what is
// obviously wrong before anything is sent (a joint vector of the wrong size or outside the URDF's
// limits, a non-finite number, a quaternion that is not of unit norm, a duration that is not
// positive); whether the goal is reachable in time is the controller's decision.
#include <unistd.h>

#include <charconv>
#include <chasles/arm_target_t.hpp>
#include <cmath>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>

#include "chasles/controller/realtime/clock.hpp"
#include "command.hpp"

namespace chasles::cli {
namespace {

// A quaternion typed by hand ("0.7071,0,0.7071,0") is off unit norm by ~1e-5; one with a norm
// further than this from 1 is a mistake (a missing component, Euler angles, (x,y,z,w) order with
// a typo), not rounding, and is refused rather than guessed at.
constexpr double kQuaternionNormTolerance = 1e-3;

struct TargetOptions {
  enum class Mode { Hold, Joint, Pose } mode = Mode::Hold;  ///< which of the three was given
  bool hold = false;
  std::string joint, pose, duration;
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

void send(const TargetOptions& options, const std::string& channel, const arm_target_t& target) {
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

Json run_target(const TargetOptions& options) {
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
                      static_cast<int>(pose->count() > 0);
    if (modes != 1) throw CLI::ValidationError("give exactly one of --hold, --joint and --pose");
    options->mode = hold->count() > 0    ? TargetOptions::Mode::Hold
                    : joint->count() > 0 ? TargetOptions::Mode::Joint
                                         : TargetOptions::Mode::Pose;
    if (hold->count() > 0 && duration->count() > 0) throw CLI::ValidationError("--hold takes no --duration");
    if (hold->count() == 0 && duration->count() == 0) {
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
      "Examples:\n"
      "  chasles target --hold\n"
      "  chasles target --robot panda.urdf --tip panda_hand --joint 0,-0.3,0,-2,0,1.7,0.8 --duration 2\n"
      "  chasles target --pose 0.4,0,0.5,0,1,0,0 --duration 3 --lcm-url 'udpm://239.255.76.67:7667?ttl=0'");
  return {command, [options] { return run_target(*options); }};
}

}  // namespace chasles::cli
