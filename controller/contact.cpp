#include "controller/contact.hpp"

#include <cmath>
#include <cstdio>
#include <limits>


namespace chasles::controller {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDefaultObserverGain = 200.0;
constexpr double kContactShareOfEffort = 0.05, kCollisionShareOfEffort = 0.15;
constexpr double kHistorySeconds = 2.0;

bool positive_or_infinite(double x) { return x > 0.0; }  // false for NaN

}  // namespace

const char* to_string(Reflex reflex) {
  switch (reflex) {
    case Reflex::kStop:
      return "stop";
    case Reflex::kCompliant:
      return "compliant";
    case Reflex::kRetract:
      return "retract";
  }
  return "?";
}

bool parse_reflex(const std::string& text, Reflex& reflex) {
  for (Reflex r : {Reflex::kStop, Reflex::kCompliant, Reflex::kRetract}) {
    if (text == to_string(r)) {
      reflex = r;
      return true;
    }
  }
  return false;
}

void ContactConfig::fill_defaults(const RobotModel& model) {
  const int n = model.dof();
  if (observer_gain.size() == 0) observer_gain = Eigen::VectorXd::Constant(n, kDefaultObserverGain);
  auto share_of_effort = [&](double share) {
    Eigen::VectorXd threshold(n);
    for (int i = 0; i < n; ++i) {
      const double effort = model.joint(i).limits.effort;
      threshold(i) = std::isfinite(effort) && effort > 0.0 ? share * effort : kInf;
    }
    return threshold;
  };
  if (contact_torque.size() == 0) contact_torque = share_of_effort(kContactShareOfEffort);
  if (collision_torque.size() == 0) collision_torque = share_of_effort(kCollisionShareOfEffort);
}

void ContactConfig::validate(const RobotModel& model) const {
  const int dof = model.dof();
  auto check_joints = [&model, dof](const Eigen::VectorXd& v, const char* name) {
    if (v.size() != dof) {
      throw ArgumentError(std::string(name) + " has " + std::to_string(v.size()) + " entries; the arm has " +
                          std::to_string(dof) + " joints");
    }
    for (int i = 0; i < dof; ++i) {
      if (!positive_or_infinite(v(i))) {
        throw ArgumentError(std::string(name) + ", joint " + model.joint(i).name + ": " + std::to_string(v(i)) +
                            "; thresholds and gains must be positive");
      }
    }
  };
  check_joints(observer_gain, "the observer gain");
  if (!observer_gain.allFinite()) throw ArgumentError("the observer gain must be finite");
  check_joints(contact_torque, "the contact torque thresholds");
  check_joints(collision_torque, "the collision torque thresholds");
  for (int i = 0; i < dof; ++i) {
    if (contact_torque(i) > collision_torque(i)) {
      throw ArgumentError("joint " + model.joint(i).name + ": the contact torque threshold " +
                          std::to_string(contact_torque(i)) + " is above the collision threshold " +
                          std::to_string(collision_torque(i)));
    }
  }
  auto check_pair = [](double contact, double collision, const char* what) {
    if (!positive_or_infinite(contact) || !positive_or_infinite(collision)) {
      throw ArgumentError(std::string("the ") + what + " thresholds must be positive");
    }
    if (contact > collision) {
      throw ArgumentError(std::string("the contact ") + what + " threshold " + std::to_string(contact) +
                          " is above the collision threshold " + std::to_string(collision));
    }
  };
  check_pair(contact_force, collision_force, "tip force");
  check_pair(contact_moment, collision_moment, "tip moment");
  if (!(retract_distance > 0.0) || !std::isfinite(retract_distance)) {
    throw ArgumentError("the retract distance must be positive and finite");
  }
  if (!(retract_duration > 0.0) || !std::isfinite(retract_duration)) {
    throw ArgumentError("the retract duration must be positive and finite");
  }
  if (!(compliant_damping > 0.0) || !std::isfinite(compliant_damping)) {
    throw ArgumentError("the compliant reflex's damping must be positive and finite");
  }
}

namespace {
ContactConfig filled(ContactConfig config, const RobotModel& model) {
  config.fill_defaults(model);
  config.validate(model);
  return config;
}
}  // namespace

