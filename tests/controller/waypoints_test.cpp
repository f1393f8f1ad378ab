// Waypoint trajectories: the C² spline through them (against the smooth paths they sample, and
// where it keeps their shape instead), its limits, and the controller following one — started
// from the moving reference without a jump, slowed to fit when allowed, refused otherwise naming
// the waypoint, joint and quantity of the largest excess and the duration that fits, judged
// against its tolerances.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "controller/controller.hpp"
#include "core/motion/waypoints.hpp"
#include "core/dynamics/dynamics.hpp"
#include "support/allocation_counter.hpp"
#include "support/arm.hpp"
#include "following.hpp"

namespace chasles::controller {
namespace {

using Eigen::VectorXd;
using chasles::testing::panda;

using testing::bent_pose;
using testing::kMs;

// Rest-to-rest time of a trapezoidal velocity profile over d (triangular when too short).
double trapezoid_time(double d, double v, double a) { return d >= v * v / a ? d / v + v / a : 2.0 * std::sqrt(d / a); }

// `count` random waypoints within the limits, each reached in the time a trapezoidal profile at
// the limits takes from the one before (as a planner times them), at rest between none of them.
motion::Waypoints random_waypoints(const motion::MotionLimits& limits, const VectorXd& from, int count, unsigned seed) {
  motion::Waypoints w(7);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double t = 0.0;
  for (int k = 0; k < count; ++k) {
    double segment = 0.0;
    for (int i = 0; i < 7; ++i) {
      // Steps of up to a fifth of the range, so the path wanders the workspace.
      const double before = k == 0 ? from(i) : w.q(i, k - 1), range = limits.upper(i) - limits.lower(i);
      w.q(i, k) = std::clamp(before + range * 0.2 * (2 * unit(rng) - 1), limits.lower(i), limits.upper(i));
      segment = std::max(segment, trapezoid_time(std::abs(w.q(i, k) - before), limits.velocity(i), limits.acceleration(i)));
    }
    t += std::max(segment, 0.05);
    w.time(k) = t;
  }
  w.count = count;
  w.id = seed;
  return w;
}

TEST(WaypointSpline, PassesThroughEveryWaypointAtItsTimeAndIsC2) {
  const RobotModel model = panda();
  const motion::MotionLimits limits(model, motion::LimitConfig{});
  motion::Reference start(7);
  start.q = bent_pose();
  start.qd = VectorXd::LinSpaced(7, -0.2, 0.2);
  start.qdd = VectorXd::LinSpaced(7, 0.5, -0.5);
  const motion::Waypoints w = random_waypoints(limits, start.q, 20, 3);
  motion::WaypointSpline spline(7);
  spline.build(start, w, limits);
  motion::Reference out(7), before(7), after(7);
  spline.sample(0.0, out);
  EXPECT_EQ(out.q, start.q);
  EXPECT_TRUE(out.qd.isApprox(start.qd, 1e-12));
  EXPECT_TRUE(out.qdd.isApprox(start.qdd, 1e-12));
  for (int k = 0; k < w.count; ++k) {
    spline.sample(w.time(k), out);
    EXPECT_LT((out.q - w.q.col(k)).cwiseAbs().maxCoeff(), 1e-12) << "waypoint " << k;
    // Continuous across the knot: one side against the other, 1 ns apart.
    spline.sample(w.time(k) - 1e-9, before);
    spline.sample(w.time(k) + 1e-9, after);
    if (k + 1 < w.count) {
      EXPECT_LT((after.qd - before.qd).cwiseAbs().maxCoeff(), 1e-6) << "waypoint " << k;
      EXPECT_LT((after.qdd - before.qdd).cwiseAbs().maxCoeff(), 1e-4) << "waypoint " << k;
    }
  }
  EXPECT_DOUBLE_EQ(spline.duration(), w.time(w.count - 1));
  spline.sample(spline.duration() + 1.0, out);
  EXPECT_EQ(out.q, w.q.col(w.count - 1));
  EXPECT_EQ(out.qd, VectorXd::Zero(7));

  // Its derivatives are those of its position (central differences).
  const double h = 1e-6;
  for (double t = 0.05; t < spline.duration(); t += 0.37) {
    spline.sample(t, out);
    spline.sample(t - h, before);
    spline.sample(t + h, after);
    EXPECT_LT(((after.q - before.q) / (2 * h) - out.qd).cwiseAbs().maxCoeff(), 1e-5) << t;
    EXPECT_LT(((after.qd - before.qd) / (2 * h) - out.qdd).cwiseAbs().maxCoeff(), 1e-4) << t;
  }
}

// A smooth path as a planner samples one, known in closed form: per joint q0 + Σ b_j (1 − cos jωt),
// j = 1..4, ω = 2π/T, at rest at both ends and, with Σ b_j j² = 0, unaccelerated there too, so
// that it starts from an arm at rest and ends as a trajectory must.
struct SmoothPath {
  VectorXd start;
  Eigen::MatrixXd b;  // n × 4
  double omega = 0.0;

