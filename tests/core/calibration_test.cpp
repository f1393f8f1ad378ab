// chasles::calibration against independent truths: synthetic arms perturbed here (not by the
// library), measured through chasles's own FK, fitted, and judged on held-out configurations by
// how well the calibrated model predicts the truth's noise-free marker poses. Also the analytic
// Jacobian against central differences, the identifiable-parameter counts against the theory
// (4R + 2P + 6), the robust loss against gross outliers, and the holdout split.
#include "core/calibration/calibration.hpp"

#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/calibration/dataset.hpp"
#include "core/calibration/urdf_writer.hpp"

#include "core/dynamics/dynamics.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "support/process.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

static_assert(std::is_base_of_v<Error, CalibrationError>);

RobotModel load(const std::string& robot) {
  UrdfOptions options;
  options.tip_link = robot == "ur5" ? "tool0" : robot == "panda" ? "panda_hand" : "tip";
  return load_urdf_file(testing::data_path(robot + ".urdf"), options);
}

/// The arm as it really is: every joint origin off by a random twist, every joint zero off, a
/// tracker somewhere around the robot and a marker some centimetres from the flange. Built here
/// from the description, independently of corrected_model().
struct Truth {
  RobotModel model;
  Transform T_tracker_base, T_tip_marker;
};

Truth make_truth(const RobotModel& nominal, std::uint64_t seed, double error_position = 3e-3,
                 double error_rotation = 3e-3) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  ChainDescription d = nominal.description();
  for (Joint& joint : d.joints) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = normal(rng) * (k < 3 ? error_rotation : error_position);
    const double offset = normal(rng) * error_rotation;
    const Transform motion = joint.type == JointType::Prismatic
                                 ? Transform(Matrix3d::Identity(), joint.axis * offset)
                                 : Transform(Eigen::AngleAxisd(offset, joint.axis).toRotationMatrix(), Vector3d::Zero());
    joint.T_parent_joint = joint.T_parent_joint * exp6(xi) * motion;
  }
  Vector6d base, tool;
  for (int k = 0; k < 6; ++k) base[k] = normal(rng);  // any orientation, about a metre away
  for (int k = 0; k < 6; ++k) tool[k] = normal(rng) * (k < 3 ? 0.3 : 0.05);
  return {RobotModel(std::move(d)), exp6(base), exp6(tool)};
}

Eigen::VectorXd random_q(const RobotModel& model, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXd q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const JointLimits& l = model.joint(i).limits;
    const double margin = 0.05 * (l.upper - l.lower);
    q[i] = l.lower + margin + unit(rng) * (l.upper - l.lower - 2.0 * margin);
  }
  return q;
}

Transform truth_pose(const Truth& truth, const Eigen::VectorXd& q) {
  return truth.T_tracker_base * forward_kinematics_space(truth.model, q) * truth.T_tip_marker;
}

std::vector<Measurement> measure(const Truth& truth, int rows, std::uint64_t seed, double sigma_p, double sigma_r,
                                 bool orientation) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Measurement> out;
  for (int k = 0; k < rows; ++k) {
    Measurement m;
    m.q = random_q(truth.model, rng);
    const Transform T = truth_pose(truth, m.q);
    m.p_tracker_marker = T.translation() + sigma_p * Vector3d(normal(rng), normal(rng), normal(rng));
    m.has_orientation = orientation;
    m.R_tracker_marker = T.linear() * exp3(Vector3d(normal(rng), normal(rng), normal(rng)) * sigma_r);
    m.line = k + 2;
    out.push_back(m);
  }
  return out;
}

/// RMS distance between the calibrated model's predictions and the truth's noise-free marker
/// positions (and orientations) at fresh configurations.
struct PredictionError {
  double position = 0.0, rotation = 0.0;
};

PredictionError prediction_error(const RobotModel& nominal, const CalibrationResult& result, const Truth& truth,
                                 std::uint64_t seed, int rows = 200) {
  const RobotModel corrected = corrected_model(nominal, result.after);
  std::mt19937_64 rng(seed);
  double sp = 0.0, sr = 0.0;
  for (int k = 0; k < rows; ++k) {
    const Eigen::VectorXd q = random_q(nominal, rng);
    const Transform predicted = predict_marker(corrected, result.after, q);
    const Transform expected = truth_pose(truth, q);
    sp += (predicted.translation() - expected.translation()).squaredNorm();
    sr += log3(Matrix3d(expected.linear().transpose() * predicted.linear())).squaredNorm();
  }
  return {std::sqrt(sp / rows), std::sqrt(sr / rows)};
}

