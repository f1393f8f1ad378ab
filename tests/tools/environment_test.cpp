// The plant's environment in one process, in simulated time: a lockstep plant::Simulation on a
// memq:// bus, answered by the test with torques it computes itself, its states and truths read
// back from the bus with the checked decoders. Each test holds the plant against a fact that does
// not come from the plant's code: statics (τ = g − J_bᵀ F holds an arm against a wrench F), a
// trapezoid drawn by hand, a spring's rest length, energy, a point mass's kinetic and potential
// energy, the friction law, the forward dynamics of the perturbed model, a Gaussian's moments.
#include "core/simulation/environment.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chasles/joint_torque_command_t.hpp>
#include <chasles/robot_state_t.hpp>
#include <chasles/sim_truth_t.hpp>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/identification/perturbation.hpp"
#include "core/lie/so3.hpp"
#include "core/model/urdf.hpp"
#include "core/simulation/plant.hpp"
#include "lcmtypes/checked.hpp"
#include "tools/simulation/environment_forms.hpp"
#include "tools/simulation/simulation.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/decompositions.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using controller::Bus;
using controller::SimulatedClock;
using plant::EnvironmentOptions;
using plant::Push;
using plant::SimulationOptions;
using plant::Wall;

constexpr double kDt = 1e-3;  // the plant's default 1000 Hz

RobotModel load(const std::string& file, const std::string& tip) {
  UrdfOptions options;
  options.tip_link = tip;
  return load_urdf_file(data_path(file), options);
}

struct Arm {
  std::string name;
  RobotModel model;
  Eigen::VectorXd q0;
};

Arm panda_arm() { return {"panda", load("panda.urdf", "panda_hand"), bent_pose()}; }

Arm ur5_arm() {
  Eigen::VectorXd q0(6);
  q0 << 0.3, -1.2, 1.4, -1.0, -1.5, 0.4;
  return {"ur5", load("ur5.urdf", "tool0"), q0};
}

Vector6d wrench(double mx, double my, double mz, double fx, double fy, double fz) {
  Vector6d F;
  F << mx, my, mz, fx, fy, fz;
  return F;
}

// A wrench given base-aligned at the tip origin, as the tip frame sees it: the same moment and
// force, rotated by R_sbᵀ (one point, so no moment arm).
Vector6d in_tip_frame(const Matrix3d& R_sb, const Vector6d& F) {
  Vector6d F_b;
  F_b << R_sb.transpose() * F.head<3>(), R_sb.transpose() * F.tail<3>();
  return F_b;
}

Eigen::VectorXd as_vector(const double* v, int n) { return Eigen::Map<const Eigen::VectorXd>(v, n); }
Vector6d tip_wrench(const sim_truth_t& truth) { return Eigen::Map<const Vector6d>(truth.tip_wrench_ext); }

// Lockstep (the plant steps once per command answering its latest state), with `environment`.
SimulationOptions lockstep(const EnvironmentOptions& environment = {}) {
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
  const plant::Plant& plant() const { return simulation_->plant(); }
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

Eigen::VectorXd position(const robot_state_t& state) { return vector_of(state.position); }
Eigen::VectorXd velocity(const robot_state_t& state) { return vector_of(state.velocity); }

// τ = g(q) − J_b(q)ᵀ F_b: what holds an arm still against gravity and a wrench F_b on its tip (tip
// frame), MR eq. 8.1 at rest with the environment's wrench on the other side.
Eigen::VectorXd holding_torque(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Vector6d& F_b) {
  Eigen::VectorXd tau = gravity_torques(model, data, q);
  tau.noalias() -= body_jacobian(model, data, q).transpose() * F_b;
  return tau;
}

// Statics: an arm commanded τ = g(q) − J_bᵀ F_b, F_b the push as the tip frame sees it, stays at
// rest under the push: the plant applies it in the frame and with the sign the contract gives (a
// push read in the tip frame, about another point or with the opposite sign moves the arm, as the
// same command without the push does). Its truth reports the push as given and, as the joint
// torque, J_bᵀ F_b. Four wrenches (a force, a moment, both) on the Panda and the UR5.
TEST(environment, AnArmHeldAgainstAPushStaysAtRest) {
  const std::vector<Vector6d> pushes = {wrench(0, 0, 0, 0, 0, -20), wrench(0, 0, 0, 12, -7, 5),
                                        wrench(1.5, -0.8, 0.6, 0, 0, 0), wrench(-0.7, 1.1, 0.4, -9, 4, 15)};
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    Data data(arm.model);
    for (const Vector6d& W : pushes) {
      SCOPED_TRACE(arm.name + ", push (" + list(W) + ")");
      const auto hold = [&](const Eigen::VectorXd& q) {
        return holding_torque(arm.model, data, q, in_tip_frame(forward_kinematics(arm.model, data, q).linear(), W));
      };
      EnvironmentOptions env;
      env.pushes.push_back({0.0, 10.0, 0.0, W});
      Rig rig(arm.model, arm.q0, lockstep(env));
      constexpr int kSteps = 200;
      for (int k = 0; k < kSteps; ++k) rig.step(hold(position(rig.states().back())));
      ASSERT_EQ(rig.states().size(), size_t{kSteps + 1});
      ASSERT_EQ(rig.truths().size(), size_t{kSteps + 1});
      double drift = 0.0;
      for (size_t k = 0; k <= kSteps; ++k) {
        const robot_state_t& state = rig.states()[k];
        const sim_truth_t& truth = rig.truths()[k];
        ASSERT_EQ(truth.seq, state.seq);
        drift = std::max(drift, max_abs_diff(position(state), arm.q0));
        EXPECT_TRUE(matrices_near(tip_wrench(truth), W, 0.0)) << "seq " << k;
        EXPECT_TRUE(truth.contact);
        const Eigen::VectorXd q = position(state);
        const Eigen::VectorXd expected =
            body_jacobian(arm.model, data, q).transpose() * in_tip_frame(data.T_sb.linear(), W);
        EXPECT_TRUE(matrices_near(as_vector(truth.tau_ext.data(), truth.num_joints), expected, 1e-9)) << "seq " << k;
      }
      // Rounding only: q̈ is M⁻¹ of a sum that cancels to ~1e-13, integrated over 0.2 s.
      EXPECT_LT(drift, 1e-9);

      // The control: the same command without the push moves the arm within the same time.
      Rig free(arm.model, arm.q0, lockstep());
      for (int k = 0; k < kSteps; ++k) free.step(hold(free.q()));
      EXPECT_GT(max_abs_diff(free.q(), arm.q0), 1e-3);
    }
  }
}

