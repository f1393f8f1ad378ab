// Waypoint trajectories over the bus, in simulated time: a planner's joint_trajectory_t sent on
// PREFIX TRAJECTORY to the controller driving the simulated Panda (world.hpp). What is judged is
// what an outside sender sees: the status's trajectory fields, and the arm's own states.
#include <gtest/gtest.h>

#include <algorithm>
#include <chasles/jog_command_t.hpp>
#include <chasles/joint_setpoint_t.hpp>
#include <chasles/joint_trajectory_t.hpp>
#include <chasles/tip_setpoint_t.hpp>
#include <cmath>
#include <random>
#include <string>

#include "core/motion/limits.hpp"
#include "core/kinematics/kinematics.hpp"
#include "world.hpp"

namespace chasles::faults {
namespace {

using Eigen::VectorXd;
using controller::DaemonOptions;
constexpr int64_t kMs = World::kMs;

VectorXd franka_acceleration() { return (VectorXd(7) << 15, 7.5, 10, 12.5, 15, 20, 20).finished(); }
VectorXd franka_jerk() { return (VectorXd(7) << 7500, 3750, 5000, 6250, 7500, 10000, 10000).finished(); }

DaemonOptions options() {
  DaemonOptions o;
  o.control = controller::Config::critically_damped(7, 20.0);
  o.control.damping = VectorXd::Constant(7, 0.5);  // the plant's, fed forward
  o.control.limits.acceleration = franka_acceleration();
  o.control.limits.jerk = franka_jerk();
  o.status_hz = 100.0;
  return o;
}

// `count` random waypoints within the limits, each timed as a trapezoidal profile at the limits
// takes from the one before (as a planner times them).
joint_trajectory_t random_trajectory(const RobotModel& model, const motion::MotionLimits& limits,
                                     const VectorXd& from, int count, unsigned seed) {
  joint_trajectory_t t{};
  t.id = seed;
  t.num_joints = 7;
  t.num_points = count;
  for (const Joint& joint : model.joints()) t.joint_names.push_back(joint.name);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  VectorXd before = from;
  double time = 0.0;
  for (int k = 0; k < count; ++k) {
    std::vector<double> q(7);
    double segment = 0.05;
    for (int i = 0; i < 7; ++i) {
      const double range = limits.upper(i) - limits.lower(i), v = limits.velocity(i), a = limits.acceleration(i);
      q[size_t(i)] = std::clamp(before(i) + 0.2 * range * (2 * unit(rng) - 1), limits.lower(i), limits.upper(i));
      const double d = std::abs(q[size_t(i)] - before(i));
      segment = std::max(segment, d >= v * v / a ? d / v + v / a : 2.0 * std::sqrt(d / a));
      before(i) = q[size_t(i)];
    }
    time += segment;
    t.time_from_start.push_back(time);
    t.positions.push_back(q);
  }
  t.path_tolerance.assign(7, 0.02);
  t.goal_tolerance.assign(7, 1e-3);
  t.goal_time_tolerance = 1.0;
  t.time_scaling = true;
  return t;
}

// The simulated arm's tip pose, from its latest state.
Transform tip_of(World& world, Data& data) {
  const std::vector<double>& q = world.recorder().state()->position;
  return forward_kinematics(world.model(), data, Eigen::Map<const VectorXd>(q.data(), 7));
}

// The case over the bus: 50 random waypoints timed by trapezoids, slowed to fit, followed
// by the simulated arm (which has joint damping, a 1 kHz step and the controller's latency) within
// 1 mrad RMS, every tick's reference within every limit, SUCCEEDED in the status at the end.
TEST(trajectory, FiftyWaypointsOverTheBusAreTrackedWithinAMilliradian) {
  World world;
  world.start_plant(bent_pose());
  world.add_controller(options());
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  const controller::Controller& c = world.controller().controller();
  const motion::MotionLimits& limits = c.limits();
  const joint_trajectory_t t = random_trajectory(world.model(), limits, bent_pose(), 50, 5);
  world.recorder().publish("TRAJECTORY", t);
  double error_sq = 0.0, jerk_ratio = 0.0;
  int64_t samples = 0;
  VectorXd qdd_before = c.reference().qdd;
  int64_t last_tick = -1;
  ASSERT_TRUE(world.run_until(
      [&] {
        if (c.trajectory().outcome == controller::TrajectoryProgress::kActive && c.trajectory().elapsed > 0.0 &&
            world.now() != last_tick) {
          error_sq += c.error().squaredNorm(), samples += 7;
          for (int i = 0; i < 7; ++i) {
            EXPECT_LE(std::abs(c.reference().qd(i)), limits.velocity(i) * (1 + 1e-9));
            EXPECT_LE(std::abs(c.reference().qdd(i)), limits.acceleration(i) * (1 + 1e-9));
            jerk_ratio = std::max(jerk_ratio, std::abs(c.reference().qdd(i) - qdd_before(i)) / 1e-3 / limits.jerk(i));
          }
        }
        qdd_before = c.reference().qdd;
        last_tick = world.now();
        const auto& s = world.recorder().status();
        return s && s->trajectory_id == 5 && s->trajectory_outcome != controller_status_t::TRAJECTORY_ACTIVE;
      },
      300.0));
  const controller_status_t& s = *world.recorder().status();
  EXPECT_EQ(s.trajectory_outcome, controller_status_t::TRAJECTORY_SUCCEEDED) << s.trajectory_message;
  EXPECT_GT(s.trajectory_time_scale, 1.0);
  EXPECT_NEAR(s.trajectory_duration, s.trajectory_time_scale * t.time_from_start.back(), 1e-9);
  EXPECT_EQ(s.trajectory_waypoint, 50);
  EXPECT_EQ(s.faults, 0);
  const double rms = std::sqrt(error_sq / static_cast<double>(samples));
  std::printf("[ trajectory ] 50 waypoints over the bus, slowed %.3fx to %.1f s: tracking RMS %.3f mrad, "
              "reference jerk at most %.2f of its limit\n",
              s.trajectory_time_scale, s.trajectory_duration, 1e3 * rms, jerk_ratio);
  EXPECT_LT(rms, 1e-3);
  EXPECT_LE(jerk_ratio, 1.0 + 1e-6);
  const VectorXd q = vector_of(world.recorder().state()->position);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(q(i), t.positions.back()[size_t(i)], 1e-3) << i;
}

// What the wire refuses (a joint the arm does not have) is counted with its reason; what the
// controller refuses (too fast, no time scaling) is REJECTED in the status, naming the waypoint,
// the joint and the quantity; the joints may come in any order.
TEST(trajectory, RefusalsAreSaidAndTheJointsMayComeInAnyOrder) {
  World world;
  world.start_plant(bent_pose());
  world.add_controller(options());
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  joint_trajectory_t t{};
  t.id = 9;
  t.num_joints = 7;
  t.num_points = 1;
  for (const Joint& joint : world.model().joints()) t.joint_names.push_back(joint.name);
  std::reverse(t.joint_names.begin(), t.joint_names.end());  // panda_joint7 first
  const VectorXd start = bent_pose();
  std::vector<double> goal(start.data(), start.data() + 7);
  std::reverse(goal.begin(), goal.end());
  goal[0] += 0.3;  // panda_joint7
  t.time_from_start = {0.05};
  t.positions = {goal};
  t.path_tolerance.assign(7, 0.0);
  t.goal_tolerance.assign(7, 0.0);
  world.recorder().publish("TRAJECTORY", t);
  ASSERT_TRUE(world.run_until(
      [&] { return world.recorder().status() && world.recorder().status()->trajectory_id == 9; }, 1.0));
  const controller_status_t& s = *world.recorder().status();
  EXPECT_EQ(s.trajectory_outcome, controller_status_t::TRAJECTORY_REJECTED);
  EXPECT_NE(s.trajectory_message.find("waypoint 0, joint panda_joint7: "), std::string::npos) << s.trajectory_message;
  EXPECT_NE(s.trajectory_message.find("(allow time scaling, or send it slower)"), std::string::npos)
      << s.trajectory_message;

  t.id = 10;
  t.time_scaling = true;
  world.recorder().publish("TRAJECTORY", t);
  ASSERT_TRUE(world.run_until(
      [&] {
        const auto& status = world.recorder().status();
        return status->trajectory_id == 10 && status->trajectory_outcome == controller_status_t::TRAJECTORY_SUCCEEDED;
      },
      5.0));
  EXPECT_NEAR(world.recorder().state()->position[6], goal[0], 2e-3);

  const int64_t rejected = world.recorder().status()->rejected_messages;
  t.id = 11;
  t.joint_names[2] = "elbow";
  world.recorder().publish("TRAJECTORY", t);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status()->rejected_messages == rejected + 1; }, 1.0));
  EXPECT_EQ(world.recorder().status()->trajectory_id, 10) << "the wire's refusal never reached the controller";
}

