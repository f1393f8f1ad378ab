// The corrected URDF: the original document with the calibration written into it, loadable by any
// URDF tool. What changes, and nothing else:
//   - the <origin> of every movable chain joint whose correction is not zero becomes
//     O ← O e^[δξ_i] e^[A_i δθ_i] (the zero offset folded in, so FK(q) of the file at encoder
//     reading q is the calibrated arm's); a comment before it keeps the original values;
//   - a fixed joint `marker_joint` from the tip link to a new, empty link `marker` carries
//     T_tip_marker, so FK to `marker` is the tracked point (and frame);
//   - a comment at the top of <robot> says so.
// Limits, inertias, meshes, transmissions and every other element are left as they are (the XML is
// re-serialised by tinyxml2, so indentation and quoting may change, content does not). The base
// transform T_tracker_base is not written into the robot: the tracker is not part of the arm, and a
// new root link would change the robot's root for every other tool; it is in the report.
#pragma once

#include <string>

#include "core/calibration/calibration.hpp"

namespace chasles {

struct CorrectedUrdfOptions {
  std::string marker_link = "marker";
  std::string marker_joint = "marker_joint";
  /// Extra text for the top comment (tool name, dataset, date...); "--" is not allowed in XML
  /// comments and is replaced.
  std::string note;
};

/// The corrected URDF text for `original_xml`, the file `nominal` was loaded from. Throws
/// CalibrationError when the XML does not parse, a chain joint is missing from it, or the marker
/// link or joint name is already taken.
std::string corrected_urdf(const std::string& original_xml, const RobotModel& nominal,
                           const KinematicCorrections& corrections, const CorrectedUrdfOptions& options = {});

/// The URDF of an identified arm (identification/dynamic_fit.hpp): the original document with each
/// body's inertia, each joint's friction and each rotor written into it, loadable by any URDF tool.
/// What changes, and nothing else:
///   - the <inertial> of every chain link that starts a body (the child link of each movable
///     joint) holds the identified body less the links riding on it as the original has them (a
///     flange, a hand, fingers: their <inertial>s stay, so a tool can still be swapped): mass,
///     the centre of mass as the origin's xyz, and the inertia about it in the link's axes (rpy 0:
///     the identified body has principal axes of its own, which an original rpy no longer fits);
///   - every movable chain joint's <dynamics> has damping = f_v and friction = f_c (other
///     attributes kept);
///   - the armature goes to Drake's rotor inertia, which the chasles loader reads back: a
///     <transmission> of the joint that has a drake:rotor_inertia or drake:gear_ratio gets
///     rotor_inertia = a / ρ² with its own gear ratio ρ; a joint without one and with a > 0 gets a
///     new transmission "<joint>_rotor" with gear ratio 1;
///   - a comment beside each changed element keeps its original, and one at the top of <robot>
///     says what was done.
/// `identified` is the nominal model with the identified bodies and armature (identified_model),
/// `viscous` and `coulomb` one value per joint. Throws CalibrationError when the XML does not
/// parse, a chain link or joint is missing from it, a transmission name is taken, or an identified
/// body weighs no more than what rides on it (the riders' <inertial>s are then not what the arm
/// carries: the message names them).
std::string identified_urdf(const std::string& original_xml, const RobotModel& identified,
                            const Eigen::VectorXd& viscous, const Eigen::VectorXd& coulomb,
                            const std::string& note = "");

/// URDF's roll-pitch-yaw of R = Rz(yaw) Ry(pitch) Rx(roll), exact to round-off everywhere,
/// gimbal lock included (there roll is kept and yaw takes the rest).
Vector3d rpy_from_rotation(const Matrix3d& R);

/// Rz(rpy[2]) Ry(rpy[1]) Rx(rpy[0]).
Matrix3d rotation_from_rpy(const Vector3d& rpy);

}  // namespace chasles
