// Building a RobotModel from URDF (via urdfdom).
#pragma once

#include <Eigen/Core>
#include <string>

#include "core/model/model.hpp"

namespace chasles {

/// The tree has several leaves and no tip link was named; what() lists the leaves.
class TipNotChosenError : public ModelError {
 public:
  using ModelError::ModelError;
};

struct UrdfOptions {
  /// The link that ends the chain. Empty: the tree's single leaf (an error lists the leaves
  /// when there are several).
  std::string tip_link;
  Vector3d gravity = Vector3d(0.0, 0.0, -9.81);
};

/// Loads the chain root → tip from a URDF file. Fixed joints are merged into their parent body;
/// joints off the chain are locked at 0 and their links' inertia rides on the body they hang
/// from. Meshes are ignored. Throws ModelError naming the file and the joint or link at fault.
RobotModel load_urdf_file(const std::string& path, const UrdfOptions& options = {});

/// The same from URDF text; `source` names it in error messages.
RobotModel load_urdf_string(const std::string& xml, const UrdfOptions& options = {},
                            const std::string& source = "<urdf string>");

/// The joints' friction a URDF states in <dynamics damping friction>: viscous damping (N·m·s/rad
/// or N·s/m) and Coulomb friction (N·m or N), one entry per movable chain joint of `model`, 0 where
/// the joint states none. What chasles_calibrate dynamics writes into an identified URDF, and what
/// the controller feeds forward with --friction-from-urdf.
struct JointFriction {
  Eigen::VectorXd viscous;
  Eigen::VectorXd coulomb;
};

/// The friction of `model`'s joints in the URDF text `xml` (the one `model` was loaded from).
/// Throws ModelError naming the model's source, and the joint, for XML that does not parse or a
/// value that is not a finite number ≥ 0.
JointFriction joint_friction_from_urdf(const std::string& xml, const RobotModel& model);

/// The same from the URDF file at `path`, read as load_urdf_file reads it (ModelError naming a file
/// that cannot be read).
JointFriction joint_friction_from_urdf_file(const std::string& path, const RobotModel& model);

}  // namespace chasles
