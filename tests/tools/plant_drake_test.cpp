// chasles_plant's Drake protocols (drake-iiwa, drake-panda) in process and in simulated time: a
// plant::Simulation on a memq:// bus, the test in the controller's seat, the statuses read back the
// way the controller reads them (controller::StatusReader) and held against references computed
// here. Apart from plant_test.cpp, which runs the plant as a process over real LCM, because nothing
// here needs a process or a network: each step is the test's to take, exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "controller/transport/protocol.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "lcmtypes/checked.hpp"
#include "tools/simulation/simulation.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/reference.hpp"
#include "tests/tools/plant_reference.hpp"

namespace chasles::testing {
namespace {

using plant_reference::iiwa_pose;
using plant_reference::kDt;
using plant_reference::panda;
using plant_reference::rk4_reference;
using controller::Bus;
using controller::JointState;
using controller::Protocol;
using controller::StatusReader;
using controller::TorqueSemantics;
using drake::lcmt_iiwa_command;
using drake::lcmt_iiwa_status;
using drake::lcmt_panda_command;
using drake::lcmt_panda_status;
using plant::SimulationOptions;

RobotModel iiwa14() {
  UrdfOptions options;
  options.tip_link = "iiwa_link_ee";
  return load_urdf_file(data_path("iiwa14.urdf"), options);
}

// Each Drake protocol on its own arm: the iiwa's on Drake's iiwa 14 (rotor inertias and all), the
// Panda's on the Panda.
struct DrakeArm {
  Protocol protocol;
  RobotModel model;
  Eigen::VectorXd q0;
};
std::vector<DrakeArm> drake_arms() {
  return {{Protocol::kDrakeIiwa, iiwa14(), iiwa_pose()}, {Protocol::kDrakePanda, panda(), bent_pose()}};
}

SimulationOptions drake_options(Protocol protocol, bool lockstep,
                                std::optional<TorqueSemantics> semantics = std::nullopt,
                                const plant::EnvironmentOptions& environment = {}) {
  SimulationOptions options;
  options.protocol = protocol;
  options.lockstep = lockstep;
  options.torque_semantics = semantics;
  options.environment = environment;
  return options;
}

Eigen::VectorXd as_vector(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

template <typename Message>
std::vector<uint8_t> bytes_of(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// A torque command as the protocol's driver takes it (what controller::CommandWriter sends, built
// here field by field): the utime of the status answered, no positions, n torques.
lcmt_iiwa_command iiwa_torques(int64_t utime, const Eigen::VectorXd& tau) {
  lcmt_iiwa_command command;
  command.utime = utime;
  command.num_joints = 0;
  command.num_torques = static_cast<int32_t>(tau.size());
  command.joint_torque.assign(tau.data(), tau.data() + tau.size());
  return command;
}
lcmt_panda_command panda_torques(int64_t utime, const Eigen::VectorXd& tau) {
  lcmt_panda_command command;
  command.utime = utime;
  command.num_joint_position = command.num_joint_velocity = 0;
  command.num_joint_torque = static_cast<int32_t>(tau.size());
  command.joint_torque.assign(tau.data(), tau.data() + tau.size());
  command.control_mode_expected = lcmt_panda_status::CONTROL_MODE_TORQUE;
  return command;
}

// One status heard: its bytes decoded by the checked decoder, what StatusReader made of it, and the
// plant's own state when it was sent.
struct Heard {
  lcmt_iiwa_status iiwa;
  lcmt_panda_status panda;
  int64_t utime = 0;
  std::string refusal;  // StatusReader's
  JointState state{7};
  std::vector<double> tau_ext;
  std::vector<double> q, qd, effort;  // the plant's
};

// A plant speaking a Drake protocol on its own memq:// bus, the test in the controller's seat.
class DrakeRig {
 public:
  DrakeRig(const RobotModel& model, const Eigen::VectorXd& q0, const SimulationOptions& options)
      : model_(model), protocol_(options.protocol), bus_("memq://"), reader_(options.protocol, model.dof()) {
    const controller::ProtocolChannels channels = controller::default_channels(options.protocol, options.prefix);
    command_channel_ = channels.command;
    subscription_ = bus_.subscribe(
        channels.status, [this](const uint8_t* data, size_t size) { hear(data, size); }, 1 << 14);
    simulation_ = std::make_unique<plant::Simulation>(model, options, q0, Eigen::VectorXd::Zero(model.dof()), bus_,
                                                      clock_);
    simulation_->start();
    deliver();
  }
  ~DrakeRig() {
    simulation_.reset();
    subscription_ = Bus::Subscription();
  }

  /// The utime of the latest status heard: what a command answering it carries.
  int64_t latest_utime() const { return heard_.back().utime; }

  /// Sends the bytes on the command channel and lets the plant handle them.
  void send(const std::vector<uint8_t>& bytes) {
    bus_.publish(command_channel_, bytes);
    deliver();
  }
  /// A torque command answering the status stamped `utime`.
  void send_torques(int64_t utime, const Eigen::VectorXd& tau) {
    send(protocol_ == Protocol::kDrakeIiwa ? bytes_of(iiwa_torques(utime, tau)) : bytes_of(panda_torques(utime, tau)));
  }
  /// Lockstep: answers the latest status with tau; the plant steps once. Then time moves on a period.
  void step(const Eigen::VectorXd& tau) {
    send_torques(latest_utime(), tau);
    clock_.advance_to(clock_.now_ns() + simulation_->period_ns());
    simulation_->serve_lockstep();
    deliver();
  }
  /// Real time: one step at the next period.
  void real_time_step() {
    clock_.advance_to(clock_.now_ns() + simulation_->period_ns());
    simulation_->step();
    deliver();
  }

  plant::Simulation& simulation() { return *simulation_; }
  const std::vector<Heard>& heard() const { return heard_; }

 private:
  void deliver() {
    while (bus_.handle_pending() > 0) {
    }
  }

  void hear(const uint8_t* data, size_t size) {
    Heard h;
    const int n = model_.dof();
    if (protocol_ == Protocol::kDrakeIiwa) {
      ASSERT_EQ(messages::decode_checked(data, size, h.iiwa, n, messages::Finite::Required), "");
      h.utime = h.iiwa.utime;
    } else {
      ASSERT_EQ(messages::decode_checked(data, size, h.panda, n, messages::Finite::Required), "");
      h.utime = h.panda.utime;
    }
    h.state = JointState(n);
    h.refusal = reader_.read(data, size, clock_.now_ns(), h.state);
    const Eigen::VectorXd& tau_ext = reader_.tau_ext();
    h.tau_ext.assign(tau_ext.data(), tau_ext.data() + n);
    if (simulation_) {
      const plant::Physics& plant = simulation_->plant();
      h.q.assign(plant.q().data(), plant.q().data() + n);
      h.qd.assign(plant.qd().data(), plant.qd().data() + n);
      h.effort.assign(plant.effort().data(), plant.effort().data() + n);
    }
    heard_.push_back(std::move(h));
  }

  const RobotModel& model_;
  Protocol protocol_;
  controller::SimulatedClock clock_;
  Bus bus_;
  std::string command_channel_;
  StatusReader reader_;
  Bus::Subscription subscription_;
  std::unique_ptr<plant::Simulation> simulation_;
  std::vector<Heard> heard_;
};

// A torque that varies from step to step and joint to joint, small enough that no effort limit clips it.
Eigen::VectorXd wiggle(int k, int n) {
  Eigen::VectorXd tau(n);
  for (int i = 0; i < n; ++i) tau[i] = 2.0 * std::sin(0.3 * k + 0.7 * i);
  return tau;
}

// (a) Every status decodes with the checked decoder, and StatusReader reads back exactly the plant's
// q, q̇ and applied torque, through the wire's signs. The fields chasles does not read say what the
// driver would: the iiwa's torque commanded is −(command + g), as Drake's simulated driver reports
// it (BuildSimplifiedIiwaControl negates its actuation), its commanded position the measured one,
// its interpolator position NaN until commands come; the Panda's desired torque is the command as
// sent, its mode idle then moving, its success rate 1 when every step had a command. The overlay:
// the torque applied is the command plus g(q) of the bare arm, computed here.
TEST(plant, DrakeStatusesReadBackThePlantsStateExactly) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    Data data(arm.model);
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, true));
    constexpr int kSteps = 60;
    for (int k = 0; k < kSteps; ++k) rig.step(wiggle(k, n));
    const std::vector<Heard>& heard = rig.heard();
    ASSERT_EQ(heard.size(), size_t{kSteps + 1});
    const double nan_count_at_start =
        arm.protocol == Protocol::kDrakeIiwa
            ? double(std::count_if(heard[0].iiwa.joint_position_ipo.begin(), heard[0].iiwa.joint_position_ipo.end(),
                                   [](double x) { return std::isnan(x); }))
            : 7.0;
    EXPECT_EQ(nan_count_at_start, 7.0) << "the iiwa's ipo is NaN before any command";
    for (int k = 0; k <= kSteps; ++k) {
      SCOPED_TRACE("status " + std::to_string(k));
      const Heard& h = heard[size_t(k)];
      ASSERT_EQ(h.refusal, "");
      EXPECT_EQ(h.state.seq, k);
      EXPECT_EQ(h.utime - heard[0].utime, 1000 * k) << "1 ms steps, in µs";
      EXPECT_EQ(h.state.utime, h.utime);
      EXPECT_TRUE(matrices_near(h.state.q, as_vector(h.q), 0.0));
      EXPECT_TRUE(matrices_near(h.state.qd, as_vector(h.qd), 0.0));
      EXPECT_TRUE(matrices_near(h.state.effort, as_vector(h.effort), 0.0));
      EXPECT_TRUE(matrices_near(as_vector(h.tau_ext), Eigen::VectorXd::Zero(n), 0.0)) << "nothing pushes";
      // The command answering the previous status, and the driver's gravity at that status's q.
      const Eigen::VectorXd command = k > 0 ? wiggle(k - 1, n) : Eigen::VectorXd::Zero(n);
      const Eigen::VectorXd applied =
          k > 0 ? Eigen::VectorXd(command + gravity_torques(arm.model, data, heard[size_t(k - 1)].state.q))
                : Eigen::VectorXd::Zero(n);
      EXPECT_TRUE(matrices_near(h.state.effort, applied, 1e-12));
      if (arm.protocol == Protocol::kDrakeIiwa) {
        EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_torque_commanded), -applied, 1e-12));
        EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_commanded), h.state.q, 0.0));
        if (k > 0) {
          EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_ipo), h.state.q, 0.0));
        }
      } else {
        EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_torque_desired), command, 0.0));
        EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_position_desired), h.state.q, 0.0));
        EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_velocity_desired), Eigen::VectorXd::Zero(n), 0.0));
        EXPECT_EQ(h.panda.robot_mode, k > 0 ? lcmt_panda_status::kMove : lcmt_panda_status::kIdle);
        EXPECT_EQ(h.panda.control_mode, k > 0 ? lcmt_panda_status::CONTROL_MODE_TORQUE : 0);
        EXPECT_EQ(h.panda.control_command_success_rate, k > 0 ? 1.0 : 0.0);
        EXPECT_EQ(h.panda.robot_utime, 1000 * k);
      }
    }
  }
}

