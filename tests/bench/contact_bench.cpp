// chasles_contact_bench: chasles's momentum observer and tip wrench (core/contact) against Orocos
// KDL 1.5.1's ChainExternalWrenchEstimator, on the same recorded motion of the UR5 and the Panda,
// in one run: the time per update of each, and the accuracy of each against the true external
// joint torque and tip wrench. tools/bench.sh runs it; it prints two tables on stdout (the
// benchmark's own lines go to stderr).
//
// The recording (made here, before anything is timed): the arm simulated at 1 kHz by RK4 on
// chasles's forward dynamics (kSubsteps per period), a computed-torque PD controller following
// quintic moves q0 → q1, hold, q1 → q2, hold, its torque decided at each sample and held until the
// next; at kPushStart a push switches on at the tip, ramping over kPushRamp to a force of 20 N and
// a moment of 1 N·m, both fixed in the base frame (at the tip's origin) and held to the end. Each
// sample k holds q_k, q̇_k, the torque applied over the step that ended at sample k (what a
// torque-controlled arm reports as measured, and what both estimators want), and the truth:
// F_env, the wrench the environment applies to the tip, in the tip frame, (m, f), and
// τ_ext = J_bᵀ F_env.
//
// What is timed, per update (one sample), each on its own estimator fed the recording in order:
// - chasles: MomentumObserver::update (τ̂_ext) + body_jacobian + tip_wrench_from_torque (F̂ in the
//   tip frame); and each of the three alone, to show where the time goes.
// - KDL: ChainExternalWrenchEstimator::JntToExtWrench (which computes τ̂_ext and F̂ in the tip
//   frame) + getEstimatedJntTorque (a copy of τ̂_ext, so the caller has it as chasles's does).
// Both with the same observer gain K_O = kGain on every joint, KDL's low-pass filter off (filter
// constant 0: its τ̂ is then the observer's residual itself, as chasles's is), KDL's default SVD
// settings. The models are the same: the KDL chain is built from chasles's RobotModel (kdl_chain
// below), and main() checks that both compute the same tip pose, body Jacobian, mass matrix and
// RNEA torques on samples of the recording before anything else, and refuses to run if not.
//
// KDL's estimator, read from its source (orocos_kdl/src/chainexternalwrenchestimator.cpp, 1.5.1):
// - "joint_torque" is the applied (motor) torque τ, as chasles's; its residual converges to the
//   torque the environment applies, with the same sign as chasles's τ̂_ext.
// - Its discretisation is explicit Euler: Ṁ by a backward difference of M between updates,
//   ∫(τ + Ṁq̇ − c − g + r) dt by a rectangle per step, so its lag is r_k = (1 − K_O T) r_{k−1} + …
//   where chasles's is exp(−K_O T), and its momentum balance is first order in T where
//   chasles's is exact for τ held over the step and trapezoidal for the smooth terms.
// - The wrench is (J_tipᵀ)⁺ τ̂ with J_tip KDL's Jacobian turned into the tip frame (changeBase by
//   R_sb⁻¹) with the reference point at the tip: that is chasles's J_b with its rows in KDL's
//   (v, ω) order, so the wrench comes out as (f, m) — KDL::Wrench's own order — on the tip, in
//   the tip frame, about the tip's origin. chasles's is (m, f): from_kdl() swaps the halves and
//   nothing else. The pseudo-inverse is an undamped SVD (singular values below eps = 1e-5 get 0).
// - setInitialMomentum(q, q̇) sets p(0) and clears the integral and the filter, but not the
//   previous M its Ṁ is differenced from, which starts at zero: the first update after
//   construction adds M q̇ / T to its torque balance, so on an arm already moving τ̂ starts with
//   an error of K_O M q̇ (217 N·m on this UR5 recording started mid-move). So the estimator is
//   started by one JntToExtWrench at the first sample (setting the previous M), then
//   setInitialMomentum at that sample. (This recording starts at rest, where it makes no
//   difference; the benchmark restarts at the same sample.)
// - It keeps a reference to the chain it is given (not a copy, whatever its comment says): the
//   chain lives beside it, in Robot.
//
// Fairness of the timing, as in dynamics_bench.cpp: one binary, the same flags (KDL itself is
// Debian's -O2 build), every input precomputed in each library's own types (Eigen vectors,
// KDL::JntArray), each estimator fed the whole recording in order (both restart at its end, once
// every few thousand updates), every result through benchmark::DoNotOptimize. This binary
// interposes malloc to count each update's heap allocations (tests/support/allocation_counter),
// which adds a thread-local test to every allocation: KDL's allocations cost a nanosecond or two
// more each than they would elsewhere.
#include <benchmark/benchmark.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <kdl/chain.hpp>
#include <kdl/chaindynparam.hpp>
#include <kdl/chainexternalwrenchestimator.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/jntspaceinertiamatrix.hpp>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/contact/observer.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/model/urdf.hpp"
#include "support/allocation_counter.hpp"

