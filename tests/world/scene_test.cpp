// A scene over the bus, in the whole loop: the controller (a Node, its worker building the world)
// and the simulated Panda on one memq:// bus. A scene_t received takes effect — the status names
// the closest pair with the scene's object — a jog toward its wall stops short of the wall's stop
// distance, and a scene refused leaves the one in force.
#include <gtest/gtest.h>

#include <chasles/jog_command_t.hpp>
#include <cstring>

#include "controller/transport/scene_message.hpp"
#include "controller/world.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/kinematics/kinematics.hpp"
#include "support/reference.hpp"
#include "wires.hpp"
#include "world.hpp"

namespace chasles::faults {
namespace {

const Wire kWire{controller::Protocol::kChasles, 1000.0};

controller::DaemonOptions with_geometry(const RobotModel& model) {
  controller::DaemonOptions options = controller_on(kWire);
  const std::string packages = chasles::testing::data_path("packages");
  controller::WorldOptions world;
  world.mode = controller::CollisionMode::kOn;
  world.urdf = chasles::testing::data_path("panda.urdf");
  world.geometry = {{packages}, packages + "/example-robot-data/robots/panda_description/srdf/panda.srdf"};
  std::vector<std::string> notes;
  options.arm = controller::load_arm_geometry(model, world, notes);
  options.clearance = controller::make_world(model, options.arm, {}, options.proximity);
  return options;
}

// A wall across +y at `y` (the arm keeps to y < y_wall), named "side wall".
geometry::Scene wall_at(double y) {
  geometry::Scene scene;
  scene.planes.push_back({"side wall", -Vector3d::UnitY(), -y, {}, {0.01, 0.10}});
  return scene;
}

TEST(SceneOverTheBus, AReceivedSceneTakesEffectAndAJogStopsShortOfItsWall) {
  World world;
  const controller::DaemonOptions options = with_geometry(world.model());
  world.start_plant(bent_pose());
  world.add_controller(options);
  world.run_for(0.5);
  ASSERT_TRUE(world.recorder().status());
  EXPECT_EQ(world.recorder().status()->clearance_pair.find(" and side wall"), std::string::npos);

  // The arm's front along +y where it stands, by a wall through the origin.
  Data data(world.model());
  const std::vector<double>& q = world.recorder().status()->q;
  forward_kinematics(world.model(), data, Eigen::Map<const Eigen::VectorXd>(q.data(), 7));
  const geometry::Proximity probe(options.arm, wall_at(0.0));
  geometry::ProximityData distances(probe);
  geometry::compute_distances(probe, data.T_body, distances);
  double front = -1e9;
  for (const auto& d : distances.distance) front = std::max(front, -d.distance);
  world.recorder().publish("SCENE", controller::encode_scene(wall_at(front + 0.12)));
  ASSERT_TRUE(world.run_until(
      [&] {
        const auto& status = world.recorder().status();
        return status && status->clearance_pair.find(" and side wall") != std::string::npos;
      },
      0.5))
      << "the status never named the wall: " << world.recorder().status()->clearance_pair;

  // A jog toward the wall at 0.1 m/s for 3 s: it stops short.
  jog_command_t jog{};
  jog.kind = jog_command_t::TWIST;
  jog.frame = jog_command_t::BASE;
  jog.num_joints = 7;
  jog.joint_velocity.assign(7, 0.0);
  jog.twist[4] = 0.1;
  double least = 1e9;
  for (int k = 0; k < 100; ++k) {
    jog.utime = world.now() / 1000;
    world.recorder().publish("JOG", jog);
    world.run_for(0.03);
    least = std::min(least, world.recorder().status()->clearance_distance);
  }
  const controller_status_t& status = *world.recorder().status();
  EXPECT_GE(least, 0.01) << "below the wall's stop distance";
  EXPECT_LE(status.clearance_distance, 0.01 + 0.005);
  // The witnesses: the other on the wall, the gap between them the pair's distance.
  const Vector3d on_arm(status.clearance_points[0]), on_wall(status.clearance_points[1]);
  EXPECT_NEAR(on_wall.y(), front + 0.12, 1e-9);
  EXPECT_NEAR((on_wall - on_arm).norm(), status.clearance_distance, 1e-9);
  EXPECT_NEAR(on_wall.y() - on_arm.y(), status.clearance_distance, 1e-9) << "the gap is along the wall's normal";
  EXPECT_NE(status.clearance_slowed_by.find(" and side wall"), std::string::npos) << status.clearance_slowed_by;
  EXPECT_LT(status.clearance_kept, 1.0);
  EXPECT_EQ(status.faults, 0);

  // A scene of a version this controller does not read is refused; the wall stays.
  scene_t bad = controller::encode_scene(wall_at(front + 0.12));
  bad.version = 99;
  world.recorder().publish("SCENE", bad);
  world.run_for(0.2);
  EXPECT_NE(world.recorder().status()->clearance_pair.find(" and side wall"), std::string::npos);
}

TEST(SceneOverTheBus, GoalsWhosePathsMeetTheWallAreRefusedBeforeAnythingMoves) {
  World world;
  const controller::DaemonOptions options = with_geometry(world.model());
  world.start_plant(bent_pose());
  world.add_controller(options);
  world.run_for(0.3);
  const std::vector<double> q0 = world.recorder().status()->q;
  Data data(world.model());
  const Transform T0 = forward_kinematics(world.model(), data, Eigen::Map<const Eigen::VectorXd>(q0.data(), 7));
  const geometry::Proximity probe(options.arm, wall_at(0.0));
  geometry::ProximityData distances(probe);
  geometry::compute_distances(probe, data.T_body, distances);
  double front = -1e9;
  for (const auto& d : distances.distance) front = std::max(front, -d.distance);
  world.recorder().publish("SCENE", controller::encode_scene(wall_at(front + 0.10)));
  world.run_for(0.1);

  // CARTESIAN: the tip 20 cm along +y, through the wall; the worker's check refuses it.
  Transform T = T0;
  T.translation().y() += 0.2;
  world.recorder().publish("TARGET", cartesian_target(T, 2.0));
  world.run_for(0.5);
  const std::string message = world.recorder().status()->message;
  EXPECT_NE(message.find("the tip's path: "), std::string::npos) << message;
  EXPECT_NE(message.find(" and side wall would come within its stop distance 0.010 m at t = "), std::string::npos)
      << message;
  // JOINT: the base swung toward +y; refused by the loop at once.
  arm_target_t joint = joint_target(Eigen::Map<const Eigen::VectorXd>(q0.data(), 7) +
                                        (Eigen::VectorXd(7) << 0.6, 0, 0, 0, 0, 0, 0).finished(),
                                    2.0);
  world.recorder().publish("TARGET", joint);
  world.run_for(0.1);
  const std::string refused = world.recorder().status()->message;
  EXPECT_NE(refused.find("the JOINT target's path: "), std::string::npos) << refused;
  EXPECT_EQ(world.recorder().status()->state, controller_status_t::HOLDING);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(world.recorder().status()->q[i], q0[i], 1e-3);
}

}  // namespace
}  // namespace chasles::faults
