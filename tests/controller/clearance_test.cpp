// Clearance in the tick (controller/clearance.hpp): a jog toward a wall and a stream that folds the
// arm into itself stop short of their stop distances, the arm integrated under the commanded
// torque; far from everything the reference is exactly what it is without a scene; a goal into a
// wall ends in a brake with the pair named; a state pushed inside a stop distance starts the reflex;
// free drive feels a repulsion along the distance's gradient, checked by finite differences; the
// tick allocates nothing.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <random>

#include "controller/controller.hpp"
#include "core/geometry/collision_model.hpp"
#include "core/kinematics/kinematics.hpp"
#include "following.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "support/reference.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using testing::kMs;

geometry::CollisionModel panda_geometry(const RobotModel& model) {
  const std::string packages = chasles::testing::data_path("packages");
  return geometry::load_collision_model(
      chasles::testing::data_path("panda.urdf"), model,
      {{packages}, packages + "/example-robot-data/robots/panda_description/srdf/panda.srdf"});
}

// The jogs' direction: sideways, where the bent Panda's hand has room to go (along +x it meets a
// singularity within 10 cm).
const Vector3d kAhead = Vector3d::UnitY();

// A wall across kAhead at kAhead·x = ahead, which the arm keeps behind.
geometry::Scene wall_at(double ahead) {
  geometry::Scene scene;
  scene.planes.push_back({"wall", -kAhead, -ahead, {}, {0.01, 0.10}});
  return scene;
}

Vector6d jog_ahead(double speed) { return (Vector6d() << Vector3d::Zero(), speed * kAhead).finished(); }

// The least distance to its stop distance of any pair at q, computed apart from the controller.
struct Judge {
  Judge(const RobotModel& model, const geometry::Proximity& proximity_)
      : proximity(proximity_), distances(proximity_), data(model), model_(model) {}
  double room(const VectorXd& q, int* pair = nullptr) {
    forward_kinematics(model_, data, q);
    geometry::compute_distances(proximity, data.T_body, distances);
    double least = std::numeric_limits<double>::infinity();
    for (size_t p = 0; p < proximity.pairs().size(); ++p) {
      const double room = distances.distance[p].distance - proximity.pairs()[p].clearance.stop;
      if (room < least) {
        least = room;
        if (pair != nullptr) *pair = static_cast<int>(p);
      }
    }
    return least;
  }
  const geometry::Proximity& proximity;
  geometry::ProximityData distances;
  Data data;
  const RobotModel& model_;
};

class Clearing : public testing::Following {
 protected:
  Clearing() : geometry_(panda_geometry(model_)) {}

  std::unique_ptr<ClearanceWorld> world(const geometry::Scene& scene) {
    return std::make_unique<ClearanceWorld>(model_, geometry::Proximity(geometry_, scene));
  }
  Jog twist_jog(const Vector6d& twist) {
    Jog jog(model_.dof());
    jog.utime = ++utime_;
    jog.kind = Jog::kTwist;
    jog.frame = Jog::kBase;
    jog.twist = twist;
    return jog;
  }
  /// Ticks `seconds` with the jog sent every 30 ms, the arm integrated under the torque; returns the
  /// least room (distance less stop) any state had.
  double jog_for(Controller& controller, const Vector6d& twist, double seconds, Judge& judge) {
    Data data(model_);
    double least = std::numeric_limits<double>::infinity();
    const int64_t end = now_ + static_cast<int64_t>(seconds * 1e9);
    int64_t next_send = now_;
    while (now_ < end) {
      if (now_ >= next_send) {
        EXPECT_TRUE(controller.set_jog(twist_jog(twist), now_ + kMs)) << controller.last_rejection();
        next_send += 30 * kMs;
      }
      EXPECT_TRUE(tick(controller)) << controller.fault_reason();
      integrate(controller, data);
      least = std::min(least, judge.room(state_.q));
      if (getenv("DBG") && (now_ / kMs) % 200 == 0) { int pp=-1; double r = judge.room(state_.q, &pp); char nm[128]; judge.proximity.name_pair(pp, nm, 128); std::printf("t %.2f room %.4f %s jog scale %.3f limited %d joint %d kept %.3f mode %d\n", now_*1e-9, r, nm, controller.jog_progress().scale, (int)controller.jog_progress().limited_by, controller.jog_progress().joint, controller.clearance().kept, (int)controller.mode()); }
    }
    return least;
  }
  /// Starts the controller at the state (HOLDING).
  void start(Controller& controller) {
    state_.effort = gravity_of(model_, state_.q);
    ASSERT_TRUE(tick(controller));
    ASSERT_EQ(controller.mode(), Mode::kHolding) << controller.reflex_reason();
  }
  /// The arm's front along kAhead at the state, by a wall through the origin.
  double front() {
    const geometry::Proximity probe(geometry_, wall_at(0.0));
    geometry::ProximityData distances(probe);
    Data data(model_);
    forward_kinematics(model_, data, state_.q);
    geometry::compute_distances(probe, data.T_body, distances);
    double front = -std::numeric_limits<double>::infinity();
    for (const auto& d : distances.distance) front = std::max(front, -d.distance);
    return front;
  }
  static VectorXd gravity_of(const RobotModel& model, const VectorXd& q) { return chasles::testing::gravity_of(model, q); }

