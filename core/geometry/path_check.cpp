#include "core/geometry/path_check.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/kinematics/kinematics.hpp"

namespace chasles::geometry {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Joint k (1-based, as body k is its child) and what it moves.
const Joint& joint_of(const RobotModel& model, int k) { return model.joint(k - 1); }

// How far joint m's origin can be from joint m − 1's: fixed in body m − 1 for a revolute joint; a
// prismatic joint slides it along its axis by up to its stroke's larger end.
double stroke(const Joint& joint) {
  if (joint.type != JointType::Prismatic) return 0.0;
  return std::max(std::abs(joint.limits.lower), std::abs(joint.limits.upper));
}

double link_length(const RobotModel& model, int m) {
  const Joint& joint = joint_of(model, m);
  return joint.T_parent_joint.translation().norm() + stroke(joint);
}

// The distance of p from the line through the origin along the unit vector `axis`.
double from_axis(const Vector3d& p, const Vector3d& axis) { return (p - p.dot(axis) * axis).norm(); }

// A bound, over every configuration, on the distance from joint k's axis of any point of a sphere
// (centre, radius) fixed in body b ≥ k: the rate, m/rad, at which joint k can move such a point.
// Body k's origin is on axis k (its local screw has no moment), so distances are measured from
// the axis in body k's frame, where it is fixed, and chained outward by the triangle inequality.
double reach(const RobotModel& model, int k, int b, const Vector3d& centre, double radius) {
  const Joint& joint = joint_of(model, k);
  if (joint.type == JointType::Prismatic) return 1.0;  // every point moves with the slide itself
  if (k == b) return from_axis(centre, joint.axis) + radius;
  const Joint& next = joint_of(model, k + 1);
  double r = from_axis(next.T_parent_joint.translation(), joint.axis) + stroke(next);
  for (int m = k + 2; m <= b; ++m) r += link_length(model, m);
  return r + centre.norm() + radius;
}

void check_options(const PathCheckOptions& options) {
  if (!(options.min_step > 0.0 && options.min_step <= 1.0)) {
    throw ArgumentError("path check: min_step must be in (0, 1], not " + std::to_string(options.min_step));
  }
  if (options.max_samples < 2) {
    throw ArgumentError("path check: max_samples must be at least 2, not " + std::to_string(options.max_samples));
  }
}

// The path's speed bound into `speed` (sized to the joints: no allocation).
void speed_bound(const RobotModel& model, const JointPath& path, Eigen::VectorXd& speed) {
  const int n = model.dof();
  if (path.speed.size() == 0) {
    for (int i = 0; i < n; ++i) {
      speed[i] = model.joint(i).limits.velocity;
      if (!std::isfinite(speed[i])) {
        throw ArgumentError("path check: joint " + model.joint(i).name +
                            " has no finite velocity limit to bound the path's speed; give JointPath::speed");
      }
    }
    return;
  }
  if (path.speed.size() != n) {
    throw ArgumentError("path check: the speed bound has " + std::to_string(path.speed.size()) + " entries, the arm " +
                        std::to_string(n) + " joints");
  }
  for (int i = 0; i < n; ++i) {
    if (!(std::isfinite(path.speed[i]) && path.speed[i] >= 0.0)) {
      throw ArgumentError("path check: the speed bound of joint " + model.joint(i).name + " must be finite and ≥ 0");
    }
  }
  speed = path.speed;
}

}  // namespace

Eigen::MatrixXd distance_rates(const RobotModel& model, const Proximity& proximity) {
  const auto& objects = proximity.arm().objects;
  const auto& pairs = proximity.pairs();
  Eigen::MatrixXd rates = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(pairs.size()), model.dof());
  // The bounding sphere of arm object o in its body's frame.
  auto sphere = [&](int o, Vector3d& centre, double& radius) {
    const CollisionObject& object = objects[static_cast<size_t>(o)];
    centre = object.T_body_object * proximity.arm_centres()[static_cast<size_t>(o)];
    radius = proximity.arm_radii()[static_cast<size_t>(o)];
  };
  for (size_t p = 0; p < pairs.size(); ++p) {
    const ProximityPair& pair = pairs[p];
    // The object that moves, and from which body on: a scene object or a plane stands still; of
    // two arm objects, the one further out moves relative to the other by the joints between.
    int moving = pair.arm, from = 0;
    if (pair.kind == ProximityPair::kSelf) {
      const int body_a = objects[static_cast<size_t>(pair.arm)].body;
      const int body_b = objects[static_cast<size_t>(pair.other)].body;
      moving = body_a > body_b ? pair.arm : pair.other;
      from = std::min(body_a, body_b);
    }
    const int body = objects[static_cast<size_t>(moving)].body;
    Vector3d centre;
    double radius;
    sphere(moving, centre, radius);
    for (int k = from + 1; k <= body; ++k) {
      rates(static_cast<Eigen::Index>(p), k - 1) = reach(model, k, body, centre, radius);
    }
  }
  return rates;
}

ConfigurationClearance configuration_clearance(const RobotModel& model, const Proximity& proximity, Data& data,
                                               ProximityData& pdata, const Eigen::Ref<const Eigen::VectorXd>& q) {
  forward_kinematics(model, data, q);
  compute_distances(proximity, data.T_body, pdata);
  ConfigurationClearance c;
  const auto& pairs = proximity.pairs();
  for (size_t p = 0; p < pairs.size(); ++p) {
    const double margin = pdata.distance[p].distance - pairs[p].clearance.stop;
    if (margin < c.margin) c = {margin, static_cast<int>(p), pdata.distance[p].distance};
  }
  return c;
}

