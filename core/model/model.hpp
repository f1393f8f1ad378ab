// RobotModel: the immutable description of a serial chain, and Data: the workspace every
// algorithm writes into (Pinocchio's Model/Data split). Build the model once, give each thread
// its own Data, and no algorithm allocates afterwards.
#pragma once

#include <Eigen/Cholesky>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/lie/types.hpp"

namespace chasles {

using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// An invalid robot description. what() names the file and the joint or link.
class ModelError : public Error {
 public:
  using Error::Error;
};

enum class JointType { Revolute, Continuous, Prismatic };

/// "revolute", "continuous" or "prismatic", as URDF spells them.
const char* to_string(JointType type);

/// Position limits (rad or m; ±π for continuous joints, which wrap), velocity (rad/s or m/s)
/// and effort (N·m or N) limits. An absent velocity or effort limit is +∞, and so is one a URDF
/// gives as 0 (what exporters write when they do not know it).
struct JointLimits {
  double lower = 0.0;
  double upper = 0.0;
  double velocity = 0.0;
  double effort = 0.0;
  /// rad/s² (m/s²): Drake's <limit drake:acceleration="..."/>, which plain URDF has no word for;
  /// infinite when the file gives none.
  double acceleration = std::numeric_limits<double>::infinity();
};

/// A body's spatial inertia in its own frame, in the compact form the recursive algorithms use:
/// mass m, first moment h = m c (c the centre of mass) and rotational inertia I about the frame
/// origin. As a 6×6 matrix in (ω, v) order, G = [[I, [h]], [[h]ᵀ, m 1]] (MR eq. 8.32).
struct SpatialInertia {
  double mass = 0.0;
  Vector3d h = Vector3d::Zero();
  Matrix3d I = Matrix3d::Zero();