// (b) The torque semantics: under overlay a zero command holds the arm where it is (the plant adds
// g(q), as the driver does), the effort read back is g(q0); under full the same zero command lets it
// fall, as a fine RK4 integration of the model with zero torque does (the tolerances of
// LockstepFallMatchesAFineIntegrationAndConservesEnergy).
TEST(plant, DrakeOverlayAddsGravityAndFullDoesNot) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    Data data(arm.model);
    constexpr int kSteps = 500;

    DrakeRig held(arm.model, arm.q0, drake_options(arm.protocol, true, TorqueSemantics::kOverlay));
    for (int k = 0; k < kSteps; ++k) held.step(zero);
    ASSERT_EQ(held.heard().size(), size_t{kSteps + 1});
    double drift = 0.0;
    for (const Heard& h : held.heard()) drift = std::max(drift, max_abs_diff(h.state.q, arm.q0));
    EXPECT_LT(drift, 1e-6);
    EXPECT_TRUE(matrices_near(held.heard().back().state.effort, gravity_torques(arm.model, data, arm.q0), 1e-9));

    DrakeRig fell(arm.model, arm.q0, drake_options(arm.protocol, true, TorqueSemantics::kFull));
    for (int k = 0; k < kSteps; ++k) fell.step(zero);
    ASSERT_EQ(fell.heard().size(), size_t{kSteps + 1});
    Eigen::VectorXd q = arm.q0, qd = zero;
    rk4_reference(arm.model, q, qd, zero, kDt / 10, kSteps * 10);
    const JointState& last = fell.heard().back().state;
    EXPECT_GT(max_abs_diff(last.q, arm.q0), 0.05) << "the arm should have fallen";
    EXPECT_TRUE(matrices_near(last.q, q, 1e-6));
    EXPECT_TRUE(matrices_near(last.qd, qd, 1e-5));
    EXPECT_TRUE(matrices_near(last.effort, zero, 0.0));
  }
}