namespace {

using chasles::Matrix6Xd;
using chasles::Transform;
using chasles::Vector3d;
using chasles::Vector6d;

constexpr double kPeriod = 1e-3;  // s: 1 kHz
constexpr int kSubsteps = 10;     // RK4 steps per period in the recording
constexpr double kGain = 100.0;   // K_O, 1/s, every joint, both estimators
// The KDL gain K' with 1 − K' T = exp(−K_O T): 95.2/s (see Robot::kdl_matched).
const double kMatchedGain = -std::expm1(-kGain * kPeriod) / kPeriod;
constexpr double kDuration = 4.5;    // s of recording
constexpr double kMove1End = 1.0;    // q0 → q1 over [0, 1.0)
constexpr double kMove2Start = 2.5;  // q1 → q2 over [2.5, 3.5)
constexpr double kMove2End = 3.5;
constexpr double kPushStart = 1.5;  // the push ramps over [1.5, 1.55] and stays
constexpr double kPushRamp = 0.05;
constexpr double kKp = 400.0, kKd = 40.0;  // 1/s², 1/s: the PD's ω_n = 20 rad/s, critically damped
constexpr double kTolerance = 1e-9;        // model agreement, relative to the largest entry (≥ 1)
constexpr size_t kChecked = 10;            // samples of the recording the models are compared on

// The windows the errors are summed over. steady: held still (from 0.2 s after a move ends) under
// a constant push or none; onset: the 0.5 s from the push's start (its ramp, the observer's lag,
// the arm giving way and recovering); free move: the first move, no push (the truth is 0: what is
// estimated is the estimator's own error, what a collision threshold must sit above); pushed
// move: the second move under the push (the truth changes with the pose). Each move's window
// runs 0.2 s past its end, while the arm settles.
enum Window { kSteady, kOnset, kFreeMove, kPushedMove, kWindows };
const char* const kWindowNames[kWindows] = {"steady", "onset", "free move", "pushed move"};
Window window_at(double t) {
  if (t >= kPushStart && t < kPushStart + 0.5) return kOnset;
  if (t < kMove1End + 0.2) return kFreeMove;
  if (t >= kMove2Start && t < kMove2End + 0.2) return kPushedMove;
  return kSteady;
}

struct Scenario {
  std::string name, urdf, tip;
  std::vector<double> q0, q1, q2;  // within the joint limits, away from singularities
  Vector3d force, moment;          // the push at full strength, base-aligned at the tip's origin
};

Eigen::VectorXd vector_of(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

chasles::UrdfOptions tip_options(const std::string& tip) {
  chasles::UrdfOptions options;
  options.tip_link = tip;
  return options;
}

// --- chasles's model as a KDL chain -------------------------------------------------------------

KDL::Vector to_kdl(const Vector3d& v) { return KDL::Vector(v.x(), v.y(), v.z()); }

KDL::Frame to_kdl(const Transform& T) {
  const chasles::Matrix3d& R = T.linear();
  return KDL::Frame(KDL::Rotation(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)),
                    to_kdl(T.translation()));
}

// chasles keeps (m, h = m c, I about the body origin); KDL's constructor takes the centre of mass
// and the rotational inertia about it (matrix entries, not products of inertia): I_c = I − m([c]ᵀ[c]).
KDL::RigidBodyInertia to_kdl(const chasles::SpatialInertia& G) {
  if (!(G.mass > 0.0)) return KDL::RigidBodyInertia(0.0, KDL::Vector::Zero(), KDL::RotationalInertia::Zero());
  const Vector3d c = G.h / G.mass;
  const chasles::Matrix3d I_c = G.I - G.mass * (c.squaredNorm() * chasles::Matrix3d::Identity() - c * c.transpose());
  return KDL::RigidBodyInertia(
      G.mass, to_kdl(c), KDL::RotationalInertia(I_c(0, 0), I_c(1, 1), I_c(2, 2), I_c(0, 1), I_c(0, 2), I_c(1, 2)));
}

// One segment per joint, as kdl_parser builds them: segment i goes from body i−1's frame to body
// i's, its joint at M_{i−1,i}'s origin with the axis expressed in body i−1's frame (KDL's segment
// pose is then M_{i−1,i} e^{[A_i] q_i}), and body i's inertia in body i's frame; then a fixed
// segment to the tip (T_last_tip), so that KDL's chain ends at chasles's tip frame.
KDL::Chain kdl_chain(const chasles::RobotModel& model) {
  KDL::Chain chain;
  for (int i = 0; i < model.dof(); ++i) {
    const chasles::Joint& joint = model.joint(i);
    const KDL::Frame T_parent_joint = to_kdl(joint.T_parent_joint);
    const KDL::Joint::JointType type =
        joint.type == chasles::JointType::Prismatic ? KDL::Joint::TransAxis : KDL::Joint::RotAxis;
    const KDL::Joint kdl_joint(joint.name, T_parent_joint.p, T_parent_joint.M * to_kdl(joint.axis), type);
    chain.addSegment(KDL::Segment(joint.name, kdl_joint, T_parent_joint, to_kdl(model.body_inertia(i))));
  }
  chain.addSegment(KDL::Segment(model.tip_link(), KDL::Joint(KDL::Joint::Fixed), to_kdl(model.T_last_tip())));
  return chain;
}

KDL::Vector gravity_of(const chasles::RobotModel& model) { return to_kdl(model.gravity()); }

// KDL's wrench (f, m) on the tip, tip frame, about the tip's origin → chasles's (m, f), the same
// wrench in the same frame about the same point.
Vector6d from_kdl(const KDL::Wrench& w) {
  Vector6d F;
  F << w.torque.x(), w.torque.y(), w.torque.z(), w.force.x(), w.force.y(), w.force.z();
  return F;
}

// --- the recording ------------------------------------------------------------------------------

struct Recording {
  // Sample k: the state, the torque held over the step that ended at it (tau[0]: the first
  // command, which nothing reads), the truth.
  std::vector<Eigen::VectorXd> q, qd, tau, tau_ext;
  std::vector<Vector6d> F_env;  // on the tip, tip frame, (m, f)
  std::vector<Matrix6Xd> J_b;   // at each sample, for timing tip_wrench_from_torque alone
  std::vector<KDL::JntArray> kq, kqd, ktau;
  double min_singular_value = 0.0;  // of J_b over the recording
  double max_speed = 0.0;           // max |q̇_i|, rad/s
};

double push_strength(double t) { return std::clamp((t - kPushStart) / kPushRamp, 0.0, 1.0); }

// The push at time t on an arm whose tip is at T_sb, in the tip frame, (m, f).
Vector6d push_on_tip(const Scenario& s, double t, const Transform& T_sb) {
  const double a = push_strength(t);
  Vector6d F;
  F << T_sb.linear().transpose() * (a * s.moment), T_sb.linear().transpose() * (a * s.force);
  return F;
}

// The quintic time scaling s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ (MR §9.2.2) from a to b over [t0, t1].
void quintic(const Eigen::VectorXd& a, const Eigen::VectorXd& b, double t0, double t1, double t, Eigen::VectorXd& q,
             Eigen::VectorXd& qd, Eigen::VectorXd& qdd) {
  const double T = t1 - t0, u = std::clamp((t - t0) / T, 0.0, 1.0);
  const double s = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
  const double sd = 30.0 * u * u * (1.0 - u) * (1.0 - u) / T;
  const double sdd = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / (T * T);
  q = a + s * (b - a);
  qd = sd * (b - a);
  qdd = sdd * (b - a);
}

Recording record(const chasles::RobotModel& model, const Scenario& s) {
  chasles::Data data(model);
  const Eigen::VectorXd q0 = vector_of(s.q0), q1 = vector_of(s.q1), q2 = vector_of(s.q2);
  const int samples = static_cast<int>(std::lround(kDuration / kPeriod));
  Recording r;
  Eigen::VectorXd q = q0, qd = Eigen::VectorXd::Zero(model.dof());
  Eigen::VectorXd q_d, qd_d, qdd_d, tau;
  r.min_singular_value = std::numeric_limits<double>::infinity();

  // q̈ of the true arm under the held torque and the push, which depends on time and on the pose.
  const auto acceleration = [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd& v) -> Eigen::VectorXd {
    const Vector6d F_env = push_on_tip(s, t, chasles::forward_kinematics(model, data, x));
    // forward_dynamics takes the wrench the tip applies to the environment: −F_env.
    return chasles::forward_dynamics(model, data, x, v, tau, -F_env);
  };

  for (int k = 0; k < samples; ++k) {
    const double t = k * kPeriod;
    // The truth at the sample.
    const Matrix6Xd J_b = chasles::body_jacobian(model, data, q);
    const Vector6d F_env = push_on_tip(s, t, data.T_sb);
    r.q.push_back(q);
    r.qd.push_back(qd);
    r.F_env.push_back(F_env);
    r.J_b.push_back(J_b);
    r.tau_ext.push_back(J_b.transpose() * F_env);
    r.min_singular_value = std::min(r.min_singular_value, Eigen::JacobiSVD<Matrix6Xd>(J_b).singularValues().minCoeff());
    r.max_speed = std::max(r.max_speed, qd.cwiseAbs().maxCoeff());

    // The controller's torque from this sample, held over the next step.
    if (t < kMove2Start) {
      quintic(q0, q1, 0.0, kMove1End, t, q_d, qd_d, qdd_d);
    } else {
      quintic(q1, q2, kMove2Start, kMove2End, t, q_d, qd_d, qdd_d);
    }
    tau = chasles::inverse_dynamics(model, data, q, qd, qdd_d + kKd * (qd_d - qd) + kKp * (q_d - q));
    if (k == 0) r.tau.push_back(tau);
    if (k + 1 == samples) break;
    r.tau.push_back(tau);

    // RK4 over the step.
    const double h = kPeriod / kSubsteps;
    for (int j = 0; j < kSubsteps; ++j) {
      const double ts = t + j * h;
      const Eigen::VectorXd k1q = qd, k1v = acceleration(ts, q, k1q);
      const Eigen::VectorXd k2q = qd + 0.5 * h * k1v, k2v = acceleration(ts + 0.5 * h, q + 0.5 * h * k1q, k2q);
      const Eigen::VectorXd k3q = qd + 0.5 * h * k2v, k3v = acceleration(ts + 0.5 * h, q + 0.5 * h * k2q, k3q);
      const Eigen::VectorXd k4q = qd + h * k3v, k4v = acceleration(ts + h, q + h * k3q, k4q);
      q += h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
      qd += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
  }
  for (size_t k = 0; k < r.q.size(); ++k) {
    r.kq.emplace_back(model.dof());
    r.kqd.emplace_back(model.dof());
    r.ktau.emplace_back(model.dof());
    r.kq.back().data = r.q[k];
    r.kqd.back().data = r.qd[k];
    r.ktau.back().data = r.tau[k];
  }
  return r;
}

// --- both estimators on one robot ---------------------------------------------------------------

// KDL's estimator with its outputs. Keeps a reference to the chain (see the top of the file).
struct KdlEstimator {
  // Filter constant 0: no low-pass filter after the observer. SVD eps and iterations: KDL's defaults.
  KdlEstimator(const KDL::Chain& chain, const KDL::Vector& gravity, double gain)
      : estimator(chain, gravity, 1.0 / kPeriod, gain, 0.0), tau_hat(chain.getNrOfJoints()) {}

  // Starts at sample 0: one update sets the M that Ṁ is differenced from (see the top of the
  // file), then setInitialMomentum clears what that update integrated.
  void restart(const Recording& rec) {
    note(estimator.JntToExtWrench(rec.kq[0], rec.kqd[0], rec.ktau[0], wrench));
    note(estimator.setInitialMomentum(rec.kq[0], rec.kqd[0]));
  }
  // One update, at sample k ≥ 1.
  void update(const Recording& rec, size_t k) {
    note(estimator.JntToExtWrench(rec.kq[k], rec.kqd[k], rec.ktau[k], wrench));
    estimator.getEstimatedJntTorque(tau_hat);
  }
  // Keeps KDL's first error code (0: none), for main() to report.
  void note(int code) {
    if (status == 0) status = code;
  }

  KDL::ChainExternalWrenchEstimator estimator;
  KDL::Wrench wrench;  // (f, m) on the tip, tip frame
  KDL::JntArray tau_hat;
  int status = 0;
};

// Both libraries' models of one robot, their estimators and outputs, and its recording. Never
// copied or moved: KDL's solvers keep a reference to `chain`.
struct Robot {
  explicit Robot(const Scenario& s);
  Robot(const Robot&) = delete;
  Robot& operator=(const Robot&) = delete;

  // chasles's observer started at the recording's first sample, and one update at sample k ≥ 1.
  // The observer's input at sample k: p, Cᵀq̇ and g, one O(n) pass.
  const chasles::Data& sample(size_t k) {
    chasles::momentum_terms(model, data, rec.q[k], rec.qd[k]);
    return data;
  }
  void restart_chasles() { observer.reset(sample(0), rec.qd[0]); }
  const Eigen::VectorXd& observe(size_t k) { return observer.update(sample(k), rec.qd[k], rec.tau[k], kPeriod); }
  void update_chasles(size_t k) {
    observe(k);
    F_hat = chasles::tip_wrench_from_torque(chasles::body_jacobian(model, data, rec.q[k]), observer.external_torque());
  }

  const Scenario scenario;
  const chasles::RobotModel model;
  chasles::Data data;
  chasles::MomentumObserver observer;
  Vector6d F_hat = Vector6d::Zero();

  const KDL::Chain chain;
  KdlEstimator kdl;
  // Scored, not timed: KDL with the gain whose Euler pole 1 − K T equals chasles's exp(−K_O T), so
  // that both are the same first-order lag and what differs is the momentum balance alone.
  KdlEstimator kdl_matched;

  const Recording rec;
};

Robot::Robot(const Scenario& s)
    : scenario(s),
      model(chasles::load_urdf_file(s.urdf, tip_options(s.tip))),
      data(model),
      observer(model, Eigen::VectorXd::Constant(model.dof(), kGain)),
      chain(kdl_chain(model)),
      kdl(chain, gravity_of(model), kGain),
      kdl_matched(chain, gravity_of(model), kMatchedGain),
      rec(record(model, s)) {}

// --- the agreement of the two models ------------------------------------------------------------

// The first disagreement beyond kTolerance, as a message; "" when they agree.
std::string compare(const std::string& what, const Eigen::MatrixXd& ours, const Eigen::MatrixXd& kdl, double& worst) {
  const double scale = std::max(1.0, kdl.cwiseAbs().maxCoeff());
  const double error = (ours - kdl).cwiseAbs().maxCoeff() / scale;
  worst = std::max(worst, error);
  if (error <= kTolerance) return "";
  std::ostringstream out;
  out << "  " << what << ": max |chasles - KDL| = " << error * scale << "\n    chasles:\n"
      << ours << "\n    KDL:\n"
      << kdl << "\n";
  return out.str();
}

// Tip pose, body Jacobian, M and RNEA torques on a few recorded samples; the KDL chain is right
// only if all agree (RNEA alone would not see the tip frame, which the wrench is expressed in).
std::string check_agreement(Robot& r, double& worst) {
  const KDL::Vector gravity = gravity_of(r.model);
  KDL::ChainFkSolverPos_recursive fk(r.chain);
  KDL::ChainJntToJacSolver jacobian(r.chain);
  KDL::ChainIdSolver_RNE rnea(r.chain, gravity);
  KDL::ChainDynParam dyn(r.chain, gravity);
  const unsigned n = r.chain.getNrOfJoints();
  if (static_cast<int>(n) != r.model.dof()) return "  " + r.scenario.name + ": the KDL chain has other joints\n";
  KDL::Frame frame;
  KDL::Jacobian J(n);
  KDL::JntArray qdd(n), tau(n);
  KDL::JntSpaceInertiaMatrix M(n);
  KDL::Wrenches f_ext(r.chain.getNrOfSegments(), KDL::Wrench::Zero());
  std::string failures;
  int status = 0;
  for (size_t k = 0; k < r.rec.q.size(); k += r.rec.q.size() / kChecked) {
    const std::string at = r.scenario.name + " sample " + std::to_string(k) + " ";
    const Eigen::VectorXd qdd_test = Eigen::VectorXd::LinSpaced(r.model.dof(), -2.0, 3.0);
    qdd.data = qdd_test;

    const Eigen::MatrixXd T_sb = chasles::forward_kinematics(r.model, r.data, r.rec.q[k]).matrix();
    status |= fk.JntToCart(r.rec.kq[k], frame);
    Eigen::Matrix4d T_kdl = Eigen::Matrix4d::Identity();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) T_kdl(i, j) = frame.M(i, j);
      T_kdl(i, 3) = frame.p(i);
    }
    failures += compare(at + "tip pose", T_sb, T_kdl, worst);

    // KDL's Jacobian is base-aligned at the tip, rows (v, ω): in the tip frame and angular first
    // it is J_b.
    const Eigen::MatrixXd J_b = chasles::body_jacobian(r.model, r.data, r.rec.q[k]);
    status |= jacobian.JntToJac(r.rec.kq[k], J);
    J.changeBase(frame.M.Inverse());
    Eigen::MatrixXd J_kdl(6, n);
    J_kdl << J.data.bottomRows<3>(), J.data.topRows<3>();
    failures += compare(at + "body Jacobian", J_b, J_kdl, worst);

    status |= dyn.JntToMass(r.rec.kq[k], M);
    failures += compare(at + "mass matrix", chasles::mass_matrix(r.model, r.data, r.rec.q[k]), M.data, worst);

    status |= rnea.CartToJnt(r.rec.kq[k], r.rec.kqd[k], qdd, f_ext, tau);
    failures += compare(at + "RNEA torques",
                        chasles::inverse_dynamics(r.model, r.data, r.rec.q[k], r.rec.qd[k], qdd_test), tau.data, worst);
  }
  if (status != 0) failures += "  " + r.scenario.name + ": a KDL solver returned an error\n";
  return failures;
}