// A 30 Hz stream over the bus, as a teleoperation device or a policy sends it, one setpoint in
// ten sent twice and one in ten lost: the simulated arm follows, the status counts what was taken
// and dropped, and when the stream stops the arm comes to rest and holds.
TEST(stream, ThirtyHertzOverTheBusIsFollowedAndComesToRestWhenItStops) {
  World world;
  world.start_plant(bent_pose());
  // The default jerk limits (a/0.02 s): libfranka's (a/0.002 s) ask the torque to change faster
  // than the torque-rate limit lets it at the start of a stream, and the arm falls behind.
  DaemonOptions o = options();
  o.control.limits = motion::LimitConfig{};
  world.add_controller(o);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  const controller::Controller& c = world.controller().controller();
  joint_setpoint_t setpoint{};
  setpoint.num_joints = 7;
  setpoint.position.resize(7);
  setpoint.velocity.resize(7);
  int sent = 0, duplicated = 0;
  double error_sq = 0.0;
  int64_t samples = 0;
  const int64_t start = world.now();
  for (int k = 0; k < 90; ++k) {  // 3 s
    const double t = k / 30.0;
    for (int i = 0; i < 7; ++i) {
      setpoint.position[size_t(i)] = bent_pose()(i) + 0.2 * std::sin(2.0 * t + i) - 0.2 * std::sin(double(i));
      setpoint.velocity[size_t(i)] = 0.4 * std::cos(2.0 * t + i);
    }
    setpoint.utime = 1'790'000'000'000'000 + static_cast<int64_t>(t * 1e6);
    if (k % 10 != 7) {
      world.recorder().publish("SETPOINT", setpoint), ++sent;
      if (k % 10 == 3) world.recorder().publish("SETPOINT", setpoint), ++duplicated;
    }
    const int64_t next = start + static_cast<int64_t>((k + 1) / 30.0 * 1e9);
    world.run_until(
        [&] {
          if (k >= 30) error_sq += c.error().squaredNorm(), samples += 7;
          return world.now() >= next;
        },
        1.0);
  }
  const controller_status_t during = *world.recorder().status();
  EXPECT_TRUE(during.streaming);
  EXPECT_EQ(during.state, controller_status_t::RUNNING);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  const controller_status_t& after = *world.recorder().status();
  EXPECT_FALSE(after.streaming);
  EXPECT_EQ(after.setpoints, sent);
  EXPECT_EQ(after.setpoints_dropped, duplicated);
  EXPECT_EQ(after.faults, 0);
  EXPECT_EQ(after.reflexes, 0);
  const double rms = std::sqrt(error_sq / static_cast<double>(samples));
  std::printf("[ stream ] 30 Hz over the bus: %d sent, %d duplicated; the arm within %.3f mrad RMS of the reference\n",
              sent, duplicated, 1e3 * rms);
  EXPECT_LT(rms, 1e-3);
  for (double v : world.recorder().state()->velocity) EXPECT_LT(std::abs(v), 1e-2);
}