// (c) Commands the driver would not take are refused and counted, never applied: the lockstep plant
// does not step on them. The iiwa's: no torques (a position command: the driver runs in torque
// mode), 3 joints, a NaN, a Panda command on its channel. The Panda's: a position or no control
// mode expected, no torques, 6 joints, a chasles command on its channel. A valid command whose utime
// no status carries (one more µs, a state not sent yet) is stale, and so, in lockstep, is one that
// answers an older status. The next valid command steps the arm from where it was.
TEST(plant, DrakeCommandsTheDriverWouldRefuseAreRefusedAndCounted) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    Data data(arm.model);
    const Eigen::VectorXd g = gravity_torques(arm.model, data, arm.q0);
    const Eigen::VectorXd tau = Eigen::VectorXd::Constant(n, 3.0);
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, true));
    const int64_t u0 = rig.latest_utime();
    int refused = 0;
    if (arm.protocol == Protocol::kDrakeIiwa) {
      lcmt_iiwa_command positions = iiwa_torques(u0, Eigen::VectorXd());
      positions.num_joints = n;
      positions.joint_position.assign(size_t(n), 0.1);
      rig.send(bytes_of(positions));
      rig.send(bytes_of(iiwa_torques(u0, Eigen::VectorXd::Constant(3, 1.0))));
      Eigen::VectorXd bad = tau;
      bad[4] = std::numeric_limits<double>::quiet_NaN();
      rig.send(bytes_of(iiwa_torques(u0, bad)));
      rig.send(bytes_of(panda_torques(u0, tau)));
      refused = 4;
    } else {
      lcmt_panda_command command = panda_torques(u0, tau);
      command.control_mode_expected = lcmt_panda_status::CONTROL_MODE_POSITION;
      rig.send(bytes_of(command));
      command.control_mode_expected = 0;
      rig.send(bytes_of(command));
      lcmt_panda_command positions = panda_torques(u0, Eigen::VectorXd());
      positions.num_joint_position = n;
      positions.joint_position.assign(size_t(n), 0.1);
      rig.send(bytes_of(positions));
      rig.send(bytes_of(panda_torques(u0, Eigen::VectorXd::Constant(6, 1.0))));
      joint_torque_command_t chasles_command;
      chasles_command.utime = u0;
      chasles_command.seq = chasles_command.state_seq = 0;
      chasles_command.num_joints = n;
      chasles_command.torque.assign(size_t(n), 0.0);
      rig.send(bytes_of(chasles_command));
      refused = 5;
    }
    rig.send_torques(u0 + 1, tau);
    rig.send_torques(u0 + 1000, tau);
    EXPECT_EQ(rig.simulation().steps(), 0) << "the plant stepped on a command it should have refused";
    EXPECT_EQ(rig.simulation().rejected_commands(), refused);
    EXPECT_EQ(rig.simulation().stale_commands(), 2);
    ASSERT_EQ(rig.heard().size(), 1u);

    rig.send_torques(u0, tau);
    ASSERT_EQ(rig.simulation().steps(), 1);
    ASSERT_EQ(rig.heard().size(), 2u);
    EXPECT_TRUE(matrices_near(rig.heard().back().state.effort, tau + g, 1e-12));
    rig.send_torques(u0, tau);  // answers status 0 again: stale in lockstep
    EXPECT_EQ(rig.simulation().steps(), 1);
    EXPECT_EQ(rig.simulation().stale_commands(), 3);
    EXPECT_EQ(rig.simulation().rejected_commands(), refused);
  }
}

