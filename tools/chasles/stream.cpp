// chasles stream: plays a stream of setpoints to the controller, each at its time — joint
// setpoints (joint_setpoint_t on <prefix>SETPOINT) or tip poses (tip_setpoint_t on
// <prefix>TIP_SETPOINT) — as a teleoperation device or a policy would send them: a recording
// replayed, or a path a script computed. Everything is read and checked before the first is sent.
#include <chasles/joint_setpoint_t.hpp>
#include <chasles/tip_setpoint_t.hpp>
#include <cmath>
#include <ctime>
#include <memory>
#include <vector>

#include "controller/transport/realtime/clock.hpp"
#include "core/lie/so3.hpp"
#include "command.hpp"
#include "lcm_start.hpp"

namespace chasles::cli {
namespace {

struct StreamOptions {
  std::string file;
  WireOptions wire;
};

// One setpoint of the file, with its time from the start, s.
struct Timed {
  double t = 0.0;
  joint_setpoint_t joint{};
  tip_setpoint_t tip{};
};

// {"kind": "joint", "points": [{"t", "position": [n], "velocity": [n]?}, ..]} or
// {"kind": "tip", "points": [{"t", "position": [3], "quaternion": [4] (w, x, y, z), "twist": [6]?}, ..]};
// times increasing from ≥ 0.
std::vector<Timed> read_stream(const std::string& path, bool& tip) {
  const Json document = read_json_file(path, "stream file");
  const std::string kind = member(document, "kind", path).is_string() ? document["kind"].get<std::string>() : "";
  if (kind != "joint" && kind != "tip") throw InputError(path + ": \"kind\" must be \"joint\" or \"tip\"");
  tip = kind == "tip";
  const Json& points = member(document, "points", path);
  if (!points.is_array() || points.empty()) throw InputError(path + ": \"points\" must be a non-empty list");
  std::vector<Timed> out;
  Eigen::Index n = -1;
  for (size_t k = 0; k < points.size(); ++k) {
    const std::string where = path + ": points[" + std::to_string(k) + "]";
    const Json& p = points[k];
    Timed timed;
    const Json& t = member(p, "t", where);
    if (!t.is_number() || !std::isfinite(t.get<double>()) || t.get<double>() < 0.0 ||
        (!out.empty() && !(t.get<double>() > out.back().t))) {
      throw InputError(where + ": \"t\" must be a finite number of seconds >= 0, after the point before");
    }
    timed.t = t.get<double>();
    if (tip) {
      const Eigen::VectorXd position = parse_vector(member(p, "position", where), 3, where + ".position", "x, y, z");
      const Eigen::VectorXd quaternion =
          parse_vector(member(p, "quaternion", where), 4, where + ".quaternion", "w, x, y, z");
      if (std::abs(quaternion.norm() - 1.0) > kQuaternionNormTolerance) {
        throw InputError(where + ": the quaternion is not of unit norm");
      }
      const Eigen::VectorXd twist = p.contains("twist") ? parse_vector(p["twist"], 6, where + ".twist", "wx..vz")
                                                        : Eigen::VectorXd::Zero(6);
      for (int i = 0; i < 3; ++i) timed.tip.position[i] = position(i);
      for (int i = 0; i < 4; ++i) timed.tip.quaternion[i] = quaternion(i);
      for (int i = 0; i < 6; ++i) timed.tip.twist[i] = twist(i);
    } else {
      const Json& position = member(p, "position", where);
      if (n < 0) n = position.is_array() ? static_cast<Eigen::Index>(position.size()) : 0;
      const Eigen::VectorXd q = parse_vector(position, n, where + ".position", "one per joint, as the first point");
      const Eigen::VectorXd qd = p.contains("velocity")
                                     ? parse_vector(p["velocity"], n, where + ".velocity", "one per joint")
                                     : Eigen::VectorXd::Zero(n);
      timed.joint.num_joints = static_cast<int32_t>(n);
      timed.joint.position.assign(q.data(), q.data() + n);
      timed.joint.velocity.assign(qd.data(), qd.data() + n);
    }
    out.push_back(std::move(timed));
  }
  return out;
}

Json run_stream(const StreamOptions& options) {
  bool tip = false;
  std::vector<Timed> points = read_stream(options.file, tip);
  const std::string channel = options.wire.prefix + (tip ? "TIP_SETPOINT" : "SETPOINT");
  lcm_t* lcm = start_lcm(options.wire.lcm_url);
  const std::unique_ptr<lcm_t, void (*)(lcm_t*)> owner(lcm, lcm_destroy);
  // Each at its time after the start, on CLOCK_MONOTONIC; stamped with the time it is sent.
  const int64_t start = controller::monotonic_ns();
  int64_t late_us = 0;
  for (Timed& p : points) {
    const int64_t at = start + static_cast<int64_t>(p.t * 1e9);
    const timespec wake{static_cast<time_t>(at / 1'000'000'000), static_cast<long>(at % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
    late_us = std::max(late_us, (controller::monotonic_ns() - at) / 1000);
    if (tip) {
      p.tip.utime = controller::realtime_us();
      publish_message(lcm, channel, p.tip);
    } else {
      p.joint.utime = controller::realtime_us();
      publish_message(lcm, channel, p.joint);
    }
  }
  Json out;
  out["channel"] = channel;
  out["kind"] = tip ? "tip" : "joint";
  out["sent"] = points.size();
  out["seconds"] = points.back().t;
  out["latest_us"] = late_us;
  return out;
}

}  // namespace

Command register_stream(CLI::App& app) {
  auto options = std::make_shared<StreamOptions>();
  CLI::App* command = app.add_subcommand(
      "stream", "Play a stream of joint setpoints or tip poses to the controller, each at its time");
  command->add_option("file", options->file, "The stream (JSON, '-' for standard input)")
      ->required()
      ->type_name("FILE.json");
  add_wire_options(*command, options->wire, "stream", "SETPOINT or TIP_SETPOINT");
  command->footer(
      "Sends each point at its time \"t\" (s after the start) and prints {\"channel\", \"kind\", \"sent\",\n"
      "\"seconds\", \"latest_us\" (the latest a point went out after its time)}. The file:\n"
      "  {\"kind\": \"joint\", \"points\": [{\"t\": 0.0, \"position\": [..], \"velocity\": [..]?}, ..]}\n"
      "    joint_setpoint_t on PREFIX SETPOINT: rad or m per joint, root to tip, and rad/s or m/s;\n"
      "  {\"kind\": \"tip\", \"points\": [{\"t\": 0.0, \"position\": [x, y, z], \"quaternion\": [w, x, y, z],\n"
      "    \"twist\": [wx, wy, wz, vx, vy, vz]?}, ..]}\n"
      "    tip_setpoint_t on PREFIX TIP_SETPOINT: the tip's pose in the base frame, m, and how it moves on\n"
      "    (rad/s, m/s, in the base frame's axes).\n"
      "Refused before anything is sent: times that do not increase from >= 0, a row of the wrong size, a\n"
      "non-finite number, a quaternion whose norm is more than 1e-3 from 1. The controller keeps the arm\n"
      "within its limits and stops it when the stream stops (see chasles monitor).\n"
      "Example:\n"
      "  chasles stream circle.json --lcm-url 'udpm://239.255.76.67:7667?ttl=0'");
  return {command, [options] { return run_stream(*options); }};
}

}  // namespace chasles::cli
