// The scene over LCM: chasles.scene_t (lcmtypes/chasles_scene_t.lcm) to geometry::Scene and back.
// The message is untrusted: its bytes go through the checked decoder (lcmtypes/checked.hpp, which
// walks every count and string length before lcm-gen's decoder may trust them), then decode_scene
// holds what they say to the contract — the version, the caps, every kind, size, pose, normal,
// clearance and name — and to the rules a scene file keeps (core/geometry/scene_file.hpp), so a
// scene means the same thing and is refused for the same faults whichever way it comes.
//
// Decoding builds hulls (qhull) and allocates: a scene is handled off the real-time thread, and
// the tick takes the Proximity built from it (the daemon's worker does both).
#pragma once

#include <chasles/scene_t.hpp>
#include <cstddef>
#include <cstdint>

#include "core/geometry/proximity.hpp"

namespace chasles::controller {

/// Checks `message` and builds the scene it describes: its objects (a CONVEX one as the convex
/// hull of its vertices), its planes, then each box's six faces (geometry::add_workspace_box), in
/// message order, every normal and quaternion normalised. Returns true with `out` replaced; or
/// false, `out` untouched, and why in `error` (NUL-terminated, cut to size − 1 bytes; "" when size
/// is 0): the first fault, naming the entry and field ("version 2; this receiver reads version 1",
/// "object 3 'bin': its 4 vertices span no volume ...", "plane 1 'wall': plane_normal (0, 0, 2) has
/// length 2, not 1"). Never throws: a message built by hand with arrays that disagree with its
/// counts is refused like a bad one.
bool decode_scene(const scene_t& message, geometry::Scene& out, char* error, size_t size);

/// The same from the bytes of a message (as heard on the bus): the checked decoder for scene_t,
/// then decode_scene. Never throws.
bool decode_scene(const void* data, size_t bytes, geometry::Scene& out, char* error, size_t size);

/// The message for `scene` (version scene_t::VERSION, `utime` as given): every object with its
/// kind, sizes and pose, a convex one with its hull's vertices; the planes, but those that end the
/// scene as workspace boxes' faces (geometry::trailing_workspace_boxes), which go as the boxes; so
/// that decode_scene gives `scene` back — to the bit but for what goes through a quaternion (the
/// rotations, the boxes' faces: within 1e-15). For tools and tests, not the tick. Throws
/// ArgumentError when the scene breaks a rule (geometry::scene_problem) or a cap of the message
/// (too many objects, planes, boxes, vertices or bound links; a hull of more than
/// MAX_HULL_VERTICES vertices).
scene_t encode_scene(const geometry::Scene& scene, int64_t utime = 0);

}  // namespace chasles::controller