// (d) A push on the tip shows in the external torque each status carries, in Drake's sign: the
// iiwa's joint_torque_external as it is, the Panda's (tau_ext_hat_filtered) negated, and
// StatusReader turns both back into J_bᵀ F_b, F_b the push as the tip frame sees it, computed here
// at each status's q. The arm is held against the push (−J_bᵀ F_b on top of the driver's g).
TEST(plant, DrakeExternalTorqueIsThePushInDrakesSign) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    Data data(arm.model);
    Vector6d W;
    W << 0.4, -0.3, 0.2, 6.0, -4.0, -12.0;  // (m, f), base-aligned at the tip origin
    const auto push_on_joints = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
      const Matrix3d R_sb = forward_kinematics(arm.model, data, q).linear();
      Vector6d F_b;
      F_b << R_sb.transpose() * W.head<3>(), R_sb.transpose() * W.tail<3>();
      return body_jacobian(arm.model, data, q).transpose() * F_b;
    };
    plant::EnvironmentOptions env;
    env.pushes.push_back({0.0, 10.0, 0.0, W});
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, true, std::nullopt, env));
    constexpr int kSteps = 100;
    for (int k = 0; k < kSteps; ++k) rig.step(-push_on_joints(rig.heard().back().state.q));
    ASSERT_EQ(rig.heard().size(), size_t{kSteps + 1});
    double drift = 0.0;
    for (size_t k = 0; k <= kSteps; ++k) {
      SCOPED_TRACE("status " + std::to_string(k));
      const Heard& h = rig.heard()[k];
      const Eigen::VectorXd expected = push_on_joints(h.state.q);
      ASSERT_GT(expected.cwiseAbs().maxCoeff(), 1.0);
      const Eigen::VectorXd wire = as_vector(arm.protocol == Protocol::kDrakeIiwa ? h.iiwa.joint_torque_external
                                                                                  : h.panda.joint_torque_external);
      const Eigen::VectorXd in_drakes_sign =
          arm.protocol == Protocol::kDrakeIiwa ? expected : Eigen::VectorXd(-expected);
      EXPECT_TRUE(matrices_near(wire, in_drakes_sign, 1e-9));
      EXPECT_TRUE(matrices_near(as_vector(h.tau_ext), expected, 1e-9));
      drift = std::max(drift, max_abs_diff(h.state.q, arm.q0));
    }
    EXPECT_LT(drift, 1e-9) << "held against the push, the arm stays";
  }
}