PathChecker::PathChecker(const RobotModel& model, const Proximity& proximity)
    : rates_(distance_rates(model, proximity)),
      rate_(rates_.rows()),
      stop_(rates_.rows()),
      margin_(rates_.rows()),
      next_(rates_.rows()),
      speed_(model.dof()),
      q_(model.dof()) {
  for (Eigen::Index p = 0; p < stop_.size(); ++p) stop_[p] = proximity.pairs()[static_cast<size_t>(p)].clearance.stop;
}

PathClearance check_path(const RobotModel& model, const Proximity& proximity, Data& data, ProximityData& pdata,
                         const JointPath& path, const PathCheckOptions& options) {
  check_options(options);
  PathChecker checker(model, proximity);
  return checker.check(model, proximity, data, pdata, path, options);
}

PathClearance PathChecker::check(const RobotModel& model, const Proximity& proximity, Data& data,
                                 ProximityData& pdata, const JointPath& path, const PathCheckOptions& options) {
  check_options(options);
  if (!path.position) throw ArgumentError("path check: the path has no position function");
  if (!(std::isfinite(path.duration) && path.duration >= 0.0)) {
    throw ArgumentError("path check: the duration must be finite and ≥ 0, not " + std::to_string(path.duration));
  }
  const double T = path.duration;
  const int n = model.dof();
  const Eigen::Index P = stop_.size();
  if (static_cast<size_t>(P) != proximity.pairs().size() || pdata.distance.size() != proximity.pairs().size()) {
    throw ArgumentError("path check: the checker or its workspace was built for another Proximity");
  }
  // w_p: how fast pair p's distance can shrink along this path, m/s.
  speed_bound(model, path, speed_);
  rate_.noalias() = rates_ * speed_;
  const Eigen::VectorXd& rate = rate_;
  const Eigen::VectorXd& stop = stop_;
  Eigen::VectorXd &q = q_, &margin = margin_, &next = next_;

  PathClearance result;
  double least_margin = kInfinity;
  auto sample = [&](double t, Eigen::VectorXd& m) {
    path.position(t, q);
    if (q.size() != n || !q.allFinite()) {
      throw ArgumentError("path check: q(" + std::to_string(t) + ") is " +
                          (q.size() != n ? "of the wrong size" : std::string("not finite")));
    }
    forward_kinematics(model, data, q);
    compute_distances(proximity, data.T_body, pdata);
    ++result.samples;
    for (Eigen::Index p = 0; p < P; ++p) {
      m[p] = pdata.distance[static_cast<size_t>(p)].distance - stop[p];
      if (m[p] < least_margin) {
        least_margin = m[p];
        result.least_pair = static_cast<int>(p);
        result.least_time = t;
        result.least_distance = pdata.distance[static_cast<size_t>(p)].distance;
      }
    }
  };
  // The pair seen below its stop distance at time t, when one is: of several, the one whose margin,
  // run straight from the sample before (`before`; none at the start), crossed zero first.
  auto below = [&](const Eigen::VectorXd& before, const Eigen::VectorXd& m, bool first) {
    int found = -1;
    double earliest = kInfinity;
    for (Eigen::Index p = 0; p < P; ++p) {
      if (!(m[p] < 0.0)) continue;
      const double crossed = first ? m[p] : before[p] / (before[p] - m[p]);
      if (crossed < earliest) earliest = crossed, found = static_cast<int>(p);
    }
    return found;
  };
  auto seen = [&](int p, double time, double t_seen) {
    result.clear = false;
    result.pair = p;
    result.time = time;
    result.time_seen = t_seen;
    result.checked_until = t_seen;
    result.distance = pdata.distance[static_cast<size_t>(p)].distance;
    return result;
  };

  double t = 0.0;
  sample(t, margin);
  if (const int p = below(margin, margin, true); p >= 0) return seen(p, 0.0, 0.0);
  const double least_step = options.min_step * T;
  while (t < T) {
    if (result.samples >= options.max_samples) {
      result.clear = false;
      result.complete = false;
      result.checked_until = t;
      return result;
    }
    // The longest step no pair can cross its stop distance in: margin over rate, the least of them.
    double safe = kInfinity;
    for (Eigen::Index p = 0; p < P; ++p) {
      if (rate[p] > 0.0) safe = std::min(safe, margin[p] / rate[p]);
    }
    // A least step is longer than the bound proves (unless it is the last, and the bound reaches
    // the end).
    const bool least = safe < least_step && safe < T - t;
    const double step = least ? least_step : safe;
    const double t_next = step >= T - t ? T : t + step;
    sample(t_next, next);
    result.least_steps += least ? 1 : 0;
    if (const int p = below(margin, next, false); p >= 0) return seen(p, std::min(t + safe, t_next), t_next);
    if (least) {
      // Between the two samples pair p's margin is at least max(m₀ − w s, m₁ − w (h − s)), whose
      // least is (m₀ + m₁ − w h) / 2: the most it can have dipped below its stop unseen.
      const double h = t_next - t;
      for (Eigen::Index p = 0; p < P; ++p) {
        result.shortfall = std::max(result.shortfall, -(margin[p] + next[p] - rate[p] * h) / 2.0);
      }
    }
    margin.swap(next);
    t = t_next;
  }
  result.checked_until = T;
  return result;
}

}  // namespace chasles::geometry