// The analytic Jacobian of the whitened residual against central differences, at a point with
// large corrections (so J_r(δξ) and Jr⁻¹(φ) are far from the identity) and a misfit rotation.
TEST(calibration, JacobianMatchesCentralDifferences) {
  for (const char* robot : {"ur5", "panda", "arm"}) {
    const RobotModel nominal = load(robot);
    const Truth truth = make_truth(nominal, 3);
    const MeasurementModel model(nominal, exp6(Vector6d::Constant(0.4)), exp6(Vector6d::Constant(0.1)), 1e-3, 1e-2);
    const int p = model.num_parameters();
    std::mt19937_64 rng(11);
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::VectorXd x(p);
    for (int j = 0; j < p; ++j) x[j] = 0.3 * normal(rng);
    for (bool orientation : {true, false}) {
      const Measurement m = measure(truth, 1, 5, 0.0, 0.0, orientation).front();
      const int k = MeasurementModel::residual_size(m, true);
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(k, p);
      Eigen::VectorXd r(k), r_plus(k), r_minus(k);
      model.evaluate(x.data(), m, true, r.data(), J.data());
      Eigen::MatrixXd J_fd(k, p);
      const double h = 1e-6;
      for (int j = 0; j < p; ++j) {
        Eigen::VectorXd xp = x, xm = x;
        xp[j] += h;
        xm[j] -= h;
        model.evaluate(xp.data(), m, true, r_plus.data(), nullptr);
        model.evaluate(xm.data(), m, true, r_minus.data(), nullptr);
        J_fd.col(j) = (r_plus - r_minus) / (2.0 * h);
      }
      EXPECT_TRUE(testing::matrices_near_relative(J, J_fd, 1e-6)) << robot << (orientation ? " pose" : " position");
      // The residual is the prediction's misfit.
      const Transform T = model.predict(x, m.q);
      EXPECT_LT((r.tail<3>() * 1e-3 - (T.translation() - m.p_tracker_marker)).norm(), 1e-12);
    }
  }
}

// The SVD finds exactly the theory's count — 4R + 2P + 6 with pose data, 3 fewer with positions —
// for a 6R, a 7R and an R-P-R arm, and the free set has that size and is well conditioned.
TEST(calibration, IdentifiableCountMatchesTheory) {
  struct Case {
    const char* robot;
    int pose, position;
  };
  for (const Case& c : {Case{"ur5", 30, 27}, Case{"panda", 34, 31}, Case{"arm", 16, 13}}) {
    const RobotModel nominal = load(c.robot);
    const Truth truth = make_truth(nominal, 4);
    for (bool orientation : {true, false}) {
      const std::vector<Measurement> rows = measure(truth, 60, 6, 0.0, 0.0, orientation);
      const MeasurementModel model(nominal, truth.T_tracker_base, truth.T_tip_marker, 1e-4, 1e-3);
      const Identifiability id =
          analyse_identifiability(model, rows, Eigen::VectorXd::Zero(model.num_parameters()), true, 1e-6);
      const int expected = orientation ? c.pose : c.position;
      EXPECT_EQ(theoretical_identifiable_count(nominal, orientation), expected) << c.robot;
      EXPECT_EQ(id.rank, expected) << c.robot << (orientation ? " pose" : " position");
      EXPECT_EQ(static_cast<int>(id.free.size()), expected) << c.robot;
      EXPECT_EQ(static_cast<int>(id.free.size() + id.fixed.size()), model.num_parameters());
      // A clear gap: the last identifiable direction is far above round-off.
      EXPECT_GT(id.singular_values[expected - 1], 1e-4) << c.robot;
      if (expected < id.singular_values.size()) {
        EXPECT_LT(id.singular_values[expected], 1e-10) << c.robot;
      }
      for (const FixedParameter& f : id.fixed) {
        EXPECT_NE(f.reason, FixedParameter::Reason::PoorlyObservable) << f.explanation;
        EXPECT_FALSE(f.explanation.empty());
      }
    }
  }
}

