// Offline kinematic calibration by Ceres: joint positions and tracker measurements of a marker on
// the arm in, corrections of the robot's joint origins, joint zero offsets and the base
// (tracker → robot) and tool (tip → marker) transforms out. Its own library, chasles::calibration,
// so that only code that calibrates links Ceres.
//
// The model of one measurement (pose, or position only as from a laser tracker):
//
//   T_tracker_marker(q) = T_tracker_base · ∏_i [ M_{i−1,i} e^[δξ_i] e^[A_i](q_i + δθ_i) ] · T_n,tip · T_tip_marker
//
// M_{i−1,i} the URDF's joint origins (fixed joints merged, RobotModel::joint(i).T_parent_joint),
// δξ_i a body twist (ω, v) in joint frame i (local PoE, Lynch & Park §4.1; Chen, Yang & Lo's local
// frame representation), δθ_i the joint zero offset (the arm is really at q_i + δθ_i when its
// encoder reads q_i), T_tracker_base = B₀ e^[β] and T_tip_marker = K₀ e^[τ] about the references
// B₀, K₀ the fit starts from. The parameter vector x (CalibrationLayout) stacks
// δξ_1 … δξ_n, δθ_1 … δθ_n, β, τ: 7n + 12 numbers, of which only 4R + 2P + 6 (pose data) or
// 4R + 2P + 3 (position data) are identifiable — see analyse_identifiability().
//
// Residual of one row, whitened by the expected noise σ_r (rad), σ_p (m):
//   pose:      r = ( log(R_measᵀ R_pred) / σ_r ,  (p_pred − p_meas) / σ_p )   (6; rotation in the
//              marker frame, position in the tracker frame)
//   position:  r = (p_pred − p_meas) / σ_p                                   (3)
// with an analytic Jacobian: δξ_i enters as the body twist J_r(δξ_i) dδξ_i at joint frame i and is
// carried to the marker by [Ad_{T_i,marker⁻¹}]; δθ_i as the joint's own screw A_i.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/kinematics/kinematics.hpp"

namespace chasles {

/// Bad calibration input (too few rows, a degenerate dataset, bad options). what() says where.
class CalibrationError : public Error {
 public:
  using Error::Error;
};

/// One measurement: the joint positions the encoders read and where the tracker saw the marker.
struct Measurement {
  Eigen::VectorXd q;                                   ///< one per chain joint (rad or m), chain order
  Vector3d p_tracker_marker = Vector3d::Zero();        ///< marker position in the tracker frame, m
  bool has_orientation = false;                        ///< R_tracker_marker was measured
  Matrix3d R_tracker_marker = Matrix3d::Identity();    ///< marker orientation in the tracker frame
  int line = 0;                                        ///< line in the dataset file (0: none)
};

/// Everything a calibration estimates, in the form a user applies it.
struct KinematicCorrections {
  std::vector<Vector6d> origin;  ///< δξ_i per chain joint: M_{i−1,i} ← M_{i−1,i} e^[δξ_i], (ω, v) in joint frame i
  Eigen::VectorXd offset;        ///< δθ_i per chain joint: the joint is at q_i + δθ_i when it reads q_i
  Transform T_tracker_base;      ///< the robot's base frame in the tracker frame
  Transform T_tip_marker;        ///< the marker in the tip link's frame

  /// No correction: zero twists and offsets, identity base and tool.
  static KinematicCorrections zero(const RobotModel& model);
};

/// The chain with the corrections applied: M_{i−1,i} ← M_{i−1,i} e^[δξ_i] e^[A_i δθ_i], the zero
/// offset folded into the origin so that FK(q) of the result is the calibrated arm's at encoder
/// reading q. Links riding on a body keep their place in that body's frame; base and tool are not
/// part of the chain (see predict_marker).
RobotModel corrected_model(const RobotModel& nominal, const KinematicCorrections& corrections);

/// T_tracker_marker = T_tracker_base · FK(q) · T_tip_marker for a model that already carries the
/// corrections (corrected_model, or a corrected URDF loaded back).
Transform predict_marker(const RobotModel& corrected, const KinematicCorrections& corrections,
                         const JointVector& q);

/// Where each parameter lives in x.
struct CalibrationLayout {
  int n = 0;  ///< joints
  int size() const { return 7 * n + 12; }
  int origin(int joint, int k) const { return 6 * joint + k; }  ///< k: 0-2 ω, 3-5 v
  int offset(int joint) const { return 6 * n + joint; }
  int base(int k) const { return 7 * n + k; }
  int tool(int k) const { return 7 * n + 6 + k; }
  /// "<joint>.origin.wx", "<joint>.offset", "base.vz", "tool.wy", ...
  std::string name(const RobotModel& model, int index) const;
  /// "rad" or "m".
  const char* unit(const RobotModel& model, int index) const;
};

/// The whitened measurement function of one row and its analytic Jacobian, about references B₀
/// (base) and K₀ (tool). Holds scratch space: one instance per thread.
class MeasurementModel {
 public:
  MeasurementModel(const RobotModel& nominal, const Transform& T_tracker_base, const Transform& T_tip_marker,
                   double sigma_position, double sigma_rotation);

