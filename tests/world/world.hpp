// The whole loop in one process, in simulated time: a controller::Node (or two) and a plant
// Simulation on one memq:// bus and one SimulatedClock, run turn by turn in a fixed order, with
// the test's Recorder on the same bus. Every message is lcm-gen encoded, dispatched by LCM and
// read by the checked decoders, as between processes; only time is simulated, so a run is exact
// and repeatable, and there are no stalls to excuse.
//
// The schedule: the plant steps at k·T_plant from its start. A state-driven controller (the
// default) ticks the instant a state is delivered, and on its watchdog's schedule when none
// comes; a clock-driven one ticks on its own period from its start (phase). After each tick the
// IK worker plans at once and the status step runs. After every turn the bus delivers what was
// sent: the network has no latency here, the delays are the ones the plant injects.
#pragma once

#include <Eigen/Core>
#include <chasles/arm_target_t.hpp>
#include <chasles/control_mode_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <type_traits>
#include <string>
#include <utility>
#include <vector>

#include "controller/node.hpp"
#include "controller/transport/protocol.hpp"
#include "core/model/model.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "tools/simulation/simulation.hpp"
#include "checks.hpp"

namespace chasles::faults {

/// A threshold or bound that never trips.
inline constexpr double kInf = std::numeric_limits<double>::infinity();

using controller::Bus;
using controller::SimulatedClock;

/// The test's seat on the bus: every state (its arrival time), command (with the state it
/// answers) and status heard, in order of arrival.
///
/// On a Drake protocol it hears the driver's status and command channels and records them as
/// chasles's messages, so that every check reads one form: a status as the robot_state_t the
/// controller makes of it (StatusReader: its sequence by arrival, chasles's signs), a command as
/// the joint_torque_command_t it stands for — numbered in order, stamped when it was heard (the
/// controller's send: the bus has no latency), answering the state with its utime, and with the
/// whole joint torque the arm gets (the torque sent plus the driver's g(q) of the bare arm `model`
/// under overlay semantics).
class Recorder {
 public:
  Recorder(Bus& bus, const SimulatedClock& clock, const std::string& prefix = "CHASLES_",
           controller::Protocol protocol = controller::Protocol::kChasles, const RobotModel* model = nullptr);

  /// Publishes a message on PREFIX + channel; commands sent this way are not the controller's
  /// and are left out of commands().
  template <typename Message>
  void publish(const std::string& channel, const Message& message) {
    if constexpr (std::is_same_v<Message, joint_torque_command_t>) own_commands_.insert({message.seq, message.utime});
    bus_.publish_message(prefix_ + channel, message);
  }

  /// Publishes a message on `channel` as it is (a driver's channel, which takes no prefix).
  template <typename Message>
  void publish_on(const std::string& channel, const Message& message) {
    bus_.publish_message(channel, message);
  }
  /// Publishes bytes on `channel` as they are; heard on the command channel, they are the test's
  /// own and left out of commands().
  void publish_raw(const std::string& channel, const std::vector<uint8_t>& bytes);
  /// Publishes `state` as the protocol's status on its driver's status channel, encoded by the
  /// plant's own encoder (a Drake status reports it as a driver commanding the arm would).
  void publish_status(const robot_state_t& state);
  /// Drake's protocols: number the statuses heard as the plant did (`seq_of(utime)`), not by
  /// arrival as the controller does, so that a command's state_seq names the plant's step even
  /// when statuses were lost on the way.
  void number_states_by(std::function<int64_t(int64_t)> seq_of) { plant_seq_ = std::move(seq_of); }
  /// Its encoding cut short by `missing` bytes: a damaged message.
  template <typename Message>
  void publish_truncated(const std::string& channel, const Message& message, size_t missing) {
    std::vector<uint8_t> bytes(size_t(message.getEncodedSize()));
    message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    bytes.resize(bytes.size() - missing);
    bus_.publish(channel, bytes);
  }

  const std::vector<HeardCommand>& commands() const { return commands_; }
  const std::vector<HeardStatus>& statuses() const { return statuses_; }
  /// Arrival times of the valid states heard, ns.
  const std::vector<int64_t>& state_arrivals() const { return state_arrivals_; }
  const std::optional<robot_state_t>& state() const { return state_; }
  /// Every valid state heard from now on, in order (off by default: a ten-minute run would keep
  /// hundreds of megabytes).
  void keep_states() { keep_states_ = true; }
  const std::vector<robot_state_t>& states() const { return states_; }
  const std::optional<controller_status_t>& status() const { return status_; }
  bool status_is(int8_t mode) const { return status_ && status_->state == mode; }
  /// Commands heard after the index'th message.
  int64_t commands_after(int64_t index) const;
  int64_t index() const { return index_; }