// The base and the first joint's origin are one transform: the base is kept, the first origin
// fixed and explained by it; the first joint's zero offset is a base rotation about its axis.
TEST(calibration, RedundanciesAreExplained) {
  const RobotModel nominal = load("ur5");
  const Truth truth = make_truth(nominal, 4);
  const std::vector<Measurement> rows = measure(truth, 60, 6, 0.0, 0.0, false);
  const MeasurementModel model(nominal, truth.T_tracker_base, truth.T_tip_marker, 1e-4, 1e-3);
  const Identifiability id = analyse_identifiability(model, rows, Eigen::VectorXd::Zero(model.num_parameters()), true, 1e-6);
  const CalibrationLayout& layout = model.layout();
  auto fixed = [&](int index) -> const FixedParameter* {
    for (const FixedParameter& f : id.fixed) {
      if (f.index == index) return &f;
    }
    return nullptr;
  };
  for (int k = 0; k < 6; ++k) {
    EXPECT_TRUE(std::binary_search(id.free.begin(), id.free.end(), layout.base(k)));
    const FixedParameter* f = fixed(layout.origin(0, k));
    ASSERT_NE(f, nullptr) << k;
    EXPECT_EQ(f->reason, FixedParameter::Reason::Redundant);
    for (const auto& [index, coefficient] : f->equivalent) EXPECT_GE(index, layout.base(0)) << f->explanation;
  }
  const FixedParameter* offset = fixed(layout.offset(0));
  ASSERT_NE(offset, nullptr);
  EXPECT_NE(offset->explanation.find("base.w"), std::string::npos) << offset->explanation;
  // Position data: the marker's orientation has no effect at all.
  for (int k = 0; k < 3; ++k) {
    const FixedParameter* f = fixed(layout.tool(k));
    ASSERT_NE(f, nullptr);
    EXPECT_EQ(f->reason, FixedParameter::Reason::NoEffect);
  }
}

// Noise-free data: the fit reproduces them to round-off, and predicts unseen configurations
// exactly, although the fixed parameters differ from the truth's.
TEST(calibration, NoiseFreeDataFitToRoundOff) {
  for (bool orientation : {true, false}) {
    const RobotModel nominal = load("panda");
    const Truth truth = make_truth(nominal, 7);
    const std::vector<Measurement> fit = measure(truth, 120, 8, 0.0, 0.0, orientation);
    const std::vector<Measurement> holdout = measure(truth, 30, 9, 0.0, 0.0, orientation);
    CalibrationOptions options;
    options.loss = LossType::None;
    const CalibrationResult result = calibrate(nominal, fit, holdout, options);
    EXPECT_TRUE(result.converged) << result.termination;
    EXPECT_GT(result.fit_before.rms_position, 1e-3);
    EXPECT_LT(result.fit_after.max_position, 1e-9);
    EXPECT_LT(result.holdout_after.max_position, 1e-9);
    if (orientation) {
      EXPECT_LT(result.fit_after.max_rotation, 1e-9);
    }
    const PredictionError e = prediction_error(nominal, result, truth, 10);
    EXPECT_LT(e.position, 1e-9);
    if (orientation) {
      EXPECT_LT(e.rotation, 1e-9);
    }
  }
}

// The round trip with noise: on fresh configurations the calibrated model is much closer to the
// truth's noise-free marker than the measurements themselves are (σ), with pose or position data.
TEST(calibration, NoisyRoundTripPredictsBelowNoise) {
  const double sigma_p = 1e-4, sigma_r = 1e-3;
  for (const char* robot : {"ur5", "panda"}) {
    for (bool orientation : {true, false}) {
      const RobotModel nominal = load(robot);
      const Truth truth = make_truth(nominal, 12);
      const std::vector<Measurement> fit = measure(truth, 200, 13, sigma_p, sigma_r, orientation);
      const std::vector<Measurement> holdout = measure(truth, 50, 14, sigma_p, sigma_r, orientation);
      CalibrationOptions options;
      options.sigma_position = sigma_p;
      options.sigma_rotation = sigma_r;
      const CalibrationResult result = calibrate(nominal, fit, holdout, options);
      const PredictionError e = prediction_error(nominal, result, truth, 15);
      const std::string what = std::string(robot) + (orientation ? " pose" : " position");
      EXPECT_LT(e.position, 0.5 * sigma_p) << what;
      if (orientation) {
        EXPECT_LT(e.rotation, 0.5 * sigma_r) << what;
      }
      // Held-out residuals are the noise: per axis σ, so |e| has RMS √3 σ.
      EXPECT_LT(result.holdout_after.rms_position, 2.0 * std::sqrt(3.0) * sigma_p) << what;
      EXPECT_GT(result.holdout_before.rms_position, 10.0 * sigma_p) << what;
      EXPECT_NEAR(result.sigma0, 1.0, 0.2) << what;
      EXPECT_TRUE(result.covariance_ok) << what;
      for (int j : result.identifiability.free) {
        EXPECT_TRUE(std::isfinite(result.stddev[j]) && result.stddev[j] > 0.0) << what << " " << j;
      }
      for (const FixedParameter& f : result.identifiability.fixed) {
        EXPECT_EQ(result.x[f.index], 0.0);
        EXPECT_EQ(result.stddev[f.index], 0.0);
      }
      std::printf("%s: held-out RMS before %.3g m, after %.3g m; truth prediction RMS %.3g m, %.3g rad; "
                  "%d identifiable (theory %d); %.3f s\n",
                  what.c_str(), result.holdout_before.rms_position, result.holdout_after.rms_position, e.position,
                  e.rotation, result.identifiability.rank, result.identifiability.theoretical, result.seconds);
    }
  }
}