  // Random amplitudes, each joint's scaled so that its velocity peaks at `velocity` of its limit
  // or its acceleration at `acceleration` of its, whichever comes first.
  SmoothPath(const motion::MotionLimits& limits, const VectorXd& from, double T, unsigned seed, double velocity = 0.56,
             double acceleration = 0.7)
      : start(from), b(from.size(), 4), omega(2 * M_PI / T) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (int i = 0; i < b.rows(); ++i) {
      b(i, 0) = unit(rng), b(i, 1) = unit(rng), b(i, 2) = unit(rng);
      b(i, 3) = -(b(i, 0) + 4 * b(i, 1) + 9 * b(i, 2)) / 16;
    }
    const VectorXd v = peak(1, T), a = peak(2, T);
    for (int i = 0; i < b.rows(); ++i) {
      b.row(i) /= std::max(v(i) / (velocity * limits.velocity(i)), a(i) / (acceleration * limits.acceleration(i)));
    }
  }
  // The d-th derivative of joint i at t.
  double at(int i, double t, int d) const {
    double sum = d == 0 ? start(i) : 0.0;
    for (int j = 1; j <= 4; ++j) {
      const double w = j * omega, c = std::cos(w * t), s = std::sin(w * t);
      const double term[4] = {1 - c, w * s, w * w * c, -w * w * w * s};
      sum += b(i, j - 1) * term[d];
    }
    return sum;
  }
  // Each joint's largest |d-th derivative| over [0, T], sampled every 0.1 ms.
  VectorXd peak(int d, double T) const {
    VectorXd p = VectorXd::Zero(b.rows());
    for (int k = 0; k <= static_cast<int>(T / 1e-4); ++k) {
      for (int i = 0; i < b.rows(); ++i) p(i) = std::max(p(i), std::abs(at(i, 1e-4 * k, d)));
    }
    return p;
  }
  // Positions only, every dt up to T, as sent.
  motion::Waypoints waypoints(double dt, double T) const {
    motion::Waypoints w(static_cast<int>(start.size()));
    w.count = static_cast<int>(std::lround(T / dt));
    for (int k = 0; k < w.count; ++k) {
      w.time(k) = dt * (k + 1);
      for (int i = 0; i < w.dof(); ++i) w.q(i, k) = at(i, w.time(k), 0);
    }
    return w;
  }
};

// How far the spline built from rest at the path's start runs from the path: RMS and largest
// over every joint, sampled every millisecond.
void deviation(const SmoothPath& path, const motion::Waypoints& w, const motion::MotionLimits& limits, double& rms, double& worst) {
  const int n = w.dof();
  motion::Reference start(n), out(n);
  start.q = path.start;
  motion::WaypointSpline spline(n);
  spline.build(start, w, limits);
  double sum = 0.0;
  worst = 0.0;
  const int ticks = static_cast<int>(std::lround(1e3 * spline.duration()));
  for (int k = 0; k <= ticks; ++k) {
    spline.sample(1e-3 * k, out);
    for (int i = 0; i < n; ++i) {
      const double e = out.q(i) - path.at(i, 1e-3 * k, 0);
      sum += e * e;
      worst = std::max(worst, std::abs(e));
    }
  }
  rms = std::sqrt(sum / ((ticks + 1.0) * n));
}

// Held out from the spline's design (issue [R], part 4): smooth paths a planner samples every
// 0.1 s for 5 s, positions only, on an arm's own limits. The spline through the samples must run
// within 0.3 mrad RMS of the path they sample, and the controller must take it as sent: unslowed,
// every tick's reference within every limit.
class SmoothPaths : public testing::Following {
 protected:
  SmoothPaths(const char* arm, const RobotModel& model, const VectorXd& start)
      : testing::Following(model, start), arm_(arm) {}
  const char* arm_;

