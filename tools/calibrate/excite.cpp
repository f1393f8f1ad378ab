// chasles_calibrate excite: an excitation trajectory for dynamic identification
// (core/identification/excitation.hpp), written as the waypoint trajectory `chasles target
// --trajectory` sends, with a report of how well it conditions the base regressor and how much of
// each limit it uses. The limits are the controller's own (controller/limits.hpp, MotionLimits from
// the URDF and the same flags chasles_controller takes), and the waypoints are checked as the
// controller will check them: through its own spline, from the arm at rest at the start.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "core/motion/limits.hpp"
#include "core/motion/waypoints.hpp"
#include "core/identification/excitation.hpp"
#include "core/model/urdf.hpp"
#include "core/number_list.hpp"
#include "tools/error_line.hpp"
#include "commands.hpp"

namespace chasles::calibrate_cli {

namespace {

struct ExciteOptions {
  std::string urdf, tip, out, report, start, acceleration_limit, jerk_limit;
  double position_margin = 0.01;  // the controller's default (--position-margin)
  double duration = 0.0;          // 0: three periods
  double lead_in = 1.0;           // s at rest at the start before the series
  int waypoints = motion::Waypoints::kMaxPoints;
  bool unscaled = false;
  ExcitationOptions excitation;
};

// One value for every joint or one per joint, as chasles_controller's --acceleration-limit takes it.
Eigen::VectorXd per_joint(const std::string& text, int n, const std::string& flag) {
  const std::vector<double> values = parse_number_list(text, flag);
  if (values.size() == 1) return Eigen::VectorXd::Constant(n, values[0]);
  if (static_cast<int>(values.size()) != n) {
    throw InputError(flag + " has " + std::to_string(values.size()) + " entries; give one or " + std::to_string(n));
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), n);
}

std::string text(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", x);
  return buffer;
}

// The duration as a whole number of periods: the series is at rest only at their ends.
int periods_in(double duration, double period) {
  const double count = std::round(duration / period);
  if (duration < period * (1.0 - 1e-9)) {
    throw InputError("--duration " + text(duration) + " s is shorter than one period (--period " + text(period) + " s)");
  }
  if (std::abs(count * period - duration) > 1e-9 * duration) {
    throw InputError("--duration " + text(duration) + " s is not a whole number of " + text(period) +
                     " s periods: the arm is at rest only at their ends");
  }
  return static_cast<int>(count);
}

Eigen::VectorXd start_pose(const ExciteOptions& o, const RobotModel& model, const motion::MotionLimits& limits) {
  const int n = model.dof();
  if (o.start.empty()) {
    // The middle of each range; 0 for a joint without limits.
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) q(i) = std::isfinite(limits.lower(i)) ? 0.5 * (limits.lower(i) + limits.upper(i)) : 0.0;
    return q;
  }
  const std::vector<double> values = parse_number_list(o.start, "--start");
  if (static_cast<int>(values.size()) != n) {
    std::string names;
    for (int i = 0; i < n; ++i) names += (i ? ", " : "") + model.joint(i).name;
    throw InputError("--start has " + std::to_string(values.size()) + " values; the arm has " + std::to_string(n) +
                     " joints (" + names + ")");
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), n);
}

// The start at rest after `lead_in` s, then the series at `count` − 1 waypoints, the last at its
// end: positions, velocities and accelerations, so that the controller's quintic pieces, matching
// all three, follow the series itself. The lead-in is what an arm a little off the start (one that
// sags under a model not yet identified) is brought back over: straight into the series' first
// piece, a few tens of ms long, the controller refused it at waypoint 0 (jerk over its limit).
motion::Waypoints waypoints_of(const FourierTrajectory& series, int count, double lead_in) {
  const int n = series.dof();
  motion::Waypoints w(n);
  w.count = count;
  w.has_velocities = w.has_accelerations = true;
  w.time(0) = lead_in;
  w.q.col(0) = series.start;
  w.qd.col(0).setZero();
  w.qdd.col(0).setZero();
  Eigen::VectorXd qddd(n);
  for (int k = 1; k < count; ++k) {
    const double t = series.duration() * k / (count - 1);
    w.time(k) = lead_in + t;
    sample_fourier(series, t, w.q.col(k), w.qd.col(k), w.qdd.col(k), qddd);
  }
  // At rest there to rounding (1e-13); the controller takes only an exact rest as the end.
  w.time(count - 1) = lead_in + series.duration();
  w.q.col(count - 1) = series.start;
  w.qd.col(count - 1).setZero();
  w.qdd.col(count - 1).setZero();
  return w;
}