// 5 % of the rows 10 cm off: the robust loss rejects them and the calibrated model is as good as
// without them; the flagged rows are exactly the corrupted ones.
TEST(calibration, RobustLossRejectsOutliers) {
  const double sigma_p = 1e-4, sigma_r = 1e-3;
  const RobotModel nominal = load("ur5");
  const Truth truth = make_truth(nominal, 21);
  for (LossType loss : {LossType::Cauchy, LossType::Huber}) {
    for (bool orientation : {true, false}) {
      std::vector<Measurement> fit = measure(truth, 200, 22, sigma_p, sigma_r, orientation);
      std::mt19937_64 rng(23);
      std::normal_distribution<double> normal(0.0, 1.0);
      std::vector<int> corrupted;
      for (int k = 0; k < 200; k += 20) {
        const Vector3d direction = Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
        fit[static_cast<size_t>(k)].p_tracker_marker += 0.1 * direction;
        corrupted.push_back(k);
      }
      CalibrationOptions options;
      options.sigma_position = sigma_p;
      options.sigma_rotation = sigma_r;
      options.loss = loss;
      const CalibrationResult result = calibrate(nominal, fit, {}, options);
      const PredictionError e = prediction_error(nominal, result, truth, 24);
      const std::string what = std::string(to_string(loss)) + (orientation ? " pose" : " position");
      EXPECT_LT(e.position, (loss == LossType::Cauchy ? 0.5 : 1.0) * sigma_p) << what;
      EXPECT_EQ(result.fit_outliers, corrupted) << what;
      EXPECT_EQ(result.fit_after.outliers, 10);
      std::printf("%s: truth prediction RMS %.3g m with 5 %% outliers\n", what.c_str(), e.position);
    }
  }
  // Without a robust loss the same data pull the model centimetres off: the loss is what helps.
  std::vector<Measurement> fit = measure(truth, 200, 22, sigma_p, sigma_r, false);
  for (int k = 0; k < 200; k += 20) fit[static_cast<size_t>(k)].p_tracker_marker += Vector3d(0.1, 0.0, 0.0);
  CalibrationOptions options;
  options.loss = LossType::None;
  EXPECT_GT(prediction_error(nominal, calibrate(nominal, fit, {}, options), truth, 24).position, 10.0 * sigma_p);
}

TEST(calibration, TooFewRowsNameTheLines) {
  const RobotModel nominal = load("panda");
  const Truth truth = make_truth(nominal, 1);
  const std::vector<Measurement> fit = measure(truth, 20, 2, 0.0, 0.0, false);  // 60 residuals, 61 parameters
  try {
    calibrate(nominal, fit, {});
    FAIL() << "no error";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("lines 2-21"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("61 parameters"), std::string::npos) << e.what();
  }
}

TEST(calibration, HoldoutSplitIsSeededAndSized) {
  const std::vector<bool> a = holdout_split(200, 0.2, 1), b = holdout_split(200, 0.2, 1), c = holdout_split(200, 0.2, 2);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_EQ(std::count(a.begin(), a.end(), true), 40);
  EXPECT_EQ(std::count(a.begin(), a.begin() + 100, true) > 5, true);  // spread over the file
  EXPECT_EQ(std::count(a.begin() + 100, a.end(), true) > 5, true);
  const std::vector<bool> none = holdout_split(10, 0.0, 1);
  EXPECT_EQ(std::count(none.begin(), none.end(), true), 0);
  EXPECT_THROW(holdout_split(10, 1.0, 1), CalibrationError);
}