// --- accuracy -----------------------------------------------------------------------------------

// RMS and max of an error norm over each window.
struct ErrorStats {
  double sum_sq[kWindows] = {}, max[kWindows] = {};
  int count[kWindows] = {};
  void add(Window w, double e) {
    sum_sq[w] += e * e;
    max[w] = std::max(max[w], e);
    ++count[w];
  }
  double rms(Window w) const { return count[w] > 0 ? std::sqrt(sum_sq[w] / count[w]) : 0.0; }
};

struct Accuracy {
  ErrorStats tau, force, moment;  // |τ̂ − τ_ext| (N·m), |f̂ − f| (N), |m̂ − m| (N·m), tip frame
  double allocations_per_update = 0.0;
  void add(double t, const Eigen::VectorXd& tau_hat, const Eigen::VectorXd& tau_ext, const Vector6d& F_hat,
           const Vector6d& F_env) {
    const Window w = window_at(t);
    tau.add(w, (tau_hat - tau_ext).norm());
    moment.add(w, (F_hat.head<3>() - F_env.head<3>()).norm());
    force.add(w, (F_hat.tail<3>() - F_env.tail<3>()).norm());
  }
};

// Each estimator over the whole recording, every update scored against the truth at its sample:
// chasles, KDL, KDL with the matched pole.
struct Scores {
  Accuracy chasles, kdl, kdl_matched;
};