// A space mouse's jog over the bus: the tip sent down at 5 cm/s in the base frame, 30 commands a
// second (some twice), for one second, then a zero command. The simulated arm's tip goes down
// 5 cm with its orientation kept, the status counts the commands and the duplicates, and the arm
// comes to rest and holds.
TEST(jog, ATwistOverTheBusMovesTheSimulatedTipAndStopsWhenTold) {
  World world;
  world.start_plant(bent_pose());
  world.add_controller(options());
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  Data data(world.model());
  const auto measured_tip = [&] { return tip_of(world, data); };
  const Transform before = measured_tip();
  jog_command_t jog{};
  jog.kind = jog_command_t::TWIST;
  jog.frame = jog_command_t::BASE;
  jog.num_joints = 0;
  jog.twist[5] = -0.05;  // m/s, down
  const int64_t start = world.now();
  int sent = 0, duplicated = 0;
  for (int k = 0; k < 30; ++k) {
    jog.utime = 1'790'000'000'000'000 + static_cast<int64_t>(k / 30.0 * 1e6);
    world.recorder().publish("JOG", jog), ++sent;
    if (k % 10 == 4) world.recorder().publish("JOG", jog), ++duplicated;
    const int64_t next = start + static_cast<int64_t>((k + 1) / 30.0 * 1e9);
    world.run_until([&] { return world.now() >= next; }, 1.0);
  }
  const controller_status_t during = *world.recorder().status();
  EXPECT_TRUE(during.jogging);
  EXPECT_EQ(during.state, controller_status_t::RUNNING);
  EXPECT_EQ(during.jog_scale, 1.0);
  EXPECT_EQ(during.jog_limited_by, controller_status_t::JOG_NONE);
  EXPECT_GT(during.jog_condition, 1.0);
  jog.twist[5] = 0.0;
  jog.utime += 1;
  world.recorder().publish("JOG", jog), ++sent;
  // Told to stop, it stops within the brake (0.05 m/s at the Panda's limits: a few tens of ms),
  // long before the 100 ms timeout would; then the timeout ends the jog and the arm holds.
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  const controller_status_t& after = *world.recorder().status();
  EXPECT_FALSE(after.jogging);
  EXPECT_EQ(after.jogs, sent);
  EXPECT_EQ(after.jogs_dropped, duplicated);
  EXPECT_EQ(after.faults, 0);
  EXPECT_EQ(after.reflexes, 0);
  const Transform tip = measured_tip();
  const Vector3d moved = tip.translation() - before.translation();
  std::printf("[ jog ] 1 s down at 5 cm/s over the bus: the tip moved (%.2f, %.2f, %.2f) mm, turned %.3f mrad\n",
              1e3 * moved.x(), 1e3 * moved.y(), 1e3 * moved.z(),
              1e3 * Eigen::AngleAxisd(before.linear().transpose() * tip.linear()).angle());
  // 1 s at 5 cm/s, give or take the ramps at both ends (a few ms at the limits) and tracking.
  EXPECT_NEAR(moved.z(), -0.05, 2e-3);
  EXPECT_LT(moved.head<2>().norm(), 1e-3);
  EXPECT_LT(Eigen::AngleAxisd(before.linear().transpose() * tip.linear()).angle(), 2e-3);
  const int64_t settled = world.now() + 200 * kMs;  // the arm settles onto the held reference
  world.run_until([&] { return world.now() >= settled; }, 1.0);
  for (double v : world.recorder().state()->velocity) EXPECT_LT(std::abs(v), 1e-2);
}