// The corrected model is the calibrated one: its FK with the reported base and tool equals the
// measurement model's own prediction, so the zero offsets are folded into the origins correctly.
TEST(calibration, CorrectedModelMatchesTheMeasurementModel) {
  const RobotModel nominal = load("arm");
  const MeasurementModel model(nominal, exp6(Vector6d::Constant(0.2)), exp6(Vector6d::Constant(0.05)), 1e-4, 1e-3);
  std::mt19937_64 rng(31);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd x(model.num_parameters());
  for (int j = 0; j < x.size(); ++j) x[j] = 0.05 * normal(rng);
  const KinematicCorrections c = model.corrections(x);
  const RobotModel corrected = corrected_model(nominal, c);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd q = random_q(nominal, rng);
    EXPECT_TRUE(testing::matrices_near(predict_marker(corrected, c, q).matrix(), model.predict(x, q).matrix(), 1e-12));
  }
}

// --- the corrected URDF ---------------------------------------------------------------------

TEST(calibrationUrdf, RpyRoundTripsEverywhereIncludingGimbalLock) {
  std::mt19937_64 rng(41);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Matrix3d> rotations;
  for (int k = 0; k < 200; ++k) rotations.push_back(exp3(Vector3d(normal(rng), normal(rng), normal(rng))));
  for (double pitch : {kPi / 2, -kPi / 2}) {
    for (double near : {0.0, 1e-12, 1e-8, 1e-5}) {
      rotations.push_back(rotation_from_rpy(Vector3d(0.3, pitch - near, -1.1)));
      rotations.push_back(rotation_from_rpy(Vector3d(normal(rng), pitch + near, normal(rng))));
    }
  }
  for (const Matrix3d& R : rotations) {
    // Rebuilt the way URDF defines rpy, independently of rotation_from_rpy.
    const Vector3d rpy = rpy_from_rotation(R);
    const double cr = std::cos(rpy[0]), sr = std::sin(rpy[0]), cp = std::cos(rpy[1]), sp = std::sin(rpy[1]),
                 cy = std::cos(rpy[2]), sy = std::sin(rpy[2]);
    Matrix3d rebuilt;
    rebuilt << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
        sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,         //
        -sp, cp * sr, cp * cr;
    EXPECT_TRUE(testing::matrices_near(rebuilt, R, 1e-15));
  }
}

/// T_base,link of `link` computed from urdfdom's own parse of `xml`: origins and joint motions
/// composed here, from the link up to the root, with none of chasles's loader.
Transform urdfdom_pose(const std::string& xml, const std::string& link_name, const RobotModel& model,
                       const Eigen::VectorXd& q) {
  const urdf::ModelInterfaceSharedPtr parsed = urdf::parseURDF(xml);
  EXPECT_TRUE(parsed != nullptr);
  Transform T = Transform::Identity();
  for (urdf::LinkConstSharedPtr link = parsed->getLink(link_name); link && link->parent_joint;
       link = parsed->getLink(link->parent_joint->parent_link_name)) {
    const urdf::Joint& joint = *link->parent_joint;
    const urdf::Pose& o = joint.parent_to_joint_origin_transform;
    const Transform origin(Eigen::Quaterniond(o.rotation.w, o.rotation.x, o.rotation.y, o.rotation.z).toRotationMatrix(),
                           Vector3d(o.position.x, o.position.y, o.position.z));
    const Vector3d axis = Vector3d(joint.axis.x, joint.axis.y, joint.axis.z).normalized();
    const int i = model.joint_index(joint.name);
    Transform motion;
    if (i >= 0 && joint.type == urdf::Joint::PRISMATIC) motion = Transform(Matrix3d::Identity(), axis * q[i]);
    if (i >= 0 && joint.type != urdf::Joint::PRISMATIC) {
      motion = Transform(Eigen::AngleAxisd(q[i], axis).toRotationMatrix(), Vector3d::Zero());
    }
    T = origin * motion * T;
  }
  return T;
}