  /// The momentum G V of a body moving with twist V.
  CHASLES_ALWAYS_INLINE Vector6d operator*(const Vector6d& V) const {
    const Vector3d w = V.head<3>(), v = V.tail<3>();
    Vector6d P;
    P.head<3>().noalias() = I * w;
    P.head<3>() += h.cross(v);
    P.tail<3>() = mass * v - h.cross(w);
    return P;
  }
  Matrix6d matrix() const;
  static SpatialInertia from_matrix(const Matrix6d& G);
};

/// A movable joint of the chain. Body i is the child link of joint i with everything rigidly
/// attached to it; its frame is that link's frame.
struct Joint {
  std::string name;
  JointType type = JointType::Revolute;
  /// M_{i−1,i}: the joint frame (= body i frame at q = 0) in the frame of body i−1, with the
  /// fixed joints between them merged in.
  Transform T_parent_joint = Transform::Identity();
  /// Unit joint axis in the joint frame; the local screw axis is A = (axis, 0) for revolute
  /// joints and (0, axis) for prismatic ones.
  Vector3d axis = Vector3d::UnitZ();
  JointLimits limits;
};

/// The shape of a joint's local screw axis, found once when the model is built so that the
/// recursive algorithms take the few-flop path of a revolute joint about ±x, ±y or ±z
/// (lie/axis.hpp) where it applies: `General` is every other joint (prismatic, or an oblique axis).
enum class AxisKind : uint8_t { RevoluteX, RevoluteY, RevoluteZ, General };

struct JointAxis {
  AxisKind kind = AxisKind::General;
  double sign = 1.0;  ///< the axis is sign · e_kind when kind is not General
};

/// The rotation of a joint's placement M_{i−1,i}, found once when the model is built so that
/// forward kinematics turns two columns instead of multiplying 3×3 matrices where it can: the
/// identity, a rotation about x, y or z (what a URDF origin with one nonzero rpy angle gives), with
/// its angle's cosine c and sine s as stored in the matrix, a quarter turn about x, y or z (c = 0,
/// s = ±1: a swap of two coordinates, one negated), or `General`. Exact: only a matrix whose other
/// entries are exactly 0 and 1 gets a special kind, and the model's placement is exactly the
/// matrix its kind says. The one rounding it takes: a cosine within 4ε of 0 beside a sine of
/// exactly ±1 is 0, a quarter turn, as the matrix urdfdom's quaternion gives for rpy = ±π/2 (whose
/// cosine comes out as ε) is one to the precision of the angle itself.
enum class PlacementKind : uint8_t { RotationX, RotationY, RotationZ, Identity, General, QuarterX, QuarterY, QuarterZ };

struct PlacementRotation {
  PlacementKind kind = PlacementKind::General;
  double c = 1.0;  ///< the rotation is [[c, −s], [s, c]] in the plane of the two other axes
  double s = 0.0;
};

/// A link of the root → tip path, placed on the body it rides on (0 = the fixed base).
struct ChainLink {
  std::string name;
  int body = 0;
  Transform T_body_link = Transform::Identity();
};

/// Everything a RobotModel is computed from. The URDF loader produces one; calibration edits one.
struct ChainDescription {
  std::string name;
  std::string source;  ///< where it came from (a file path), for error messages
  std::string base_link;
  std::string tip_link;
  std::vector<Joint> joints;                     ///< n movable joints, root to tip
  std::vector<Matrix6d> inertia;                 ///< G_i of body i (index i−1) in its own frame, (ω, v) order
  std::vector<ChainLink> links;                  ///< every link from base to tip
  Transform T_last_tip = Transform::Identity();  ///< tip frame in the frame of body n
  Vector3d gravity = Vector3d(0.0, 0.0, -9.81);  ///< in the base frame, m/s²
  /// Armature of joint i (index i−1): the reflected inertia of its motor's rotor, I_rotor ρ² for a
  /// gear ratio ρ, kg·m² for a revolute joint, kg for a prismatic one. It adds to M's diagonal only:
  /// the rotor spins about the joint axis at ρ q̇_i whatever the arm's pose (the gyroscopic coupling
  /// with the links is neglected, as Drake, Pinocchio and MuJoCo do). Empty: none (all zero);
  /// otherwise one finite value ≥ 0 per joint.
  std::vector<double> armature;
  /// Questionable but loadable data met on the way (a point mass, a link whose own inertia is not
  /// physical though its body is), one sentence each, naming the link; tools print them once.
  std::vector<std::string> warnings;
};

/// Eigen's Cholesky factorisation M = L Lᵀ (an Eigen::LLT: solve, matrixL, rcond and info as
/// usual) with a factorisation written for the small n of an arm: at n = 6 or 7 Eigen's compute
/// spends more in dynamic-size block products and their dispatch than in the n³/6 flops (a fifth
/// of forward dynamics).
class CholeskyFactor : public Eigen::LLT<Eigen::MatrixXd> {
 public:
  using Eigen::LLT<Eigen::MatrixXd>::LLT;
  /// What compute(M) gives (the same factor, L1 norm and info, to rounding), M symmetric of this
  /// factor's size; only M's lower triangle is read. Allocates nothing.
  void factorize(const Eigen::MatrixXd& M);
};

struct Data;

/// The immutable model of a serial chain, with the quantities of Modern Robotics ch. 4 and 8
/// derived once: home tip pose M, home body frames M_i, space and body screw axes S_i and B_i.
class RobotModel {
 public:
  /// Checks the description and derives the rest; throws ModelError if it is not a valid chain.
  explicit RobotModel(ChainDescription description);

  int dof() const { return dof_; }
  const ChainDescription& description() const { return d_; }
  const std::string& name() const { return d_.name; }
  const std::string& base_link() const { return d_.base_link; }
  const std::string& tip_link() const { return d_.tip_link; }
  const std::vector<Joint>& joints() const { return d_.joints; }
  const Joint& joint(int i) const { return d_.joints[static_cast<size_t>(i)]; }
  const std::vector<ChainLink>& links() const { return d_.links; }
  const Matrix6d& inertia(int i) const { return d_.inertia[static_cast<size_t>(i)]; }
  /// The same in compact form, for the recursive algorithms.
  const SpatialInertia& body_inertia(int i) const { return G_[static_cast<size_t>(i)]; }
  const Transform& T_last_tip() const { return d_.T_last_tip; }
  const Vector3d& gravity() const { return d_.gravity; }
  /// Each joint's armature (ChainDescription::armature), zero where none was given: M(q) is the
  /// rigid bodies' mass matrix plus diag(armature()).
  const Eigen::VectorXd& armature() const { return armature_; }
  const std::vector<std::string>& warnings() const { return d_.warnings; }

