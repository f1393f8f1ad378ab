// chasles jog: jogs the arm from a terminal or a script — joint velocities or a tip twist sent as
// jog_command_t on <prefix>JOG at a steady rate for a given time, then one zero command so the
// arm stops at once rather than at the controller's stream timeout. What the controller made of
// it (slowed, halted at a limit or before a singularity) is in its status (chasles monitor).
#include <chasles/jog_command_t.hpp>
#include <cmath>
#include <ctime>
#include <memory>
#include <vector>

#include "controller/transport/realtime/clock.hpp"
#include "command.hpp"
#include "lcm_start.hpp"

namespace chasles::cli {
namespace {

struct JogOptions {
  std::string joint_velocity, twist, frame = "base";
  double seconds = 1.0;
  double rate = 50.0;
  WireOptions wire;
};

// Comma-separated finite numbers, as many as written; `option` names them in errors.
std::vector<double> parse_numbers(const std::string& text, const std::string& option) {
  std::vector<double> values;
  size_t at = 0;
  while (at <= text.size()) {
    const size_t comma = std::min(text.find(',', at), text.size());
    const Eigen::VectorXd one = parse_list(text.substr(at, comma - at), 1, option);
    values.push_back(one(0));
    at = comma + 1;
  }
  return values;
}

Json run_jog(const JogOptions& options) {
  const std::string channel = options.wire.prefix + "JOG";
  jog_command_t jog{};
  Json out;
  out["channel"] = channel;
  if (!options.joint_velocity.empty()) {
    jog.kind = jog_command_t::JOINT_VELOCITY;
    jog.joint_velocity = parse_numbers(options.joint_velocity, "--joint-velocity");
    jog.num_joints = static_cast<int32_t>(jog.joint_velocity.size());
    out["kind"] = "JOINT_VELOCITY";
    out["joint_velocity"] = jog.joint_velocity;
  } else {
    const Eigen::VectorXd twist = parse_list(options.twist, 6, "--twist");
    jog.kind = jog_command_t::TWIST;
    jog.frame = options.frame == "tool" ? jog_command_t::TOOL : jog_command_t::BASE;
    jog.num_joints = 0;
    for (int k = 0; k < 6; ++k) jog.twist[k] = twist(k);
    out["kind"] = "TWIST";
    out["frame"] = options.frame;
    out["twist"] = vector_json(twist);
  }
  out["rate"] = options.rate;
  out["seconds"] = options.seconds;

  lcm_t* lcm = start_lcm(options.wire.lcm_url);
  const std::unique_ptr<lcm_t, void (*)(lcm_t*)> owner(lcm, lcm_destroy);
  // Absolute deadlines on CLOCK_MONOTONIC: the rate holds however long a publish takes.
  const int64_t period_ns = static_cast<int64_t>(1e9 / options.rate);
  const int64_t start = controller::monotonic_ns();
  const int64_t end = start + static_cast<int64_t>(options.seconds * 1e9);
  int64_t sent = 0;
  for (int64_t next = start; next < end; next += period_ns) {
    const timespec wake{static_cast<time_t>(next / 1'000'000'000), static_cast<long>(next % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
    jog.utime = controller::realtime_us();
    publish_message(lcm, channel, jog);
    ++sent;
  }
  // The stop: the same command at zero speed, newer than the last.
  std::fill(jog.joint_velocity.begin(), jog.joint_velocity.end(), 0.0);
  std::fill(jog.twist, jog.twist + 6, 0.0);
  jog.utime = std::max(controller::realtime_us(), jog.utime + 1);
  publish_message(lcm, channel, jog);
  out["sent"] = sent + 1;
  return out;
}

}  // namespace

Command register_jog(CLI::App& app) {
  auto options = std::make_shared<JogOptions>();
  CLI::App* command = app.add_subcommand(
      "jog", "Jog the arm: joint velocities or a tip twist (jog_command_t) at a steady rate for a while, then a stop");
  CLI::Option* joint =
      command
          ->add_option("--joint-velocity", options->joint_velocity,
                       "Joint velocities, rad/s or m/s, comma-separated, root to tip (one per joint)")
          ->type_name("V,V,...");
  CLI::Option* twist = command
                           ->add_option("--twist", options->twist,
                                        "Tip twist: angular velocity wx,wy,wz (rad/s), then linear vx,vy,vz (m/s)")
                           ->type_name("WX,WY,WZ,VX,VY,VZ");
  command
      ->add_option("--frame", options->frame,
                   "The twist's frame: base (the tip's velocities in the base frame's axes) or tool (the body "
                   "twist, in the tip frame's axes)")
      ->check(CLI::IsMember({"base", "tool"}))
      ->capture_default_str();
  command->add_option("--seconds", options->seconds, "How long to jog, s")
      ->check(CLI::Range(1e-3, 3600.0))
      ->capture_default_str();
  command->add_option("--rate", options->rate, "Commands per second (the controller stops after 100 ms without)")
      ->check(CLI::Range(10.0, 1000.0))
      ->capture_default_str();
  add_wire_options(*command, options->wire, "jog", "JOG");
  command->parse_complete_callback([=] {
    if ((joint->count() > 0) == (twist->count() > 0)) {
      throw CLI::ValidationError("give exactly one of --joint-velocity and --twist");
    }
  });
  command->footer(
      "Sends chasles.jog_command_t on PREFIX JOG every 1/rate s for --seconds, then one zero command, and\n"
      "prints {\"channel\", \"kind\", \"joint_velocity\" | \"frame\", \"twist\", \"rate\", \"seconds\", \"sent\"}.\n"
      "The controller keeps every joint within its limits and a twist short of a singularity; its status\n"
      "says how (jogging, jog_scale, jog_limited_by, jog_condition): see chasles monitor.\n"
      "Examples:\n"
      "  chasles jog --joint-velocity 0.2,0,0,0,0,0,0 --seconds 2\n"
      "  chasles jog --twist 0,0,0,0,0,-0.05 --seconds 1.5            # the tip down at 5 cm/s\n"
      "  chasles jog --twist 0,0,0.3,0,0,0 --frame tool --rate 100    # turn about the tool's z");
  return {command, [options] { return run_jog(*options); }};
}

}  // namespace chasles::cli