// The largest distance, every millisecond, between the controller's spline after the lead-in and
// the series.
double spline_deviation(const motion::WaypointSpline& spline, const FourierTrajectory& series, double lead_in) {
  const int n = series.dof();
  motion::Reference ref(n);
  Eigen::VectorXd q(n), qd(n), qdd(n), qddd(n);
  double worst = 0.0;
  const long steps = std::lround(series.duration() * 1e3);
  for (long k = 0; k <= steps; ++k) {
    const double t = 1e-3 * k;
    spline.sample(lead_in + t, ref);
    sample_fourier(series, t, q, qd, qdd, qddd);
    worst = std::max(worst, (ref.q - q).cwiseAbs().maxCoeff());
  }
  return worst;
}

// An arm not identified yet reads its own model error as external torque, and the excitation is as
// fast and far as the limits allow: under the default collision thresholds (a 15 N tip force) the
// reflex aborts it.
const char* const kCollisionAdvice =
    "until the arm is identified, run the controller with its collision thresholds off while the excitation runs "
    "(its model error reads as external force): chasles_controller ... --collision-torque inf --collision-force inf "
    "--collision-moment inf";

Json trajectory_json(const RobotModel& model, const motion::Waypoints& w) {
  Json points = Json::array();
  for (int k = 0; k < w.count; ++k) {
    points.push_back({{"time_from_start", w.time(k)},
                      {"positions", cli::vector_json(w.q.col(k))},
                      {"velocities", cli::vector_json(w.qd.col(k))},
                      {"accelerations", cli::vector_json(w.qdd.col(k))}});
  }
  Json names = Json::array();
  for (const Joint& joint : model.joints()) names.push_back(joint.name);
  // Time scaling on: an arm that is not quite at rest at the start (one that sags under a model
  // not yet identified) makes the first quintic steeper than planned, which the controller refuses
  // outright without it; slowed by a few per cent, the excitation identifies as well.
  return {{"id", 1}, {"joint_names", names}, {"points", points}, {"time_scaling", true}};
}

Json report_json(const RobotModel& model, const BaseParameters& base, const ExcitationResult& r,
                 const motion::MotionLimits& limits, const ExciteOptions& o, int points, double deviation) {
  const FourierTrajectory& s = r.trajectory;
  Eigen::VectorXd q0 = s.start;  // the constant of Swevers's form
  for (int l = 0; l < s.harmonics(); ++l) q0 += s.b.col(l) / (s.omega() * (l + 1));
  Json joints = Json::array();
  for (int i = 0; i < model.dof(); ++i) {
    joints.push_back({{"name", model.joint(i).name},
                      {"lowest", r.peaks.lowest(i)},
                      {"highest", r.peaks.highest(i)},
                      {"lower_limit", cli::number(limits.lower(i))},
                      {"upper_limit", cli::number(limits.upper(i))},
                      {"velocity_fraction", r.peaks.velocity(i) / limits.velocity(i)},
                      {"acceleration_fraction", r.peaks.acceleration(i) / limits.acceleration(i)},
                      {"jerk_fraction", r.peaks.jerk(i) / limits.jerk(i)}});
  }
  return {{"robot", model.name()},
          {"tip_link", model.tip_link()},
          {"base_parameters", base.count},
          {"condition_number", r.condition_number},
          {"columns_normalized", !o.unscaled},
          {"condition_number_normalized", r.scaled_condition_number},
          {"condition_number_raw", r.raw_condition_number},
          {"start_condition_number", r.start_condition_number},
          {"samples_per_period", o.excitation.samples},
          {"harmonics", s.harmonics()},
          {"period", s.period},
          {"periods", s.periods},
          {"duration", s.duration()},
          {"lead_in", o.lead_in},
          {"seed", o.excitation.seed},
          {"iterations", r.iterations},
          {"seconds", r.seconds},
          {"start", cli::vector_json(s.start)},
          {"q0", cli::vector_json(q0)},
          {"a", cli::rows_json(s.a)},
          {"b", cli::rows_json(s.b)},
          {"waypoints", points},
          {"spline_deviation", deviation},
          {"joints", joints}};
}

std::string percent(double fraction) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << 100.0 * fraction << " %";
  return text.str();
}