  geometry::CollisionModel geometry_;
  int64_t utime_ = 0;
};

TEST_F(Clearing, AJogTowardAWallStopsShortOfItsStopDistance) {
  const auto w = world(wall_at(front() + 0.15));  // 15 cm ahead of the arm
  Judge judge(model_, w->proximity);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.set_clearance_world(w.get()));
  start(controller);
  const double least = jog_for(controller, jog_ahead(0.1), 4.0, judge);
  EXPECT_GE(least, 0.0) << "a state below its stop distance";
  EXPECT_EQ(controller.mode(), Mode::kRunning);
  EXPECT_EQ(controller.faults(), 0);
  // At rest against the wall, short by the reference's margin.
  int pair = -1;
  const double room = judge.room(state_.q, &pair);
  EXPECT_LE(room, config_.clearance.reference_margin + 1e-3);
  EXPECT_LT(state_.qd.norm(), 1e-3);
  char name[128];
  w->proximity.name_pair(pair, name, sizeof(name));
  EXPECT_STREQ(controller.clearance().slowing_name, name);
  EXPECT_NE(std::strstr(name, " and wall"), nullptr) << name;
  EXPECT_LT(controller.clearance().kept, 1.0);
}

TEST_F(Clearing, FarFromEverythingTheReferenceIsExactlyTheSources) {
  const auto w = world(wall_at(5.0));
  Controller with(model_, config_), without(model_, config_);
  ASSERT_TRUE(with.set_clearance_world(w.get()));
  state_.effort = gravity_of(model_, state_.q);
  const auto tick_both = [&] {
    now_ += kMs;
    ++state_.seq;
    state_.arrival_ns = now_;
    ASSERT_TRUE(with.tick(now_, &state_));
    ASSERT_TRUE(without.tick(now_, &state_));
  };
  tick_both();
  for (int k = 0; k < 1500; ++k) {
    if (k % 30 == 0) {
      const Jog jog = twist_jog((Vector6d() << 0, 0, 0.3, 0.1, 0.05, 0).finished());
      ASSERT_TRUE(with.set_jog(jog, now_));
      ASSERT_TRUE(without.set_jog(jog, now_));
    }
    tick_both();
    ASSERT_EQ(with.reference().q, without.reference().q) << k;
    ASSERT_EQ(with.reference().qd, without.reference().qd) << k;
    ASSERT_EQ(with.torque(), without.torque()) << k;
    state_.q = with.reference().q;
    state_.qd = with.reference().qd;
  }
  EXPECT_EQ(with.clearance().slowing, -1);
  EXPECT_GT(with.clearance().closest_distance, 0.05);  // beyond every influence distance
}

TEST_F(Clearing, AStreamThatFoldsTheArmIntoItselfStopsShort) {
  const auto w = world({});
  Judge judge(model_, w->proximity);
  // A goal in self-collision within the limits, drawn at random, reached in a straight line from a
  // start that is clear.
  std::mt19937 random(3);
  VectorXd goal(7);
  do {
    for (int i = 0; i < 7; ++i) {
      const JointLimits& l = model_.joint(i).limits;
      goal(i) = std::uniform_real_distribution<double>(l.lower + 0.1, l.upper - 0.1)(random);
    }
  } while (judge.room(goal) > -0.02);
  ASSERT_GT(judge.room(state_.q), 0.05);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.set_clearance_world(w.get()));
  start(controller);
  Data data(model_);
  double least = std::numeric_limits<double>::infinity();
  const VectorXd from = state_.q;
  for (int k = 0; k < 6000; ++k) {
    if (k % 10 == 0) {  // 100 Hz setpoints along the line, over 4 s, then held
      Setpoint setpoint(7);
      setpoint.utime = ++utime_;
      setpoint.q = from + std::min(1.0, k / 4000.0) * (goal - from);
      ASSERT_TRUE(controller.set_setpoint(setpoint, now_)) << controller.last_rejection();
    }
    ASSERT_TRUE(tick(controller)) << controller.fault_reason();
    integrate(controller, data);
    least = std::min(least, judge.room(state_.q));
  }
  EXPECT_GE(least, 0.0);
  EXPECT_LE(judge.room(state_.q), config_.clearance.reference_margin + 1e-3);
  EXPECT_EQ(controller.faults(), 0);
  EXPECT_EQ(controller.reflexes(), 0);
  EXPECT_GE(controller.clearance().slowing, 0);
}