// A Cartesian stream over the bus: the tip's pose sampled along a 6 cm line at 6 cm/s, 30
// setpoints a second, the orientation held. The simulated tip ends on the line's end, the status
// counts the setpoints, and when they stop the arm comes to rest and holds.
TEST(stream, ACartesianStreamOverTheBusLeadsTheSimulatedTip) {
  World world;
  world.start_plant(bent_pose());
  world.add_controller(options());
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  Data data(world.model());
  const auto measured_tip = [&] { return tip_of(world, data); };
  const Transform before = measured_tip();
  const Eigen::Quaterniond orientation(before.linear());
  tip_setpoint_t setpoint{};
  setpoint.quaternion[0] = orientation.w(), setpoint.quaternion[1] = orientation.x();
  setpoint.quaternion[2] = orientation.y(), setpoint.quaternion[3] = orientation.z();
  const Vector3d velocity(0.0, 0.06, 0.0);  // m/s
  for (int k = 0; k < 3; ++k) setpoint.twist[3 + k] = velocity(k);
  const int64_t start = world.now();
  for (int k = 0; k <= 30; ++k) {
    const double t = k / 30.0;
    if (k == 30) std::fill(setpoint.twist, setpoint.twist + 6, 0.0);  // the end, at rest
    const Vector3d p = before.translation() + velocity * t;
    for (int i = 0; i < 3; ++i) setpoint.position[i] = p(i);
    setpoint.utime = 1'790'000'000'000'000 + static_cast<int64_t>(t * 1e6);
    world.recorder().publish("TIP_SETPOINT", setpoint);
    const int64_t next = start + static_cast<int64_t>((k + 1) / 30.0 * 1e9);
    world.run_until([&] { return world.now() >= next; }, 1.0);
  }
  const controller_status_t during = *world.recorder().status();
  EXPECT_TRUE(during.streaming);
  ASSERT_TRUE(world.run_until([&] { return world.recorder().status_is(controller_status_t::HOLDING); }, 1.0));
  const controller_status_t& after = *world.recorder().status();
  EXPECT_FALSE(after.streaming);
  EXPECT_EQ(after.setpoints, 31);
  EXPECT_EQ(after.faults, 0);
  EXPECT_EQ(after.reflexes, 0);
  const Transform tip = measured_tip();
  const Vector3d off = tip.translation() - (before.translation() + velocity);
  std::printf("[ tip stream ] 6 cm along y over the bus: the tip ended %.2f mm from the line's end, turned %.3f mrad\n",
              1e3 * off.norm(), 1e3 * Eigen::AngleAxisd(before.linear().transpose() * tip.linear()).angle());
  EXPECT_LT(off.norm(), 1e-3);
  EXPECT_LT(Eigen::AngleAxisd(before.linear().transpose() * tip.linear()).angle(), 2e-3);
}

}  // namespace
}  // namespace chasles::faults
