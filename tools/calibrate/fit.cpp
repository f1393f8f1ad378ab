// chasles_calibrate fit: dataset in, corrected URDF and JSON report out, summary on stdout.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "core/calibration/calibration.hpp"
#include "core/calibration/dataset.hpp"
#include "core/calibration/urdf_writer.hpp"
#include "core/model/urdf.hpp"
#include "tools/error_line.hpp"
#include "commands.hpp"

namespace chasles::calibrate_cli {

namespace {

struct FitOptions {
  std::string urdf, tip, data, out, report;
  double holdout = 0.2;
  std::uint64_t seed = 1;
  std::string loss = "cauchy";
  CalibrationOptions calibration;
  bool position_only = false;
  std::string marker_link = "marker";
};

const char* const kCorrectedUrdfContents =
    "The corrected URDF is the input URDF with (1) the <origin> of every movable joint between the base and the "
    "tip that the fit corrected replaced by O*exp([dxi])*exp([A]*dtheta) - the joint zero offset folded in, so its "
    "FK at the encoder readings q is the calibrated arm's; the original values stay in a comment beside each - and "
    "(2) a fixed joint 'marker_joint' from the tip link to a new empty link (default 'marker') carrying "
    "T_tip_marker. Limits, inertias, meshes and everything else are unchanged. The tracker-to-base transform is "
    "not part of the robot: it is T_tracker_base in the report. To predict a measurement with any URDF library: "
    "T_tracker_marker = T_tracker_base * FK(q; base link -> marker link).";

Json stats_json(const ResidualStats& s, bool pose) {
  Json out;
  out["rows"] = s.rows;
  out["outliers"] = s.outliers;
  out["rms_position_m"] = cli::number(s.rms_position);
  out["max_position_m"] = cli::number(s.max_position);
  out["rms_rotation_rad"] = pose ? cli::number(s.rms_rotation) : Json(nullptr);
  out["max_rotation_rad"] = pose ? cli::number(s.max_rotation) : Json(nullptr);
  return out;
}

const char* reason_name(FixedParameter::Reason reason) {
  switch (reason) {
    case FixedParameter::Reason::NoEffect: return "no effect";
    case FixedParameter::Reason::Redundant: return "redundant";
    case FixedParameter::Reason::PoorlyObservable: return "poorly observable";
  }
  return "unknown";
}

std::vector<int> lines_of(const std::vector<Measurement>& rows, const std::vector<int>& indices) {
  std::vector<int> lines;
  for (int k : indices) lines.push_back(rows[static_cast<size_t>(k)].line);
  return lines;
}

Json report_json(const FitOptions& o, const RobotModel& nominal, const std::vector<Measurement>& fit,
                 const std::vector<Measurement>& holdout, const CalibrationResult& r, int changed_joints) {
  const CalibrationLayout& layout = r.layout;
  Json report = report_header(nominal, o.urdf);
  report["data"] = o.data;
  report["measurements"] = r.pose_data ? "pose" : "position";
  report["model"] =
      "T_tracker_marker = T_tracker_base * FK(q) * T_tip_marker, FK of the corrected URDF from base_link to "
      "tip_link at the encoder readings q (zero offsets are folded into the joint origins); 4x4 matrices are "
      "lists of rows, SI units";
  report["T_tracker_base"] = cli::transform_json(r.after.T_tracker_base);
  report["T_tip_marker"] = cli::transform_json(r.after.T_tip_marker);
  report["corrected_urdf"] = {{"path", o.out},
                              {"changed_joint_origins", changed_joints},
                              {"marker_link", o.marker_link},
                              {"marker_joint", "marker_joint"},
                              {"contents", kCorrectedUrdfContents}};
  Json split;
  split["rows"] = static_cast<int>(fit.size() + holdout.size());
  split["fit_rows"] = static_cast<int>(fit.size());
  split["holdout_rows"] = static_cast<int>(holdout.size());
  split["holdout_fraction"] = o.holdout;
  split["seed"] = o.seed;
  Json lines = Json::array();
  for (const Measurement& m : holdout) lines.push_back(m.line);
  split["holdout_lines"] = lines;
  report["split"] = split;
  report["options"] = {{"sigma_position_m", o.calibration.sigma_position},
                       {"sigma_rotation_rad", o.calibration.sigma_rotation},
                       {"loss", to_string(o.calibration.loss)},
                       {"loss_scale_sigma", o.calibration.loss_scale},
                       {"rank_tolerance", o.calibration.rank_tolerance},
                       {"position_only", o.position_only}};

  const Identifiability& id = r.identifiability;
  Json identifiability;
  identifiability["parameters"] = id.num_parameters;
  identifiability["rank"] = id.rank;
  identifiability["free"] = static_cast<int>(id.free.size());
  identifiability["theoretical"] = id.theoretical;
  identifiability["theory"] =
      "4R + 2P + 6 for pose data (R revolute, P prismatic joints; base and tool included), 3 fewer for position "
      "data: Everett, Driels & Mooring (1987); for product-of-exponentials models Okamura & Park (1996), He, Zhao, "
      "Yang & Yang (2010)";
  identifiability["method"] =
      "SVD of the stacked whitened identification Jacobian with unit-norm columns at the uncalibrated model; "
      "free parameters chosen in the order base, tool, joint offsets, joint origins from the tip down, each "
      "admitted while the chosen columns' smallest singular value stays above rank_tolerance times the largest";
  identifiability["rank_tolerance"] = id.tolerance;
  identifiability["singular_values"] = cli::vector_json(id.singular_values);
  Json fixed = Json::array();
  for (const FixedParameter& f : id.fixed) {
    Json item;
    item["parameter"] = layout.name(nominal, f.index);
    item["reason"] = reason_name(f.reason);
    Json equivalent = Json::array();
    for (const auto& [index, coefficient] : f.equivalent) {
      equivalent.push_back({{"parameter", layout.name(nominal, index)}, {"coefficient", coefficient}});
    }
    item["equivalent"] = equivalent;
    item["explanation"] = f.explanation;
    fixed.push_back(item);
  }
  identifiability["fixed"] = fixed;
  report["identifiability"] = identifiability;

  Json parameters = Json::array();
  for (int j = 0; j < layout.size(); ++j) {
    const bool free = std::binary_search(id.free.begin(), id.free.end(), j);
    parameters.push_back({{"name", layout.name(nominal, j)},
                          {"unit", layout.unit(nominal, j)},
                          {"free", free},
                          {"estimate", r.x[j]},
                          {"stddev", cli::number(r.stddev[j])}});
  }
  report["parameters"] = parameters;
  report["parameters_note"] =
      "estimates are about the uncalibrated model with its best base and tool (T_tracker_base_before, "
      "T_tip_marker_before): joint origins as body twists (w, v) in the joint frame, base and tool as right "
      "perturbations exp([x]); stddev from the Ceres covariance of the free parameters scaled by sigma0^2";
  report["T_tracker_base_before"] = cli::transform_json(r.before.T_tracker_base);
  report["T_tip_marker_before"] = cli::transform_json(r.before.T_tip_marker);

  report["residuals"] = {
      {"fit", {{"before", stats_json(r.fit_before, r.pose_data)}, {"after", stats_json(r.fit_after, r.pose_data)}}},
      {"holdout",
       {{"before", stats_json(r.holdout_before, r.pose_data)}, {"after", stats_json(r.holdout_after, r.pose_data)}}},
      {"note",
       "before: the URDF as given with the best base and tool for it; rows flagged as outliers are left out of "
       "both"}};
  Json outliers;
  outliers["fit_lines"] = lines_of(fit, r.fit_outliers);
  outliers["holdout_lines"] = lines_of(holdout, r.holdout_outliers);
  outliers["rule"] = "whitened residual norm above max(outlier threshold, 5 x median) under the calibrated model";
  report["outliers"] = outliers;
  report["solver"] = {{"converged", r.converged},
                      {"termination", r.termination},
                      {"iterations", r.iterations},
                      {"sigma0", r.sigma0},
                      {"covariance", r.covariance_ok},
                      {"seconds", r.seconds}};
  return report;
}

std::string format(const char* pattern, double a, double b) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, pattern, a, b);
  return buffer;
}