// The written URDF loads in urdfdom and in chasles; FK to the marker link by both equals the
// calibrated model's, so the zero offsets and the tool are where a URDF user finds them; the rest
// of the robot (inertias, limits, links off the chain) is unchanged.
TEST(calibrationUrdf, CorrectedUrdfCarriesTheCalibration) {
  for (const char* robot : {"ur5", "panda", "arm"}) {
    const std::string xml = testing::read_file(testing::data_path(std::string(robot) + ".urdf"));
    const RobotModel nominal = load(robot);
    const MeasurementModel model(nominal, exp6(Vector6d::Constant(0.2)), exp6(Vector6d::Constant(0.05)), 1e-4, 1e-3);
    std::mt19937_64 rng(43);
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::VectorXd x(model.num_parameters());
    for (int j = 0; j < x.size(); ++j) x[j] = 0.01 * normal(rng);
    x.segment<6>(model.layout().origin(0, 0)).setZero();  // one joint left alone
    x[model.layout().offset(0)] = 0.0;
    const KinematicCorrections c = model.corrections(x);
    const std::string corrected = corrected_urdf(xml, nominal, c);

    UrdfOptions to_marker;
    to_marker.tip_link = "marker";
    const RobotModel loaded = load_urdf_string(corrected, to_marker, "corrected");
    UrdfOptions to_tip;
    to_tip.tip_link = nominal.tip_link();
    const RobotModel loaded_tip = load_urdf_string(corrected, to_tip, "corrected");
    ASSERT_EQ(loaded.dof(), nominal.dof());
    for (int k = 0; k < 10; ++k) {
      const Eigen::VectorXd q = random_q(nominal, rng);
      const Transform expected = inverse(c.T_tracker_base) * model.predict(x, q);
      EXPECT_TRUE(testing::matrices_near(forward_kinematics_space(loaded, q).matrix(), expected.matrix(), 1e-12)) << robot;
      EXPECT_TRUE(testing::matrices_near(urdfdom_pose(corrected, "marker", nominal, q).matrix(), expected.matrix(), 1e-12))
          << robot;
    }
    for (int i = 0; i < nominal.dof(); ++i) {
      EXPECT_TRUE(testing::matrices_near(loaded_tip.inertia(i), nominal.inertia(i), 1e-12)) << robot << " body " << i;
      EXPECT_EQ(loaded_tip.joint(i).limits.lower, nominal.joint(i).limits.lower);
      EXPECT_EQ(loaded_tip.joint(i).limits.upper, nominal.joint(i).limits.upper);
      EXPECT_EQ(loaded_tip.joint(i).limits.effort, nominal.joint(i).limits.effort);
    }
    // The untouched joint keeps its original text; every corrected one records the original.
    const std::string first = nominal.joint(0).name;
    EXPECT_EQ(corrected.find("origin was", corrected.find("name=\"" + first + "\"")),
              corrected.find("origin was", corrected.find("name=\"" + nominal.joint(1).name + "\"")));
    size_t notes = 0;
    for (size_t at = corrected.find("origin was"); at != std::string::npos; at = corrected.find("origin was", at + 1)) ++notes;
    EXPECT_EQ(notes, static_cast<size_t>(nominal.dof() - 1)) << robot;
    // Calibrating the corrected file again needs another marker name.
    EXPECT_THROW(corrected_urdf(corrected, loaded_tip, c), CalibrationError);
  }
}

// --- the identified URDF -------------------------------------------------------------------------

RobotModel load_identified(const std::string& xml, const RobotModel& like) {
  UrdfOptions options;
  options.tip_link = like.tip_link();
  return load_urdf_string(xml, options, "identified");
}

/// The model with every body's mass distribution scaled by 0.9–1.1 and carried by a small rigid
/// motion (G ← s [Ad_X]ᵀ G [Ad_X]: a congruence, so every body stays physical), and armature.
RobotModel perturbed_bodies(const RobotModel& nominal, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ChainDescription d = nominal.description();
  for (Matrix6d& G : d.inertia) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = normal(rng) * (k < 3 ? 0.2 : 0.02);
    const Matrix6d Ad = adjoint(exp6(xi));
    G = (0.9 + 0.2 * unit(rng)) * Ad.transpose() * G * Ad;
  }
  Eigen::VectorXd armature(nominal.dof());
  for (int i = 0; i < nominal.dof(); ++i) armature[i] = 0.05 + 0.2 * unit(rng);
  return with_armature(RobotModel(std::move(d)), armature);
}

