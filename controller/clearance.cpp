#include "controller/clearance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace chasles::controller {
namespace {

// Each joint's space twist (ω, v) at the body poses of `at`: [Ad_{T_0i}] A_i.
void joint_twists(const RobotModel& model, const Data& at, Eigen::Matrix<double, 6, Eigen::Dynamic>& twists) {
  for (int j = 0; j < model.dof(); ++j) {
    const Transform& T = at.T_body[static_cast<size_t>(j) + 1];
    const Vector6d& A = model.local_axis(j);
    const Vector3d w = T.linear() * A.head<3>();
    twists.col(j).head<3>() = w;
    twists.col(j).tail<3>() = T.linear() * A.tail<3>() + T.translation().cross(w);
  }
}

}  // namespace

ClearanceWorld::ClearanceWorld(const RobotModel& model, geometry::Proximity proximity_)
    : proximity(std::move(proximity_)),
      at_state(proximity),
      at_reference(proximity),
      along_path(proximity),
      path_checker(model, proximity),
      rates(geometry::distance_rates(model, proximity)),
      free_step(Eigen::VectorXd::Zero(model.dof())),
      speed(Eigen::VectorXd::Zero(model.dof())),
      row(Eigen::VectorXd::Zero(model.dof())),
      twists(6, model.dof()) {}

Clearance::Clearance(const RobotModel& model, const ClearanceConfig& config)
    : config_(config), cut_(model.dof()), carried_qdd_(Eigen::VectorXd::Zero(model.dof())) {}

void Clearance::set_world(ClearanceWorld* world) {
  world_ = world;
  status_ = ClearanceStatus{};
}

int Clearance::observe(const Data& at_state) {
  inside_ = -1;
  if (world_ == nullptr) return -1;
  const geometry::Proximity& proximity = world_->proximity;
  geometry::ProximityData& distances = world_->at_state;
  geometry::compute_distances(proximity, at_state.T_body, distances);
  status_.closest = distances.closest;
  if (distances.closest < 0) return -1;
  const geometry::PairDistance& closest = distances.distance[static_cast<size_t>(distances.closest)];
  status_.closest_distance = closest.distance;
  status_.closest_arm = closest.p_arm;
  status_.closest_other = closest.p_other;
  proximity.name_pair(distances.closest, status_.closest_name, sizeof(status_.closest_name));
  int inside = -1;
  double deepest = 0.0;
  for (size_t p = 0; p < proximity.pairs().size(); ++p) {
    const double below = proximity.pairs()[p].clearance.stop - distances.distance[p].distance;
    if (below > deepest) deepest = below, inside = static_cast<int>(p);
  }
  return inside_ = inside;
}

const char* Clearance::inside_reason(int pair) {
  char name[128];
  world_->proximity.name_pair(pair, name, sizeof(name));
  std::snprintf(reason_, sizeof(reason_), "%s at %.4f m, inside its stop distance %.4f m", name,
                world_->at_state.distance[static_cast<size_t>(pair)].distance,
                world_->proximity.pairs()[static_cast<size_t>(pair)].clearance.stop);
  return reason_;
}

bool Clearance::path_clear(const RobotModel& model, Data& data, const geometry::JointPath& path, char* why,
                           size_t size) {
  if (world_ == nullptr) return true;
  const geometry::PathClearance c =
      world_->path_checker.check(model, world_->proximity, data, world_->along_path, path);
  if (c.clear) return true;
  if (c.pair < 0) {  // never seen with the default options: a path needs at most 1/min_step samples
    std::snprintf(why, size, "its path could not be checked to its end (%d samples, to t = %.3f s of %.3f s)",
                  c.samples, c.checked_until, path.duration);
    return false;
  }
  char name[128];
  world_->proximity.name_pair(c.pair, name, sizeof(name));
  std::snprintf(why, size, "%s would come within its stop distance %.3f m at t = %.3f s of %.3f s", name,
                world_->proximity.pairs()[static_cast<size_t>(c.pair)].clearance.stop, c.time, path.duration);
  return false;
}

void Clearance::distance_row(const RobotModel& model, const geometry::PairDistance& d,
                             const geometry::ProximityPair& pair, Eigen::VectorXd& row) const {
  // d grows as the other's witness moves along n and the arm's against it: ḋ = n·(ṗ_other − ṗ_arm),
  // each witness moved by the joints below its body (ṗ = v_j + ω_j × p per joint j).
  const auto& objects = world_->proximity.arm().objects;
  const auto& twists = world_->twists;
  const int arm_body = objects[static_cast<size_t>(pair.arm)].body;
  const int other_body = pair.kind == geometry::ProximityPair::kSelf ? objects[static_cast<size_t>(pair.other)].body : 0;
  const Vector3d arm_lever = d.p_arm.cross(d.normal), other_lever = d.p_other.cross(d.normal);
  for (int j = 0; j < model.dof(); ++j) {
    // n·(v + ω × p) = n·v + ω·(p × n)
    const double v = twists.col(j).tail<3>().dot(d.normal);
    row(j) = (j < other_body ? v + twists.col(j).head<3>().dot(other_lever) : 0.0) -
             (j < arm_body ? v + twists.col(j).head<3>().dot(arm_lever) : 0.0);
  }
}