// The trapezoid, drawn by hand: push A from 0.1 s for 0.3 s with 0.05 s ramps, push B a step from
// 0.2 s to 0.25 s; they add. The values at chosen samples (t = seq × 1 ms) are read off the
// drawing, not computed from Push::profile.
TEST(environment, PushesFollowTheirRampsAndAdd) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  const Vector6d A = wrench(0.4, -0.2, 0.1, 3, -6, 30), B = wrench(0, 0.5, 0, -10, 0, 0);
  EnvironmentOptions env;
  env.pushes.push_back({0.1, 0.3, 0.05, A});
  env.pushes.push_back({0.2, 0.05, 0.0, B});
  Rig rig(arm.model, arm.q0, lockstep(env), Eigen::VectorXd::Constant(7, 2.0));
  for (int k = 0; k < 450; ++k) rig.step(gravity_torques(arm.model, data, position(rig.states().back())));
  ASSERT_EQ(rig.truths().size(), 451u);

  struct Sample {
    int seq;
    double a, b;  // how much of A and of B
    bool contact;
  };
  const std::vector<Sample> samples = {
      {0, 0, 0, false},    {50, 0, 0, false},    {99, 0, 0, false},  {101, 0.02, 0, true}, {110, 0.2, 0, true},
      {125, 0.5, 0, true}, {149, 0.98, 0, true}, {150, 1, 0, true},  {199, 1, 0, true},    {200, 1, 1, true},
      {225, 1, 1, true},   {250, 1, 1, true},    {251, 1, 0, true},  {350, 1, 0, true},    {375, 0.5, 0, true},
      {390, 0.2, 0, true}, {399, 0.02, 0, true}, {401, 0, 0, false}, {450, 0, 0, false}};
  for (const Sample& s : samples) {
    const sim_truth_t& truth = rig.truths()[static_cast<size_t>(s.seq)];
    ASSERT_EQ(truth.seq, s.seq);
    EXPECT_TRUE(matrices_near(tip_wrench(truth), s.a * A + s.b * B, 1e-12)) << "seq " << s.seq;
    EXPECT_EQ(truth.contact, s.contact) << "seq " << s.seq;
  }
}

// The tip origin's depth inside a wall, by forward kinematics.
double depth(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Wall& wall) {
  return -(forward_kinematics(model, data, q).translation() - wall.point).dot(wall.normal);
}

// A spring's rest: an arm pressing on a wall with a constant force F along −n (τ = g(q) − J_bᵀ F_b
// with F_b = (0, F n) in the tip frame, recomputed every state) comes to rest with the tip F/K
// inside it, the wall then pushing back with exactly F n. Settling is by the joints' damping alone;
// its slowest mode, the tip sliding along the wall, decays with a time constant of about 0.5 s, and
// after 5 s the rest depth is within 3e-11 m of F/K on both arms (measured): 1e-9 m, 5e-7 of the
// 2 mm, leaves room for other machines' rounding and fails any other rest. On the way, at every
// sample, the wall's force is along n, not negative, with no moment, and it acts exactly when the
// tip origin is inside (by the test's own kinematics). A floor under the Panda, a tilted wall
// beside the UR5.
TEST(environment, AnArmPressingOnAWallRestsAtForceOverStiffness) {
  constexpr double kForce = 20.0, kStiffness = 1e4;
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    Data data(arm.model);
    const Vector3d n = (arm.name == "panda" ? Vector3d(0, 0, 1) : Vector3d(1, -0.5, 2)).normalized();
    const Vector3d p0 = forward_kinematics(arm.model, data, arm.q0).translation();
    const Wall wall{p0 - 0.001 * n, n, kStiffness, 100.0};  // 1 mm from the tip
    EnvironmentOptions env;
    env.walls.push_back(wall);
    Rig rig(arm.model, arm.q0, lockstep(env), Eigen::VectorXd::Constant(arm.model.dof(), 5.0));
    const Vector6d pressed = wrench(0, 0, 0, kForce * n.x(), kForce * n.y(), kForce * n.z());
    constexpr int kSteps = 5000;
    for (int k = 0; k < kSteps; ++k) {
      const Eigen::VectorXd q = position(rig.states().back());
      rig.step(
          holding_torque(arm.model, data, q, in_tip_frame(forward_kinematics(arm.model, data, q).linear(), pressed)));
    }
    ASSERT_EQ(rig.truths().size(), size_t{kSteps + 1});
    bool touched = false;
    for (size_t k = 0; k < rig.truths().size(); ++k) {
      const sim_truth_t& truth = rig.truths()[k];
      const Vector6d F = tip_wrench(truth);
      const double along = F.tail<3>().dot(n);
      ASSERT_TRUE(matrices_near(F.head<3>(), Vector3d::Zero(), 0.0)) << "a moment about the tip origin, seq " << k;
      ASSERT_TRUE(matrices_near(F.tail<3>(), along * n, 1e-12)) << "not along the normal, seq " << k;
      ASSERT_GE(along, 0.0) << "the wall pulled, seq " << k;
      const bool inside = depth(arm.model, data, position(rig.states()[k]), wall) > 0.0;
      ASSERT_EQ(truth.contact, inside) << "seq " << k;
      if (!inside) {
        ASSERT_EQ(along, 0.0) << "seq " << k;
      }
      touched = touched || inside;
    }
    EXPECT_TRUE(touched);
    EXPECT_LT(rig.qd().cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_NEAR(depth(arm.model, data, rig.q(), wall), kForce / kStiffness, 1e-9);
    EXPECT_TRUE(matrices_near(tip_wrench(rig.truths().back()), pressed, 1e-5));
  }
}

// The wall's spring energy ½ K δ² while the tip origin is inside.
double wall_energy(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Wall& wall) {
  const double d = depth(model, data, q, wall);
  return d > 0.0 ? 0.5 * wall.stiffness * d * d : 0.0;
}

