#include "controller/jog.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/se3.hpp"

namespace chasles::controller {
namespace {

// The probe that tells whether a twist leads toward a singularity: the condition number a step
// this long (rad or m, on the joint moving most) along its joint velocity reaches. Small enough
// to see the local slope, large enough to stand above round-off (κ changes by ~1e-3 relative).
constexpr double kProbeStep = 1e-3;

}  // namespace

void JogConfig::validate() const {
  if (!(std::isfinite(slow_condition) && std::isfinite(stop_condition) && slow_condition >= 1.0 &&
        stop_condition > slow_condition)) {
    throw ArgumentError("jog: the condition numbers must be finite with 1 <= slow (" + std::to_string(slow_condition) +
                        ") < stop (" + std::to_string(stop_condition) + ")");
  }
  if (!(std::isfinite(pose_time_constant) && pose_time_constant > 0.0)) {
    throw ArgumentError("the Cartesian stream's time constant must be positive and finite, not " +
                        std::to_string(pose_time_constant));
  }
}

void JacobianSpectrum::compute(const Matrix6Xd& J) {
  rank_ = static_cast<int>(std::min<Eigen::Index>(6, J.cols()));
  eigen_.compute(J * J.transpose());  // eigenvalues ascending: σ_k² of the rank_ largest at the end
  const auto& lambda = eigen_.eigenvalues();
  const double largest = lambda(5), smallest = lambda(6 - rank_);
  condition_ = smallest > 0.0 ? std::sqrt(largest / smallest) : std::numeric_limits<double>::infinity();
}

void JacobianSpectrum::solve(const Matrix6Xd& J, const Vector6d& V, Eigen::VectorXd& qd) const {
  // J⁺ = Jᵀ (J Jᵀ)⁺, the inverse taken on the rank_ largest eigenvalues; one at round-off level of
  // the largest is a direction J cannot move in, left out rather than divided by.
  const auto& lambda = eigen_.eigenvalues();
  const auto& U = eigen_.eigenvectors();
  const double floor = lambda(5) * 1e-14;
  Vector6d w = Vector6d::Zero();
  for (int k = 6 - rank_; k < 6; ++k) {
    if (lambda(k) > floor) w += U.col(k) * (U.col(k).dot(V) / lambda(k));
  }
  qd.noalias() = J.transpose() * w;
}

Jogger::Jogger(int dof, const JogConfig& config)
    : config_(config),
      otg_(dof),
      qd_(Eigen::VectorXd::Zero(dof)),
      step_(Eigen::VectorXd::Zero(dof)),
      stop_(Eigen::VectorXd::Zero(dof)),
      J_(6, dof),
      dJ_(6, dof),
      J_ahead_(6, dof) {
  config_.validate();
  for (motion::KinematicState* state : {&from_, &out_}) {
    state->p = state->v = state->a = Eigen::VectorXd::Zero(dof);
  }
}

// J_b at q + step to first order, from J_b at q: the look-ahead costs a 6 × n product and a 6 × 6
// eigenproblem instead of a pass over the chain. Its error grows with the step's square; the
// steps it looks along are the probe's 1e-3 and a brake's stop, short where a singularity is
// near, since the speed is cut there first.
double Jogger::condition_ahead(const Eigen::VectorXd& step) {
  body_jacobian_change(J_, step, dJ_);
  J_ahead_ = J_ + dJ_;
  spectrum_.compute(J_ahead_);
  return spectrum_.condition();
}

bool Jogger::step(const Data& at_reference, const Jog& jog, bool halt, const motion::MotionLimits& limits,
                  const motion::Limits& otg_limits, double dt, motion::Reference& ref, JogProgress& progress) {
  const bool twist = jog.kind == Jog::kTwist;
  const Matrix6Xd& J = start_at(at_reference, progress);
  qd_.setZero();
  if (!halt) {
    if (twist) {
      Vector6d V_b = jog.twist;
      if (jog.frame == Jog::kBase) {  // both halves from the base's axes into the tip's
        const Matrix3d& R = at_reference.T_sb.linear();
        V_b.head<3>() = R.transpose() * jog.twist.head<3>();
        V_b.tail<3>() = R.transpose() * jog.twist.tail<3>();
      }
      spectrum_.solve(J, V_b, qd_);
    } else {
      qd_ = jog.joint_velocity;
    }
  }
  return advance(twist, halt, limits, otg_limits, dt, ref, progress);
}

bool Jogger::follow_pose(const Data& at_reference, const Transform& target, const Vector6d& twist, bool halt,
                         const motion::MotionLimits& limits, const motion::Limits& otg_limits, double dt, motion::Reference& ref,
                         JogProgress& progress) {
  const Matrix6Xd& J = start_at(at_reference, progress);
  qd_.setZero();
  if (!halt) {
    // In the tip frame: the error's body twist (what moves the tip onto the target in a unit of
    // time) over the time constant, and the target's own twist.
    const Matrix3d& R = at_reference.T_sb.linear();
    Vector6d V_b = log6(inverse(at_reference.T_sb) * target) / config_.pose_time_constant;
    V_b.head<3>() += R.transpose() * twist.head<3>();
    V_b.tail<3>() += R.transpose() * twist.tail<3>();
    spectrum_.solve(J, V_b, qd_);
  }
  return advance(true, halt, limits, otg_limits, dt, ref, progress);
}

const Matrix6Xd& Jogger::start_at(const Data& at_reference, JogProgress& progress) {
  J_ = at_reference.J_b;
  const Matrix6Xd& J = J_;
  spectrum_.compute(J);
  progress = JogProgress{};
  progress.condition = spectrum_.condition();
  return J;
}

bool Jogger::advance(bool twist, bool halt, const motion::MotionLimits& limits,
                     const motion::Limits& otg_limits, double dt, motion::Reference& ref, JogProgress& progress) {
  const int n = static_cast<int>(qd_.size());
  if (!halt) {
    // One factor for every joint, so that the motion keeps the direction asked for.
    double scale = 1.0;
    const auto cut = [&](double allowed, double speed, JogProgress::Limit why, int joint) {
      if (speed * scale > allowed) {
        scale = allowed / speed;
        progress.limited_by = why;
        progress.joint = joint;
      }
    };
    for (int i = 0; i < n; ++i) {
      const double speed = std::abs(qd_(i));
      if (speed == 0.0) continue;
      cut(otg_limits.velocity(i), speed, JogProgress::kVelocity, i);
      const double room = qd_(i) > 0.0 ? limits.upper(i) - ref.q(i) : ref.q(i) - limits.lower(i);
      cut(motion::speed_that_stops_within(room, otg_limits.acceleration(i), otg_limits.jerk(i)), speed, JogProgress::kPosition,
          i);
    }
    const double fastest = qd_.cwiseAbs().maxCoeff();
    if (twist && fastest > 0.0 && progress.condition > config_.slow_condition) {
      step_ = (kProbeStep / fastest) * qd_;
      if (condition_ahead(step_) > progress.condition) {  // toward the singularity: slower as κ rises
        const double allowed = std::clamp((config_.stop_condition - progress.condition) /
                                              (config_.stop_condition - config_.slow_condition),
                                          0.0, 1.0);
        if (allowed < scale) {
          scale = allowed;
          progress.limited_by = JogProgress::kSingularity;
          progress.joint = -1;
        }
      }
    }
    qd_ *= scale;
    progress.scale = scale;
  }
  from_.p = ref.q;
  from_.v = ref.qd;
  from_.a = ref.qdd;
  // Within the limits by construction (the velocity target is), so the plan is always found.
  otg_.plan_velocity(from_, qd_, otg_limits);
  otg_.at_time(dt, out_);

  // The guarantee: from where this step leaves the reference it must still be able to stop within
  // the position limits and, for a twist heading into a singularity, short of the stop threshold.
  // Else it halts: that brake was the last step's stop, checked then.
  if (!halt && qd_.cwiseAbs().maxCoeff() > 0.0) {
    bool safe = true;
    for (int i = 0; i < n && safe; ++i) {
      stop_(i) = motion::stop_position(out_.p(i), out_.v(i), out_.a(i), otg_limits.velocity(i),
                                       otg_limits.acceleration(i), otg_limits.jerk(i));
      // A joint outside its range (the arm started there) may come back in, not go further out.
      const bool out_above = stop_(i) > limits.upper(i) && stop_(i) > ref.q(i);
      const bool out_below = stop_(i) < limits.lower(i) && stop_(i) < ref.q(i);
      if (out_above || out_below) {
        safe = false;
        progress.limited_by = JogProgress::kPosition;
        progress.joint = i;
      }
    }
    if (safe && twist) {
      step_ = stop_ - ref.q;
      const double at_stop = condition_ahead(step_);
      if (at_stop >= config_.stop_condition && at_stop > progress.condition) {
        safe = false;
        progress.limited_by = JogProgress::kSingularity;
        progress.joint = -1;
      }
    }
    if (!safe) {
      qd_.setZero();
      progress.scale = 0.0;
      otg_.plan_velocity(from_, qd_, otg_limits);
      otg_.at_time(dt, out_);
    }
  }
  ref.q = out_.p;
  ref.qd = out_.v;
  ref.qdd = out_.a;
  return qd_.cwiseAbs().maxCoeff() == 0.0 && otg_.duration() <= dt;
}

}  // namespace chasles::controller
