// The rig every environment test file uses: a lockstep plant::Simulation on its own memq:// bus,
// the test in the controller's seat, its states and truths read back with the checked decoders;
// the two arms (the Panda and the UR5), wrenches and the statics that hold an arm against one.
// environment_test.cpp holds the plant's world (pushes, walls) against statics and energy,
// environment_model_test.cpp the arm it hides from the controller (payload, friction, inertias),
// environment_io_test.cpp what it reports and reads (the truth, the effort noise, the specs).
#pragma once

#include <gtest/gtest.h>

#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/model/urdf.hpp"
#include "core/simulation/environment.hpp"
#include "core/simulation/plant.hpp"
#include "lcmtypes/checked.hpp"
#include "tools/simulation/simulation.hpp"
#include "support/arm.hpp"
#include "support/reference.hpp"

namespace chasles::testing {

using controller::Bus;
using controller::SimulatedClock;
using plant::EnvironmentOptions;
using plant::Push;
using plant::SimulationOptions;
using plant::Wall;

inline constexpr double kDt = 1e-3;  // the plant's default 1000 Hz

inline RobotModel load(const std::string& file, const std::string& tip) {
  UrdfOptions options;
  options.tip_link = tip;
  return load_urdf_file(data_path(file), options);
}

struct Arm {
  std::string name;
  RobotModel model;
  Eigen::VectorXd q0;
};

inline Arm panda_arm() { return {"panda", load("panda.urdf", "panda_hand"), bent_pose()}; }

inline Arm ur5_arm() {
  Eigen::VectorXd q0(6);
  q0 << 0.3, -1.2, 1.4, -1.0, -1.5, 0.4;
  return {"ur5", load("ur5.urdf", "tool0"), q0};
}

inline Vector6d wrench(double mx, double my, double mz, double fx, double fy, double fz) {
  Vector6d F;
  F << mx, my, mz, fx, fy, fz;
  return F;
}

// A wrench given base-aligned at the tip origin, as the tip frame sees it: the same moment and
// force, rotated by R_sbᵀ (one point, so no moment arm).
inline Vector6d in_tip_frame(const Matrix3d& R_sb, const Vector6d& F) {
  Vector6d F_b;
  F_b << R_sb.transpose() * F.head<3>(), R_sb.transpose() * F.tail<3>();
  return F_b;
}

inline Eigen::VectorXd as_vector(const double* v, int n) { return Eigen::Map<const Eigen::VectorXd>(v, n); }
inline Vector6d tip_wrench(const sim_truth_t& truth) { return Eigen::Map<const Vector6d>(truth.tip_wrench_ext); }

// Lockstep (the plant steps once per command answering its latest state), with `environment`.
inline SimulationOptions lockstep(const EnvironmentOptions& environment = {}) {
  SimulationOptions options;
  options.lockstep = true;
  options.environment = environment;
  return options;
}

// A plant on its own memq:// bus, with the test on the same bus in the controller's seat.
class Rig {
 public:
  Rig(const RobotModel& model, const Eigen::VectorXd& q0, SimulationOptions options,
      const Eigen::VectorXd& damping = Eigen::VectorXd())
      : model_(model), bus_("memq://") {
    subscriptions_.push_back(bus_.subscribe(
        options.prefix + "STATE",
        [this](const uint8_t* data, size_t size) {
          robot_state_t m;
          const std::string why = messages::decode_checked(data, size, m, model_.dof(), messages::Finite::Required);
          ASSERT_EQ(why, "") << "the plant sent a bad robot_state_t";
          states_.push_back(std::move(m));
          arrivals_.push_back({'S', states_.back().seq});
        },
        1 << 14));
    subscriptions_.push_back(bus_.subscribe(
        options.prefix + "TRUTH",
        [this](const uint8_t* data, size_t size) {
          sim_truth_t m;
          const std::string why = messages::decode_checked(data, size, m, model_.dof(), messages::Finite::Required);
          ASSERT_EQ(why, "") << "the plant sent a bad sim_truth_t";
          truths_.push_back(std::move(m));
          arrivals_.push_back({'T', truths_.back().seq});
        },
        1 << 14));
    prefix_ = options.prefix;
    const Eigen::VectorXd D = damping.size() == 0 ? Eigen::VectorXd::Zero(model.dof()) : damping;
    simulation_ = std::make_unique<plant::Simulation>(model, options, q0, D, bus_, clock_);
    simulation_->start();
    deliver();
  }
  ~Rig() {
    simulation_.reset();
    subscriptions_.clear();
  }

  /// Lockstep: answers the latest state produced with tau; the plant steps once.
  void step(const Eigen::VectorXd& tau) {
    joint_torque_command_t command;
    command.utime = clock_.utime_us();
    command.seq = ++command_seq_;
    command.state_seq = simulation_->steps();
    command.num_joints = model_.dof();
    command.torque.assign(tau.data(), tau.data() + tau.size());
    bus_.publish_message(prefix_ + "COMMAND", command);
    deliver();  // the plant steps and sends the state (through its faults) and the truth
    clock_.advance_to(clock_.now_ns() + simulation_->period_ns());
    simulation_->serve_lockstep();  // the delayed states that are due
    deliver();
  }

  /// Real time: one step at the next period (braked until a command comes).
  void real_time_step() {
    clock_.advance_to(clock_.now_ns() + simulation_->period_ns());
    simulation_->step();
    deliver();
  }

  plant::Simulation& simulation() { return *simulation_; }
  /// chasles's own plant, which the rig always runs.
  const plant::Plant& plant() const { return dynamic_cast<const plant::Plant&>(simulation_->plant()); }
  /// The plant's true state (the sent position may be noisy).
  const Eigen::VectorXd& q() const { return simulation_->plant().q(); }
  const Eigen::VectorXd& qd() const { return simulation_->plant().qd(); }
  const std::vector<robot_state_t>& states() const { return states_; }
  const std::vector<sim_truth_t>& truths() const { return truths_; }
  /// 'S' or 'T' and the seq, for every state and truth heard, in order of arrival.
  const std::vector<std::pair<char, int64_t>>& arrivals() const { return arrivals_; }

 private:
  void deliver() {
    while (bus_.handle_pending() > 0) {
    }
  }

  const RobotModel& model_;
  SimulatedClock clock_;
  Bus bus_;
  std::string prefix_;
  std::vector<Bus::Subscription> subscriptions_;
  std::unique_ptr<plant::Simulation> simulation_;
  std::vector<robot_state_t> states_;
  std::vector<sim_truth_t> truths_;
  std::vector<std::pair<char, int64_t>> arrivals_;
  int64_t command_seq_ = 0;
};

inline Eigen::VectorXd position(const robot_state_t& state) { return vector_of(state.position); }
inline Eigen::VectorXd velocity(const robot_state_t& state) { return vector_of(state.velocity); }

// τ = g(q) − J_b(q)ᵀ F_b: what holds an arm still against gravity and a wrench F_b on its tip (tip
// frame), MR eq. 8.1 at rest with the environment's wrench on the other side.
inline Eigen::VectorXd holding_torque(const RobotModel& model, Data& data, const Eigen::VectorXd& q,
                                      const Vector6d& F_b) {
  Eigen::VectorXd tau = gravity_torques(model, data, q);
  tau.noalias() -= body_jacobian(model, data, q).transpose() * F_b;
  return tau;
}

}  // namespace chasles::testing