void print_summary(const FitOptions& o, const RobotModel& nominal, const std::vector<Measurement>& fit,
                   const std::vector<Measurement>& holdout, const CalibrationResult& r, int changed_joints) {
  const Identifiability& id = r.identifiability;
  std::cout << "chasles_calibrate fit: " << nominal.name() << " (" << nominal.base_link() << " -> "
            << nominal.tip_link() << "), " << fit.size() + holdout.size() << " rows of "
            << (r.pose_data ? "poses" : "positions") << ": " << fit.size() << " fitted, " << holdout.size()
            << " held out (seed " << o.seed << ")\n";
  std::cout << "identifiable parameters: " << id.free.size() << " of " << id.num_parameters << " (SVD rank "
            << id.rank << "; theory " << (r.pose_data ? "4R+2P+6" : "4R+2P+3") << " = " << id.theoretical << "), "
            << id.fixed.size() << " fixed - see the report for why\n";
  std::cout << "                   position RMS / max (mm)";
  if (r.pose_data) std::cout << "   rotation RMS / max (mrad)";
  std::cout << "\n";
  auto row = [&](const char* name, const ResidualStats& s) {
    if (s.rows == 0) return;
    std::cout << "  " << name << format("%10.4f / %-10.4f", 1e3 * s.rms_position, 1e3 * s.max_position);
    if (r.pose_data) std::cout << format("     %10.4f / %-10.4f", 1e3 * s.rms_rotation, 1e3 * s.max_rotation);
    std::cout << "\n";
  };
  row("fit      before", r.fit_before);
  row("fit      after ", r.fit_after);
  row("held-out before", r.holdout_before);
  row("held-out after ", r.holdout_after);
  const size_t outliers = r.fit_outliers.size() + r.holdout_outliers.size();
  std::cout << "outliers: " << outliers << (outliers > 0 ? " rows (lines in the report), left out of the figures" : "")
            << "\n";
  std::cout << "solver: " << (r.converged ? "converged" : "NOT converged") << ", " << r.iterations
            << " iterations, " << format("%.3f s, sigma0 %.3g", r.seconds, r.sigma0) << "\n";
  std::cout << "wrote " << o.out << " (" << changed_joints << " joint origins corrected, marker link '"
            << o.marker_link << "') and " << o.report << "\n";
}