  const RobotModel& nominal() const { return nominal_; }
  const CalibrationLayout& layout() const { return layout_; }
  int num_parameters() const { return layout_.size(); }
  const Transform& reference_base() const { return B0_; }
  const Transform& reference_tool() const { return K0_; }
  double sigma_position() const { return sigma_p_; }
  double sigma_rotation() const { return sigma_r_; }

  /// 6 for a row with orientation used, 3 otherwise.
  static int residual_size(const Measurement& m, bool use_orientation) {
    return m.has_orientation && use_orientation ? 6 : 3;
  }

  /// The residual of `m` at x (see the file comment) and, unless `jacobian` is null, its
  /// residual_size × num_parameters Jacobian, row-major (Ceres's layout).
  void evaluate(const double* x, const Measurement& m, bool use_orientation, double* residual,
                double* jacobian) const;

  /// The predicted T_tracker_marker at encoder reading q.
  Transform predict(const Eigen::Ref<const Eigen::VectorXd>& x, const JointVector& q) const;

  /// x as corrections: T_tracker_base = B₀ e^[β], T_tip_marker = K₀ e^[τ].
  KinematicCorrections corrections(const Eigen::Ref<const Eigen::VectorXd>& x) const;

 private:
  const RobotModel& nominal_;
  CalibrationLayout layout_;
  Transform B0_, K0_;
  double sigma_p_, sigma_r_;
  std::vector<Vector6d> A_;
  // Scratch: corrected origins, joint motions, marker in joint frame i, the body-twist Jacobian.
  mutable std::vector<Transform> C_, E_, P_;
  mutable Eigen::Matrix<double, 6, Eigen::Dynamic> J_body_;
};

/// A parameter held at zero, and why.
struct FixedParameter {
  enum class Reason {
    NoEffect,          ///< the measurements do not depend on it (tool orientation with position data)
    Redundant,         ///< its effect is a combination of the free parameters' (exactly, to 1e-6)
    PoorlyObservable,  ///< nearly such a combination: these configurations do not separate it
  };
  int index = 0;
  Reason reason = Reason::Redundant;
  /// Free parameters whose combination Σ c_k x_k has the same first-order effect as a unit change
  /// of this one (largest |c_k| first, physical units), and the relative misfit of that combination.
  std::vector<std::pair<int, double>> equivalent;
  double misfit = 0.0;
  std::string explanation;  ///< one sentence for people
};

/// Which parameters a dataset can determine. From the stacked whitened Jacobian J (rows of every
/// measurement) at x, with each column scaled to unit norm so that units do not matter:
///   rank        the number of singular values of J·S above tolerance · σ_max;
///   free        chosen greedily in a preference order — base, tool, joint offsets, joint origins
///               from the tip down — a parameter joining only if the chosen columns' smallest
///               singular value stays above tolerance · σ_max (so the free set is well
///               conditioned and as large as the rank);
///   fixed       the rest, each with the combination of free parameters that duplicates it.
/// Theory (Everett, Driels & Mooring 1987, "Kinematic modelling for robot calibration"; for PoE
/// models Okamura & Park 1996 and He, Zhao, Yang & Yang 2010): a complete, minimal model of an arm
/// with R revolute and P prismatic joints, base and tool has 4R + 2P + 6 parameters identifiable
/// from pose measurements; position measurements lose the tool's 3 orientation parameters.
struct Identifiability {
  int num_parameters = 0;
  int rank = 0;                      ///< numerical rank of the scaled identification Jacobian
  int theoretical = 0;               ///< 4R + 2P + 6, − 3 without orientation data
  double tolerance = 0.0;
  Eigen::VectorXd singular_values;   ///< of the column-scaled Jacobian, relative to the largest, descending
  std::vector<int> free;             ///< indices into x, ascending
  std::vector<FixedParameter> fixed; ///< ascending index
};

/// 4R + 2P + 6 for pose data, 4R + 2P + 3 for position data (see Identifiability).
int theoretical_identifiable_count(const RobotModel& model, bool pose_data);

/// Identifiability of the parameters at x from `rows` (see Identifiability). Throws
/// CalibrationError when the rows give fewer residuals than there are parameters.
Identifiability analyse_identifiability(const MeasurementModel& model, const std::vector<Measurement>& rows,
                                        const Eigen::VectorXd& x, bool use_orientation, double tolerance);

enum class LossType { None, Huber, Cauchy };
/// "none", "huber", "cauchy".
const char* to_string(LossType loss);

struct CalibrationOptions {
  /// Expected measurement noise, per axis: position in m, rotation in rad. They weigh position
  /// against orientation and set the unit of the loss scale; the standard deviations reported are
  /// rescaled by the fit's own residual variance, so they do not depend on these.
  double sigma_position = 1e-4;
  double sigma_rotation = 1e-3;
  /// Use the orientation of rows that have one (false: fit positions only).
  bool use_orientation = true;
  /// Robust loss on each row's whitened residual norm |r|; the scale is that norm (multiples of σ)
  /// beyond which a row counts as doubtful.
  LossType loss = LossType::Cauchy;
  double loss_scale = 5.0;
  /// Relative singular value below which a direction counts as unidentifiable.
  double rank_tolerance = 1e-6;
  int max_iterations = 100;
  /// Standard deviations by ceres::Covariance (sparse QR).
  bool covariance = true;
  /// A row is flagged as an outlier when its whitened residual norm under the calibrated model
  /// exceeds max(outlier_threshold, 5 × the median norm). Flagged rows stay in the fit (the loss
  /// decides their weight) and are left out of the residual statistics.
  double outlier_threshold = 10.0;
};

/// RMS and largest error over a set of rows: position |p_pred − p_meas| (m), rotation
/// |log(R_measᵀ R_pred)| (rad; NaN when no row has an orientation).
struct ResidualStats {
  int rows = 0;      ///< rows counted (outliers left out)
  int outliers = 0;  ///< rows left out as outliers
  double rms_position = 0.0, max_position = 0.0;
  double rms_rotation = 0.0, max_rotation = 0.0;
};

struct CalibrationResult {
  CalibrationLayout layout;
  KinematicCorrections before;  ///< the nominal robot with the best base and tool for it
  KinematicCorrections after;   ///< the calibrated model
  Eigen::VectorXd x;            ///< estimates about `before`'s base and tool (fixed ones 0)
  Eigen::VectorXd stddev;       ///< standard deviations of x (0 for fixed; NaN if not computed)
  Identifiability identifiability;
  bool pose_data = false;       ///< orientations were fitted
  ResidualStats fit_before, fit_after, holdout_before, holdout_after;
  std::vector<int> fit_outliers;      ///< indices into the fit rows flagged as outliers
  std::vector<int> holdout_outliers;  ///< indices into the held-out rows flagged as outliers
  double sigma0 = 0.0;          ///< a-posteriori standard deviation of unit weight: √(2 cost / (m − r))
  bool covariance_ok = false;
  int iterations = 0;
  bool converged = false;
  std::string termination;      ///< Ceres's message of the final solve
  double seconds = 0.0;         ///< wall-clock time of calibrate()
};

/// Calibrates `nominal` on the `fit` rows and evaluates on `holdout` (may be empty):
///   1. base and tool start from a closed-form registration of the nominal tip positions to the
///      measured ones (Kabsch/Horn), then are refined with the robot held nominal, under a Huber
///      loss (Cauchy would take every row of an uncalibrated arm for an outlier) — the "before"
///      model, the best the uncalibrated robot can do;
///   2. identifiability at that point (analyse_identifiability);
///   3. the free parameters by Levenberg-Marquardt under the robust loss (a Huber pass first
///      when the loss is Cauchy, whose redescending weights want a good start);
///   4. covariance of the free parameters, scaled by sigma0².
/// Throws CalibrationError on bad options, rows of the wrong size, or too few rows.
CalibrationResult calibrate(const RobotModel& nominal, const std::vector<Measurement>& fit,
                            const std::vector<Measurement>& holdout, const CalibrationOptions& options = {});

/// Which rows to hold out: round(fraction · rows) of them, chosen by a seeded shuffle that gives the
/// same answer with every standard library. true = held out.
std::vector<bool> holdout_split(int rows, double fraction, std::uint64_t seed);

/// Residual statistics of `rows` under the model (corrected + corrections), leaving out the rows
/// whose indices are in `excluded`. Rotation statistics only with use_orientation.
ResidualStats residual_stats(const RobotModel& corrected, const KinematicCorrections& corrections,
                             const std::vector<Measurement>& rows, bool use_orientation,
                             const std::vector<int>& excluded = {});

}  // namespace chasles
