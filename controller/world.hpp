// The arm's collision geometry and its scene, loaded before the loop starts (or by the worker for
// a new scene): what Clearance (clearance.hpp) computes with. Offline work: reads files, allocates.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "controller/clearance.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/geometry/proximity.hpp"

namespace chasles::controller {

/// Whether to keep the arm clear with its collision geometry.
enum class CollisionMode {
  kAuto,  ///< if the URDF's collision geometry loads; else say why and go on without
  kOn,    ///< it must load: an error otherwise
  kOff,   ///< none
};

struct WorldOptions {
  CollisionMode mode = CollisionMode::kAuto;
  std::string urdf;                       ///< the file the model was loaded from
  geometry::GeometryOptions geometry;     ///< package dirs and the SRDF
  geometry::ProximityOptions proximity;   ///< the self pairs' clearance
};

/// The arm's collision model from `options`, its self pairs in contact at q = 0 dropped
/// (drop_pairs_closer_than, at each pair's stop distance) and each said in `notes`. Without
/// geometry (kOff, none in the URDF, or kAuto and it failed to load: said in `notes`), empty.
/// Throws ModelError under kOn when it does not load.
geometry::CollisionModel load_arm_geometry(const RobotModel& model, const WorldOptions& options,
                                           std::vector<std::string>& notes);

/// The world for `arm` and `scene`, or nullptr when the arm has no collision object.
std::shared_ptr<ClearanceWorld> make_world(const RobotModel& model, const geometry::CollisionModel& arm,
                                           const geometry::Scene& scene, const geometry::ProximityOptions& options);

/// "auto", "on", "off".
bool parse_collision_mode(const std::string& text, CollisionMode& mode);

}  // namespace chasles::controller
