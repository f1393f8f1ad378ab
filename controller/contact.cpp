#include "controller/contact.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>


namespace chasles::controller {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDefaultObserverGain = 200.0;
constexpr double kContactShareOfEffort = 0.05, kCollisionShareOfEffort = 0.15, kIsolationShareOfEffort = 0.01;
constexpr double kHistorySeconds = 2.0;

bool positive_or_infinite(double x) { return x > 0.0; }  // false for NaN
// The locator looks at most every 10 ms (100 Hz) while a contact lasts: older than this, it has gone.
constexpr double kLocationFresh = 0.05;  // s
// A link's name in a reason, at most 48 characters of it.
int link_length(std::string_view link) { return static_cast<int>(std::min<size_t>(link.size(), 48)); }

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

bool parse_link_policy(const std::string& text, LinkPolicy& policy, std::string& why) {
  std::vector<std::string> fields;
  size_t start = 0;
  for (size_t comma = text.find(','); ; comma = text.find(',', start)) {
    fields.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (fields.size() != 4) {
    why = "'" + text + "': give LINK,FORCE,REFLEX,guided|strict (4 fields, found " + std::to_string(fields.size()) + ")";
    return false;
  }
  LinkPolicy p;
  p.link = fields[0];
  if (p.link.empty()) {
    why = "'" + text + "': the link is empty";
    return false;
  }
  char* end = nullptr;
  p.collision_force = std::strtod(fields[1].c_str(), &end);
  if (fields[1].empty() || *end != '\0' || !positive_or_infinite(p.collision_force)) {
    why = "'" + text + "': the collision force '" + fields[1] + "' must be a positive number of N or inf";
    return false;
  }
  if (!parse_reflex(fields[2], p.reflex)) {
    why = "'" + text + "': the reflex '" + fields[2] + "' is none of stop, compliant, retract";
    return false;
  }
  if (fields[3] != "guided" && fields[3] != "strict") {
    why = "'" + text + "': '" + fields[3] + "' is neither guided (free drive: a person) nor strict (a collision)";
    return false;
  }
  p.guided = fields[3] == "guided";
  policy = p;
  return true;
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
  if (isolation_torque.size() == 0) isolation_torque = share_of_effort(kIsolationShareOfEffort);
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
  check_joints(isolation_torque, "the isolation torque floors");
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
  std::vector<const LinkPolicy*> by_body(static_cast<size_t>(dof) + 1, nullptr);
  for (const LinkPolicy& p : links) {
    const int body = body_of_link(model, p.link);
    if (body < 0) throw ArgumentError("the contact policy of link '" + p.link + "': no such link on the chain");
    if (!positive_or_infinite(p.collision_force)) {
      throw ArgumentError("the contact policy of link '" + p.link + "': the collision force must be positive");
    }
    if (const LinkPolicy* other = by_body[static_cast<size_t>(body)]) {
      throw ArgumentError("the contact policies of links '" + other->link + "' and '" + p.link +
                          "': both ride on one body, which isolation cannot tell apart; give one");
    }
    by_body[static_cast<size_t>(body)] = &p;
  }
}

int body_of_link(const RobotModel& model, const std::string& link) {
  for (const ChainLink& l : model.links()) {
    if (l.name == link) return l.body;
  }
  return -1;
}

namespace {
ContactConfig filled(ContactConfig config, const RobotModel& model) {
  config.fill_defaults(model);
  config.validate(model);
  return config;
}

// Per body 0…n: the config's default, named after the body's first link on the chain, unless a
// link of the body has a policy of its own.
std::vector<LinkPolicy> policies_by_body(const RobotModel& model, const ContactConfig& config) {
  std::vector<LinkPolicy> policies(static_cast<size_t>(model.dof()) + 1,
                                   LinkPolicy{"", config.collision_force, config.reflex, true});
  for (auto it = model.links().rbegin(); it != model.links().rend(); ++it) {
    policies[static_cast<size_t>(it->body)].link = it->name;
  }
  for (const LinkPolicy& p : config.links) policies[static_cast<size_t>(body_of_link(model, p.link))] = p;
  return policies;
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
      history_tip_(Eigen::Matrix3Xd::Zero(3, history_q_.cols())),
      policies_(policies_by_body(model, config_)) {}

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
    estimate_.body = 0;
    location_pending_ = false;
    location_age_ = kInf;
    return;
  }
  estimate_.tau_ext = observer_.update(data, qd, effort, dt);
  location_age_ += dt;
  estimate_.wrench_tip = tip_wrench_from_torque(J_b, estimate_.tau_ext);
  estimate_.wrench_base = base_aligned_wrench(data.T_sb, estimate_.wrench_tip);
  allowance_base_ = allowance_.isZero(0.0) ? Vector6d::Zero()
                                           : base_aligned_wrench(data.T_sb, tip_wrench_from_torque(J_b, allowance_));
  isolate();
  classify();
  judge_location();
}

void ContactMonitor::take_location(const LocatedContact& located) {
  if (located.body < 1 || located.body > model_->dof()) return;
  located_ = located;
  location_pending_ = true;
  location_age_ = 0.0;
}

bool ContactMonitor::location_fresh() const { return location_age_ <= kLocationFresh; }

// The locator's body while its estimate is recent: it looked at the arm's shape, and a force whose
// line passes through the distal joints' axes (a push on a tool's centre, on the last joint's
// axis) leaves their torque at zero. Else the most distal joint over its floor: a force on body b
// leaves the joints beyond b untouched.
void ContactMonitor::isolate() {
  estimate_.body = 0;
  isolated_link_ = {};
  if (location_fresh()) {
    estimate_.body = located_.body;
    isolated_link_ = located_.link;
    return;
  }
  for (int i = model_->dof() - 1; i >= 0; --i) {
    if (std::abs(estimate_.tau_ext(i)) >= config_.isolation_torque(i)) {
      estimate_.body = i + 1;
      isolated_link_ = policy(estimate_.body).link;
      return;
    }
  }
}

// Judged once, at the first state after it arrived: the located force against its link's policy,
// when the thresholds in the tick found no collision of their own. (A located force is not compared
// with the contact threshold here: the locator flags its own contact, contact_estimate_t.contact.)
void ContactMonitor::judge_location() {
  if (!location_pending_) return;
  location_pending_ = false;
  if (estimate_.collision) return;
  // Raised, as the tip's threshold is, by the force the law means to press with.
  const double limit = policy(located_.body).collision_force + allowance_base_.tail<3>().norm();
  const double force = located_.force.norm();
  if (!(force >= limit)) return;
  estimate_.collision = estimate_.contact = true;
  estimate_.body = located_.body;
  std::snprintf(reason_, sizeof(reason_), "collision: %.3g N located on %.*s at (%.3f, %.3f, %.3f) m, over %.3g",
                force, link_length(located_.link), located_.link.data(), located_.point.x(), located_.point.y(),
                located_.point.z(), limit);
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
  const char* on = estimate_.body > 0 ? ", on " : "";
  // Isolated by the torques alone, the link is where the contact begins: the most distal joint
  // that feels it moves that link, and a push on a later one may leave the joints between at zero.
  const char* beyond = estimate_.body > 0 && !location_fresh() ? " or beyond" : "";
  if (e.joint >= 0) {
    std::snprintf(reason_, sizeof(reason_), "%s: joint %s external torque %.3g over %.3g%s%.*s%s", level,
                  model_->joint(e.joint).name.c_str(), e.value, e.limit, on, link_length(isolated_link_),
                  isolated_link_.data(), beyond);
  } else {
    std::snprintf(reason_, sizeof(reason_), "%s: tip %s %.3g %s over %.3g%s%.*s%s", level, e.what, e.value,
                  e.what[0] == 'f' ? "N" : "N*m", e.limit, on, link_length(isolated_link_), isolated_link_.data(),
                  beyond);
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
