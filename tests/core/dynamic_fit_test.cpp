// Dynamic identification against independent truths: the zero-phase filter against the
// Butterworth magnitude |H|² = 1 / (1 + (tan(π f / f_s) / tan(π f_c / f_s))^2N) and against
// analytic derivatives; the fit against a Panda changed here (tests/support/identification_run:
// log-Cholesky offsets, friction, rotors) whose torques come from RNEA, not from the regressor.
#include "core/identification/dynamic_fit.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/dynamics/dynamics.hpp"
#include "core/identification/log_cholesky.hpp"
#include "core/model/payload.hpp"
#include "core/model/urdf.hpp"
#include "core/identification/zero_phase_filter.hpp"
#include "support/arm.hpp"
#include "support/identification_run.hpp"
#include "support/reference.hpp"

namespace chasles {
namespace {

using testing::panda;

Eigen::VectorXd times(double seconds, double rate_hz) {
  return Eigen::VectorXd::LinSpaced(static_cast<Eigen::Index>(std::lround(seconds * rate_hz)), 0.0,
                                    seconds - 1.0 / rate_hz);
}

// The filtfilt gain of a digital Butterworth low-pass at f: the square of its magnitude.
double butterworth_gain(double f, double fc, double fs, int order) {
  return 1.0 / (1.0 + std::pow(std::tan(kPi * f / fs) / std::tan(kPi * fc / fs), 2 * order));
}

TEST(zeroPhaseFilter, SinusoidsPassWithButterworthGainAndNoPhase) {
  const double fs = 1000.0, fc = 10.0;
  const LowPassFilter filter = butterworth_low_pass(4, fc, fs);
  const Eigen::VectorXd t = times(20.0, fs);
  for (const double f : {0.5, 1.0, 5.0, 10.0, 20.0}) {
    const Eigen::VectorXd x = (2.0 * kPi * f * t).array().sin();
    const Eigen::VectorXd y = zero_phase_filter(filter, x);
    // y ≈ g (cos φ sin ωt + sin φ cos ωt) over whole periods in the middle, away from the ends.
    const Eigen::Index a = 5000, m = 10000;
    Eigen::MatrixXd basis(m, 2);
    basis.col(0) = (2.0 * kPi * f * t.segment(a, m)).array().sin();
    basis.col(1) = (2.0 * kPi * f * t.segment(a, m)).array().cos();
    const Eigen::Matrix2d normal = basis.transpose() * basis;  // well conditioned: whole periods
    const Eigen::Vector2d c = normal.inverse() * (basis.transpose() * y.segment(a, m));
    const double gain = c.norm();
    EXPECT_NEAR(gain, butterworth_gain(f, fc, fs, 4), 1e-9) << "f = " << f << " Hz";
    if (f <= fc) {
      EXPECT_NEAR(std::atan2(c[1], c[0]), 0.0, 1e-9) << "f = " << f << " Hz";
    }
  }
  EXPECT_NEAR(butterworth_gain(fc, fc, fs, 4), 0.5, 1e-15);  // −3 dB each way: −6 dB in all
}

TEST(zeroPhaseFilter, EndsStartInSteadyStateAndKeepARamp) {
  // The point reflection continues a line exactly, and a line passes a zero-phase filter with
  // unit DC gain unchanged: so a ramp comes out as it went in, ends included.
  const LowPassFilter filter = butterworth_low_pass(4, 10.0, 1000.0);
  const Eigen::VectorXd t = times(2.0, 1000.0);
  const Eigen::VectorXd ramp = (3.0 - 2.0 * t.array()).matrix();
  EXPECT_LT((zero_phase_filter(filter, ramp) - ramp).cwiseAbs().maxCoeff(), 1e-6);
  const Eigen::VectorXd constant = Eigen::VectorXd::Constant(50, -1.25);  // shorter than the padding
  EXPECT_LT((zero_phase_filter(filter, constant) - constant).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(zeroPhaseFilter, AccelerationOfASmoothVelocityMatchesItsDerivative) {
  const double fs = 1000.0, dt = 1.0 / fs;
  const LowPassFilter filter = butterworth_low_pass(4, 10.0, fs);
  const Eigen::VectorXd t = times(10.0, fs);
  const double f[3] = {0.3, 1.1, 2.3}, a[3] = {1.0, 0.5, 0.2}, phase[3] = {0.4, 1.9, -0.7};
  Eigen::VectorXd qd = Eigen::VectorXd::Zero(t.size()), qdd = qd;
  for (int l = 0; l < 3; ++l) {
    const double w = 2.0 * kPi * f[l];
    qd += a[l] * (w * t.array() + phase[l]).sin().matrix();
    qdd += a[l] * w * (w * t.array() + phase[l]).cos().matrix();
  }
  const Eigen::VectorXd estimate = central_difference(zero_phase_filter(filter, qd), dt);
  const double scale = qdd.cwiseAbs().maxCoeff();
  // Within 1e-4 beyond the 2 / f_c s the fit leaves out at either end, within 2e-5 (the
  // differences' own error) a second in; at the very ends, where the reflection's third
  // derivative has the wrong sign, within 1 %.
  const Eigen::Index trimmed = 200, second = 1000;
  const Eigen::VectorXd error = (estimate - qdd).cwiseAbs() / scale;
  EXPECT_LT(error.segment(trimmed, t.size() - 2 * trimmed).maxCoeff(), 1e-4);
  EXPECT_LT(error.segment(second, t.size() - 2 * second).maxCoeff(), 2e-5);
  EXPECT_LT(error.maxCoeff(), 1e-2);
  // The differences alone are fourth-order accurate inside (halving the step divides their error
  // by 16) and second-order in the two samples at either end (by 4).
  const auto errors = [](double rate) {
    const Eigen::VectorXd t_rate = times(1.0, rate);
    const Eigen::VectorXd e = central_difference((2.0 * kPi * 3.0 * t_rate.array()).sin().matrix(), 1.0 / rate) -
                              2.0 * kPi * 3.0 * (2.0 * kPi * 3.0 * t_rate.array()).cos().matrix();
    return std::pair{e.segment(2, t_rate.size() - 4).cwiseAbs().maxCoeff(),
                     std::max(e.head(2).cwiseAbs().maxCoeff(), e.tail(2).cwiseAbs().maxCoeff())};
  };
  const auto [inside, ends] = errors(200.0);
  const auto [inside_fine, ends_fine] = errors(400.0);
  EXPECT_NEAR(inside / inside_fine, 16.0, 0.3);
  EXPECT_NEAR(ends / ends_fine, 4.0, 0.3);
}

TEST(zeroPhaseFilter, RefusesDesignsItCannotMake) {
  EXPECT_THROW(butterworth_low_pass(3, 10.0, 1000.0), ArgumentError);
  EXPECT_THROW(butterworth_low_pass(10, 10.0, 1000.0), ArgumentError);
  EXPECT_THROW(butterworth_low_pass(4, 500.0, 1000.0), ArgumentError);
  EXPECT_THROW(butterworth_low_pass(4, 0.0, 1000.0), ArgumentError);
  EXPECT_THROW(zero_phase_filter(butterworth_low_pass(4, 10.0, 1000.0), Eigen::VectorXd::Zero(1)), ArgumentError);
}

// One fit shared by the tests that judge it: 12 s of the true arm at 500 Hz, noise 0.05 N·m.
constexpr double kNoise = 0.05;

struct Fit {
  testing::TrueArm truth = testing::perturbed_panda(7);
  DynamicFitResult result = identify_dynamics(panda(), testing::synthetic_run(truth, 12.0, 500.0, kNoise, 11));
};

const Fit& fit() {
  static const Fit f;
  return f;
}

TEST(dynamicFit, FindsTheBaseParametersTheoryCounts) {
  const DynamicFitResult& r = fit().result;
  EXPECT_EQ(r.base.count, 62);  // 43 inertial + 14 friction + 5 rotors (regressor_test.cpp)
  EXPECT_EQ(r.rank, r.base.count);
  EXPECT_EQ(r.log.decimation, 20);  // 500 Hz to 2.5 × 10 Hz
  EXPECT_EQ(r.log.segments, 1);
  EXPECT_EQ(r.log.holdout_blocks, (std::vector<int>{8, 9}));  // the end of the motion
  EXPECT_GT(r.condition_number, r.condition_number_scaled);  // SI units spread the columns
}

TEST(dynamicFit, RecoversTheTrueBaseParametersWithinTheirStandardErrors) {
  const Fit& f = fit();
  const DynamicFitResult& r = f.result;
  const Eigen::VectorXd beta_true = base_parameter_values(r.base, f.truth.parameters());
  const Eigen::VectorXd z = (r.beta - beta_true).cwiseQuotient(r.beta_standard_error);
  Eigen::Index worst = 0;
  z.cwiseAbs().maxCoeff(&worst);
  EXPECT_LT(std::abs(z[worst]), 4.0) << base_parameter_expression(panda(), r.base, static_cast<int>(worst)) << ": "
                                      << r.beta[worst] << " vs true " << beta_true[worst] << " ± "
                                      << r.beta_standard_error[worst];
  // The standard errors say what the errors are: neither far too small nor far too large.
  const double rms_z = std::sqrt(z.squaredNorm() / static_cast<double>(z.size()));
  EXPECT_GT(rms_z, 0.3);
  EXPECT_LT(rms_z, 2.0);
  std::printf("base parameters: max |z| %.2f (%s), RMS z %.2f; %d samples fitted, condition number %.3g (%.3g with "
              "unit columns); fit %.3f s (solver %.3f s, %d iterations)\n",
              std::abs(z[worst]), base_parameter_expression(panda(), r.base, static_cast<int>(worst)).c_str(), rms_z,
              r.log.fit_samples, r.condition_number, r.condition_number_scaled, r.seconds, r.solver_seconds,
              r.iterations);
}

TEST(dynamicFit, PredictsHeldOutTorquesToTheNoise) {
  const DynamicFitResult& r = fit().result;
  EXPECT_NEAR(r.log.holdout_seconds, 0.2 * r.log.motion_seconds, 0.01);  // the last 2 of 10 blocks of the motion
  for (int i = 0; i < panda().dof(); ++i) {
    EXPECT_LE(r.holdout_rms[i], 1.5 * kNoise) << panda().joint(i).name;
    EXPECT_GE(r.holdout_rms_nominal[i], 10.0 * r.holdout_rms[i]) << panda().joint(i).name;
    std::printf("%s: held-out RMS %.4f -> %.4f N*m\n", panda().joint(i).name.c_str(), r.holdout_rms_nominal[i],
                r.holdout_rms[i]);
  }
}

TEST(dynamicFit, EveryBodyIsPhysicalAndEveryFrictionNonNegative) {
  const DynamicFitResult& r = fit().result;
  const ParameterLayout layout = parameter_layout(panda());
  for (int i = 0; i < layout.n; ++i) {
    EXPECT_NO_THROW(log_cholesky_from_inertia(r.pi.segment<10>(layout.inertial(i)))) << panda().joint(i).name;
    EXPECT_GE(r.pi[layout.viscous(i)], 0.0);
    EXPECT_GE(r.pi[layout.coulomb(i)], 0.0);
    EXPECT_GE(r.pi[layout.armature(i)], 0.0);
  }
  EXPECT_NO_THROW(identified_model(panda(), r.pi));
}

// A run of the arm with the fit's defaults, to be spoilt.
JointSamples good_run(double seconds = 12.0) {
  return testing::synthetic_run(testing::perturbed_panda(7), seconds, 500.0, kNoise, 11);
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const IdentificationError& e) {
    return e.what();
  }
  return "no IdentificationError";
}

TEST(dynamicFit, BadInputIsRefusedSayingWhat) {
  JointSamples samples = good_run(3.0);
  JointSamples six = samples;
  six.q.conservativeResize(6, Eigen::NoChange);
  EXPECT_NE(error_of([&] { identify_dynamics(panda(), six); }).find("has 7 joints"), std::string::npos);

  JointSamples not_finite = samples;
  not_finite.qd(2, 100) = std::nan("");
  EXPECT_EQ(error_of([&] { identify_dynamics(panda(), not_finite); }),
            "sample 100 (t = 0.2 s): joint 'panda_joint3' velocity is nan; every value must be finite");

  JointSamples backwards = samples;
  backwards.t[40] = backwards.t[39];
  EXPECT_NE(error_of([&] { identify_dynamics(panda(), backwards); }).find("sample 40 (t = 0.078 s) is not after"),
            std::string::npos);

  const std::string short_log = error_of([&] { identify_dynamics(panda(), good_run(1.0)); });
  EXPECT_NE(short_log.find("the log is too short: 0.998 s at 500 Hz hold 0.598 s of motion, which give 12 samples "
                           "to fit (61 torques) for 62 base parameters, and 59 held out; left out: 0 s of rest and, in "
                           "the motion, 27 % of the joints' torques where they were slow or stuck; the fit needs 15 "
                           "torques per parameter: log at least 9.55 s of motion"),
            std::string::npos)
      << short_log;

  // 3 s once passed, 7 torques per parameter, and its report claimed 0.05–0.1 N·m where another
  // motion showed 0.39: the fit follows a short motion and nothing else.
  const std::string three = error_of([&] { identify_dynamics(panda(), samples); });
  EXPECT_NE(three.find("the log is too short: 3 s at 500 Hz hold 2.6 s of motion"), std::string::npos) << three;

  const JointSamples still = testing::synthetic_run(testing::perturbed_panda(7), 12.0, 500.0, kNoise, 11, 4);
  EXPECT_EQ(error_of([&] { identify_dynamics(panda(), still); }),
            "the log does not excite the arm: joints that barely move: 'panda_joint5' (range 0), under 0.0175 rad or "
            "m; run an excitation trajectory that moves every joint");

  DynamicFitOptions fast;
  fast.cutoff_hz = 300.0;
  EXPECT_NE(error_of([&] { identify_dynamics(panda(), samples, fast); })
                .find("the cut-off 300 Hz is not below the log's Nyquist frequency 250 Hz"),
            std::string::npos);
}

// Rest before the motion, as a log started by hand has: the arm held still, its torques gravity
// plus whatever static friction holds (up to 0.8 N·m here, under the breakaway), which no model
// of the moving arm explains. The rest is left out whole and the fit is as good as without it.
TEST(dynamicFit, RestInTheLogIsLeftOut) {
  const testing::TrueArm truth = testing::perturbed_panda(7);
  const JointSamples motion = good_run();
  const Eigen::Index n = 7, rest = 3000, N = motion.t.size();  // 6 s at 500 Hz
  JointSamples log;
  log.t = Eigen::VectorXd::LinSpaced(rest + N, 0.0, static_cast<double>(rest + N - 1) / 500.0);
  log.q.resize(n, rest + N), log.qd.resize(n, rest + N), log.tau.resize(n, rest + N);
  log.q.rightCols(N) = motion.q, log.qd.rightCols(N) = motion.qd, log.tau.rightCols(N) = motion.tau;
  Data data(truth.model);
  const Eigen::VectorXd held = gravity_torques(truth.model, data, motion.q.col(0)) +
                               Eigen::VectorXd::LinSpaced(n, 0.8, -0.8);  // static friction's share
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, kNoise);
  for (Eigen::Index k = 0; k < rest; ++k) {
    log.q.col(k) = motion.q.col(0);
    log.qd.col(k).setZero();
    for (Eigen::Index i = 0; i < n; ++i) log.tau(i, k) = held[i] + noise(rng);
  }
  // The rest ends at a standstill, the motion starts moving: the step between is within the
  // 1 / f_c s either side of the slow samples that the fit leaves out.
  const DynamicFitResult r = identify_dynamics(panda(), log);
  EXPECT_NEAR(r.log.rest_seconds, 6.0, 0.3);
  EXPECT_NEAR(r.log.motion_seconds, fit().result.log.motion_seconds + 0.2, 0.3);
  for (int i = 0; i < 7; ++i) {
    EXPECT_LE(r.holdout_rms[i], 1.5 * kNoise) << panda().joint(i).name;
    EXPECT_GE(r.holdout_rms_nominal[i], 10.0 * r.holdout_rms[i]) << panda().joint(i).name;
  }
}

TEST(dynamicFit, AJointStuckForMostOfTheMotionIsNamed) {
  JointSamples stuck = good_run();
  for (Eigen::Index k = 1000; k < stuck.t.size(); ++k) {  // panda_joint7 sticks after 2 s
    stuck.q(6, k) = stuck.q(6, 999);
    stuck.qd(6, k) = 0.0;
  }
  const std::string message = error_of([&] { identify_dynamics(panda(), stuck); });
  EXPECT_NE(message.find("joints stuck or still for most of the motion: 'panda_joint7' (moving 1"), std::string::npos)
      << message;
}

// A Panda's log given an iiwa's URDF: both have seven joints, but the Panda's wrist runs where the
// iiwa's cannot go.
TEST(dynamicFit, AnotherArmsLogIsRefused) {
  const RobotModel iiwa = load_urdf_file(testing::data_path("iiwa14.urdf"), UrdfOptions{"iiwa_link_ee"});
  const std::string message = error_of([&] { identify_dynamics(iiwa, good_run()); });
  EXPECT_NE(message.find("the log's joints leave the URDF's limits: 'iiwa_joint_6' spans [1.19, 2.63] against "
                         "[-2.09, 2.09] (rad or m)"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("a log of another arm, or the wrong URDF or tip link?"), std::string::npos) << message;

  // A continuous joint, whose model says ±π, may turn any number of times: two turns of j3 pass the
  // check (and the log is refused for what it is: j1 and j2 stand still).
  const RobotModel arm = load_urdf_file(testing::data_path("arm.urdf"), UrdfOptions{"tip"});
  JointSamples turning;
  turning.t = Eigen::VectorXd::LinSpaced(1000, 0.0, 1.998);
  turning.q = Eigen::MatrixXd::Zero(3, 1000);
  turning.q.row(1).setConstant(0.25);
  turning.q.row(2) = 2.0 * kPi * turning.t.transpose();
  turning.qd = Eigen::MatrixXd::Zero(3, 1000);
  turning.qd.row(2).setConstant(2.0 * kPi);
  turning.tau = Eigen::MatrixXd::Zero(3, 1000);
  const std::string turns = error_of([&] { identify_dynamics(arm, turning); });
  EXPECT_NE(turns.find("joints that barely move: 'j1' (range 0), 'j2' (range 0)"), std::string::npos) << turns;
}

// A fit stopped before it converged is a guess at the bodies: refused, not written.
TEST(dynamicFit, AFitThatDoesNotConvergeIsRefused) {
  DynamicFitOptions one;
  one.max_iterations = 1;
  const std::string message = error_of([&] { identify_dynamics(panda(), good_run(), one); });
  EXPECT_NE(message.find("dynamic identification: the fit did not converge (1 iterations"), std::string::npos)
      << message;
}

TEST(dynamicFit, ALogThatLeavesACombinationOpenIsRefused) {
  // Every joint moves far enough, but at one constant speed: nothing tells viscous friction from
  // Coulomb's, nor the inertias from anything (q̈ = 0).
  JointSamples slow = good_run();
  const Eigen::Index N = slow.t.size();
  const double speed = 0.15;  // rad/s, above the fit's min_speed; ±0.9 rad about the middles
  for (Eigen::Index k = 0; k < N; ++k) {
    for (int i = 0; i < 7; ++i) {
      const JointLimits& l = panda().joint(i).limits;
      slow.q(i, k) = 0.5 * (l.lower + l.upper) + speed * (slow.t[k] - 0.5 * slow.t[N - 1]);
    }
    slow.qd.col(k) = speed * Eigen::VectorXd::Ones(7);
  }
  const std::string message = error_of([&] { identify_dynamics(panda(), slow); });
  EXPECT_NE(message.find("the log does not excite the arm: the torques determine"), std::string::npos) << message;
}

// --- the payload ---------------------------------------------------------------------------------

// A 1.2 kg box, 8 × 6 × 14 cm, its centre 2 cm, −1 cm and 8 cm from the tip, turned 0.3 rad about x.
Payload box_payload() {
  Payload p;
  p.mass = 1.2;
  p.centre = Vector3d(0.02, -0.01, 0.08);
  const Vector3d sides(0.08, 0.06, 0.14);
  const Matrix3d R = Eigen::AngleAxisd(0.3, Vector3d::UnitX()).toRotationMatrix();
  const Vector3d moments(sides[1] * sides[1] + sides[2] * sides[2], sides[0] * sides[0] + sides[2] * sides[2],
                         sides[0] * sides[0] + sides[1] * sides[1]);
  p.inertia = R * (p.mass / 12.0 * moments).asDiagonal() * R.transpose();
  return p;
}

TEST(payloadFit, ParametersAreWhatWithPayloadAddsToTheLastBody) {
  const Payload p = box_payload();
  const int last = panda().dof() - 1;
  const Matrix6d added = with_payload(panda(), p).inertia(last) - panda().inertia(last);
  EXPECT_TRUE(added.isApprox(spatial_inertia(payload_parameters(panda(), p)).matrix(), 1e-12));
  const Payload back = payload_from_parameters(panda(), payload_parameters(panda(), p));
  EXPECT_NEAR(back.mass, p.mass, 1e-15);
  EXPECT_LT((back.centre - p.centre).norm(), 1e-15);
  EXPECT_LT((back.inertia - p.inertia).norm(), 1e-15);
}

TEST(payloadFit, FindsTheBoxOnAKnownArm) {
  const testing::TrueArm arm = testing::perturbed_panda(7);
  const Payload box = box_payload();
  const testing::TrueArm carrying{with_payload(arm.model, box), arm.viscous, arm.coulomb};
  const PayloadFitResult r =
      identify_payload(arm.model, arm.viscous, arm.coulomb, testing::synthetic_run(carrying, 6.0, 500.0, kNoise, 13));
  const Vector10d truth = payload_parameters(panda(), box);
  const Vector10d z = (r.pi - truth).cwiseQuotient(r.standard_error);
  for (int k = 0; k < 10; ++k) EXPECT_LT(std::abs(z[k]), 4.0) << kInertialParameterNames[k];
  EXPECT_NEAR(r.payload.mass, box.mass, 0.02);
  EXPECT_LT((r.payload.centre - box.centre).norm(), 3e-3);
  double without = 0.0, with = 0.0;
  for (int i = 0; i < panda().dof(); ++i) {
    EXPECT_LE(r.holdout_rms[i], 1.5 * kNoise) << panda().joint(i).name;
    without += r.holdout_rms_without[i] * r.holdout_rms_without[i];
    with += r.holdout_rms[i] * r.holdout_rms[i];
  }
  EXPECT_GE(std::sqrt(without), 10.0 * std::sqrt(with));
  EXPECT_TRUE(payload_problem(r.payload).empty()) << payload_problem(r.payload);
  std::printf("payload: %.4f kg (± %.4f), centre (%.4f, %.4f, %.4f) m, max |z| %.2f; held-out RMS %.3f -> %.4f N*m "
              "(all joints); %.3f s, %d iterations\n",
              r.payload.mass, r.mass_standard_error, r.payload.centre.x(), r.payload.centre.y(), r.payload.centre.z(),
              z.cwiseAbs().maxCoeff(), std::sqrt(without / 7), std::sqrt(with / 7), r.seconds, r.iterations);
}

TEST(payloadFit, BadInputIsRefused) {
  const testing::TrueArm arm = testing::perturbed_panda(7);
  const JointSamples samples = testing::synthetic_run(arm, 0.4, 500.0, kNoise, 13);
  EXPECT_THROW(identify_payload(arm.model, arm.viscous.head(6), arm.coulomb, samples), ArgumentError);
  const std::string message = error_of([&] { identify_payload(arm.model, arm.viscous, arm.coulomb, samples); });
  EXPECT_NE(message.find("the log is too short: 0.398 s at 500 Hz hold 0 s of motion, which give 0 samples to fit "
                         "(0 torques) for 10 payload parameters, and 0 held out; the fit needs 15 torques per "
                         "parameter: log at least"),
            std::string::npos)
      << message;
}

}  // namespace
}  // namespace chasles
