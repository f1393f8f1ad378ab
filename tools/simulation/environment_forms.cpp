#include "tools/simulation/environment_forms.hpp"

#include <charconv>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "core/number_list.hpp"

namespace chasles::plant {
namespace {

std::string count_error(const std::string& form, const std::string& counts, size_t got) {
  return form + " (" + counts + "); got " + std::to_string(got);
}

// "NUMBER[,SEED]": the number as every list entry is read, the seed a whole number that fits the
// generator's 64 bits (a double would round seeds beyond 2^53).
std::pair<double, uint64_t> number_and_seed(const std::string& text, const std::string& option,
                                            const std::string& form) {
  const size_t comma = text.find(',');
  const std::string seed_text = comma == std::string::npos ? std::string() : text.substr(comma + 1);
  if (seed_text.find(',') != std::string::npos) {
    throw ArgumentError(option + " takes " + form + "; got more than two entries in '" + text + "'");
  }
  const std::vector<double> number = parse_number_list(text.substr(0, comma), option);
  uint64_t seed = 0;
  if (comma != std::string::npos) {
    const char* end = seed_text.data() + seed_text.size();
    const auto [stop, error] = std::from_chars(seed_text.data(), end, seed);
    if (seed_text.empty() || error != std::errc() || stop != end) {
      throw ArgumentError(option + ": SEED '" + seed_text + "' is not a whole number from 0 to 18446744073709551615");
    }
  }
  return {number[0], seed};
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
  const size_t n = static_cast<size_t>(model.dof());
  // Pairs (no stiction) or triples, for every joint or one per joint: 2, 3, 2n and 3n never clash.
  const size_t width = v.size() == 3 || v.size() == 3 * n ? 3 : 2;
  if (v.size() != width && v.size() != width * n) {
    throw ArgumentError(count_error(
        "--friction takes VISCOUS,COULOMB[,STICTION] for every joint or one such pair or triple per joint",
        "2, 3, " + std::to_string(2 * n) + " or " + std::to_string(3 * n) + " numbers for " + std::to_string(n) +
            " joints: N*m*s/rad, N*m, N*m",
        v.size()));
  }
  Friction friction;
  friction.viscous.resize(static_cast<Eigen::Index>(n));
  friction.coulomb.resize(static_cast<Eigen::Index>(n));
  if (width == 3) friction.stiction.resize(static_cast<Eigen::Index>(n));
  for (size_t i = 0; i < n; ++i) {
    const size_t first = v.size() == width ? 0 : width * i;
    const auto joint = static_cast<Eigen::Index>(i);
    friction.viscous[joint] = v[first];
    friction.coulomb[joint] = v[first + 1];
    if (width == 3) friction.stiction[joint] = v[first + 2];
  }
  check_friction(friction, model, "--friction");
  return friction;
}

InertiaPerturbation parse_perturbation(const std::string& text) {
  const auto [fraction, seed] = number_and_seed(text, "--perturb-inertia", "FRACTION[,SEED]");
  const InertiaPerturbation perturbation{fraction, seed};
  check_perturbation(perturbation, "--perturb-inertia");
  return perturbation;
}

EffortNoise parse_effort_noise(const std::string& text) {
  const auto [sigma, seed] = number_and_seed(text, "--effort-noise", "SIGMA[,SEED]");
  const EffortNoise noise{sigma, seed};
  check_effort_noise(noise, "--effort-noise");
  return noise;
}

Stalls parse_stalls(const std::string& text) {
  const std::vector<double> v = parse_number_list(text, "--stall");
  if (v.size() != 3 && v.size() != 4) {
    throw ArgumentError(count_error("--stall takes MIN_MS,MAX_MS,EVERY_S[,SEED]", "3 or 4 numbers: ms, ms, s", v.size()));
  }
  Stalls stalls{v[0], v[1], v[2], 0};
  if (!(stalls.min_ms >= 0.0 && stalls.min_ms <= stalls.max_ms && stalls.max_ms > 0.0 && stalls.every_s > 0.0)) {
    throw ArgumentError("--stall: 0 <= MIN_MS <= MAX_MS, MAX_MS > 0 and EVERY_S > 0; got '" + text + "'");
  }
  if (v.size() == 4) {
    if (!(v[3] >= 0.0 && v[3] < 9007199254740992.0) || v[3] != static_cast<double>(static_cast<uint64_t>(v[3]))) {
      throw ArgumentError("--stall: SEED is a whole number from 0 to 2^53");
    }
    stalls.seed = static_cast<uint64_t>(v[3]);
  }
  return stalls;
}

}  // namespace chasles::plant
