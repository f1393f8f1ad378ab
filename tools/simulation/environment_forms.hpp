// chasles_plant's command-line forms of the environment (environment.hpp in core/simulation):
// --push, --wall, --payload, --friction and --perturb-inertia as text, and of the sensor's
// --effort-noise (messaging.hpp). Each throws chasles::ArgumentError with a one-line message that
// starts with the option and says what to give instead.
#pragma once

#include <string>

#include "core/model/model.hpp"
#include "core/simulation/environment.hpp"
#include "tools/simulation/messaging.hpp"

namespace chasles::plant {

/// "START,DURATION,RAMP,mx,my,mz,fx,fy,fz" (--push).
Push parse_push(const std::string& text);
/// "PX,PY,PZ,NX,NY,NZ[,K,D]" (--wall); the normal is normalised.
Wall parse_wall(const std::string& text);
/// "KG[,CX,CY,CZ]" (--payload).
Payload parse_payload(const std::string& text);
/// "VISCOUS,COULOMB[,STICTION]" for every joint, or one such pair or triple per joint, root to tip
/// (--friction).
Friction parse_friction(const std::string& text, const RobotModel& model);
/// "FRACTION[,SEED]" (--perturb-inertia): 0 ≤ FRACTION < 1, SEED a whole number (default 0).
InertiaPerturbation parse_perturbation(const std::string& text);
/// "SIGMA[,SEED]" (--effort-noise): SIGMA ≥ 0 in N·m, SEED a whole number (default 0).
EffortNoise parse_effort_noise(const std::string& text);
/// "MIN_MS,MAX_MS,EVERY_S[,SEED]" (--stall): 0 ≤ MIN_MS ≤ MAX_MS, MAX_MS > 0, EVERY_S > 0.
Stalls parse_stalls(const std::string& text);

}  // namespace chasles::plant