TEST(identifiedUrdf, AModelsOwnParametersLoadBackAsTheSameModel) {
  for (const char* robot : {"panda", "iiwa14", "ur5"}) {
    const std::string xml = testing::read_file(testing::data_path(std::string(robot) + ".urdf"));
    UrdfOptions options;
    const std::string name = robot;
    options.tip_link = name == "iiwa14" ? "iiwa_link_ee" : name == "ur5" ? "tool0" : "panda_hand";
    const RobotModel nominal = load_urdf_string(xml, options, robot);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(nominal.dof());
    const RobotModel loaded = load_identified(identified_urdf(xml, nominal, zero, zero), nominal);
    ASSERT_EQ(loaded.dof(), nominal.dof());
    for (int i = 0; i < nominal.dof(); ++i) {
      EXPECT_TRUE(testing::matrices_near_relative(loaded.inertia(i), nominal.inertia(i), 1e-12))
          << robot << " body " << i;
      EXPECT_NEAR(loaded.armature()[i], nominal.armature()[i], 1e-12 * std::max(1.0, nominal.armature()[i])) << robot;
      EXPECT_TRUE(testing::matrices_near(loaded.joint(i).T_parent_joint.matrix(),
                                         nominal.joint(i).T_parent_joint.matrix(), 0.0));
    }
  }
}

TEST(identifiedUrdf, APerturbedModelLoadsBackWithItsDynamicsAndFriction) {
  const std::string xml = testing::read_file(testing::data_path("panda.urdf"));
  const RobotModel nominal = load("panda");
  const RobotModel identified = perturbed_bodies(nominal, 61);
  Eigen::VectorXd viscous(7), coulomb(7);
  viscous << 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7;
  coulomb << 1.5, 1.4, 1.3, 1.2, 1.1, 1.0, 0.9;
  const std::string text = identified_urdf(xml, identified, viscous, coulomb, "a test");
  const RobotModel loaded = load_identified(text, nominal);

  // The dynamics, armature included, of the model that was written.
  std::mt19937_64 rng(62);
  std::normal_distribution<double> normal(0.0, 1.0);
  Data expected_data(identified), loaded_data(loaded);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd q = random_q(nominal, rng);
    Eigen::VectorXd qd(7), qdd(7);
    for (int i = 0; i < 7; ++i) qd[i] = normal(rng), qdd[i] = normal(rng);
    const Eigen::VectorXd expected = inverse_dynamics(identified, expected_data, q, qd, qdd);
    EXPECT_TRUE(testing::matrices_near_relative(inverse_dynamics(loaded, loaded_data, q, qd, qdd), expected, 1e-9));
  }
  // Friction where URDF keeps it, the rotors as Drake's, the riders as they were.
  const urdf::ModelInterfaceSharedPtr parsed = urdf::parseURDF(text);
  ASSERT_TRUE(parsed);
  for (int i = 0; i < 7; ++i) {
    const urdf::JointConstSharedPtr joint = parsed->getJoint(nominal.joint(i).name);
    ASSERT_TRUE(joint && joint->dynamics);
    EXPECT_EQ(joint->dynamics->damping, viscous[i]);
    EXPECT_EQ(joint->dynamics->friction, coulomb[i]);
    EXPECT_NE(text.find("name=\"" + nominal.joint(i).name + "_rotor\""), std::string::npos);
  }
  EXPECT_EQ(parsed->getLink("panda_hand")->inertial->mass, 0.73);
  EXPECT_EQ(parsed->getLink("panda_leftfinger")->inertial->mass, 0.015);
  EXPECT_NE(text.find("xmlns:drake=\"http://drake.mit.edu\""), std::string::npos);
  EXPECT_NE(text.find("a test"), std::string::npos);
  // Each changed element keeps its original beside it: seven bodies, seven <dynamics>.
  size_t notes = 0;
  for (size_t at = text.find("; was <"); at != std::string::npos; at = text.find("; was <", at + 1)) ++notes;
  EXPECT_EQ(notes, 14u);
}

TEST(identifiedUrdf, ABodyLighterThanItsRidersIsRefusedNamingThem) {
  const std::string xml = testing::read_file(testing::data_path("panda.urdf"));
  const RobotModel nominal = load("panda");
  ChainDescription d = nominal.description();
  d.inertia[6] *= 0.3;  // 0.45 kg, against the hand's 0.73 and the fingers' 0.03
  const RobotModel light(std::move(d));
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(7);
  try {
    identified_urdf(xml, light, zero, zero);
    FAIL() << "no CalibrationError";
  } catch (const CalibrationError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("the identified body moved by joint 'panda_joint7' weighs"), std::string::npos) << what;
    EXPECT_NE(what.find("'panda_hand', 'panda_leftfinger', 'panda_rightfinger'"), std::string::npos) << what;
  }
}