// Real time: a command is judged by the state its utime names. Answering every status in time is
// never late and releases the brake; answering the one before (a controller a cycle behind) is late
// every step, and 20 in a row brake the arm (the Panda then reports a reflex, and its success rate
// counts the braked steps as steps without a command). drake-franka-driver's 0.1 s expiry is the
// plant's --max-command-lag-ms.
TEST(plant, DrakeRealTimeJudgesCommandsByTheStateTheirUtimeNames) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    DrakeRig rig(arm.model, arm.q0, drake_options(arm.protocol, false));
    for (int k = 0; k < 30; ++k) {
      rig.send_torques(rig.latest_utime(), zero);
      rig.real_time_step();
    }
    plant::Simulation& simulation = rig.simulation();
    EXPECT_EQ(simulation.late_cycles(), 0);
    EXPECT_FALSE(simulation.braking());
    EXPECT_EQ(simulation.stale_commands(), 0);
    if (arm.protocol == Protocol::kDrakePanda) {
      EXPECT_EQ(rig.heard().back().panda.robot_mode, lcmt_panda_status::kMove);
      EXPECT_EQ(rig.heard().back().panda.control_command_success_rate, 1.0);
    }
    for (int k = 0; k < 25; ++k) {
      rig.send_torques(rig.heard()[rig.heard().size() - 2].utime, zero);
      rig.real_time_step();
    }
    EXPECT_EQ(simulation.late_cycles(), 25);
    EXPECT_EQ(simulation.late_stops(), 1);
    EXPECT_TRUE(simulation.braking());
    if (arm.protocol == Protocol::kDrakePanda) {
      // 55 steps since the first command (fewer than libfranka's 100), braked from the 20th late one
      // on: 49 of them applied a fresh command.
      EXPECT_EQ(rig.heard().back().panda.robot_mode, lcmt_panda_status::kReflex);
      EXPECT_DOUBLE_EQ(rig.heard().back().panda.control_command_success_rate, 49.0 / 55.0);
    }
  }
}