  void expect_followed_as_sent(unsigned seed) {
    SCOPED_TRACE(seed);
    Controller controller(model_, config_);
    ASSERT_TRUE(tick(controller));
    const motion::MotionLimits& limits = controller.limits();
    const SmoothPath path(limits, state_.q, 5.0, seed);
    // The path itself within the arm's range and jerk limit: it can be followed.
    for (int k = 0; k <= 5000; ++k) {
      for (int i = 0; i < model_.dof(); ++i) {
        ASSERT_GT(path.at(i, 1e-3 * k, 0), limits.lower(i));
        ASSERT_LT(path.at(i, 1e-3 * k, 0), limits.upper(i));
      }
    }
    ASSERT_TRUE((path.peak(3, 5.0).array() < limits.jerk.array()).all());
    const motion::Waypoints w = path.waypoints(0.1, 5.0);
    ASSERT_EQ(w.count, 50);
    double rms = 0.0, worst = 0.0;
    deviation(path, w, limits, rms, worst);
    std::printf("[ smooth path ] %s seed %u: velocity %.2f, acceleration %.2f of the limits at most; "
                "spline %.3g mrad RMS, %.3g max\n",
                arm_, seed, (path.peak(1, 5.0).array() / limits.velocity.array()).maxCoeff(),
                (path.peak(2, 5.0).array() / limits.acceleration.array()).maxCoeff(), 1e3 * rms, 1e3 * worst);
    EXPECT_LT(rms, 0.3e-3);
    EXPECT_LT(worst, 1e-3);

    {
      // Taken on the real-time thread: built and checked without allocating.
      const chasles::testing::AllocationCounter counter;
      ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
      EXPECT_EQ(counter.count(), 0);
    }
    const TrajectoryProgress& p = controller.trajectory();
    EXPECT_EQ(p.scale, 1.0);
    EXPECT_EQ(p.duration, 5.0);
    motion::Reference before = controller.reference();
    const int64_t give_up = now_ + 6000 * kMs;
    while (p.outcome == TrajectoryProgress::kActive && now_ < give_up) {
      ASSERT_TRUE(tick(controller));
      expect_within_limits(controller, before);
      ASSERT_FALSE(HasFatalFailure());
      before = controller.reference();
      state_.q = before.q;
    }
    EXPECT_EQ(p.outcome, TrajectoryProgress::kSucceeded) << p.message;
  }
};

// The UR5 on the controller's default rate limits (acceleration v/0.4, jerk a/0.02).
class SmoothPathsUr5 : public SmoothPaths {
 protected:
  SmoothPathsUr5()
      : SmoothPaths("UR5", chasles::testing::ur5(), (VectorXd(6) << 0.3, -1.2, 1.5, -1.9, 0.6, 0.3).finished()) {}
};

// The Panda on libfranka's rate limits, from the middle of its range.
class SmoothPathsPanda : public SmoothPaths {
 protected:
  SmoothPathsPanda() : SmoothPaths("Panda", panda(), (VectorXd(7) << 0, 0, 0, -1.5708, 0, 1.8675, 0).finished()) {
    config_.limits.acceleration = testing::franka_acceleration();
    config_.limits.jerk = testing::franka_jerk();
  }
};

TEST_F(SmoothPathsUr5, SampledEveryTenthOfASecondAreFollowedAsSent) {
  for (unsigned seed = 1; seed <= 5; ++seed) expect_followed_as_sent(seed);
}

TEST_F(SmoothPathsPanda, SampledEveryTenthOfASecondAreFollowedAsSent) {
  for (unsigned seed = 1; seed <= 5; ++seed) expect_followed_as_sent(seed);
}

// The peak of each rate along the spline, found apart from WaypointSpline::excess: every joint's
// velocity, acceleration and jerk (by differences of the acceleration within the segment) at 101
// points of each segment, the largest ratio to its limit, and the first segment where any is over.
struct SampledPeak {
  int waypoint = -1, joint = -1, first_over = -1;
  motion::LimitExcess::Quantity quantity = motion::LimitExcess::kNone;
  double value = 0.0, ratio = 0.0;
};
SampledPeak sampled_peak(const motion::WaypointSpline& spline, const motion::Waypoints& w, const motion::MotionLimits& limits) {
  const int n = w.dof();
  SampledPeak peak;
  motion::Reference at(n), next(n);
  const double dt = 1e-7;
  for (int k = 0; k < w.count; ++k) {
    const double from = k == 0 ? 0.0 : w.time(k - 1), to = w.time(k);
    for (int m = 0; m <= 100; ++m) {
      const double t = std::min(from + (to - from) * m / 100.0, to - 2 * dt);
      spline.sample(t, at);
      spline.sample(t + dt, next);
      for (int i = 0; i < n; ++i) {
        const double values[3] = {std::abs(at.qd(i)), std::abs(at.qdd(i)), std::abs(next.qdd(i) - at.qdd(i)) / dt};
        const double limit[3] = {limits.velocity(i), limits.acceleration(i), limits.jerk(i)};
        for (int q = 0; q < 3; ++q) {
          const double ratio = values[q] / limit[q];
          if (ratio > 1.0 && peak.first_over < 0) peak.first_over = k;
          if (ratio > peak.ratio) {
            const auto quantity = static_cast<motion::LimitExcess::Quantity>(motion::LimitExcess::kVelocity + q);
            peak = {k, i, peak.first_over, quantity, values[q], ratio};
          }
        }
      }
    }
  }
  return peak;
}

// A trajectory too fast for the arm is refused naming the largest excess over its whole length
// (not the first segment over a limit) and the duration it fits in: sent at that duration it is
// taken as it is, sent 1 % faster it is not.
TEST_F(SmoothPathsUr5, ARefusalNamesThePeakAndADurationThatFits) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  const motion::MotionLimits& limits = controller.limits();
  const SmoothPath path(limits, state_.q, 5.0, 7);
  motion::Waypoints w = path.waypoints(0.1, 5.0);
  w.time *= 0.5;  // twice as fast: velocity to 1.1 of its limit, acceleration to 2.8
  motion::Reference rest(6);
  rest.q = state_.q;
  motion::WaypointSpline spline(6);
  spline.build(rest, w, limits);
  const SampledPeak peak = sampled_peak(spline, w, limits);
  ASSERT_GE(peak.first_over, 0);
  ASSERT_NE(peak.first_over, peak.waypoint) << "the case needs a peak after the first excess";