void run_fit(FitOptions o) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = o.tip;
  const std::string xml = read_text_file(o.urdf, "URDF");
  const RobotModel nominal = load_urdf_string(xml, urdf_options, o.urdf);
  tools::warn("chasles_calibrate", o.urdf, nominal.warnings());
  const Dataset dataset = read_dataset(o.data, nominal);
  o.calibration.loss = o.loss == "huber" ? LossType::Huber : o.loss == "none" ? LossType::None : LossType::Cauchy;
  o.calibration.use_orientation = !o.position_only;

  const std::vector<bool> held = holdout_split(static_cast<int>(dataset.rows.size()), o.holdout, o.seed);
  std::vector<Measurement> fit, holdout;
  for (size_t k = 0; k < dataset.rows.size(); ++k) (held[k] ? holdout : fit).push_back(dataset.rows[k]);
  const CalibrationResult result = calibrate(nominal, fit, holdout, o.calibration);

  int changed_joints = 0;
  for (int i = 0; i < nominal.dof(); ++i) {
    changed_joints += result.after.origin[static_cast<size_t>(i)].isZero(0.0) && result.after.offset[i] == 0.0 ? 0 : 1;
  }
  CorrectedUrdfOptions urdf_out;
  urdf_out.marker_link = o.marker_link;
  urdf_out.note = "Dataset: " + o.data + "; report: " + o.report + ".";
  const std::string urdf_text = corrected_urdf(xml, nominal, result.after, urdf_out);
  const std::string report_text =
      cli::dump(report_json(o, nominal, fit, holdout, result, changed_joints), true) + "\n";
  write_files_atomically({{o.out, urdf_text}, {o.report, report_text}});
  print_summary(o, nominal, fit, holdout, result, changed_joints);
}

}  // namespace