Scores measure_accuracy(Robot& r) {
  Scores scores;
  long chasles_allocations = 0, kdl_allocations = 0;
  r.restart_chasles();
  r.kdl.restart(r.rec);
  r.kdl_matched.restart(r.rec);
  for (size_t k = 1; k < r.rec.q.size(); ++k) {
    const double t = static_cast<double>(k) * kPeriod;
    {
      chasles::testing::AllocationCounter counter;
      r.update_chasles(k);
      chasles_allocations += counter.count();
    }
    scores.chasles.add(t, r.observer.external_torque(), r.rec.tau_ext[k], r.F_hat, r.rec.F_env[k]);
    {
      chasles::testing::AllocationCounter counter;
      r.kdl.update(r.rec, k);
      kdl_allocations += counter.count();
    }
    scores.kdl.add(t, r.kdl.tau_hat.data, r.rec.tau_ext[k], from_kdl(r.kdl.wrench), r.rec.F_env[k]);
    r.kdl_matched.update(r.rec, k);
    scores.kdl_matched.add(t, r.kdl_matched.tau_hat.data, r.rec.tau_ext[k], from_kdl(r.kdl_matched.wrench),
                           r.rec.F_env[k]);
  }
  const double updates = static_cast<double>(r.rec.q.size() - 1);
  scores.chasles.allocations_per_update = static_cast<double>(chasles_allocations) / updates;
  scores.kdl.allocations_per_update = static_cast<double>(kdl_allocations) / updates;
  return scores;
}