// Energy: the Panda falls from a bent pose with no torque and no joint damping onto a floor 2 cm
// under its tip and bounces. A wall without damping is a spring: kinetic + potential + ½ K δ² stays
// constant (it does no work the spring does not store); with damping it never grows and ends
// lower (it does no positive work: its force is at most K δ, and zero while the tip leaves fast).
// Away from the wall's surface RK4 keeps this energy to 1e-9 J per step; in the step where the tip
// enters or leaves, the force's slope jumps and RK4's error there is second order in the step:
// measured at up to 2.5 m/s, 4.5e-4 J at one RK4 step per 1 ms step, 8e-6 J with 10 substeps
// (either sign). The test runs 10 substeps and allows 3e-5 J per step and 1e-4 J over the run:
// far below what a wall doing work would show (1e4 N/m over millimetres: 1e-2 J and more).
TEST(environment, AWallStoresOrDissipatesEnergyButNeverGivesAny) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  const Vector3d p0 = forward_kinematics(arm.model, data, arm.q0).translation();
  for (const double damping : {0.0, 100.0}) {
    SCOPED_TRACE("wall damping " + std::to_string(damping));
    const Wall wall{p0 - Vector3d(0, 0, 0.02), Vector3d::UnitZ(), 1e4, damping};
    EnvironmentOptions env;
    env.walls.push_back(wall);
    SimulationOptions options = lockstep(env);
    options.substeps = 10;
    Rig rig(arm.model, arm.q0, options);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(7);
    std::vector<double> energy;
    int inside = 0, clamped = 0;
    for (int k = 0; k <= 400; ++k) {
      const Eigen::VectorXd& q = rig.q();
      energy.push_back(kinetic_energy(arm.model, data, q, rig.qd()) + potential_energy(arm.model, data, q) +
                       wall_energy(arm.model, data, q, wall));
      const sim_truth_t& truth = rig.truths().back();
      inside += truth.contact;
      clamped += truth.contact && tip_wrench(truth).tail<3>().z() == 0.0;
      if (k < 400) rig.step(zero);
    }
    EXPECT_GT(inside, 20) << "the tip should have been in the wall for a while";
    double largest_rise = 0.0;
    for (size_t k = 1; k < energy.size(); ++k) largest_rise = std::max(largest_rise, energy[k] - energy[k - 1]);
    EXPECT_LT(largest_rise, 3e-5);
    if (damping == 0.0) {
      EXPECT_NEAR(energy.back(), energy.front(), 1e-4);
      EXPECT_EQ(clamped, 0);
    } else {
      EXPECT_LT(energy.back(), energy.front() - 0.01) << "the wall's damping should have taken energy";
      EXPECT_GT(clamped, 0) << "the tip should have left faster than the wall relaxes (the clamp)";
    }
  }
}

// J_p: the base-frame velocity of a point fixed at c in the tip frame, ṗ = R_sb (v_b + ω_b × c).
Eigen::MatrixXd point_jacobian(const RobotModel& model, Data& data, const Eigen::VectorXd& q, const Vector3d& c) {
  const Matrix6Xd& J_b = body_jacobian(model, data, q);
  return data.T_sb.linear() * (J_b.bottomRows<3>() - hat3(c) * J_b.topRows<3>());
}

// A point mass m at c has kinetic energy ½ m |J_p q̇|² and potential −m gᵀ p, so it adds
// m J_pᵀ J_p to M(q) and −m J_pᵀ g to g(q). with_payload's model says the same, at seeded
// configurations of both arms.
TEST(environment, APayloadAddsAPointMassToTheModel) {
  const plant::Payload payload{1.7, Vector3d(0.03, -0.05, 0.12)};
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    const RobotModel loaded = plant::with_payload(arm.model, payload);
    Data nominal(arm.model), data(loaded);
    std::srand(5);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd q = arm.q0 + 0.5 * Eigen::VectorXd::Random(arm.model.dof());
      const Eigen::MatrixXd J_p = point_jacobian(arm.model, nominal, q, payload.centre);
      const Eigen::MatrixXd M0 = mass_matrix(arm.model, nominal, q);
      const Eigen::VectorXd g0 = gravity_torques(arm.model, nominal, q);
      EXPECT_TRUE(matrices_near(mass_matrix(loaded, data, q) - M0, payload.mass * J_p.transpose() * J_p, 1e-12));
      EXPECT_TRUE(matrices_near(gravity_torques(loaded, data, q) - g0,
                                -payload.mass * J_p.transpose() * arm.model.gravity(), 1e-12));
    }
  }
}

// A hidden payload, seen from the nominal model: an arm holding still with the true gravity torques
// g_true = g − m J_pᵀ g_vec (the test's own, from the point mass) stays still, and its truth is
// τ_ext = g − g_true, the payload's weight on the joints; no contact. At the first sample, at rest
// with no torque yet, the arm falls with M_true q̈ = −g_true, so the nominal model sees
// τ_ext = M q̈ + g = g − M M_true⁻¹ g_true: the payload's inertia is in it too (held with only the
// nominal g(q) the arm sags the same way, and τ_ext = g − g_true holds only while q̈ = 0).
TEST(environment, AHiddenPayloadIsExternalTorqueToTheNominalModel) {
  const plant::Payload payload{2.5, Vector3d(0.02, -0.04, 0.1)};
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    Data data(arm.model);
    const Eigen::Vector3d& g_vec = arm.model.gravity();
    const auto true_gravity = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
      const Eigen::MatrixXd J_p = point_jacobian(arm.model, data, q, payload.centre);
      return gravity_torques(arm.model, data, q) - payload.mass * J_p.transpose() * g_vec;
    };
    EnvironmentOptions env;
    env.payload = payload;
    Rig rig(arm.model, arm.q0, lockstep(env));

    const Eigen::VectorXd g0 = gravity_torques(arm.model, data, arm.q0);
    const Eigen::MatrixXd J_p0 = point_jacobian(arm.model, data, arm.q0, payload.centre);
    const Eigen::MatrixXd M0 = mass_matrix(arm.model, data, arm.q0);
    const Eigen::MatrixXd M_true0 = M0 + payload.mass * J_p0.transpose() * J_p0;
    const Eigen::VectorXd g_true0 = true_gravity(arm.q0);
    const Eigen::VectorXd expected0 = g0 - M0 * M_true0.llt().solve(g_true0);
    const sim_truth_t& first = rig.truths().front();
    EXPECT_TRUE(matrices_near(as_vector(first.tau_ext.data(), first.num_joints), expected0, 1e-9));
    EXPECT_GT(max_abs_diff(expected0, g0 - g_true0), 0.1) << "the payload's inertia should show at the first sample";

    for (int k = 0; k < 300; ++k) rig.step(true_gravity(position(rig.states().back())));
    double drift = 0.0;
    for (size_t k = 1; k < rig.states().size(); ++k) {
      const Eigen::VectorXd q = position(rig.states()[k]);
      const sim_truth_t& truth = rig.truths()[k];
      drift = std::max(drift, max_abs_diff(q, arm.q0));
      EXPECT_TRUE(matrices_near(as_vector(truth.tau_ext.data(), truth.num_joints),
                                gravity_torques(arm.model, data, q) - true_gravity(q), 1e-9))
          << "seq " << k;
      EXPECT_TRUE(matrices_near(tip_wrench(truth), Vector6d::Zero(), 0.0));
      EXPECT_FALSE(truth.contact);
    }
    EXPECT_LT(drift, 1e-9);
    EXPECT_GT(max_abs_diff(g0, g_true0), 1.0) << "the payload should weigh on the joints";
  }
}

