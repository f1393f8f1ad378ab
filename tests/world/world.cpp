#include "world.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/dynamics/dynamics.hpp"
#include "lcmtypes/checked.hpp"

namespace chasles::faults {
namespace {

constexpr size_t kPositions = 8192;  // states remembered by seq: seconds, far more than a command answers
constexpr int kQueue = 1 << 16;      // the test's subscriptions lose nothing, whatever the burst

}  // namespace

Recorder::Recorder(Bus& bus, const SimulatedClock& clock, const std::string& prefix, controller::Protocol protocol,
                   const RobotModel* model)
    : bus_(bus),
      clock_(clock),
      prefix_(prefix),
      protocol_(protocol),
      model_(model),
      positions_(kPositions, {-1, Eigen::VectorXd()}) {
  const controller::ProtocolChannels driver = controller::default_channels(protocol, prefix);
  if (protocol == controller::Protocol::kChasles) {
    subscriptions_.push_back(bus.subscribe(
        driver.status,
        [this](const uint8_t* data, size_t size) {
          robot_state_t m;
          if (!messages::decode_checked(data, size, m, messages::kAnyArm, messages::Finite::Required).empty()) return;
          on_state(m);
        },
        kQueue));
    subscriptions_.push_back(bus.subscribe(
        driver.command,
        [this](const uint8_t* data, size_t size) {
          HeardCommand c{};
          if (own_raw(data, size) || !messages::decode_checked(data, size, c.message).empty()) return;
          if (own_commands_.count({c.message.seq, c.message.utime}) > 0) return;
          on_command(std::move(c));
        },
        kQueue));
  } else {
    const int n = model->dof();
    reader_.emplace(protocol, n);
    data_.emplace(*model);
    subscriptions_.push_back(bus.subscribe(
        driver.status,
        [this, n](const uint8_t* data, size_t size) {
          controller::JointState state(n);
          if (!reader_->read(data, size, clock_.now_ns(), state).empty()) return;
          robot_state_t m;
          m.utime = state.utime;
          const int64_t plant_seq = plant_seq_ ? plant_seq_(state.utime) : -1;
          m.seq = plant_seq >= 0 ? plant_seq : state.seq;
          m.num_joints = n;
          m.position.assign(state.q.data(), state.q.data() + n);
          m.velocity.assign(state.qd.data(), state.qd.data() + n);
          m.effort.assign(state.effort.data(), state.effort.data() + n);
          seq_of_utime_[m.utime] = m.seq;
          on_state(m);
        },
        kQueue));
    subscriptions_.push_back(bus.subscribe(
        driver.command, [this](const uint8_t* data, size_t size) { hear_drake_command(data, size); }, kQueue));
  }
  subscriptions_.push_back(bus.subscribe(
      prefix + "STATUS",
      [this](const uint8_t* data, size_t size) {
        HeardStatus s{};
        if (!messages::decode_checked(data, size, s.message).empty()) return;
        s.index = ++index_;
        status_ = s.message;
        statuses_.push_back(std::move(s));
      },
      kQueue));
}

void Recorder::on_state(const robot_state_t& m) {
  ++index_;
  state_arrivals_.push_back(clock_.now_ns());
  positions_[size_t(m.seq) % kPositions] = {m.seq, vector_of(m.position)};
  state_ = m;
  if (keep_states_) states_.push_back(m);
}

void Recorder::on_command(HeardCommand c) {
  c.index = ++index_;
  const auto& [seq, q] = positions_[size_t(std::max<int64_t>(c.message.state_seq, 0)) % kPositions];
  if (seq == c.message.state_seq) c.q_answered = q;
  commands_.push_back(std::move(c));
}

bool Recorder::own_raw(const uint8_t* data, size_t size) {
  const auto own = own_raw_.find(std::vector<uint8_t>(data, data + size));
  if (own == own_raw_.end()) return false;
  own_raw_.erase(own);
  return true;
}

void Recorder::publish_raw(const std::string& channel, const std::vector<uint8_t>& bytes) {
  own_raw_.insert(bytes);
  bus_.publish(channel, bytes);
}

void Recorder::publish_status(const robot_state_t& state) {
  const int n = state.num_joints;
  plant::StatePublisher publisher(bus_, controller::default_channels(protocol_, prefix_).status, n, {}, 1, protocol_);
  const Eigen::VectorXd q = vector_of(state.position), qd = vector_of(state.velocity),
                        effort = vector_of(state.effort), zero = Eigen::VectorXd::Zero(n);
  const plant::DriverReport report{qd,   effort, effort, zero, q, zero, true, 1.0, drake::lcmt_panda_status::kMove,
                                   drake::lcmt_panda_status::CONTROL_MODE_TORQUE, state.utime};
  publisher.encode(state.utime, state.seq, q, report);
  publisher.send(clock_.now_ns());
}

void Recorder::hear_drake_command(const uint8_t* data, size_t size) {
  if (own_raw(data, size)) return;
  const int n = model_->dof();
  HeardCommand c{};
  std::vector<double> torque;
  int64_t utime = 0;
  if (protocol_ == controller::Protocol::kDrakeIiwa) {
    drake::lcmt_iiwa_command m;
    if (!messages::decode_checked(data, size, m, n).empty() || m.num_torques != n) return;
    utime = m.utime;
    torque = m.joint_torque;
  } else {
    drake::lcmt_panda_command m;
    if (!messages::decode_checked(data, size, m, n).empty() || m.num_joint_torque != n) return;
    utime = m.utime;
    torque = m.joint_torque;
  }
  const auto answered = seq_of_utime_.find(utime);
  c.message.utime = clock_.utime_us();  // sent now: the bus has no latency here
  c.message.seq = ++drake_commands_;
  c.message.state_seq = answered == seq_of_utime_.end() ? -1 : answered->second;
  c.message.num_joints = n;
  c.message.torque = torque;
  const auto& [seq, q] = positions_[size_t(std::max<int64_t>(c.message.state_seq, 0)) % kPositions];
  if (controller::default_torque_semantics(protocol_) == controller::TorqueSemantics::kOverlay && seq >= 0 &&
      seq == c.message.state_seq) {
    const Eigen::VectorXd& g = gravity_torques(*model_, *data_, q);
    for (int i = 0; i < n; ++i) c.message.torque[size_t(i)] += g(i);
  }
  on_command(std::move(c));
}

int64_t Recorder::commands_after(int64_t index) const {
  return std::count_if(commands_.begin(), commands_.end(), [index](const HeardCommand& c) { return c.index > index; });
}

World::World(const RobotModel& model, controller::Protocol protocol)
    : model_(model), bus_("memq://"), recorder_(std::make_unique<Recorder>(bus_, clock_, "CHASLES_", protocol, &model)) {
  recorder_->number_states_by([this](int64_t utime) { return plant_ ? plant_->state_seq(utime) : -1; });
}

World::~World() {
  controllers_.clear();  // their subscriptions before the bus
  plant_.reset();
  recorder_.reset();
}

plant::Simulation& World::start_plant(const Eigen::VectorXd& q0, const plant::SimulationOptions& options) {
  plant_.reset();
  plant_clock_ = std::make_unique<plant::PausableClock>(clock_);
  return started(std::make_unique<plant::Simulation>(model_, options, q0, Eigen::VectorXd::Constant(q0.size(), 0.5),
                                                     bus_, *plant_clock_));
}

plant::Simulation& World::start_plant(std::unique_ptr<plant::Physics> engine, const plant::SimulationOptions& options) {
  plant_.reset();
  plant_clock_ = std::make_unique<plant::PausableClock>(clock_);
  return started(std::make_unique<plant::Simulation>(model_, options, std::move(engine), bus_, *plant_clock_));
}

plant::Simulation& World::started(std::unique_ptr<plant::Simulation> simulation) {
  plant_ = std::move(simulation);
  plant_->start();
  plant_next_ = now() + plant_->period_ns();
  bus_.handle_pending();
  answer_states();
  return *plant_;
}

void World::kill_plant() { plant_.reset(); }

int World::add_controller(const controller::DaemonOptions& options, int64_t phase_ns, const RobotModel* model) {
  auto c = std::make_unique<Controller>();
  c->options = options;
  c->node = std::make_unique<controller::Node>(model ? *model : model_, c->options, clock_,
                                               controller::Buses{bus_, bus_, bus_});
  c->next = c->node->first_tick() + phase_ns;
  controllers_.push_back(std::move(c));
  return static_cast<int>(controllers_.size()) - 1;
}

// The earliest turn due by `until`, if any: the plant's step first at a tie (its state is then
// heard by a controller ticking at the same instant), then the controllers in the order added.
void World::turn(int64_t until) {
  bus_.handle_pending();  // what the test sent just now arrives now
  answer_states();
  while (true) {
    int64_t next = until + 1;
    if (plant_) next = std::min(next, plant_next_);
    for (const auto& c : controllers_) {
      if (c->ticking) next = std::min(next, c->next);
    }
    if (next > until) break;
    clock_.advance_to(next);
    if (plant_ && plant_next_ == next) {
      plant_->step();
      plant_next_ += plant_->period_ns();
      if (const int64_t stall = plant_->stall_due(); stall > 0) {  // as chasles_plant's loop holds
        plant_clock_->pause(stall);
        plant_next_ += stall;
        ++stalls_;
      }
      bus_.handle_pending();
      answer_states();
    }
    for (auto& c : controllers_) {
      if (c->ticking && c->next == next) run_tick(*c);
    }
  }
  clock_.advance_to(until);
  bus_.handle_pending();
  answer_states();
}

void World::run_tick(Controller& c) {
  c.next = c.node->tick(c.next);
  bus_.handle_pending();
  c.node->plan();
  c.node->report();
  c.node->locate();
  bus_.handle_pending();
}

// State-driven controllers tick on the state just delivered, at the same instant.
void World::answer_states() {
  for (auto& c : controllers_) {
    if (c->ticking && c->options.tick == controller::TickSource::kState && c->node->state_waiting()) run_tick(*c);
  }
}

void World::run_for(double seconds) { turn(now() + static_cast<int64_t>(std::llround(seconds * 1e9))); }

bool World::run_until(const std::function<bool()>& done, double seconds) {
  const int64_t end = now() + static_cast<int64_t>(std::llround(seconds * 1e9));
  while (!done()) {
    if (now() >= end) return false;
    turn(std::min(end, now() + kMs / 10));
  }
  return true;
}

void World::send_joint_target(const Eigen::VectorXd& goal, double duration) {
  recorder_->publish("TARGET", testing::joint_target(goal, duration));
}

control_mode_t mode_message(controller::Law law, int n) {
  control_mode_t m{};
  m.law = static_cast<int8_t>(law);
  m.num_joints = 0;
  m.damping_ratio = 1.0;
  for (int i = 0; i < 6; ++i) m.cartesian_stiffness[i][i] = i < 3 ? 50.0 : 1000.0;
  m.stiffness_frame_quaternion[0] = 1.0;
  m.num_posture = 0;
  m.nullspace_stiffness = 10.0;
  if (law == controller::Law::kJointImpedance) {
    const double k[7] = {600, 600, 600, 600, 250, 150, 50};  // franka_ros's example stiffness
    m.num_joints = n;
    for (int i = 0; i < n; ++i) m.joint_stiffness.push_back(k[std::min(i, 6)]);
    m.joint_damping.assign(size_t(n), 0.0);
  }
  return m;
}

control_mode_t cartesian_mode(double translational, double rotational) {
  control_mode_t m = mode_message(controller::Law::kCartesianImpedance, 0);
  for (int i = 0; i < 6; ++i) m.cartesian_stiffness[i][i] = i < 3 ? rotational : translational;
  return m;
}

arm_target_t cartesian_target(const Transform& T, double duration) {
  arm_target_t t{};
  t.mode = arm_target_t::CARTESIAN;
  const Eigen::Quaterniond r(T.linear());
  for (int i = 0; i < 3; ++i) t.tip_position[i] = T.translation()(i);
  t.tip_quaternion[0] = r.w(), t.tip_quaternion[1] = r.x(), t.tip_quaternion[2] = r.y(), t.tip_quaternion[3] = r.z();
  t.duration = duration;
  return t;
}

}  // namespace chasles::faults
