#include "controller/reference/jogging.hpp"

#include <Eigen/Geometry>

#include "core/lie/so3.hpp"

namespace chasles::controller {

JoggedMotion::JoggedMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits,
                           GeneratorLimits& generator, double timeout, JogProgress& progress)
    : limits_(limits), generator_(generator), timeout_(timeout), progress_(progress), jogger_(dof, config) {}

void JoggedMotion::start(int64_t now_ns) {
  clock_.restart();
  tick_ns_ = now_ns;
}

double JoggedMotion::step(int64_t now_ns, bool& halt) {
  const double dt = stream_step(tick_ns_, now_ns);
  tick_ns_ = now_ns;
  halt = clock_.silent(now_ns, timeout_);
  return dt;
}

JogMotion::JogMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits, GeneratorLimits& generator,
                     double timeout, JogProgress& progress)
    : JoggedMotion(dof, config, limits, generator, timeout, progress), jog_(dof) {}

bool JogMotion::take(const Jog& jog, const Data& data, int64_t now_ns) {
  if (!clock_.take_if_newer(jog.utime)) return false;
  clock_.take(jog.utime, now_ns, timeout_);
  generator_.fit_to_arm(data);
  jog_.utime = jog.utime;
  jog_.kind = jog.kind;
  jog_.frame = jog.frame;
  jog_.joint_velocity = jog.joint_velocity;
  jog_.twist = jog.twist;
  return true;
}

ReferenceSource::Progress JogMotion::advance(const Tick& tick, motion::Reference& ref) {
  bool halt = false;
  const double dt = step(tick.now_ns, halt);
  const Data& at_reference = tick.kinematics->at(*tick.model, ref.q);
  const bool at_rest =
      jogger_.step(at_reference, jog_, halt, limits_, generator_.limits(), dt, ref, progress_) && halt;
  return at_rest ? Progress::kArrived : Progress::kMoving;
}

TipStreamMotion::TipStreamMotion(int dof, const JogConfig& config, const motion::MotionLimits& limits,
                                 GeneratorLimits& generator, double timeout, JogProgress& progress)
    : JoggedMotion(dof, config, limits, generator, timeout, progress) {}

bool TipStreamMotion::take(const TipSetpoint& setpoint, const Data& data, int64_t now_ns) {
  if (!clock_.take_if_newer(setpoint.utime)) return false;
  generator_.fit_to_arm(data);
  const double age = clock_.take(setpoint.utime, now_ns, timeout_);
  const Eigen::Vector4d& w = setpoint.quaternion;
  twist_ = setpoint.twist;
  target_.linear() = exp3(twist_.head<3>() * age) *
                     Eigen::Quaterniond(w(0), w(1), w(2), w(3)).normalized().toRotationMatrix();
  target_.translation() = setpoint.position + twist_.tail<3>() * age;
  return true;
}

ReferenceSource::Progress TipStreamMotion::advance(const Tick& tick, motion::Reference& ref) {
  bool halt = false;
  const double dt = step(tick.now_ns, halt);
  if (!halt) {  // the pose moves on with its twist: the rotation in the base's axes, on the left
    target_.linear() = exp3(twist_.head<3>() * dt) * target_.linear();
    target_.translation() += twist_.tail<3>() * dt;
  }
  const Data& at_reference = tick.kinematics->at(*tick.model, ref.q);
  const bool at_rest =
      jogger_.follow_pose(at_reference, target_, twist_, halt, limits_, generator_.limits(), dt, ref, progress_) &&
      halt;
  return at_rest ? Progress::kArrived : Progress::kMoving;
}

}  // namespace chasles::controller