// Receiving a valid Drake command and encoding a Drake status allocate nothing once constructed,
// the effort noise drawn.
TEST(plant, DrakeCommandsAndStatusesAllocateNothing) {
  for (const Protocol protocol : {Protocol::kDrakeIiwa, Protocol::kDrakePanda}) {
    SCOPED_TRACE(controller::to_string(protocol));
    const Eigen::VectorXd q = bent_pose(), tau = Eigen::VectorXd::Constant(7, 1.5);
    controller::SimulatedClock clock;
    const int64_t latest = 5;
    plant::StateTimes times(1e-3, &latest);
    times.start(1'000'000);
    plant::CommandInbox inbox(clock, "COMMAND", 7, protocol, &times);
    const std::vector<uint8_t> command = protocol == Protocol::kDrakeIiwa ? bytes_of(iiwa_torques(1'003'000, tau))
                                                                          : bytes_of(panda_torques(1'003'000, tau));
    Bus bus("memq://");
    plant::Faults faults;
    faults.effort_noise = {0.1, 5};
    plant::StatePublisher publisher(bus, "STATUS", 7, faults, 4, protocol);
    const plant::DriverReport report{q, tau, tau, tau, q, tau, true, 1.0, 2, 4, 1000};
    inbox.receive(command.data(), command.size());
    publisher.encode(1, 1, q, report);
    long allocations = 0;
    {
      AllocationCounter counter;
      for (int k = 0; k < 100; ++k) {
        inbox.receive(command.data(), command.size());
        publisher.encode(k, k, q, report);
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0);
    EXPECT_EQ(inbox.rejected(), 0);
    EXPECT_EQ(inbox.take().state_seq, 3) << "utime 1'003'000 is state 3's";
  }
}

// A real-time Drake plant's steps allocate nothing, in process: each command received from the bus
// (the overlay's gravity added, its utime mapped to a state), each status encoded and sent with the
// push's external torque in it, then the brake when the commands stop. What the test's own publish
// allocates (LCM's memq provider copies each message) is counted apart.
TEST(plant, DrakeRealTimeStepsAllocateNothing) {
  for (const Protocol protocol : {Protocol::kDrakeIiwa, Protocol::kDrakePanda}) {
    SCOPED_TRACE(controller::to_string(protocol));
    const RobotModel model = panda();
    Vector6d W;
    W << 0.1, 0, 0, 0, 0, -5;
    plant::EnvironmentOptions env;
    env.pushes.push_back({0.0, 10.0, 0.0, W});
    controller::SimulatedClock clock;
    Bus bus("memq://");
    plant::Simulation simulation(model, drake_options(protocol, false, std::nullopt, env), bent_pose(),
                                 Eigen::VectorXd::Zero(7), bus, clock);
    const std::string channel = controller::default_channels(protocol).command;
    lcmt_iiwa_command iiwa = iiwa_torques(0, Eigen::VectorXd::Constant(7, 0.5));
    lcmt_panda_command panda_command = panda_torques(0, Eigen::VectorXd::Constant(7, 0.5));
    std::vector<uint8_t> bytes(static_cast<size_t>(
        protocol == Protocol::kDrakeIiwa ? iiwa.getEncodedSize() : panda_command.getEncodedSize()));
    long sent_allocations = 0;
    const auto step = [&](bool command) {
      if (command) {  // answers the latest state, by its utime
        const int64_t utime = simulation.state_utime(simulation.steps());
        if (protocol == Protocol::kDrakeIiwa) {
          iiwa.utime = utime;
          iiwa.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        } else {
          panda_command.utime = utime;
          panda_command.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        }
        {
          AllocationCounter sending;  // the test's side: LCM's memq copies what is published
          bus.publish(channel, bytes);
          sent_allocations += sending.count();
        }
        while (bus.handle_pending() > 0) {
        }
      }
      clock.advance_to(clock.now_ns() + simulation.period_ns());
      simulation.step();
    };
    simulation.start();
    for (int k = 0; k < 5; ++k) step(true);
    sent_allocations = 0;
    long allocations = 0;
    {
      AllocationCounter counter;
      for (int k = 0; k < 100; ++k) step(true);
      for (int k = 0; k < 100; ++k) step(false);
      allocations = counter.count();
    }
    EXPECT_EQ(allocations - sent_allocations, 0) << sent_allocations << " in the test's own sends";
    EXPECT_EQ(simulation.steps(), 205);
    EXPECT_EQ(simulation.rejected_commands() + simulation.stale_commands(), 0);
    EXPECT_TRUE(simulation.braking()) << "silence for 100 ms: the watchdog brakes";
  }
}

// A command's positions, when it carries them (the iiwa's num_joints n: drake-iiwa-driver's default
// torque mode; a Panda command's joint_position), are reported as the commanded ones —
// joint_position_commanded and, while commanding, joint_position_ipo; joint_position_desired — and
// not applied: the torque alone moves the arm (the plant has no impedance controller).
TEST(plant, DrakeCommandPositionsAreReportedNotApplied) {
  for (const DrakeArm& arm : drake_arms()) {
    SCOPED_TRACE(controller::to_string(arm.protocol));
    const int n = arm.model.dof();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    const Eigen::VectorXd p = arm.q0 + Eigen::VectorXd::Constant(n, 0.25);
    DrakeRig with(arm.model, arm.q0, drake_options(arm.protocol, true));
    DrakeRig without(arm.model, arm.q0, drake_options(arm.protocol, true));
    for (int k = 0; k < 20; ++k) {
      if (arm.protocol == Protocol::kDrakeIiwa) {
        lcmt_iiwa_command command = iiwa_torques(with.latest_utime(), zero);
        command.num_joints = n;
        command.joint_position.assign(p.data(), p.data() + n);
        with.send(bytes_of(command));
      } else {
        lcmt_panda_command command = panda_torques(with.latest_utime(), zero);
        command.num_joint_position = n;
        command.joint_position.assign(p.data(), p.data() + n);
        command.control_mode_expected |= lcmt_panda_status::CONTROL_MODE_POSITION;  // as Drake's sender marks it
        with.send(bytes_of(command));
      }
      without.step(zero);
    }
    ASSERT_EQ(with.heard().size(), 21u);
    const Heard& h = with.heard().back();
    if (arm.protocol == Protocol::kDrakeIiwa) {
      EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_commanded), p, 0.0));
      EXPECT_TRUE(matrices_near(as_vector(h.iiwa.joint_position_ipo), p, 0.0));
    } else {
      EXPECT_TRUE(matrices_near(as_vector(h.panda.joint_position_desired), p, 0.0));
    }
    EXPECT_TRUE(matrices_near(h.state.q, without.heard().back().state.q, 0.0)) << "the positions moved the arm";
  }
}

}  // namespace
}  // namespace chasles::testing
