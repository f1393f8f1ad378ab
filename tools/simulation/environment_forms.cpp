#include "chasles/tools/simulation/environment_forms.hpp"

#include <vector>

#include "chasles/core/error.hpp"
#include "chasles/core/number_list.hpp"

namespace chasles::plant {
namespace {

std::string count_error(const std::string& form, const std::string& counts, size_t got) {
  return form + " (" + counts + "); got " + std::to_string(got);
}

}  // namespace

Push parse_push(const std::string& text) {
  const std::vector<double> v = parse_number_list(text, "--push");
  if (v.size() != 9) {
    throw ArgumentError(
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
  const std::vector<double> v = parse_number_list(text, "--wall");
  if (v.size() != 6 && v.size() != 8) {
    throw ArgumentError(
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

Payload parse_payload(const std::string& text) { return chasles::parse_payload(text, "--payload"); }

Friction parse_friction(const std::string& text, const RobotModel& model) {
  const std::vector<double> v = parse_number_list(text, "--friction");
  const int n = model.dof();
  if (v.size() != 2 && v.size() != 2 * static_cast<size_t>(n)) {
    throw ArgumentError(count_error(
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