// Hidden friction is exactly the law at every sample, τ_ext = −b q̇ − (f_c + (f_s − f_c)
// exp(−(q̇ / v_st)²)) tanh(q̇ / v_s) with the state's q̇ (Olsson et al. 1998's stiction and Stribeck
// effect, written out here), while the joints run through both signs and both regimes of the tanh
// (|q̇| well below and well above v_s). v_s keeps the stiffest mode friction adds resolved: at every
// configuration the arm passes through, f_s / v_s ≤ λ_min(M(q)) / h, so h λ ≤ 1 for λ of M⁻¹ times
// the friction's slope, well inside RK4's real-axis limit of 2.79.
TEST(environment, HiddenFrictionIsTheFrictionLaw) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  Eigen::VectorXd b(7), f_c(7), f_s(7), wobble(7);
  b << 0.3, 0.3, 0.2, 0.2, 0.05, 0.05, 0.02;
  f_c << 1.0, 1.0, 0.8, 0.8, 0.3, 0.3, 0.1;
  f_s << 1.5, 1.0, 1.2, 0.8, 0.45, 0.3, 0.15;
  wobble << 6, -5, 4, 6, -1.5, 1.2, 0.8;
  const double v_st = 0.2;
  EnvironmentOptions env;
  env.friction = {b, f_c, f_s, v_st};
  Rig rig(arm.model, arm.q0, lockstep(env));
  const Eigen::VectorXd v_s = rig.plant().friction_velocity();
  EXPECT_TRUE((v_s.array() > 0.0).all());
  int slow = 0, fast = 0;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::VectorXd q = position(rig.states().back());
    const double s = std::sin(2 * kPi * k * kDt / 0.4);  // torques that turn the joints back and forth
    rig.step(gravity_torques(arm.model, data, q) + s * wobble);
  }
  for (size_t k = 0; k < rig.states().size(); ++k) {
    const Eigen::VectorXd q = position(rig.states()[k]), qd = velocity(rig.states()[k]);
    const sim_truth_t& truth = rig.truths()[k];
    Eigen::VectorXd expected(7);
    for (int i = 0; i < 7; ++i) {
      const double level = f_c[i] + (f_s[i] - f_c[i]) * std::exp(-(qd[i] / v_st) * (qd[i] / v_st));
      expected[i] = -b[i] * qd[i] - level * std::tanh(qd[i] / v_s[i]);
    }
    ASSERT_TRUE(matrices_near(as_vector(truth.tau_ext.data(), truth.num_joints), expected, 1e-9)) << "seq " << k;
    EXPECT_FALSE(truth.contact);
    const double lambda_min =
        test::symmetric_eigenvalues(mass_matrix(arm.model, data, q))[0];
    ASSERT_LE((f_s.array() / v_s.array()).maxCoeff(), lambda_min / kDt) << "seq " << k;
    for (int i = 0; i < 7; ++i) {
      slow += std::abs(qd[i]) > 0.0 && std::abs(qd[i]) < 0.3 * v_s[i];
      fast += std::abs(qd[i]) > 3.0 * v_s[i];
    }
  }
  EXPECT_GT(slow, 100);
  EXPECT_GT(fast, 100);
}

// Friction takes energy and never gives any: the Panda swinging freely from a bent pose (no torque,
// no damping) under Coulomb friction alone loses energy at every step; with a v_s too small for
// the step RK4 would ring around q̇ = 0 and pump energy in. Without friction the same swing keeps it
// to 1e-9 J per step.
TEST(environment, FrictionOnlyTakesEnergy) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  EnvironmentOptions env;
  env.friction = {Eigen::VectorXd::Zero(7), Eigen::VectorXd::Constant(7, 2.0)};
  Rig rig(arm.model, arm.q0, lockstep(env));
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(7);
  double previous = 0.0, largest_rise = -1.0;
  for (int k = 0; k <= 2000; ++k) {
    const double e = kinetic_energy(arm.model, data, rig.q(), rig.qd()) + potential_energy(arm.model, data, rig.q());
    if (k > 0) largest_rise = std::max(largest_rise, e - previous);
    previous = e;
    if (k < 2000) rig.step(zero);
  }
  EXPECT_LT(largest_rise, 1e-9);
}

// TRUTH goes out only when asked: never with an empty environment (the default); with --truth, or
// anything in the environment, once per state produced, right after it, with its seq and utime.
// States the fault injection drops or delays still have their truth, on time: with half the
// states dropped and the rest delayed 3 ms, every truth 0..N arrives, in order, each before its
// state. With nothing hidden the truth is zero to rounding (the plant's model is the nominal one).
// Real time too (braked, no controller).
TEST(environment, TruthIsOnTheBusOnlyWhenAskedWithTheStatesSeq) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  const auto hold = [&](Rig& rig) {
    for (int k = 0; k < 30; ++k) rig.step(gravity_torques(arm.model, data, rig.q()));
  };
  {
    Rig rig(arm.model, arm.q0, lockstep());
    hold(rig);
    EXPECT_FALSE(rig.simulation().publishes_truth());
    EXPECT_EQ(rig.states().size(), 31u);
    EXPECT_TRUE(rig.truths().empty());
    EXPECT_EQ(rig.simulation().truth().steps, -1) << "not published, not computed";
  }
  {
    SimulationOptions options = lockstep();
    options.truth = true;
    Rig rig(arm.model, arm.q0, options);
    hold(rig);
    ASSERT_EQ(rig.truths().size(), 31u);
    ASSERT_EQ(rig.arrivals().size(), 62u);
    for (size_t k = 0; k < 31; ++k) {
      EXPECT_EQ(rig.arrivals()[2 * k], std::make_pair('S', static_cast<int64_t>(k)));
      EXPECT_EQ(rig.arrivals()[2 * k + 1], std::make_pair('T', static_cast<int64_t>(k)));
      const sim_truth_t& truth = rig.truths()[k];
      EXPECT_EQ(truth.utime, rig.states()[k].utime);
      EXPECT_EQ(truth.num_joints, 7);
      EXPECT_LT(as_vector(truth.tau_ext.data(), 7).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_TRUE(matrices_near(tip_wrench(truth), Vector6d::Zero(), 0.0));
      EXPECT_FALSE(truth.contact);
    }
    EXPECT_EQ(rig.simulation().truth().steps, 30);
  }
  {
    EnvironmentOptions env;
    env.pushes.push_back({0.0, 1.0, 0.01, wrench(0, 0, 0, 0, 0, -5)});
    SimulationOptions options = lockstep(env);
    options.faults.seed = 3;
    options.faults.drop = 0.5;
    options.faults.delay_ms = 3.0;
    Rig rig(arm.model, arm.q0, options);
    EXPECT_TRUE(rig.simulation().publishes_truth());
    hold(rig);
    for (int k = 0; k < 10; ++k) rig.step(gravity_torques(arm.model, data, rig.q()));  // the last delayed states come
    ASSERT_EQ(rig.truths().size(), 41u);
    for (size_t k = 0; k < rig.truths().size(); ++k) EXPECT_EQ(rig.truths()[k].seq, static_cast<int64_t>(k));
    EXPECT_LT(rig.states().size(), 35u) << "about half the states should have been dropped";
    EXPECT_GT(rig.states().size(), 5u);
    for (const robot_state_t& state : rig.states()) {
      const auto state_at = std::find(rig.arrivals().begin(), rig.arrivals().end(), std::make_pair('S', state.seq));
      const auto truth_at = std::find(rig.arrivals().begin(), rig.arrivals().end(), std::make_pair('T', state.seq));
      EXPECT_LT(truth_at, state_at) << "state " << state.seq << " was delayed, its truth not";
    }
  }
  {
    SimulationOptions options;
    options.truth = true;
    Rig rig(arm.model, arm.q0, options);
    for (int k = 0; k < 5; ++k) rig.real_time_step();
    ASSERT_EQ(rig.truths().size(), 6u);
    for (size_t k = 0; k < 6; ++k) EXPECT_EQ(rig.truths()[k].seq, rig.states()[k].seq);
  }
}