  {
    // Refused, slowed in search of the duration that fits, and said without allocating.
    const chasles::testing::AllocationCounter counter;
    EXPECT_FALSE(controller.set_trajectory(w, now_));
    EXPECT_EQ(counter.count(), 0);
  }
  const std::string why = controller.last_rejection();
  std::printf("[ refusal ] %s\n", why.c_str());
  const std::string named = "trajectory 0: waypoint " + std::to_string(peak.waypoint) + ", joint " +
                            model_.joint(peak.joint).name + ": " + to_string(peak.quantity) + " peaks at ";
  ASSERT_EQ(why.rfind(named, 0), 0u) << why;
  EXPECT_NEAR(std::stod(why.substr(named.size())), peak.value, 1e-3 * peak.value) << why;
  const size_t fits = why.find("; fits in ");
  ASSERT_NE(fits, std::string::npos) << why;
  const double duration = std::stod(why.substr(fits + 10));
  EXPECT_NE(why.find(" s instead of 2.50 s (allow time scaling, or send it slower)"), std::string::npos) << why;

  spline.build(rest, w, limits, duration / 2.5);
  EXPECT_FALSE(spline.excess(limits));
  EXPECT_TRUE(spline.fits(limits));
  spline.build(rest, w, limits, 0.99 * duration / 2.5);
  EXPECT_TRUE(spline.excess(limits));
  EXPECT_FALSE(spline.fits(limits));