void run_excite(ExciteOptions o) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = o.tip;
  const RobotModel model = load_urdf_string(read_text_file(o.urdf, "URDF"), urdf_options, o.urdf);
  tools::warn("chasles_calibrate", o.urdf, model.warnings());
  const int n = model.dof();

  motion::LimitConfig config;
  config.position_margin = o.position_margin;
  if (!o.acceleration_limit.empty()) config.acceleration = per_joint(o.acceleration_limit, n, "--acceleration-limit");
  if (!o.jerk_limit.empty()) config.jerk = per_joint(o.jerk_limit, n, "--jerk-limit");
  const motion::MotionLimits limits(model, config);
  ExcitationLimits excitation_limits;
  excitation_limits.lower = limits.lower;
  excitation_limits.upper = limits.upper;
  excitation_limits.velocity = limits.velocity;
  excitation_limits.acceleration = limits.acceleration;
  excitation_limits.jerk = limits.jerk;

  o.excitation.periods = o.duration > 0.0 ? periods_in(o.duration, o.excitation.period) : 3;
  o.excitation.normalize_columns = !o.unscaled;
  const Eigen::VectorXd start = start_pose(o, model, limits);
  const BaseParameters base = base_parameters(model, 50, 1);
  const ExcitationResult result = optimize_excitation(model, base, excitation_limits, start, o.excitation);

  const motion::Waypoints waypoints = waypoints_of(result.trajectory, o.waypoints, o.lead_in);
  motion::Reference at_rest(n);
  at_rest.hold(start);
  motion::WaypointSpline spline(n);
  spline.build(at_rest, waypoints, limits);
  if (const motion::WaypointExcess e = spline.excess(limits)) {
    throw InputError("the controller's spline through " + std::to_string(o.waypoints) + " waypoints leaves the " +
                     motion::to_string(e.excess.quantity) + " limit of joint " + model.joint(e.excess.joint).name +
                     " before waypoint " + std::to_string(e.waypoint) + " (" + text(e.excess.value) + " against " +
                     text(e.excess.limit) + "): give more --waypoints or a shorter --duration");
  }
  const double deviation = spline_deviation(spline, result.trajectory, o.lead_in);

  std::vector<std::pair<std::string, std::string>> files{
      {o.out, cli::dump(trajectory_json(model, waypoints), false) + "\n"}};
  const Json report = report_json(model, base, result, limits, o, o.waypoints, deviation);
  if (!o.report.empty()) files.emplace_back(o.report, cli::dump(report, true) + "\n");
  write_files_atomically(files);

  std::cout << "chasles_calibrate excite: " << model.name() << " (" << model.base_link() << " -> " << model.tip_link()
            << "), " << base.count << " base parameters\n"
            << "cond(W_b) " << result.condition_number << (o.unscaled ? " (columns as they are" : " (unit-norm columns")
            << "; seeded start " << result.start_condition_number << "), raw " << result.raw_condition_number
            << ", normalized " << result.scaled_condition_number << "; " << result.iterations << " iterations, "
            << std::setprecision(3) << result.seconds << " s\n"
            << std::setprecision(6) << o.excitation.harmonics << " harmonics, period " << o.excitation.period << " s, "
            << result.trajectory.periods << " periods (" << result.trajectory.duration() << " s), " << o.waypoints
            << " waypoints; the controller's spline stays within " << deviation << " rad of the series\n"
            << "peak of limit     velocity  acceleration  jerk     position range\n";
  for (int i = 0; i < n; ++i) {
    std::cout << std::left << std::setw(16) << model.joint(i).name << std::right << std::setw(10)
              << percent(result.peaks.velocity(i) / limits.velocity(i)) << std::setw(12)
              << percent(result.peaks.acceleration(i) / limits.acceleration(i)) << std::setw(10)
              << percent(result.peaks.jerk(i) / limits.jerk(i)) << "     [" << std::setprecision(4)
              << result.peaks.lowest(i) << ", " << result.peaks.highest(i) << "]\n"
              << std::setprecision(6);
  }
  std::cout << "wrote " << o.out;
  if (!o.report.empty()) std::cout << ", " << o.report;
  std::string pose;  // to 1e-10 rad: the controller's spline starts from where the arm is anyway
  char value[32];
  for (int i = 0; i < n; ++i) {
    std::snprintf(value, sizeof(value), "%.10g", start(i));
    pose += (i ? "," : "") + std::string(value);
  }
  std::cout << "\nthe arm must be at rest at the start first: chasles target --joint " << pose << "\n"
            << kCollisionAdvice << "\n";
}

}  // namespace