// The reported effort is a noisy sensor's: over 10 000 states of the Panda turned back and forth, the
// reports minus the torque applied (the same run's without noise, whose reports are exact) have, per
// joint, a mean within 4 σ/√N of 0 and a standard deviation within 5 % of σ (measured: within 0.7 %),
// 68.3 % of them within ±σ (a Gaussian's share) and no correlation between the two joints of a
// Box–Muller pair or from one state to the next. The motion is the same bit for bit: the noise is on
// the report only. The same seed draws the same noise, another seed other noise.
TEST(environment, EffortNoiseIsOnTheReportedEffortOnly) {
  const Arm arm = panda_arm();
  Data data(arm.model);
  constexpr double kSigma = 0.05;
  constexpr int kSteps = 10'000;
  Eigen::VectorXd wobble(7);
  wobble << 6, -5, 4, 6, -1.5, 1.2, 0.8;
  const auto run = [&](Rig& rig, int steps) {
    for (int k = 0; k < steps; ++k) {
      const double s = std::sin(2 * kPi * k * kDt / 0.4);
      rig.step(gravity_torques(arm.model, data, rig.q()) + s * wobble);
    }
  };
  SimulationOptions noisy_options = lockstep();
  noisy_options.faults.effort_noise = {kSigma, 3};
  Rig noisy(arm.model, arm.q0, noisy_options, Eigen::VectorXd::Constant(7, 2.0));
  Rig exact(arm.model, arm.q0, lockstep(), Eigen::VectorXd::Constant(7, 2.0));
  run(noisy, kSteps);
  run(exact, kSteps);
  ASSERT_EQ(noisy.states().size(), size_t{kSteps + 1});
  ASSERT_EQ(exact.states().size(), size_t{kSteps + 1});
  EXPECT_FALSE(noisy.simulation().publishes_truth()) << "the noise hides nothing from the nominal model";
  EXPECT_EQ(exact.plant().effort(), noisy.plant().effort());

  Eigen::MatrixXd residual(kSteps + 1, 7);
  for (int k = 0; k <= kSteps; ++k) {
    const robot_state_t& a = noisy.states()[static_cast<size_t>(k)];
    const robot_state_t& b = exact.states()[static_cast<size_t>(k)];
    ASSERT_EQ(a.position, b.position) << "seq " << k;
    ASSERT_EQ(a.velocity, b.velocity) << "seq " << k;
    residual.row(k) = (vector_of(a.effort) - vector_of(b.effort)).transpose();
  }
  const double N = kSteps + 1;
  const Eigen::RowVectorXd mean = residual.colwise().mean();
  const Eigen::MatrixXd centred = residual.rowwise() - mean;
  const Eigen::RowVectorXd deviation = (centred.colwise().squaredNorm() / (N - 1)).cwiseSqrt();
  const double within = static_cast<double>((residual.array().abs() < kSigma).count()) / (7 * N);
  const auto correlation = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& y) {
    return x.dot(y) / (x.norm() * y.norm());
  };
  for (int i = 0; i < 7; ++i) {
    SCOPED_TRACE("joint " + std::to_string(i + 1));
    EXPECT_LT(std::abs(mean[i]), 4 * kSigma / std::sqrt(N));
    EXPECT_NEAR(deviation[i] / kSigma, 1.0, 0.05);
    const Eigen::VectorXd x = centred.col(i);
    EXPECT_LT(std::abs(correlation(x.head(kSteps), x.tail(kSteps))), 0.04) << "one state to the next";
  }
  EXPECT_NEAR(within, 0.6827, 0.01);
  for (int i = 0; i < 6; i += 2) {
    EXPECT_LT(std::abs(correlation(centred.col(i), centred.col(i + 1))), 0.04) << "joints " << i + 1 << ", " << i + 2;
  }

  Rig again(arm.model, arm.q0, noisy_options, Eigen::VectorXd::Constant(7, 2.0));
  SimulationOptions other_seed = noisy_options;
  other_seed.faults.effort_noise.seed = 4;
  Rig other(arm.model, arm.q0, other_seed, Eigen::VectorXd::Constant(7, 2.0));
  run(again, 50);
  run(other, 50);
  for (size_t k = 0; k <= 50; ++k) {
    EXPECT_EQ(again.states()[k].effort, noisy.states()[k].effort) << "seq " << k;
    EXPECT_NE(other.states()[k].effort, noisy.states()[k].effort) << "seq " << k;
  }
}