  motion::Waypoints slower = w;
  slower.time *= duration / 2.5;
  ASSERT_TRUE(controller.set_trajectory(slower, now_)) << controller.last_rejection();
  EXPECT_EQ(controller.trajectory().scale, 1.0);
  slower.time = w.time * (0.99 * duration / 2.5);
  EXPECT_FALSE(controller.set_trajectory(slower, now_));
}

// Waypoints that are not samples of a smooth curve keep their shape, where the C² spline through
// them would swing far past them: a joint sent to the same position twice stands still between;
// a 10 ms segment meeting a 2 s one; a waypoint on the edge of the range.
TEST(WaypointSpline, PausesUnevenTimesAndTheRangesEdgeKeepTheWaypointsShape) {
  const RobotModel model = panda();
  const motion::MotionLimits limits(model, motion::LimitConfig{});
  motion::Reference start(7), out(7);
  start.q = bent_pose();
  motion::WaypointSpline spline(7);

  motion::Waypoints pause(7);
  pause.count = 4;
  pause.time.head(4) << 1.0, 2.0, 3.0, 4.0;
  for (int k = 0; k < 4; ++k) pause.q.col(k) = bent_pose();
  pause.q(0, 0) += 0.3, pause.q(0, 1) += 0.3, pause.q(0, 2) += 0.1, pause.q(0, 3) += 0.4;
  spline.build(start, pause, limits);
  for (double t = 1.0; t <= 2.0; t += 0.01) {
    spline.sample(t, out);
    EXPECT_EQ(out.q(0), pause.q(0, 0)) << t;
    EXPECT_EQ(out.qd(0), 0.0) << t;
    EXPECT_EQ(out.qdd(0), 0.0) << t;
  }
  for (double t = 0.0; t <= 4.0; t += 0.01) {
    spline.sample(t, out);
    EXPECT_EQ(out.q.tail(6), bent_pose().tail(6)) << "the joints sent nowhere stay " << t;
  }

  // panda_joint2: 10 mrad in 10 ms, then 10 mrad in 1.99 s. The spline would leave the first
  // segment at 1.5 rad/s and coast 0.4 rad past the second waypoint, within the joint's range;
  // the shape-keeping curve comes to it at 15 mrad/s, and its quintic (velocity 3 times the
  // slope) passes it by 0.1 mrad.
  motion::Waypoints uneven(7);
  uneven.count = 2;
  uneven.time.head(2) << 0.01, 2.0;
  uneven.q.col(0) = uneven.q.col(1) = bent_pose();
  uneven.q(1, 0) += 0.01, uneven.q(1, 1) += 0.02;
  spline.build(start, uneven, limits);
  double low = 1e9, high = -1e9;
  for (double t = 0.0; t <= 2.0; t += 1e-4) {
    spline.sample(t, out);
    low = std::min(low, out.q(1)), high = std::max(high, out.q(1));
  }
  EXPECT_EQ(low, bent_pose()(1));
  EXPECT_LT(high, uneven.q(1, 1) + 1.1e-4);

  // panda_joint1 up to its upper limit (less the margin) and back: the spline would turn 17 mrad
  // beyond it, which no slowing down cures.
  motion::Waypoints edge(7);
  edge.count = 2;
  edge.time.head(2) << 1.5, 3.0;
  edge.q.col(0) = edge.q.col(1) = bent_pose();
  edge.q(0, 0) = limits.upper(0), edge.q(0, 1) = 1.0;
  spline.build(start, edge, limits);
  high = -1e9;
  for (double t = 0.0; t <= 3.0; t += 1e-4) {
    spline.sample(t, out);
    high = std::max(high, out.q(0));
  }
  EXPECT_EQ(high, limits.upper(0));
  EXPECT_NE(spline.excess(limits).excess.quantity, motion::LimitExcess::kPosition);
}