Command register_fit(CLI::App& app) {
  auto options = std::make_shared<FitOptions>();
  FitOptions& o = *options;
  CLI::App* fit = app.add_subcommand("fit", "Fit a corrected URDF to a dataset; write it and a JSON report");
  fit->add_option("--urdf", o.urdf, "Robot description (URDF file)")->required()->type_name("FILE");
  fit->add_option("--tip", o.tip, "Link the marker is mounted on (the chain's end); needed with several leaves")
      ->type_name("LINK");
  fit->add_option("--data", o.data,
                  "Dataset CSV: a header naming each chain joint exactly as the URDF does, then x,y,z (marker "
                  "position in the tracker frame, m) and optionally qw,qx,qy,qz; one row per configuration "
                  "('-': standard input)")
      ->required()
      ->type_name("CSV");
  fit->add_option("--holdout", o.holdout, "Fraction of rows held out to judge the fit, chosen by --seed")
      ->check(CLI::Range(0.0, 0.9))
      ->capture_default_str();
  fit->add_option("--seed", o.seed, "Seed of the held-out split")->capture_default_str();
  fit->add_option("--out", o.out, "Corrected URDF to write")->required()->type_name("FILE");
  fit->add_option("--report", o.report, "JSON report to write")->required()->type_name("FILE");
  fit->add_option("--loss", o.loss, "Robust loss on each row's whitened residual")
      ->check(CLI::IsMember({"cauchy", "huber", "none"}))
      ->capture_default_str();
  fit->add_option("--loss-scale", o.calibration.loss_scale,
                  "Residual norm, in multiples of sigma, beyond which a row is doubted")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  fit->add_option("--sigma-pos", o.calibration.sigma_position, "Tracker position noise per axis (m)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  fit->add_option("--sigma-rot", o.calibration.sigma_rotation, "Tracker orientation noise per axis (rad)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  fit->add_flag("--position-only", o.position_only, "Ignore the quaternion columns: fit positions only");
  fit->add_option("--rank-tol", o.calibration.rank_tolerance,
                  "Relative singular value below which a parameter direction counts as unidentifiable")
      ->check(CLI::Range(1e-15, 0.5))
      ->capture_default_str();
  fit->add_option("--max-iterations", o.calibration.max_iterations, "Levenberg-Marquardt iterations per stage")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  fit->add_option("--marker-link", o.marker_link, "Name of the marker link added to the corrected URDF")
      ->capture_default_str();
  fit->footer(std::string("Estimates per-joint corrections of the joint origins (local PoE: O <- O*exp([dxi])), "
                          "joint zero offsets, the tracker-to-base and tip-to-marker transforms; only the "
                          "identifiable ones (the report lists the others and why). ") +
              kCorrectedUrdfContents +
              "\nFiles are written atomically (temporary file, fsync, rename); on any error nothing is written.\n"
              "Example:\n"
              "  chasles_calibrate fit --urdf ur5.urdf --tip tool0 --data ur5.csv --holdout 0.2 --out ur5_cal.urdf "
              "--report ur5_cal.json");
  return {fit, [options]() { run_fit(*options); }};
}

}  // namespace chasles::calibrate_cli
