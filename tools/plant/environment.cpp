#include "environment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "chasles/core/lie/so3.hpp"
#include "chasles/tools/number_list.hpp"

namespace chasles::plant {
namespace {

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", x);
  return text;
}

[[noreturn]] void refuse(const std::string& what, const std::string& why) {
  throw std::invalid_argument(what + ": " + why);
}

bool finite(const Eigen::Ref<const Eigen::MatrixXd>& values) { return values.allFinite(); }

void check_push(const Push& push, const std::string& what) {
  if (!std::isfinite(push.start) || !std::isfinite(push.duration) || !std::isfinite(push.ramp) ||
      !finite(push.wrench)) {
    refuse(what, "a number is not finite");
  }
  if (push.start < 0.0) refuse(what, "START " + number(push.start) + " s is before the plant's first step (0)");
  if (!(push.duration > 0.0)) refuse(what, "DURATION " + number(push.duration) + " s is not positive");
  if (push.ramp < 0.0) refuse(what, "RAMP " + number(push.ramp) + " s is negative");
  if (push.ramp > 0.5 * push.duration) {
    refuse(what, "RAMP " + number(push.ramp) + " s is longer than half of DURATION " + number(push.duration) +
                     " s: the ramps in and out must both fit in the window (RAMP <= DURATION/2)");
  }
}

// Checks and normalises.
void check_wall(Wall& wall, const std::string& what) {
  if (!finite(wall.point) || !finite(wall.normal) || !std::isfinite(wall.stiffness) || !std::isfinite(wall.damping)) {
    refuse(what, "a number is not finite");
  }
  const double length = wall.normal.stableNorm();
  if (!(length > 0.0) || !std::isfinite(length)) {
    refuse(what, "the normal (" + number(wall.normal.x()) + ", " + number(wall.normal.y()) + ", " +
                     number(wall.normal.z()) + ") has no direction; give one pointing to the free side");
  }
  wall.normal /= length;
  if (!(wall.stiffness > 0.0)) refuse(what, "stiffness K " + number(wall.stiffness) + " N/m is not positive");
  if (wall.damping < 0.0) refuse(what, "damping D " + number(wall.damping) + " N*s/m is negative");
}

void check_payload(const Payload& payload, const std::string& what) {
  if (const std::string problem = payload_problem(payload); !problem.empty()) refuse(what, problem);
}

void check_friction(const Friction& friction, const RobotModel& model, const std::string& what) {
  const int n = model.dof();
  if (friction.viscous.size() != n || friction.coulomb.size() != n) {
    refuse(what, "has " + std::to_string(friction.viscous.size()) + " viscous and " +
                     std::to_string(friction.coulomb.size()) + " Coulomb coefficients; the arm has " +
                     std::to_string(n) + " joints");
  }
  for (int i = 0; i < n; ++i) {
    const std::string joint = "joint " + model.joint(i).name;
    if (!std::isfinite(friction.viscous[i]) || !std::isfinite(friction.coulomb[i])) {
      refuse(what, joint + ": a coefficient is not finite");
    }
    const bool prismatic = model.joint(i).type == JointType::Prismatic;
    if (friction.viscous[i] < 0.0) {
      refuse(what, joint + ": viscous friction " + number(friction.viscous[i]) + (prismatic ? " N*s/m" : " N*m*s/rad") +
                       " is negative");
    }
    if (friction.coulomb[i] < 0.0) {
      refuse(what, joint + ": Coulomb friction " + number(friction.coulomb[i]) + (prismatic ? " N" : " N*m") +
                       " is negative");
    }
  }
}

std::vector<double> numbers(const std::string& text, const std::string& option) {
  return tools::parse_number_list(text, option);  // names the entry that is not a finite number
}

std::string count_error(const std::string& form, const std::string& counts, size_t got) {
  return form + " (" + counts + "); got " + std::to_string(got);
}

}  // namespace

double Push::profile(double t) const {
  const double end = start + duration;
  if (t < start || t > end) return 0.0;
  if (ramp <= 0.0) return 1.0;
  return std::min({1.0, (t - start) / ramp, (end - t) / ramp});
}

EnvironmentOptions checked_environment(const EnvironmentOptions& options, const RobotModel& model) {
  EnvironmentOptions out = options;
  for (size_t i = 0; i < out.pushes.size(); ++i) check_push(out.pushes[i], "push " + std::to_string(i + 1));
  for (size_t i = 0; i < out.walls.size(); ++i) check_wall(out.walls[i], "wall " + std::to_string(i + 1));
  if (out.payload) check_payload(*out.payload, "payload");
  if (!out.friction.empty()) check_friction(out.friction, model, "friction");
  return out;
}

Push parse_push(const std::string& text) {
  const std::vector<double> v = numbers(text, "--push");
  if (v.size() != 9) {
    throw std::invalid_argument(
        count_error("--push takes START,DURATION,RAMP,mx,my,mz,fx,fy,fz", "9 numbers: s, s, s, N*m, N", v.size()));
  }
  Push push;
  push.start = v[0];
  push.duration = v[1];
  push.ramp = v[2];
  for (int i = 0; i < 6; ++i) push.wrench[i] = v[static_cast<size_t>(3 + i)];
  check_push(push, "--push");
  return push;
}

Wall parse_wall(const std::string& text) {
  const std::vector<double> v = numbers(text, "--wall");
  if (v.size() != 6 && v.size() != 8) {
    throw std::invalid_argument(
        count_error("--wall takes PX,PY,PZ,NX,NY,NZ[,K,D]", "6 or 8 numbers: m, unit normal, N/m, N*s/m", v.size()));
  }
  Wall wall;
  wall.point = Vector3d(v[0], v[1], v[2]);
  wall.normal = Vector3d(v[3], v[4], v[5]);
  if (v.size() == 8) {
    wall.stiffness = v[6];
    wall.damping = v[7];
  }
  check_wall(wall, "--wall");
  return wall;
}

Payload parse_payload(const std::string& text) { return tools::parse_payload(text, "--payload"); }

Friction parse_friction(const std::string& text, const RobotModel& model) {
  const std::vector<double> v = numbers(text, "--friction");
  const int n = model.dof();
  if (v.size() != 2 && v.size() != 2 * static_cast<size_t>(n)) {
    throw std::invalid_argument(count_error(
        "--friction takes VISCOUS,COULOMB for every joint or a pair per joint",
        "2 or " + std::to_string(2 * n) + " numbers for " + std::to_string(n) + " joints: N*m*s/rad, N*m", v.size()));
  }
  Friction friction;
  friction.viscous.resize(n);
  friction.coulomb.resize(n);
  for (int i = 0; i < n; ++i) {
    const size_t pair = v.size() == 2 ? 0 : 2 * static_cast<size_t>(i);
    friction.viscous[i] = v[pair];
    friction.coulomb[i] = v[pair + 1];
  }
  check_friction(friction, model, "--friction");
  return friction;
}

}  // namespace chasles::plant