// The controller fed its own reference, or the model integrated, as the arm; gains stiff enough
// for sub-mrad tracking.
class Following : public testing::Following {
 protected:
  Following() : testing::Following(40.0) {}
};

// The case: 50 random waypoints timed by trapezoids, which a spline through them cannot
// follow at the limits, so it is refused as sent and taken slowed when allowed; then every tick's
// reference keeps to every limit, its jerk by differences of its acceleration, the arm follows
// it within 1 mrad RMS, and the outcome is SUCCEEDED at the last waypoint.
TEST_F(Following, FiftyTrapezoidTimedWaypointsSlowedToFitAndTracked) {
  Controller controller(model_, config_);
  Data plant(model_);
  ASSERT_TRUE(tick(controller));
  motion::Waypoints w = random_waypoints(controller.limits(), bent_pose(), 50, 11);
  w.goal_tolerance = VectorXd::Constant(7, 1e-3);
  w.goal_time = 0.5;
  EXPECT_FALSE(controller.set_trajectory(w, now_));
  const std::string why = controller.last_rejection();
  EXPECT_NE(why.find("trajectory 11: waypoint "), std::string::npos) << why;
  EXPECT_NE(why.find(" s (allow time scaling, or send it slower)"), std::string::npos) << why;
  EXPECT_EQ(controller.trajectory().outcome, TrajectoryProgress::kRejected);
  EXPECT_EQ(controller.mode(), Mode::kHolding);

  w.time_scaling = true;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  const TrajectoryProgress& p = controller.trajectory();
  EXPECT_EQ(p.outcome, TrajectoryProgress::kActive);
  EXPECT_GT(p.scale, 1.0);
  EXPECT_DOUBLE_EQ(p.duration, p.scale * w.time(49));
  const motion::MotionLimits& limits = controller.limits();
  motion::Reference previous = controller.reference();
  double error_sq = 0.0;
  int64_t samples = 0;
  long allocations = 0;
  while (p.outcome == TrajectoryProgress::kActive && now_ < 200'000 * kMs) {
    {
      const chasles::testing::AllocationCounter counter;
      ASSERT_TRUE(tick(controller));
      allocations += counter.count();
    }
    const motion::Reference& r = controller.reference();
    for (int i = 0; i < 7; ++i) {
      ASSERT_LE(std::abs(r.qd(i)), limits.velocity(i) * (1 + 1e-9)) << now_;
      ASSERT_LE(std::abs(r.qdd(i)), limits.acceleration(i) * (1 + 1e-9)) << now_;
      ASSERT_LE(std::abs(r.qdd(i) - previous.qdd(i)) / 1e-3, limits.jerk(i) * (1 + 1e-9)) << now_ << " joint " << i;
    }
    previous = r;
    error_sq += controller.error().squaredNorm();
    samples += 7;
    integrate(controller, plant);
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(p.outcome, TrajectoryProgress::kSucceeded) << p.message;
  EXPECT_EQ(p.waypoint, 50);
  const double rms = std::sqrt(error_sq / static_cast<double>(samples));
  std::printf("[ trajectory ] 50 waypoints slowed %.3fx to %.2f s, tracking RMS %.3g mrad\n", p.scale, p.duration, 1e3 * rms);
  EXPECT_LT(rms, 1e-3);
  EXPECT_LT((state_.q - w.q.col(49)).cwiseAbs().maxCoeff(), 1e-3);
}

TEST_F(Following, BadTrajectoriesAreRefusedNamingWhatIsWrong) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  const auto refused = [&](const motion::Waypoints& w, const char* words) {
    EXPECT_FALSE(controller.set_trajectory(w, now_)) << words;
    EXPECT_NE(std::string(controller.last_rejection()).find(words), std::string::npos) << controller.last_rejection();
    // The trajectory taken first goes on: the status tells its progress, the refusal is counted.
    EXPECT_EQ(controller.trajectory().outcome, TrajectoryProgress::kActive);
  };
  motion::Waypoints w(7);
  w.count = 2;
  w.time(0) = 1.0, w.time(1) = 2.0;
  w.q.col(0) = bent_pose(), w.q.col(1) = bent_pose();
  w.q(1, 1) += 0.1;
  w.time_scaling = true;
  ASSERT_TRUE(controller.set_trajectory(w, now_));

  // w with one thing changed.
  const auto changed = [&w](auto change) {
    motion::Waypoints bad(w);
    change(bad);
    return bad;
  };
  refused(changed([](motion::Waypoints& b) { b.count = 0; }), "0 waypoints; 1 to 1000 are taken");
  refused(changed([](motion::Waypoints& b) { b.time(1) = 1.0; }), "waypoint 1: time 1 s is not after 1 s");
  refused(changed([](motion::Waypoints& b) { b.time(0) = 0.0; }), "waypoint 0: time 0 s is not after 0 s");
  refused(changed([](motion::Waypoints& b) { b.q(4, 1) = std::nan(""); }), "waypoint 1, joint panda_joint5: a value that is not finite");
  // panda_joint4 ∈ [−3.07, −0.07]
  refused(changed([](motion::Waypoints& b) { b.q(3, 0) = 0.0; }), "waypoint 0, joint panda_joint4: position 0 outside");
  refused(changed([](motion::Waypoints& b) {
            b.has_velocities = true;
            b.qd.setZero();
            b.qd(2, 1) = 0.1;
          }),
          "the last waypoint must be at rest");
  refused(changed([](motion::Waypoints& b) { b.path_tolerance(0) = -1.0; }), "tolerances must be finite and non-negative");
  const motion::Waypoints hasty = changed([](motion::Waypoints& b) {
    b.time_scaling = false;
    b.time(0) = 0.01;  // 0.1 rad of panda_joint2 in 10 ms
    b.q(1, 0) += 0.1;
  });
  refused(hasty, "waypoint 0, joint panda_joint2: ");
  refused(hasty, "(allow time scaling, or send it slower)");
  // None of this disturbed the trajectory taken first, which ends as it was sent.
  while (controller.mode() == Mode::kRunning) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  EXPECT_EQ((controller.reference().q - w.q.col(1)).cwiseAbs().maxCoeff(), 0.0);
}

