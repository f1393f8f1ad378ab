// What the plant with an environment reports and reads (environment_rig.hpp): the truth on the
// bus, only when asked and with its state's seq; the effort noise, on the reported effort only and
// with a Gaussian's moments, in chasles's statuses and Drake's; a step and its truth that allocate
// nothing; the specs' command-line forms and the truth's decoder, with the messages they refuse
// with. Apart from what the environment does to the arm (environment_test.cpp,
// environment_model_test.cpp): here the plant's boundary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "tools/simulation/environment_forms.hpp"
#include "support/allocation_counter.hpp"
#include "tests/tools/environment_rig.hpp"

namespace chasles::testing {
namespace {

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
  // 8 (fingerprint) + 8 (utime) + 8 (seq) + 4 (num_joints) + 7 × 8 + 6 × 8 + 1 (contact) + 4
  // (num_contacts) = 137 bytes.
  ASSERT_EQ(bytes.size(), 137u);
  EXPECT_EQ(decode(std::vector<uint8_t>(bytes.begin(), bytes.end() - 1), 7), "truncated: 136 bytes");
  EXPECT_EQ(decode(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 20), 7), "truncated: 20 bytes");
  std::vector<uint8_t> forged = bytes;
  forged[24] = 0x7f;  // num_joints, big-endian, after the fingerprint, utime and seq: 0x7f000007
  EXPECT_EQ(decode(forged, messages::kAnyArm), "num_joints 2130706439 in a message of 137 bytes");
  forged = bytes;
  forged[133] = 0x7f;  // num_contacts, the last 4 bytes: 0x7f000000
  EXPECT_EQ(decode(forged, messages::kAnyArm), "num_contacts 2130706432 in a message of 137 bytes");

  // A contact goes through whole: the names, the point, the normal and the force.
  truth.num_contacts = 1;
  truth.contact_link = {"panda_link4"};
  truth.contact_other = {"pusher"};
  truth.contact_point = {{0.1, 0.2, 0.3}};
  truth.contact_normal = {{0.0, 1.0, 0.0}};
  truth.contact_force = {{0.5, 20.0, -0.25}};
  bytes = encode(truth);
  ASSERT_EQ(messages::decode_checked(bytes.data(), bytes.size(), back), "");
  EXPECT_EQ(back.contact_link, truth.contact_link);
  EXPECT_EQ(back.contact_other, truth.contact_other);
  EXPECT_EQ(back.contact_point, truth.contact_point);
  EXPECT_EQ(back.contact_normal, truth.contact_normal);
  EXPECT_EQ(back.contact_force, truth.contact_force);
  EXPECT_EQ(decode(std::vector<uint8_t>(bytes.begin(), bytes.end() - 8), 7), "of " + std::to_string(bytes.size() - 8) +
                                                                             " bytes; expected " + std::to_string(bytes.size()) + " for 7 joints");
  truth.contact_force[0][1] = std::nan("");
  EXPECT_EQ(decode(encode(truth), 7), "with non-finite contact_force");
  truth.contact_force[0][1] = 20.0;
  truth.num_contacts = 0;
  truth.contact_link.clear(), truth.contact_other.clear();
  truth.contact_point.clear(), truth.contact_normal.clear(), truth.contact_force.clear();
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

// More contacts than a message holds: the MAX_CONTACTS largest forces go out, in the engine's
// order, and publishing them allocates nothing of its own.
TEST(environment, TruthPublisherSendsTheLargestContactsWithoutAllocating) {
  Bus bus("memq://");
  std::vector<sim_truth_t> heard;
  const auto subscription = bus.subscribe("TRUTH", [&heard](const uint8_t* data, size_t size) {
    sim_truth_t m;
    if (messages::decode_checked(data, size, m, 7, messages::Finite::Required).empty()) heard.push_back(m);
  });
  plant::TruthPublisher publisher(bus, "TRUTH", 7);
  plant::Truth truth;
  truth.tau_ext = Eigen::VectorXd::Constant(7, 0.25);
  const int total = sim_truth_t::MAX_CONTACTS + 6;
  truth.contacts.reserve(size_t(total));
  // Forces |f| = 1 + (k * 37) % total: a permutation of 1 … total, the six smallest scattered.
  for (int k = 0; k < total; ++k) {
    plant::ArmContact c;
    c.link = "panda_link4", c.other = "pusher";
    c.point = Vector3d(k, 0, 0);
    c.normal = Vector3d::UnitY();
    c.force = Vector3d(0, 1.0 + (k * 37) % total, 0);
    truth.contacts.push_back(c);
  }
  truth.contact = true;
  publisher.publish(1, 0, truth);  // the first send may set up LCM's own buffers
  bus.handle_pending();
  // memq:// copies every message it queues: what the bus allocates for a send of the same bytes
  // is the baseline, and the publisher adds nothing to it.
  const std::vector<uint8_t> same(size_t(heard.back().getEncodedSize()));
  long baseline = 0;
  {
    AllocationCounter counter;
    bus.publish("TRUTH", same);  // zeros: heard, and not a truth
    baseline = counter.count();
  }
  AllocationCounter counter;
  publisher.publish(2, 1, truth);
  EXPECT_EQ(counter.count(), baseline);
  bus.handle_pending();
  ASSERT_EQ(heard.size(), 2u);
  const sim_truth_t& m = heard.back();
  ASSERT_EQ(m.num_contacts, sim_truth_t::MAX_CONTACTS);
  double previous = -1.0;
  for (int k = 0; k < m.num_contacts; ++k) {
    EXPECT_GT(m.contact_force[size_t(k)][1], 6.0);  // none of the six smallest
    EXPECT_GT(m.contact_point[size_t(k)][0], previous);  // in the engine's order
    previous = m.contact_point[size_t(k)][0];
    EXPECT_EQ(m.contact_link[size_t(k)], "panda_link4");
  }
}

}  // namespace
}  // namespace chasles::testing