// Drake's statuses report the same noisy effort as their measured torque, in their drivers' signs —
// the iiwa's joint_torque_measured negated, the Panda's joint_torque (tau_J) not — and nothing else
// noisy: the commanded and desired torques, the external one, the positions are as given. The
// draws do not depend on the protocol: three publishers with one seed add the same noise.
TEST(environment, DrakeStatusesReportTheNoisyEffortAsMeasuredTorque) {
  const Eigen::VectorXd q = bent_pose(), qd = Eigen::VectorXd::LinSpaced(7, -1.0, 1.0);
  const Eigen::VectorXd effort = Eigen::VectorXd::LinSpaced(7, -20.0, 30.0);
  const Eigen::VectorXd commanded = effort + Eigen::VectorXd::Constant(7, 1.0);
  const Eigen::VectorXd desired = effort - Eigen::VectorXd::Constant(7, 2.0);
  const Eigen::VectorXd tau_ext = Eigen::VectorXd::LinSpaced(7, 0.5, 3.5);
  const plant::DriverReport report{qd, effort, commanded, desired, q, tau_ext, true, 1.0, 2, 4, 1000};
  plant::Faults faults;
  faults.effort_noise = {0.2, 9};
  Bus bus("memq://");
  std::vector<robot_state_t> states;
  std::vector<drake::lcmt_iiwa_status> iiwas;
  std::vector<drake::lcmt_panda_status> pandas;
  std::vector<Bus::Subscription> subscriptions;
  subscriptions.push_back(bus.subscribe("CHASLES", [&](const uint8_t* data, size_t size) {
    states.emplace_back();
    ASSERT_EQ(messages::decode_checked(data, size, states.back(), 7, messages::Finite::Required), "");
  }));
  subscriptions.push_back(bus.subscribe("IIWA", [&](const uint8_t* data, size_t size) {
    iiwas.emplace_back();
    ASSERT_EQ(messages::decode_checked(data, size, iiwas.back(), 7, messages::Finite::Required), "");
  }));
  subscriptions.push_back(bus.subscribe("PANDA", [&](const uint8_t* data, size_t size) {
    pandas.emplace_back();
    ASSERT_EQ(messages::decode_checked(data, size, pandas.back(), 7, messages::Finite::Required), "");
  }));
  plant::StatePublisher chasles(bus, "CHASLES", 7, faults, 4, controller::Protocol::kChasles);
  plant::StatePublisher iiwa(bus, "IIWA", 7, faults, 4, controller::Protocol::kDrakeIiwa);
  plant::StatePublisher panda(bus, "PANDA", 7, faults, 4, controller::Protocol::kDrakePanda);
  for (int k = 0; k < 20; ++k) {
    for (plant::StatePublisher* publisher : {&chasles, &iiwa, &panda}) {
      publisher->encode(k, k, q, report);
      publisher->send(0);
    }
    while (bus.handle_pending() > 0) {
    }
  }
  ASSERT_EQ(states.size(), 20u);
  ASSERT_EQ(iiwas.size(), 20u);
  ASSERT_EQ(pandas.size(), 20u);
  for (size_t k = 0; k < 20; ++k) {
    const Eigen::VectorXd measured = vector_of(states[k].effort);
    EXPECT_GT(max_abs_diff(measured, effort), 0.0) << "state " << k;
    EXPECT_LT(max_abs_diff(measured, effort), 8.6 * 0.2) << "Box-Muller's bound";
    EXPECT_EQ(vector_of(iiwas[k].joint_torque_measured), -measured) << "state " << k;
    EXPECT_EQ(vector_of(pandas[k].joint_torque), measured) << "state " << k;
    EXPECT_EQ(vector_of(iiwas[k].joint_torque_commanded), -commanded);
    EXPECT_EQ(vector_of(iiwas[k].joint_torque_external), tau_ext);
    EXPECT_EQ(vector_of(iiwas[k].joint_position_measured), q);
    EXPECT_EQ(vector_of(pandas[k].joint_torque_desired), desired);
    EXPECT_EQ(vector_of(pandas[k].joint_torque_external), -tau_ext);
    EXPECT_EQ(vector_of(states[k].velocity), qd);
    if (k > 0) {
      EXPECT_NE(vector_of(states[k].effort), vector_of(states[k - 1].effort)) << "a new draw per state";
    }
  }
}

// M q̈ = τ − g at rest: the acceleration of a model under a torque from rest.
Eigen::VectorXd acceleration_from_rest(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& tau) {
  Data data(model);
  return mass_matrix(model, data, q).llt().solve(tau - gravity_torques(model, data, q));
}

// The plant integrates with_perturbed_inertias(model, f, seed), not the model it was given. One
// 0.1 ms step from rest under a fixed torque: q̇(h) = q̈(0) h + O(h³) (from rest q̈ changes only at
// second order: its first derivative is ∂q̈/∂q q̇ = 0 and the Coriolis terms are quadratic in q̇), so
// q̇(h)/h is M_perturbed⁻¹(τ − g_perturbed) to 1e-7 relative (measured; 1e-5 with 1 ms steps), and
// not the nominal model's acceleration (20 % of the largest away on the UR5, 83 % on the Panda).
// Its truth at rest, before any torque, is what the nominal model makes of that fall:
// τ_ext = M q̈_true + g with q̈_true = −M_perturbed⁻¹ g_perturbed. A payload goes on the perturbed
// arm: the plant with both moves bit for bit as a plant given that model.
TEST(environment, PerturbedInertiasAreTheArmThePlantIntegrates) {
  for (const Arm& arm : {panda_arm(), ur5_arm()}) {
    SCOPED_TRACE(arm.name);
    const int n = arm.model.dof();
    const plant::InertiaPerturbation perturbation{0.2, 7};
    const RobotModel perturbed = with_perturbed_inertias(arm.model, perturbation.fraction, perturbation.seed);
    Data data(arm.model);
    const Eigen::VectorXd tau = 0.5 * gravity_torques(arm.model, data, arm.q0);
    EnvironmentOptions env;
    env.perturbation = perturbation;

    constexpr double kShortStep = 1e-4;
    plant::Plant plant(arm.model, arm.q0, Eigen::VectorXd::Zero(n), kShortStep, 1, env);
    plant.step(tau);
    const Eigen::VectorXd qdd = plant.qd() / kShortStep;
    const Eigen::VectorXd qdd_perturbed = acceleration_from_rest(perturbed, arm.q0, tau);
    const Eigen::VectorXd qdd_nominal = acceleration_from_rest(arm.model, arm.q0, tau);
    const double scale = qdd_perturbed.cwiseAbs().maxCoeff();
    EXPECT_LT(max_abs_diff(qdd, qdd_perturbed) / scale, 1e-6);
    EXPECT_GT(max_abs_diff(qdd, qdd_nominal) / scale, 0.05) << "the nominal model should not be what moves";

    Rig rig(arm.model, arm.q0, lockstep(env));
    EXPECT_TRUE(rig.simulation().publishes_truth());
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    const Eigen::VectorXd falling = acceleration_from_rest(perturbed, arm.q0, zero);
    const Eigen::VectorXd expected =
        mass_matrix(arm.model, data, arm.q0) * falling + gravity_torques(arm.model, data, arm.q0);
    const sim_truth_t& first = rig.truths().front();
    EXPECT_TRUE(matrices_near(as_vector(first.tau_ext.data(), n), expected, 1e-9));
    EXPECT_GT(expected.cwiseAbs().maxCoeff(), 0.5) << "the model error should weigh";

    env.payload = plant::Payload{1.5, Vector3d(0.02, 0.0, 0.08)};
    plant::Plant both(arm.model, arm.q0, Eigen::VectorXd::Zero(n), kDt, 1, env);
    const RobotModel reference_model = plant::with_payload(perturbed, *env.payload);
    plant::Plant reference(reference_model, arm.q0, Eigen::VectorXd::Zero(n), kDt, 1);
    for (int k = 0; k < 200; ++k) {
      both.step(tau);
      reference.step(tau);
    }
    EXPECT_EQ(both.q(), reference.q());
    EXPECT_EQ(both.qd(), reference.qd());
    EXPECT_GT(max_abs_diff(both.q(), arm.q0), 1e-3) << "it should have moved";
  }
}