// A trajectory taken mid-motion starts from the moving reference: no jump in the reference's
// position, velocity or acceleration. A joint off the path ABORTS it, naming the joint; a new
// target PREEMPTS one.
TEST_F(Following, StartsWithoutAJumpAndEndsAsItsTolerancesSay) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  Target target(7);
  target.mode = Target::kJoint;
  target.num_joints = 7;
  target.q = bent_pose();
  target.q(0) += 0.5;
  target.duration = 2.0;
  ASSERT_TRUE(controller.set_target(target, now_));
  for (int k = 0; k < 700; ++k) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  const motion::Reference moving = controller.reference();
  ASSERT_GT(std::abs(moving.qd(0)), 0.1);
  motion::Waypoints w(7);
  w.count = 2;
  w.time(0) = 1.0, w.time(1) = 2.0;
  w.q.col(0) = bent_pose(), w.q.col(1) = bent_pose();
  w.q(0, 1) -= 0.2;
  w.time_scaling = true;
  w.path_tolerance = VectorXd::Constant(7, 0.01);
  w.id = 5;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  ASSERT_TRUE(tick(controller));
  const motion::Reference& r = controller.reference();
  // One tick on: the reference moved on as its velocity and acceleration said.
  EXPECT_LT(std::abs(r.q(0) - (moving.q(0) + 1e-3 * moving.qd(0) + 0.5e-6 * moving.qdd(0))), 1e-6);
  EXPECT_LT(std::abs(r.qd(0) - (moving.qd(0) + 1e-3 * moving.qdd(0))), 1e-2);
  state_.q = r.q;
  for (int k = 0; k < 100; ++k) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  state_.q(6) += 0.02;  // pushed off the path
  ASSERT_TRUE(tick(controller));
  const TrajectoryProgress& p = controller.trajectory();
  EXPECT_EQ(p.outcome, TrajectoryProgress::kAborted);
  EXPECT_EQ(p.id, 5);
  EXPECT_NE(std::string(p.message).find("joint panda_joint7: 0.02"), std::string::npos) << p.message;
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(controller.reference().q, state_.q) << "holds where the arm is";

  w.id = 6;
  w.path_tolerance.setZero();
  w.q.col(0) = state_.q, w.q.col(1) = state_.q;
  w.q(0, 1) += 0.1;
  ASSERT_TRUE(controller.set_trajectory(w, now_));
  ASSERT_TRUE(tick(controller));
  target.q = state_.q;
  ASSERT_TRUE(controller.set_target(target, now_));
  EXPECT_EQ(p.outcome, TrajectoryProgress::kPreempted);
  EXPECT_EQ(p.id, 6);
  EXPECT_STREQ(p.message, "a JOINT target");
}