bool Clearance::shape(const RobotModel& model, const Data& at_from, const motion::Reference& from, double dt,
                      const Eigen::VectorXd& acceleration, motion::Reference& ref) {
  if (++uncut_ticks_ > ClearanceStatus::kSlowingHold) {
    status_.slowing = -1;
    status_.kept = 1.0;
    status_.slowing_name[0] = '\0';
  }
  if (world_ == nullptr || !(dt > 0.0)) return false;
  ClearanceWorld& w = *world_;
  const auto& pairs = w.proximity.pairs();
  geometry::compute_distances(w.proximity, at_from.T_body, w.at_reference);
  w.free_step = (ref.q - from.q) / dt;
  w.speed = w.free_step.cwiseAbs();
  // Each pair within its influence may close at most at a rate its room sets: the source's step is
  // slowed along its own path by the least factor that keeps every pair within its rate — never a
  // motion the source did not ask for (a slide along the wall) — and since no rate asks a pair to
  // open, a factor in [0, 1] always exists.
  double scale = 1.0;
  int most = -1;
  bool twists = false;
  for (size_t p = 0; p < pairs.size(); ++p) {
    const geometry::PairDistance& d = w.at_reference.distance[p];
    const geometry::Clearance& c = pairs[p].clearance;
    // Watched from its influence distance, or from farther when the step could close it faster
    // than the deceleration stops it from there: its stop distance plus v²/2a, v bounded by the
    // joints' speeds and the pair's rates. Otherwise a fast stream met its first pair too close
    // to slow for, and the reference's velocity dropped in one tick by more than the arm follows.
    const double v = w.rates.row(static_cast<Eigen::Index>(p)).dot(w.speed);
    const double watch = std::max(c.influence, c.stop + config_.reference_margin + v * v / (2.0 * config_.deceleration));
    if (d.distance >= watch) continue;
    if (!d.exact) geometry::compute_exactly(w.proximity, w.at_reference, static_cast<int>(p));
    if (d.distance >= watch) continue;
    if (!twists) joint_twists(model, at_from, w.twists), twists = true;
    distance_row(model, d, pairs[p], w.row);
    const double rate = w.row.dot(w.free_step);
    const double room = d.distance - c.stop - config_.reference_margin;
    // Inside the margin already (a scene put there, a push): no deeper, and never driven out.
    const double least = room <= 0.0 ? 0.0 : -std::min(room / config_.time_constant, std::sqrt(2.0 * config_.deceleration * room));
    if (rate < least && least / rate < scale) scale = least / rate, most = static_cast<int>(p);
  }
  if (most < 0) return false;
  uncut_ticks_ = 0;
  status_.slowing = most;
  w.proximity.name_pair(status_.slowing, status_.slowing_name, sizeof(status_.slowing_name));
  status_.kept = scale;
  // The source's path, slowed: its step and its velocity at the step's end both scaled, and the
  // acceleration that makes over the tick, within the limits — the law's feedforward for the motion
  // the reference makes. (The source's own, scaled, pushed the arm on into what the reference was
  // held short of.) A stream's or a jog's generator plans its next step from its own acceleration
  // instead, scaled (hand_back): from this one, or from none, it regains only J·dt of its
  // braking per tick, and under a small cut at every tick a stream ran up to 0.17 rad past its
  // last setpoint, into a joint's position limit.
  carried_qdd_ = scale * ref.qdd;
  ref.q = from.q + scale * dt * w.free_step;
  ref.qd *= scale;
  ref.qdd = ((ref.qd - from.qd) / dt).cwiseMax(-acceleration).cwiseMin(acceleration);
  cut_ = ref;
  carried_ = true;
  return true;
}

void Clearance::hand_back(motion::Reference& ref) {
  if (carried_ && ref.q == cut_.q && ref.qd == cut_.qd && ref.qdd == cut_.qdd) ref.qdd = carried_qdd_;
  carried_ = false;
}

void Clearance::repel(const RobotModel& model, const Data& at_state, Eigen::VectorXd& tau) {
  if (world_ == nullptr) return;
  ClearanceWorld& w = *world_;
  const auto& pairs = w.proximity.pairs();
  bool twists = false;
  for (size_t p = 0; p < pairs.size(); ++p) {
    const geometry::PairDistance& d = w.at_state.distance[p];
    const geometry::Clearance& c = pairs[p].clearance;
    if (!d.exact || d.distance >= c.influence) continue;
    if (!twists) joint_twists(model, at_state, w.twists), twists = true;
    distance_row(model, d, pairs[p], w.row);
    const double share = std::clamp((c.influence - d.distance) / (c.influence - c.stop), 0.0, 1.0);
    tau += config_.repulsion * share * w.row;  // the generalised force of f pushing the pair apart
  }
}

}  // namespace chasles::controller