 private:
  Bus& bus_;
  const SimulatedClock& clock_;
  std::string prefix_;
  void on_state(const robot_state_t& m);
  void on_command(HeardCommand c);
  void hear_drake_command(const uint8_t* data, size_t size);
  controller::Protocol protocol_;
  const RobotModel* model_;  // Drake's protocols: the arm, for its g(q)
  std::optional<controller::StatusReader> reader_;
  std::optional<Data> data_;
  std::map<int64_t, int64_t> seq_of_utime_;  // Drake's: the states heard, by utime
  std::function<int64_t(int64_t)> plant_seq_;
  int64_t drake_commands_ = 0;
  int64_t index_ = 0;
  std::vector<std::pair<int64_t, Eigen::VectorXd>> positions_;  // by seq modulo its size
  std::vector<int64_t> state_arrivals_;
  std::optional<robot_state_t> state_;
  bool keep_states_ = false;
  std::vector<robot_state_t> states_;
  std::optional<controller_status_t> status_;
  std::vector<HeardStatus> statuses_;
  std::vector<HeardCommand> commands_;
  std::set<std::pair<int64_t, int64_t>> own_commands_;
  std::multiset<std::vector<uint8_t>> own_raw_;
  bool own_raw(const uint8_t* data, size_t size);
  std::vector<Bus::Subscription> subscriptions_;
};

class World {
 public:
  static constexpr int64_t kMs = 1'000'000;

  /// The arm of both the plant and the controllers: the Panda to its TCP (checks.hpp's panda())
  /// unless given. Keeps a reference to it.
  explicit World(const RobotModel& model = panda(), controller::Protocol protocol = controller::Protocol::kChasles);
  const RobotModel& model() const { return model_; }
  ~World();

  Recorder& recorder() { return *recorder_; }
  /// The memq:// bus everything is on, for a test's own subscriptions.
  Bus& bus() { return bus_; }
  int64_t now() const { return clock_.now_ns(); }

  /// A plant at q0 (damping 0.5 on every joint by default), its first state sent now.
  plant::Simulation& start_plant(const Eigen::VectorXd& q0, const plant::SimulationOptions& options = {});
  /// A plant on another engine (MuJoCo's), started where it stands.
  plant::Simulation& start_plant(std::unique_ptr<plant::Physics> engine, const plant::SimulationOptions& options);
  /// The plant stops as a killed process does: no more states, no goodbye.
  void kill_plant();
  plant::Simulation* plant() { return plant_.get(); }
  /// How many times the plant has stalled (SimulationOptions::stalls).
  int64_t plant_stalls() const { return stalls_; }

  /// A controller whose first tick comes one period plus `phase_ns` from now (state-driven: its
  /// first watchdog tick, unless a state comes first); it has been listening since it was
  /// added. Returns its index.
  /// `model`: the controller's own, when it differs from the plant's (a payload it is told of).
  int add_controller(const controller::DaemonOptions& options, int64_t phase_ns = kMs / 2,
                     const RobotModel* model = nullptr);
  controller::Node& controller(int i = 0) { return *controllers_.at(size_t(i))->node; }
  /// Whether controller i ticks (a controller that is only listening, as a daemon does before its
  /// loop starts, does not).
  void set_ticking(int i, bool ticking) { controllers_.at(size_t(i))->ticking = ticking; }

  /// Runs every turn due up to now + seconds.
  void run_for(double seconds);
  /// Runs until `done` holds after a turn, at most `seconds`; whether it held.
  bool run_until(const std::function<bool()>& done, double seconds);

  /// A JOINT target to `goal` over `duration` s.
  void send_joint_target(const Eigen::VectorXd& goal, double duration);

 private:
  struct Controller {
    controller::DaemonOptions options;
    std::unique_ptr<controller::Node> node;
    int64_t next = 0;
    bool ticking = true;
  };
  void turn(int64_t until);
  void run_tick(Controller& c);
  void answer_states();
  plant::Simulation& started(std::unique_ptr<plant::Simulation> simulation);

  const RobotModel& model_;
  SimulatedClock clock_;
  Bus bus_;
  std::unique_ptr<Recorder> recorder_;
  std::unique_ptr<plant::PausableClock> plant_clock_;  // the plant's: it stands while the plant stalls
  std::unique_ptr<plant::Simulation> plant_;
  int64_t plant_next_ = 0;
  int64_t stalls_ = 0;
  std::vector<std::unique_ptr<Controller>> controllers_;
};

/// A control_mode_t for `law`: unit damping ratio; Cartesian stiffness 50 N·m/rad and 1000 N/m
/// about the tip; under joint impedance, franka_ros's example stiffness.
control_mode_t mode_message(controller::Law law, int n);
/// CARTESIAN_IMPEDANCE with this translational (N/m) and rotational (N·m/rad) stiffness.
control_mode_t cartesian_mode(double translational, double rotational = 50.0);
/// A CARTESIAN target to the tip pose T over `duration` s.
arm_target_t cartesian_target(const Transform& T, double duration);

}  // namespace chasles::faults