// A control law preempts a running trajectory: the reference brakes to rest from where it was
// going, within the limits and without a jump, and holds there.
TEST_F(Following, ALawPreemptsATrajectoryAndTheReferenceBrakesToRest) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  motion::Waypoints w(7);
  w.count = 1;
  w.time(0) = 1.0;
  w.q.col(0) = bent_pose();
  w.q(0, 0) += 0.6;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  for (int k = 0; k < 400; ++k) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
  }
  const motion::Reference moving = controller.reference();
  ASSERT_GT(moving.qd(0), 0.5);
  LawSettings settings(7);
  settings.law = Law::kJointImpedance;
  settings.joint_stiffness = VectorXd::Constant(7, 300.0);
  ASSERT_TRUE(controller.set_law(settings, now_)) << controller.mode_rejection();
  EXPECT_EQ(controller.trajectory().outcome, TrajectoryProgress::kPreempted);
  motion::Reference before = moving;
  int ticks = 0;
  while (controller.mode() == Mode::kRunning && ticks < 2000) {
    ASSERT_TRUE(tick(controller));
    expect_within_limits(controller, before);
    ASSERT_FALSE(HasFatalFailure());
    // No jump: each tick moves on from the last by what its velocity and acceleration say.
    const motion::Reference& r = controller.reference();
    ASSERT_LT(std::abs(r.q(0) - before.q(0) - 1e-3 * before.qd(0)), 1e-3 * 1e-3 * 15.0) << ticks;
    before = r;
    state_.q = r.q;
    ++ticks;
  }
  EXPECT_EQ(controller.mode(), Mode::kHolding);
  EXPECT_EQ(controller.reference().qd.norm(), 0.0);
  EXPECT_LT(controller.reference().q(0), bent_pose()(0) + 0.6) << "stopped before the preempted goal";
  EXPECT_LT(ticks, 300);  // from under 1.2 rad/s at 15 rad/s², jerk-limited: about 0.1 s
}

// Past the end the arm must come within the goal tolerance within goal_time, else ABORTED.
TEST_F(Following, AGoalMissedPastGoalTimeAborts) {
  Controller controller(model_, config_);
  ASSERT_TRUE(tick(controller));
  motion::Waypoints w(7);
  w.count = 1;
  w.time(0) = 1.0;
  w.q.col(0) = bent_pose();
  w.q(2, 0) += 0.05;
  w.goal_tolerance = VectorXd::Constant(7, 1e-3);
  w.goal_time = 0.2;
  ASSERT_TRUE(controller.set_trajectory(w, now_)) << controller.last_rejection();
  const TrajectoryProgress& p = controller.trajectory();
  while (p.outcome == TrajectoryProgress::kActive && now_ < 5000 * kMs) {
    ASSERT_TRUE(tick(controller));
    state_.q = controller.reference().q;
    state_.q(2) -= 0.01;  // an arm that stops 10 mrad short
  }
  EXPECT_EQ(p.outcome, TrajectoryProgress::kAborted);
  EXPECT_NE(std::string(p.message).find("joint panda_joint3: 0.01 rad from its goal"), std::string::npos) << p.message;
  EXPECT_NEAR(1e-9 * static_cast<double>(now_) - 1e-3, 1.0 + 0.2, 2e-3);
}

}  // namespace
}  // namespace chasles::controller