  /// M: the tip pose at q = 0.
  const Transform& home_tip() const { return M_; }
  /// M_i: the pose of body i (index i−1) at q = 0.
  const Transform& home_body(int i) const { return M_body_[static_cast<size_t>(i)]; }
  /// Local screw axis A_i of joint i in its own frame.
  const Vector6d& local_axis(int i) const { return A_[static_cast<size_t>(i)]; }
  /// The shape of joint i's axis (RevoluteX/Y/Z when it is exactly ±x, ±y or ±z).
  const JointAxis& joint_axis(int i) const { return axis_kind_[static_cast<size_t>(i)]; }
  /// The shape of joint i's placement rotation M_{i−1,i} (its T_parent_joint's).
  const PlacementRotation& placement_rotation(int i) const { return placement_[static_cast<size_t>(i)]; }
  /// S: space screw axes at q = 0, one column per joint (MR §4.1.1).
  const Matrix6Xd& space_axes() const { return S_; }
  /// B: body screw axes at q = 0 in the tip frame, B_i = [Ad_{M⁻¹}] S_i (MR §4.1.3).
  const Matrix6Xd& body_axes() const { return B_; }

  /// Index of the joint with this name, or −1.
  int joint_index(const std::string& name) const;

  /// Whether `data` was sized for a model of this shape (Pinocchio's model.check(data)): the same
  /// number of joints and of chain links. A Data serves every model of the same chain, so one of
  /// another payload passes. The algorithms assert it in debug builds.
  bool check(const Data& data) const;

 private:
  ChainDescription d_;
  int dof_ = 0;  // d_.joints.size(), kept: every loop of every algorithm reads it, and a vector's size divides
  Transform M_;
  std::vector<Transform> M_body_;
  std::vector<Vector6d> A_;
  std::vector<JointAxis> axis_kind_;
  std::vector<PlacementRotation> placement_;
  std::vector<SpatialInertia> G_;
  Eigen::VectorXd armature_;
  Matrix6Xd S_;
  Matrix6Xd B_;
};

/// The model with `armature` (one value per joint, kg·m² or kg, finite and ≥ 0) in place of its
/// own, as Pinocchio's model.armature or MuJoCo's joint armature set by hand: for an arm whose URDF
/// does not say, or says otherwise. Throws ModelError naming the joint at fault, or the count.
/// Allocates: built once, off any real-time loop.
RobotModel with_armature(const RobotModel& model, const Eigen::VectorXd& armature);

/// Scratch and results of the algorithms for one model; one per thread. Sized on construction,
/// never resized afterwards. Vectors indexed by body run 0..n with entry 0 the fixed base.
struct Data {
  explicit Data(const RobotModel& model);

  // Kinematics.
  /// T_{i−1,i}(q_i) = M_{i−1,i} exp([A_i] q_i), entry 0 unused: written by local_transforms. For an
  /// arm whose joints are all axis-aligned the dynamics turn by sin_q and cos_q and form none, bar
  /// compute_tick_terms, which composes the body poses from them.
  std::vector<Transform> T_local;
  Eigen::VectorXd sin_q, cos_q;    ///< sin q_i and cos q_i, all computed before the transforms
  std::vector<Transform> T_body;   ///< T_0i, pose of body i in the base frame; T_body[0] = I
  Transform T_sb;                  ///< tip pose in the base (space) frame
  std::vector<Transform> T_link;   ///< pose of every chain link (RobotModel::links order)
  Matrix6Xd J_s;                   ///< space Jacobian
  Matrix6Xd J_b;                   ///< body Jacobian at the tip

  // Dynamics: body twists, their derivatives and the wrenches between bodies, each in the body's
  // own frame; crb_column[i] = C_i A_i, the momentum of bodies i…n (composite inertia C_i) moving
  // together about joint i at unit rate, in body i's frame: the column the CRBA carries toward the base.
  std::vector<Vector6d> V, Vd, F;
  std::vector<Vector6d> crb_column;
  Eigen::VectorXd tau;  ///< inverse dynamics
  Eigen::VectorXd g;    ///< gravity torques
  Eigen::VectorXd c;    ///< velocity product C(q, q̇) q̇
  Eigen::MatrixXd M;    ///< mass matrix
  Eigen::VectorXd qdd;  ///< forward dynamics
  Eigen::VectorXd p;      ///< generalized momentum M(q) q̇
  Eigen::VectorXd ct_qd;  ///< Cᵀ(q, q̇) q̇, the momentum balance's velocity term
  Eigen::VectorXd bias;   ///< c(q, q̇) + g(q): the torque that holds the arm at q̈ = 0
  CholeskyFactor M_llt;  ///< of M, as forward_dynamics left it

  /// How often the joint transforms and the body Jacobian were computed into this Data since it was
  /// built: one increment each, so a test can count what a control tick costs.
  struct Passes {
    int64_t joint_transforms = 0;
    int64_t body_jacobians = 0;
  } passes;
};

}  // namespace chasles