// The plant's step and its truth allocate nothing, with every part of the environment in use.
TEST(environment, StepAndTruthAllocateNothing) {
  const Arm arm = panda_arm();
  EnvironmentOptions env;
  env.pushes.push_back({0.0, 1.0, 0.01, wrench(0.1, 0, 0, 0, 0, -5)});
  Data data(arm.model);
  const Vector3d p0 = forward_kinematics(arm.model, data, arm.q0).translation();
  env.walls.push_back({p0 - Vector3d(0, 0, 0.005), Vector3d::UnitZ(), 1e4, 100});
  env.payload = plant::Payload{1.0, Vector3d(0, 0, 0.1)};
  env.friction = {Eigen::VectorXd::Constant(7, 0.1), Eigen::VectorXd::Constant(7, 0.5)};
  env.perturbation = plant::InertiaPerturbation{0.2, 1};
  plant::Plant plant(arm.model, arm.q0, Eigen::VectorXd::Constant(7, 0.5), kDt, 2, env);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(7);
  plant.step(tau);
  plant.sample_truth();
  long allocations = 0;
  {
    AllocationCounter counter;
    for (int k = 0; k < 200; ++k) {
      plant.step(tau);
      plant.sample_truth();
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_TRUE(plant.truth().contact) << "the wall should have been reached";
}

// What the command-line forms give, and what they refuse, with messages that say which part is
// wrong. The same checks guard options set in process (Simulation refuses them).
TEST(environment, SpecsAreParsedAndCheckedWithSpecificMessages) {
  const RobotModel model = panda_arm().model;

  const Push push = plant::parse_push("0.5,1,0.25,1,2,3,4,5,6");
  EXPECT_EQ(push.start, 0.5);
  EXPECT_EQ(push.duration, 1.0);
  EXPECT_EQ(push.ramp, 0.25);
  EXPECT_EQ(push.wrench, wrench(1, 2, 3, 4, 5, 6));
  EXPECT_EQ(plant::parse_push("0,1,0.5,0,0,0,0,0,1").ramp, 0.5) << "RAMP = DURATION/2 fits";

  const Wall wall = plant::parse_wall("0.1,-0.2,0.3,0,3,4");
  EXPECT_EQ(wall.point, Vector3d(0.1, -0.2, 0.3));
  EXPECT_TRUE(matrices_near(wall.normal, Vector3d(0, 0.6, 0.8), 1e-15)) << "normalised";
  EXPECT_EQ(wall.stiffness, 10'000.0);
  EXPECT_EQ(wall.damping, 100.0);
  const Wall stiff = plant::parse_wall("0,0,0,0,0,2,5e4,0");
  EXPECT_EQ(stiff.stiffness, 5e4);
  EXPECT_EQ(stiff.damping, 0.0);

  const plant::Payload payload = plant::parse_payload("1.5");
  EXPECT_EQ(payload.mass, 1.5);
  EXPECT_EQ(payload.centre, Vector3d::Zero());
  EXPECT_EQ(plant::parse_payload("0,0.1,0.2,0.3").centre, Vector3d(0.1, 0.2, 0.3));

  const plant::Friction all = plant::parse_friction("0.1,0.5", model);
  EXPECT_EQ(all.viscous, Eigen::VectorXd::Constant(7, 0.1));
  EXPECT_EQ(all.coulomb, Eigen::VectorXd::Constant(7, 0.5));
  const plant::Friction each = plant::parse_friction("1,2,3,4,5,6,7,8,9,10,11,12,13,14", model);
  EXPECT_EQ(each.viscous[2], 5.0);
  EXPECT_EQ(each.coulomb[6], 14.0);
  EXPECT_EQ(each.stiction.size(), 0);
  const plant::Friction sticking = plant::parse_friction("0.1,0.5,0.8", model);
  EXPECT_EQ(sticking.stiction, Eigen::VectorXd::Constant(7, 0.8));

  const auto refuses = [](const std::function<void()>& parse, const std::string& needle) {
    try {
      parse();
      ADD_FAILURE() << "accepted; expected a refusal containing: " << needle;
    } catch (const chasles::ArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refuses([] { plant::parse_push("0,1,0.1,0,0,0,0,0"); }, "--push takes START,DURATION,RAMP,mx,my,mz,fx,fy,fz");
  refuses([] { plant::parse_push("0,1,0.1,0,0,0,0,0"); }, "got 8");
  refuses([] { plant::parse_push("0,1,0.1,0,0,0,0,0,nan"); }, "--push: entry 8 ('nan') is not finite");
  refuses([] { plant::parse_push("0,1,inf,0,0,0,0,0,1"); }, "--push: entry 2 ('inf') is not finite");
  refuses([] { plant::parse_push("0,1,x,0,0,0,0,0,1"); }, "--push: entry 2 ('x') is not a number");
  refuses([] { plant::parse_push("0,1,0.6,0,0,0,0,0,1"); }, "--push: RAMP 0.6 s is longer than half of DURATION 1 s");
  refuses([] { plant::parse_push("0,0,0,0,0,0,0,0,1"); }, "--push: DURATION 0 s is not positive");
  refuses([] { plant::parse_push("0,1,-0.1,0,0,0,0,0,1"); }, "--push: RAMP -0.1 s is negative");
  refuses([] { plant::parse_push("-1,1,0,0,0,0,0,0,1"); }, "--push: START -1 s is before");
  refuses([] { plant::parse_wall("0,0,0,0,0"); }, "--wall takes PX,PY,PZ,NX,NY,NZ[,K,D] (6 or 8 numbers");
  refuses([] { plant::parse_wall("0,0,0,0,0,1,1e4"); }, "got 7");
  refuses([] { plant::parse_wall("0,0,0,0,0,0"); }, "--wall: the normal (0, 0, 0) has no direction");
  refuses([] { plant::parse_wall("0,0,0,0,0,1,0,1"); }, "--wall: stiffness K 0 N/m is not positive");
  refuses([] { plant::parse_wall("0,0,0,0,0,1,1e4,-1"); }, "--wall: damping D -1 N*s/m is negative");
  refuses([] { plant::parse_wall("0,0,0,0,0,-inf"); }, "--wall: entry 5 ('-inf') is not finite");
  refuses([] { plant::parse_payload("-0.5"); }, "--payload: mass -0.5 kg is negative");
  refuses([] { plant::parse_payload("nan"); }, "--payload: entry 0 ('nan') is not finite");
  refuses([] { plant::parse_payload("1,0,0"); }, "--payload takes KG[,CX,CY,CZ] (1 or 4 numbers");
  refuses([&] { plant::parse_friction("0.1", model); }, "(2, 3, 14 or 21 numbers for 7 joints");
  refuses([&] { plant::parse_friction("0.1,0.2,0.3,0.4", model); }, "got 4");
  refuses([&] { plant::parse_friction("0.1,0.5,0.2", model); },
          "--friction: joint panda_joint1: stiction 0.2 N*m is below Coulomb friction 0.5");
  refuses([&] { plant::parse_friction("-0.1,0.5", model); }, "--friction: joint panda_joint1: viscous friction -0.1");
  refuses([&] { plant::parse_friction("1,2,3,4,5,6,7,8,9,10,11,12,13,-14", model); },
          "--friction: joint panda_joint7: Coulomb friction -14 N*m is negative");

  const plant::InertiaPerturbation perturbation = plant::parse_perturbation("0.2,18446744073709551615");
  EXPECT_EQ(perturbation.fraction, 0.2);
  EXPECT_EQ(perturbation.seed, UINT64_MAX) << "a seed beyond 2^53 is read whole, not as a double";
  EXPECT_EQ(plant::parse_perturbation("0").seed, 0u);
  const plant::EffortNoise noise = plant::parse_effort_noise("0.05,7");
  EXPECT_EQ(noise.sigma, 0.05);
  EXPECT_EQ(noise.seed, 7u);
  EXPECT_EQ(plant::parse_effort_noise("0").sigma, 0.0);
  refuses([] { plant::parse_perturbation("1"); }, "--perturb-inertia: FRACTION 1 is not in [0, 1)");
  refuses([] { plant::parse_perturbation("-0.1,3"); }, "--perturb-inertia: FRACTION -0.1 is not in [0, 1)");
  refuses([] { plant::parse_perturbation("twenty"); }, "--perturb-inertia: entry 0 ('twenty') is not a number");
  refuses([] { plant::parse_perturbation("inf"); }, "--perturb-inertia: entry 0 ('inf') is not finite");
  refuses([] { plant::parse_perturbation("0.2,-3"); }, "--perturb-inertia: SEED '-3' is not a whole number");
  refuses([] { plant::parse_perturbation("0.2,1.5"); }, "--perturb-inertia: SEED '1.5' is not a whole number");
  refuses([] { plant::parse_perturbation("0.2,18446744073709551616"); }, "SEED '18446744073709551616' is not");
  refuses([] { plant::parse_perturbation("0.2,1,2"); }, "--perturb-inertia takes FRACTION[,SEED]");
  refuses([] { plant::parse_effort_noise("-0.01"); }, "--effort-noise: SIGMA -0.01 N*m is not a standard deviation");
  refuses([] { plant::parse_effort_noise("nan,2"); }, "--effort-noise: entry 0 ('nan') is not finite");
  refuses([] { plant::parse_effort_noise("0.1,"); }, "--effort-noise: SEED '' is not a whole number");
  refuses([] { plant::parse_effort_noise("x"); }, "--effort-noise: entry 0 ('x') is not a number");

  // In process: the same checks, naming the item.
  Bus bus("memq://");
  SimulatedClock clock;
  const Eigen::VectorXd q0 = bent_pose(), damping = Eigen::VectorXd::Zero(7);
  const auto simulation_refuses = [&](const EnvironmentOptions& env, const std::string& needle) {
    refuses([&] { plant::Simulation simulation(model, lockstep(env), q0, damping, bus, clock); }, needle);
  };
  EnvironmentOptions env;
  env.pushes = {{0, 1, 0, wrench(0, 0, 0, 0, 0, 1)}, {0, 1, 0.7, wrench(0, 0, 0, 0, 0, 1)}};
  simulation_refuses(env, "push 2: RAMP 0.7 s is longer than half of DURATION 1 s");
  env = {};
  env.walls = {{Vector3d::Zero(), Vector3d::Zero(), 1e4, 100}};
  simulation_refuses(env, "wall 1: the normal (0, 0, 0) has no direction");
  env = {};
  env.payload = plant::Payload{-1.0, Vector3d::Zero()};
  simulation_refuses(env, "payload: mass -1 kg is negative");
  env = {};
  env.friction = {Eigen::VectorXd::Zero(6), Eigen::VectorXd::Zero(6)};
  simulation_refuses(env, "friction: has 6 viscous and 6 Coulomb coefficients; the arm has 7 joints");
  env = {};
  env.perturbation = plant::InertiaPerturbation{1.0, 0};
  simulation_refuses(env, "perturbation: FRACTION 1 is not in [0, 1)");
  SimulationOptions noisy = lockstep();
  noisy.faults.effort_noise.sigma = -1.0;
  refuses([&] { plant::Simulation simulation(model, noisy, q0, damping, bus, clock); },
          "effort noise: SIGMA -1 N*m is not a standard deviation");
}

// The checked decoder of sim_truth_t (lcmtypes/checked.hpp), which every reader of TRUTH uses:
// a good message decodes; a wrong joint count, a forged count, a truncated message and non-finite
// numbers are refused, each saying so.
TEST(environment, TruthDecoderRefusesWhatIsNotATruth) {
  sim_truth_t truth;
  truth.utime = 1;
  truth.seq = 2;
  truth.num_joints = 7;
  truth.tau_ext.assign(7, 0.5);
  for (int i = 0; i < 6; ++i) truth.tip_wrench_ext[i] = i;
  truth.contact = true;
  const auto encode = [](const sim_truth_t& m) {
    std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
    m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    return bytes;
  };
  const auto decode = [](const std::vector<uint8_t>& bytes, int arm) {
    sim_truth_t m;
    return messages::decode_checked(bytes.data(), bytes.size(), m, arm, messages::Finite::Required);
  };
  std::vector<uint8_t> bytes = encode(truth);
  EXPECT_EQ(decode(bytes, 7), "");
  sim_truth_t back;
  ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), back), "");
  EXPECT_EQ(back.tau_ext, truth.tau_ext);
  EXPECT_EQ(back.tip_wrench_ext[5], 5.0);
  EXPECT_TRUE(back.contact);

  EXPECT_EQ(decode(bytes, 6), "for 7 joints; the arm has 6");
  // 8 (fingerprint) + 8 (utime) + 8 (seq) + 4 (num_joints) + 7 × 8 + 6 × 8 + 1 (contact) = 133 bytes.
  ASSERT_EQ(bytes.size(), 133u);
  EXPECT_EQ(decode(std::vector<uint8_t>(bytes.begin(), bytes.end() - 1), 7), "of 132 bytes; expected 133 for 7 joints");
  EXPECT_EQ(decode(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 20), 7), "truncated: 20 bytes");
  std::vector<uint8_t> forged = bytes;
  forged[24] = 0x7f;  // num_joints, big-endian, after the fingerprint, utime and seq: 0x7f000007
  EXPECT_EQ(decode(forged, messages::kAnyArm), "num_joints 2130706439 in a message of 133 bytes");
  truth.tip_wrench_ext[3] = std::nan("");
  EXPECT_EQ(decode(encode(truth), 7), "with non-finite tip_wrench_ext");
  truth.tip_wrench_ext[3] = 0.0;
  truth.tau_ext[6] = -INFINITY;
  EXPECT_EQ(decode(encode(truth), 7), "with non-finite tau_ext");
  robot_state_t state{};
  state.num_joints = 0;
  std::vector<uint8_t> state_bytes(static_cast<size_t>(state.getEncodedSize()));
  state.encode(state_bytes.data(), 0, static_cast<int>(state_bytes.size()));
  EXPECT_EQ(decode(state_bytes, messages::kAnyArm), "not a sim_truth_t (wrong fingerprint)");
}

}  // namespace
}  // namespace chasles::testing