Command register_excite(CLI::App& app) {
  auto options = std::make_shared<ExciteOptions>();
  ExciteOptions& o = *options;
  CLI::App* excite = app.add_subcommand(
      "excite", "Write an excitation trajectory for dynamic identification, as chasles target --trajectory sends it");
  excite->add_option("--urdf", o.urdf, "Robot description (URDF file)")->required()->type_name("FILE");
  excite->add_option("--tip", o.tip, "The chain's last link; needed with several leaves")->type_name("LINK");
  excite->add_option("--out", o.out, "Waypoint trajectory to write (JSON)")->required()->type_name("FILE");
  excite->add_option("--report", o.report, "JSON report to write: condition numbers, coefficients, peaks")
      ->type_name("FILE");
  excite->add_option("--duration", o.duration, "Length of the run, a whole number of periods, s (default: 3 periods)")
      ->check(CLI::PositiveNumber);
  excite->add_option("--lead-in", o.lead_in,
                     "Time the first waypoint holds the start, s: the arm is brought back there if it is a little "
                     "off (its series then starts at this time)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  excite->add_option("--period", o.excitation.period, "Period of the Fourier series, s (base frequency 1/period)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  excite->add_option("--harmonics", o.excitation.harmonics, "Harmonics per joint, L")
      ->check(CLI::Range(2, 50))
      ->capture_default_str();
  excite->add_option("--seed", o.excitation.seed, "Seed of the random start of the optimisation")->capture_default_str();
  excite->add_option("--start", o.start,
                     "The pose the arm is at rest in when the trajectory starts and ends, q1,...,qn (rad, m; "
                     "default: the middle of each joint's range)")
      ->type_name("Q");
  excite->add_option("--samples", o.excitation.samples, "States per period stacked into W_b")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  excite->add_option("--iterations", o.excitation.iterations, "L-BFGS iterations at most")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  excite->add_option("--waypoints", o.waypoints, "Waypoints written (the message takes at most 1000)")
      ->check(CLI::Range(2, motion::Waypoints::kMaxPoints))
      ->capture_default_str();
  excite->add_flag("--unscaled", o.unscaled,
                   "Minimise the condition number of W_b as it is, not of W_b with unit-norm columns");
  excite->add_option("--acceleration-limit", o.acceleration_limit,
                     "Joint acceleration limits, rad/s², one or one per joint, as chasles_controller takes them "
                     "(default: the URDF velocity limit / 0.4 s)")
      ->type_name("A");
  excite->add_option("--jerk-limit", o.jerk_limit,
                     "Joint jerk limits, rad/s³, one or one per joint (default: the acceleration limit / 0.02 s)")
      ->type_name("J");
  excite->add_option("--position-margin", o.position_margin,
                     "The controller's margin inside the URDF's position limits, rad")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  excite->footer(
      "Each joint follows q(t) = q0 + sum_l [a_l/(w l) sin(w l t) - b_l/(w l) cos(w l t)], w = 2 pi / period, at "
      "rest at the start and at the end of every period, its coefficients chosen to minimise the condition "
      "number of the base regressor W_b stacked along a period, within the controller's position, velocity, "
      "acceleration and jerk limits (checked every 1 ms, and through the controller's own spline).\n"
      "The file holds at most 1000 waypoints with positions, velocities and accelerations, the first the start at "
      "rest after --lead-in s: the arm must first be brought to rest at the start (chasles target --joint START), "
      "and a little off it is brought back. It asks for time "
      "scaling, so that the controller slows rather than refuses it when the arm is not quite at the start.\n" +
      std::string(kCollisionAdvice) + ".\n"
      "Files are written atomically (temporary file, fsync, rename); on any error nothing is written.\n"
      "Example:\n"
      "  chasles_calibrate excite --urdf panda.urdf --tip panda_hand --out excitation.json --report excitation_report.json\n"
      "  chasles target --robot panda.urdf --tip panda_hand --joint 0,0,0,-1.5708,0,1.8675,0 --duration 5\n"
      "  chasles target --robot panda.urdf --tip panda_hand --trajectory excitation.json");
  return {excite, [options]() { run_excite(*options); }};
}

}  // namespace chasles::calibrate_cli