TEST_F(Clearing, AGoalWhosePathMeetsAWallIsRefusedBeforeAnythingMoves) {
  const auto w = world(wall_at(front() + 0.08));
  Judge judge(model_, w->proximity);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.set_clearance_world(w.get()));
  start(controller);
  const VectorXd start_q = state_.q;
  VectorXd goal = state_.q;
  goal(0) += 0.6;  // the arm swung about the base toward +y: into the wall
  Target target(7);
  target.mode = Target::kJoint;
  target.num_joints = 7;
  target.q = goal;
  target.duration = 2.0;
  const chasles::testing::AllocationCounter counter;
  EXPECT_FALSE(controller.set_target(target, now_));
  EXPECT_EQ(counter.count(), 0);
  const std::string why = controller.last_rejection();
  EXPECT_EQ(why.rfind("the JOINT target's path: ", 0), 0u) << why;
  EXPECT_NE(why.find(" and wall would come within its stop distance 0.010 m at t = "), std::string::npos) << why;
  EXPECT_NE(why.find(" s of 2.000 s"), std::string::npos) << why;
  // When: the quintic at that time is within a few millimetres of the stop distance, and earlier
  // it is clear.
  const double t = std::stod(why.substr(why.find("at t = ") + 7));
  const auto at = [&](double s) {
    motion::QuinticTrajectory quintic(7);
    motion::Reference from(7), out(7);
    from.q = start_q;
    quintic.start(from, goal, 2.0);
    quintic.sample(s, out);
    return judge.room(out.q);
  };
  EXPECT_GT(at(0.9 * t), 0.0);
  EXPECT_LT(at(t + 0.01), 0.005);
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(tick(controller));
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(controller.reference().q, start_q);
  // The same goal, the wall 40 cm further: it goes.
  const auto far = world(wall_at(front() + 0.48));
  ASSERT_TRUE(controller.set_clearance_world(far.get()));
  EXPECT_TRUE(send(controller, goal, 2.0)) << controller.last_rejection();
}

TEST_F(Clearing, AGoalMetByAWallAfterItStartedWaitsAlongItsPathThenStopsShortNamingThePair) {
  Data data(model_);
  const auto w = world(wall_at(front() + 0.08));
  Judge judge(model_, w->proximity);
  Controller controller(model_, config_);
  start(controller);
  VectorXd goal = state_.q;
  goal(0) += 0.6;  // the arm swung about the base toward +y: into the wall, which is not there yet
  ASSERT_TRUE(send(controller, goal, 2.0)) << controller.last_rejection();
  ASSERT_TRUE(tick(controller));
  ASSERT_TRUE(controller.set_clearance_world(w.get()));  // a scene arrives mid-motion
  double least = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3000; ++k) {
    ASSERT_TRUE(tick(controller)) << controller.fault_reason();
    integrate(controller, data);
    least = std::min(least, judge.room(state_.q));
  }
  EXPECT_GE(least, 0.0);
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(std::strncmp(controller.last_rejection(), "the motion stopped short: ", 26), 0) << controller.last_rejection();
  EXPECT_NE(std::strstr(controller.last_rejection(), " and wall"), nullptr) << controller.last_rejection();
}

TEST_F(Clearing, AGoalPassingNearAWallIsSlowedAlongItsPathAndStillArrives) {
  Data data(model_);
  const auto w = world(wall_at(front() + 0.08));
  Judge judge(model_, w->proximity);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.set_clearance_world(w.get()));
  start(controller);
  // The farthest swing toward the wall whose path the check lets through, in 0.4 s: it comes
  // nearest, and fast enough for the damper to slow it where it ends.
  VectorXd goal = state_.q;
  double swing = 0.6;
  for (; swing > 0.0; swing -= 0.02) {
    goal(0) = state_.q(0) + swing;
    if (send(controller, goal, 0.4)) break;
  }
  ASSERT_GT(swing, 0.0);
  double least = std::numeric_limits<double>::infinity(), kept = 1.0;
  int ticks = 0;
  for (; ticks < 5000 && controller.mode() == Mode::kRunning; ++ticks) {
    ASSERT_TRUE(tick(controller)) << controller.fault_reason();
    integrate(controller, data);
    least = std::min(least, judge.room(state_.q));
    kept = std::min(kept, controller.clearance().kept);
  }
  std::printf("a swing of %.2f rad: %d ticks for a 0.4 s goal, least room %.4f m, least share kept %.3f\n", swing,
              ticks, least, kept);
  EXPECT_GE(least, 0.0);
  EXPECT_LT(kept, 1.0) << "never slowed: the test's wall is too far";
  EXPECT_GT(ticks, 400);  // later than planned: it waited along its path
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_LE((controller.reference().q - goal).cwiseAbs().maxCoeff(), 1e-12);  // and arrived
}