// --- the benchmarks -----------------------------------------------------------------------------

// "<library>/<robot>/<what>": each iteration is one update at the next sample; at the end of the
// recording the estimator restarts at its beginning.
template <class Restart, class Update>
void add(const char* library, Robot& robot, const char* what, Restart restart, Update update) {
  const std::string name = std::string(library) + "/" + robot.scenario.name + "/" + what;
  benchmark::RegisterBenchmark(name.c_str(), [&robot, restart, update](benchmark::State& state) {
    const size_t samples = robot.rec.q.size();
    restart(robot);
    size_t k = 1;
    for (auto _ : state) {
      update(robot, k);
      if (++k == samples) {
        restart(robot);
        k = 1;
      }
    }
  })->Unit(benchmark::kNanosecond);
}

void register_benchmarks(Robot& r) {
  add(
      "chasles", r, "update", [](Robot& x) { x.restart_chasles(); },
      [](Robot& x, size_t k) {
        x.update_chasles(k);
        benchmark::DoNotOptimize(x.F_hat.data());
        benchmark::DoNotOptimize(x.observer.external_torque().data());
      });
  add(
      "kdl", r, "update", [](Robot& x) { x.kdl.restart(x.rec); },
      [](Robot& x, size_t k) {
        x.kdl.update(x.rec, k);
        benchmark::DoNotOptimize(&x.kdl.wrench);
        benchmark::DoNotOptimize(x.kdl.tau_hat.data.data());
      });
  // chasles's update in its three parts, to show where its time goes.
  add(
      "chasles", r, "observer", [](Robot& x) { x.restart_chasles(); },
      [](Robot& x, size_t k) {
        benchmark::DoNotOptimize(x.observe(k).data());
      });
  add(
      "chasles", r, "body_jacobian", [](Robot&) {},
      [](Robot& x, size_t k) { benchmark::DoNotOptimize(chasles::body_jacobian(x.model, x.data, x.rec.q[k]).data()); });
  add(
      "chasles", r, "tip_wrench", [](Robot&) {},
      [](Robot& x, size_t k) {
        x.F_hat = chasles::tip_wrench_from_torque(x.rec.J_b[k], x.rec.tau_ext[k]);
        benchmark::DoNotOptimize(x.F_hat.data());
      });
}