ContactMonitor::ContactMonitor(const RobotModel& model, const ContactConfig& config, const Eigen::VectorXd& damping,
                               double period, const Eigen::VectorXd& coulomb)
    : model_(&model),
      config_(filled(config, model)),
      observer_(model, config_.observer_gain, damping, coulomb),
      estimate_(model.dof()),
      allowance_(Eigen::VectorXd::Zero(model.dof())),
      history_q_(Eigen::MatrixXd::Zero(model.dof(), static_cast<Eigen::Index>(std::ceil(kHistorySeconds / period)))),
      history_tip_(Eigen::Matrix3Xd::Zero(3, history_q_.cols())) {}

void ContactMonitor::set_model(const RobotModel& model) {
  model_ = &model;
  started_ = false;  // the new model's momentum is not the old one's
}

void ContactMonitor::update(const Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                            const Eigen::VectorXd& effort, double dt) {
  const Matrix6Xd& J_b = data.J_b;
  estimate_.tip_position = data.T_sb.translation();
  remember(q);
  if (!started_ || !(dt > 0.0 && std::isfinite(dt))) {
    observer_.reset(data, qd);
    started_ = true;
    estimate_.tau_ext.setZero();
    estimate_.wrench_tip.setZero();
    estimate_.wrench_base.setZero();
    estimate_.contact = estimate_.collision = false;
    return;
  }
  estimate_.tau_ext = observer_.update(data, qd, effort, dt);
  estimate_.wrench_tip = tip_wrench_from_torque(J_b, estimate_.tau_ext);
  estimate_.wrench_base = base_aligned_wrench(data.T_sb, estimate_.wrench_tip);
  allowance_base_ = allowance_.isZero(0.0) ? Vector6d::Zero()
                                           : base_aligned_wrench(data.T_sb, tip_wrench_from_torque(J_b, allowance_));
  classify();
}

// What tripped is named by its ratio to its threshold: the largest over a collision threshold,
// else the largest over a contact threshold.
void ContactMonitor::classify() {
  struct Excess {
    double ratio = 1.0, value = 0.0, limit = 0.0;
    int joint = -1;
    const char* what = nullptr;
  } collision, contact;
  auto consider = [&](double value, double contact_limit, double collision_limit, int joint, const char* what) {
    if (value / collision_limit > collision.ratio) collision = {value / collision_limit, value, collision_limit, joint, what};
    if (value / contact_limit > contact.ratio) contact = {value / contact_limit, value, contact_limit, joint, what};
  };
  for (int i = 0; i < model_->dof(); ++i) {
    const double allowed = std::abs(allowance_(i));
    consider(std::abs(estimate_.tau_ext(i)), config_.contact_torque(i), config_.collision_torque(i) + allowed, i,
             "torque");
  }
  const double force = allowance_base_.tail<3>().norm(), moment = allowance_base_.head<3>().norm();
  consider(estimate_.wrench_base.tail<3>().norm(), config_.contact_force, config_.collision_force + force, -1, "force");
  consider(estimate_.wrench_base.head<3>().norm(), config_.contact_moment, config_.collision_moment + moment, -1,
           "moment");
  estimate_.collision = collision.what != nullptr;
  estimate_.contact = contact.what != nullptr;
  const Excess& e = estimate_.collision ? collision : contact;
  if (e.what == nullptr) return;
  const char* level = estimate_.collision ? "collision" : "contact";
  if (e.joint >= 0) {
    std::snprintf(reason_, sizeof(reason_), "%s: joint %s external torque %.3g over %.3g", level,
                  model_->joint(e.joint).name.c_str(), e.value, e.limit);
  } else {
    std::snprintf(reason_, sizeof(reason_), "%s: tip %s %.3g %s over %.3g", level, e.what, e.value,
                  e.what[0] == 'f' ? "N" : "N*m", e.limit);
  }
}

void ContactMonitor::remember(const Eigen::VectorXd& q) {
  history_q_.col(history_next_) = q;
  history_tip_.col(history_next_) = estimate_.tip_position;
  history_next_ = (history_next_ + 1) % static_cast<int>(history_q_.cols());
  history_count_ = std::min<int>(history_count_ + 1, static_cast<int>(history_q_.cols()));
}

void ContactMonitor::retract_goal(double distance, Eigen::VectorXd& q) const {
  const int size = static_cast<int>(history_q_.cols());
  const int newest = (history_next_ + size - 1) % size;
  int k = newest;
  for (int back = 0; back < history_count_; ++back) {
    k = (newest - back + size) % size;
    if ((history_tip_.col(k) - history_tip_.col(newest)).norm() >= distance) break;
  }
  q = history_q_.col(k);
}

}  // namespace chasles::controller