TEST_F(Clearing, AStatePushedInsideAStopDistanceStartsTheReflex) {
  const auto w = world(wall_at(front() + 0.05));
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.set_clearance_world(w.get()));
  start(controller);
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  state_.q(0) += 0.3;  // pushed: swung about the base through the wall
  ASSERT_TRUE(tick(controller));
  EXPECT_EQ(controller.mode(), Mode::kReflex);
  EXPECT_NE(std::strstr(controller.reflex_reason(), " and wall at "), nullptr) << controller.reflex_reason();
  EXPECT_NE(std::strstr(controller.reflex_reason(), "inside its stop distance 0.0100 m"), nullptr);
  EXPECT_EQ(controller.reflexes(), 1);
}

TEST_F(Clearing, FreeDriveFeelsTheGradientOfTheDistanceScaledByItsDepthInTheInfluence) {
  Data data(model_);
  const auto w = world(wall_at(front() + 0.06));
  Controller with(model_, config_), without(model_, config_);
  ASSERT_TRUE(with.set_clearance_world(w.get()));
  state_.effort = gravity_of(model_, state_.q);
  LawSettings free_drive(7);
  free_drive.law = Law::kFreeDrive;
  for (Controller* c : {&with, &without}) {
    ASSERT_TRUE(c->tick(now_ + kMs, &state_));
    ASSERT_TRUE(c->set_law(free_drive, now_ + kMs)) << c->mode_rejection();
  }
  now_ += kMs;
  for (int k = 0; k < 100; ++k) {  // past the switch's fade
    now_ += kMs;
    state_.arrival_ns = now_;
    ASSERT_TRUE(with.tick(now_, &state_));
    ASSERT_TRUE(without.tick(now_, &state_));
  }
  const VectorXd repulsion = with.torque() - without.torque();
  // Every pair within its influence pushes by f ∂d/∂q; ∂d/∂q by central differences.
  geometry::ProximityData plus(w->proximity), minus(w->proximity);
  Data data_plus(model_), data_minus(model_);
  VectorXd expected = VectorXd::Zero(7);
  int within = 0;
  geometry::ProximityData here(w->proximity);
  forward_kinematics(model_, data, state_.q);
  geometry::compute_distances(w->proximity, data.T_body, here);
  for (size_t p = 0; p < w->proximity.pairs().size(); ++p) {
    const geometry::Clearance& c = w->proximity.pairs()[p].clearance;
    if (!here.distance[p].exact || here.distance[p].distance >= c.influence) continue;
    ++within;
    const double share = (c.influence - here.distance[p].distance) / (c.influence - c.stop);
    for (int j = 0; j < 7; ++j) {
      const double h = 1e-6;
      VectorXd q = state_.q;
      q(j) += h;
      forward_kinematics(model_, data_plus, q);
      geometry::compute_distances(w->proximity, data_plus.T_body, plus);
      q(j) -= 2 * h;
      forward_kinematics(model_, data_minus, q);
      geometry::compute_distances(w->proximity, data_minus.T_body, minus);
      expected(j) += config_.clearance.repulsion * share * (plus.distance[p].distance - minus.distance[p].distance) / (2 * h);
    }
  }
  ASSERT_GE(within, 1);
  EXPECT_LE((repulsion - expected).norm(), 1e-5 * expected.norm()) << repulsion.transpose() << "\n" << expected.transpose();
}

TEST_F(Clearing, ATickJoggingAgainstAWallAllocatesNothing) {
  const auto w = world(wall_at(front() + 0.03));
  Judge judge(model_, w->proximity);
  Controller controller(model_, config_);
  ASSERT_TRUE(controller.set_clearance_world(w.get()));
  start(controller);
  jog_for(controller, jog_ahead(0.1), 1.0, judge);
  ASSERT_GE(controller.clearance().slowing, 0);
  const Jog jog = twist_jog(jog_ahead(0.1));
  const chasles::testing::AllocationCounter counter;
  ASSERT_TRUE(controller.set_jog(jog, now_));
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(tick(controller));
  EXPECT_EQ(counter.count(), 0);
}

}  // namespace
}  // namespace chasles::controller