// The console report on stderr, and the median CPU time of each benchmark kept for the table (the
// mean of its runs when there are no aggregates: one repetition).
class Reporter : public benchmark::ConsoleReporter {
 public:
  Reporter() : ConsoleReporter(OO_None) {
    SetOutputStream(&std::cerr);
    SetErrorStream(&std::cerr);
  }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.error_occurred) continue;
      const std::string& name = run.run_name.function_name;
      if (run.run_type == Run::RT_Aggregate && run.aggregate_name == "median") {
        median_[name] = run.GetAdjustedCPUTime();
      } else if (run.run_type == Run::RT_Iteration) {
        auto& [sum, count] = plain_[name];
        sum += run.GetAdjustedCPUTime();
        ++count;
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  // ns per update, or NaN if the benchmark did not run.
  double ns(const std::string& name) const {
    if (const auto m = median_.find(name); m != median_.end()) return m->second;
    if (const auto p = plain_.find(name); p != plain_.end()) return p->second.first / p->second.second;
    return std::nan("");
  }

 private:
  std::map<std::string, double> median_;
  std::map<std::string, std::pair<double, int>> plain_;
};

void print_tables(const std::vector<std::unique_ptr<Robot>>& robots, const std::vector<Scores>& scores,
                  const Reporter& reporter) {
  std::printf(
      "Contact estimation: chasles (MomentumObserver::update + body_jacobian + tip_wrench_from_torque)\n"
      "against KDL (ChainExternalWrenchEstimator::JntToExtWrench + getEstimatedJntTorque), K_O = %g/s\n"
      "on every joint, %g Hz, KDL's filter off.\n\n",
      kGain, 1.0 / kPeriod);
  std::printf("%-6s  %10s  %10s  %11s  %26s  %14s  %10s\n", "robot", "chasles ns", "KDL ns", "KDL/chasles",
              "chasles: observer, J_b, F", "chasles allocs", "KDL allocs");
  for (size_t i = 0; i < robots.size(); ++i) {
    const std::string c = "chasles/" + robots[i]->scenario.name + "/";
    const double ours = reporter.ns(c + "update"), kdl = reporter.ns("kdl/" + robots[i]->scenario.name + "/update");
    std::printf("%-6s  %10.0f  %10.0f  %11.2f  %10.0f %7.0f %7.0f  %14.1f  %10.1f\n", robots[i]->scenario.name.c_str(),
                ours, kdl, kdl / ours, reporter.ns(c + "observer"), reporter.ns(c + "body_jacobian"),
                reporter.ns(c + "tip_wrench"), scores[i].chasles.allocations_per_update,
                scores[i].kdl.allocations_per_update);
  }
  std::printf(
      "\nns: median CPU time per update (one sample: τ̂_ext and the tip wrench in the tip frame); chasles's in\n"
      "its parts, each timed alone: MomentumObserver::update, body_jacobian, tip_wrench_from_torque.\n"
      "allocs: heap allocations per update.\n\n");

  std::printf(
      "Accuracy on the recording (%g s at %g Hz: two moves, holds, a push ramping to 20 N and 1 N·m from\n"
      "t = %g s), each estimate against the truth at its sample; RMS and max over each window.\n"
      "τ: |τ̂ − τ_ext| N·m; f: |f̂ − f| N and m: |m̂ − m| N·m, the wrench on the tip in the tip frame.\n"
      "KDL K': KDL with K' = %.1f/s, whose Euler pole 1 − K'T is chasles's exp(−K_O T) (not timed).\n\n",
      kDuration, 1.0 / kPeriod, kPushStart, kMatchedGain);
  std::printf("%-6s  %-11s  %-7s  %9s %9s  %9s %9s  %9s %9s\n", "robot", "window", "library", "τ rms", "τ max", "f rms",
              "f max", "m rms", "m max");
  for (size_t i = 0; i < robots.size(); ++i) {
    for (int w = 0; w < kWindows; ++w) {
      const Window window = static_cast<Window>(w);
      const std::pair<const char*, const Accuracy*> rows[] = {
          {"chasles", &scores[i].chasles}, {"KDL", &scores[i].kdl}, {"KDL K'", &scores[i].kdl_matched}};
      for (const auto& [library, a] : rows) {
        std::printf("%-6s  %-11s  %-7s  %9.2e %9.2e  %9.2e %9.2e  %9.2e %9.2e\n", robots[i]->scenario.name.c_str(),
                    kWindowNames[w], library, a->tau.rms(window), a->tau.max[w], a->force.rms(window), a->force.max[w],
                    a->moment.rms(window), a->moment.max[w]);
      }
    }
  }
  std::printf(
      "\nsteady: held still under a constant push or none; onset: the 0.5 s from the push's start; free\n"
      "move: the first move, no push (truth 0); pushed move: the second, under the push. Both observers\n"
      "lag the truth by design (time constant 1/K_O), which is most of the onset's error for both.\n");
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  const std::string data = CHASLES_BENCH_DATA;
  // The same push on both arms: 20 N sideways and down, 1 N·m, fixed in the base frame.
  const Vector3d force = 20.0 * Vector3d(0.6, -0.4, -0.7).normalized();
  const Vector3d moment = Vector3d(0.0, 0.6, 0.8);
  const std::vector<Scenario> scenarios = {
      {"ur5",
       data + "/ur5.urdf",
       "tool0",
       {0.0, -1.2, 1.6, -1.9, -1.57, 0.0},
       {0.6, -0.9, 1.2, -1.6, -1.2, 0.5},
       {-0.5, -1.5, 1.9, -2.2, -1.9, -0.4},
       force,
       moment},
      {"panda",
       data + "/panda.urdf",
       "panda_hand",
       {0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785},
       {0.5, -0.3, 0.3, -1.9, 0.4, 1.9, 0.3},
       {-0.4, 0.1, -0.3, -1.5, -0.3, 1.7, 1.2},
       force,
       moment},
  };

  // Everything but the tables goes to stderr.
  std::vector<std::unique_ptr<Robot>> robots;
  try {
    for (const Scenario& s : scenarios) robots.push_back(std::make_unique<Robot>(s));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chasles_contact_bench: %s\n", e.what());
    return 1;
  }

  std::string failures;
  double worst = 0.0;
  for (auto& robot : robots) failures += check_agreement(*robot, worst);
  if (!failures.empty()) {
    std::fprintf(stderr,
                 "chasles_contact_bench: the KDL chain built from chasles's model does not agree with it "
                 "(relative tolerance %g), so the estimators would not see the same arm; not running.\n%s",
                 kTolerance, failures.c_str());
    return 1;
  }
  std::fprintf(stderr,
               "chasles_contact_bench: tip pose, body Jacobian, M and RNEA torques of the KDL chain agree with "
               "chasles on %zu samples per robot; worst relative difference %.1e\n",
               kChecked, worst);
  for (const auto& robot : robots) {
    std::fprintf(stderr, "chasles_contact_bench: %s recording: %zu samples, max |q̇_i| %.2f rad/s, min σ(J_b) %.3f\n",
                 robot->scenario.name.c_str(), robot->rec.q.size(), robot->rec.max_speed,
                 robot->rec.min_singular_value);
  }

  std::vector<Scores> scores;
  for (auto& robot : robots) scores.push_back(measure_accuracy(*robot));
  for (const auto& robot : robots) {
    for (const KdlEstimator* kdl : {&robot->kdl, &robot->kdl_matched}) {
      if (kdl->status != 0) {
        std::fprintf(stderr, "chasles_contact_bench: KDL's estimator returned an error on %s: %s\n",
                     robot->scenario.name.c_str(), kdl->estimator.strError(kdl->status));
        return 1;
      }
    }
  }

  for (auto& robot : robots) register_benchmarks(*robot);
  Reporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  print_tables(robots, scores, reporter);
  return 0;
}