// --- datasets ----------------------------------------------------------------------------------

TEST(calibrationDataset, RoundTripsAndAcceptsAnyColumnOrder) {
  const RobotModel nominal = load("ur5");
  const Truth truth = make_truth(nominal, 51);
  const std::vector<Measurement> rows = measure(truth, 5, 52, 1e-4, 1e-3, true);
  const Dataset back = parse_dataset(format_dataset(nominal, rows, true), nominal, "d.csv");
  ASSERT_EQ(back.rows.size(), rows.size());
  EXPECT_TRUE(back.has_orientation);
  for (size_t k = 0; k < rows.size(); ++k) {
    EXPECT_EQ(back.rows[k].q, rows[k].q);
    EXPECT_EQ(back.rows[k].p_tracker_marker, rows[k].p_tracker_marker);
    EXPECT_TRUE(testing::matrices_near(back.rows[k].R_tracker_marker, rows[k].R_tracker_marker, 1e-15));
    EXPECT_EQ(back.rows[k].line, static_cast<int>(k) + 2);
  }
  const std::string shuffled =
      "# measured 2024-05-01\r\nz, y, x, wrist_3_joint,wrist_2_joint,wrist_1_joint,elbow_joint,shoulder_lift_joint,"
      "shoulder_pan_joint\r\n\r\n3,2,1,0.6,0.5,0.4,0.3,0.2,0.1\r\n";
  const Dataset d = parse_dataset(shuffled, nominal, "s.csv");
  ASSERT_EQ(d.rows.size(), 1u);
  EXPECT_FALSE(d.has_orientation);
  EXPECT_EQ(d.rows[0].line, 4);
  EXPECT_EQ(d.rows[0].p_tracker_marker, Vector3d(1, 2, 3));
  EXPECT_NEAR(d.rows[0].q[0], 0.1, 0.0);
  EXPECT_NEAR(d.rows[0].q[5], 0.6, 0.0);
}

TEST(calibrationDataset, BadInputNamesTheLine) {
  const RobotModel nominal = load("ur5");
  const std::string header =
      "shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,wrist_3_joint,x,y,z";
  const std::string good = "0,0,0,0,0,0,1,2,3";
  struct Case {
    std::string text, fragment;
  };
  const std::vector<Case> cases = {
      {header + "\n" + good + "\n0,0,0,0,0,nan,1,2,3\n", "bad.csv:3: column 'wrist_3_joint': 'nan' is not a finite number"},
      {header + "\n" + good + "\n" + good + "\n0,0,0,0,0,1,2,3\n", "bad.csv:4: 8 fields, expected 9"},
      {header + "\n0,0,0,0,0,0,1,2,inf\n", "bad.csv:2: column 'z'"},
      {header + "\n0,0,0,0,x,0,1,2,3\n", "bad.csv:2: column 'wrist_2_joint': 'x' is not a finite number"},
      {header + "\n0,0,0,0,,0,1,2,3\n", "bad.csv:2: column 'wrist_2_joint'"},
      {"shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,wrist_9_joint,x,y,z\n" + good,
       "bad.csv:1: unknown column 'wrist_9_joint'"},
      {"shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,x,y,z\n0,0,0,0,0,1,2,3",
       "bad.csv:1: no column for joint 'wrist_3_joint'"},
      {header + ",x\n", "bad.csv:1: column 'x' appears twice"},
      {header + ",qw,qx\n", "bad.csv:1: the orientation needs all four columns"},
      {header + ",qw,qx,qy,qz\n" + good + ",2,0,0,0\n", "bad.csv:2: the quaternion (qw, qx, qy, qz) has norm 2"},
      {header + "\n", "no data rows"},
      {"", "no header line"},
  };
  for (const Case& c : cases) {
    try {
      parse_dataset(c.text, nominal, "bad.csv");
      ADD_FAILURE() << "no error for: " << c.text;
    } catch (const CalibrationError& e) {
      EXPECT_NE(std::string(e.what()).find(c.fragment), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace chasles
