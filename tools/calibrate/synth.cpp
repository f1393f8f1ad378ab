// chasles_calibrate synth: a dataset measured on a perturbed copy of the robot (the "truth"), with
// tracker noise and optional gross outliers, and the truth itself as a URDF and a JSON file.
#include <cmath>
#include <cstdint>
#include <iostream>
#include <random>

#include "core/calibration/calibration.hpp"
#include "core/calibration/dataset.hpp"
#include "core/calibration/urdf_writer.hpp"
#include "core/lie/se3.hpp"
#include "core/model/urdf.hpp"
#include "tools/error_line.hpp"
#include "commands.hpp"

namespace chasles::calibrate_cli {

namespace {

struct SynthOptions {
  std::string urdf, tip, errors, out, truth, truth_report;
  std::uint64_t seed = 1;
  double error_position = 2e-3, error_rotation = 2e-3;
  double noise_position = 1e-4, noise_rotation = 1e-3;
  int rows = 200;
  bool position_only = false;
  double outliers = 0.0, outlier_size = 0.1;
  std::string marker_link = "marker";
};

/// Uniform and normal draws that are the same with every standard library (std:: distributions
/// are implementation-defined): 53-bit uniforms from mt19937_64, Box-Muller normals.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double normal() {
    const double u = 1.0 - uniform();  // (0, 1]
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * kPi * uniform());
  }
  Vector3d normal3() { return Vector3d(normal(), normal(), normal()); }

 private:
  std::mt19937_64 engine_;
};

Transform parse_transform(const Json& value, const std::string& where) {
  Matrix4d T;
  if (!value.is_array() || value.size() != 4) throw InputError(where + " must be 4 rows of 4 numbers");
  for (size_t i = 0; i < 4; ++i) {
    T.row(static_cast<Eigen::Index>(i)) =
        cli::parse_vector(value[i], 4, where + "[" + std::to_string(i) + "]", "a 4x4 row").transpose();
  }
  const Matrix3d R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || std::abs(R.determinant() - 1.0) > 1e-6 ||
      (T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-12) {
    throw InputError(where + " is not a rigid transform");
  }
  const Eigen::Quaterniond q(R);
  return Transform(q.normalized().toRotationMatrix(), T.topRightCorner<3, 1>());
}

/// The truth from an explicit spec: {"origins": {joint: [wx,wy,wz,vx,vy,vz]}, "offsets": {joint: x},
/// "T_tracker_base": 4x4, "T_tip_marker": 4x4}; whatever is not given is zero or the identity.
KinematicCorrections parse_errors(const std::string& spec, const RobotModel& model) {
  const bool inline_json = spec.find('{') != std::string::npos;
  const std::string where = inline_json ? "--errors" : spec;
  Json document;
  if (inline_json) {
    try {
      document = Json::parse(spec);
    } catch (const std::exception& e) {
      throw InputError("--errors: not valid JSON: " + std::string(e.what()));
    }
  } else {
    document = cli::read_json_file(spec, "errors spec");
  }
  if (!document.is_object()) throw InputError(where + ": expected an object");
  KinematicCorrections truth = KinematicCorrections::zero(model);
  auto joint_of = [&](const std::string& name, const std::string& key) {
    const int i = model.joint_index(name);
    if (i < 0) throw InputError(where + ": " + key + ": '" + name + "' is not a joint of the chain");
    return i;
  };
  for (const auto& item : document.items()) {
    const std::string& key = item.key();
    if (key == "origins" || key == "offsets") {
      if (!item.value().is_object()) throw InputError(where + ": " + key + " must be an object keyed by joint name");
      for (const auto& entry : item.value().items()) {
        const int i = joint_of(entry.key(), key);
        const std::string at = where + ": " + key + "." + entry.key();
        if (key == "origins") {
          truth.origin[static_cast<size_t>(i)] = cli::parse_vector(entry.value(), 6, at, "a twist wx,wy,wz,vx,vy,vz");
        } else {
          truth.offset[i] = cli::parse_vector(Json::array({entry.value()}), 1, at, "a number")[0];
        }
      }
    } else if (key == "T_tracker_base") {
      truth.T_tracker_base = parse_transform(item.value(), where + ": T_tracker_base");
    } else if (key == "T_tip_marker") {
      truth.T_tip_marker = parse_transform(item.value(), where + ": T_tip_marker");
    } else {
      throw InputError(where + ": unknown key '" + key + "' (origins, offsets, T_tracker_base, T_tip_marker)");
    }
  }
  return truth;
}

/// Random errors of the given sizes on every joint origin and zero, a tracker anywhere about a
/// metre from the robot, a marker a few centimetres from the flange.
KinematicCorrections random_errors(const RobotModel& model, const SynthOptions& o, Random& random) {
  KinematicCorrections truth = KinematicCorrections::zero(model);
  for (int i = 0; i < model.dof(); ++i) {
    Vector6d& xi = truth.origin[static_cast<size_t>(i)];
    xi << o.error_rotation * random.normal3(), o.error_position * random.normal3();
    truth.offset[i] =
        (model.joint(i).type == JointType::Prismatic ? o.error_position : o.error_rotation) * random.normal();
  }
  Eigen::Quaterniond q(random.normal(), random.normal(), random.normal(), random.normal());  // uniform on SO(3)
  truth.T_tracker_base = Transform(q.normalized().toRotationMatrix(), random.normal3());
  truth.T_tip_marker = exp6((Vector6d() << 0.3 * random.normal3(), 0.05 * random.normal3()).finished());
  return truth;
}

Eigen::VectorXd random_configuration(const RobotModel& model, Random& random) {
  Eigen::VectorXd q(model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    const JointLimits& l = model.joint(i).limits;
    // 5 % inside each limit: arms are not measured against their end stops.
    const double margin = 0.05 * (l.upper - l.lower);
    q[i] = l.lower + margin + random.uniform() * (l.upper - l.lower - 2.0 * margin);
  }
  return q;
}

Json truth_json(const RobotModel& model, const KinematicCorrections& truth, const std::vector<int>& outlier_lines,
                const SynthOptions& o) {
  Json out;
  out["T_tracker_base"] = cli::transform_json(truth.T_tracker_base);
  out["T_tip_marker"] = cli::transform_json(truth.T_tip_marker);
  Json origins, offsets;
  for (int i = 0; i < model.dof(); ++i) {
    origins[model.joint(i).name] = cli::vector_json(truth.origin[static_cast<size_t>(i)]);
    offsets[model.joint(i).name] = truth.offset[i];
  }
  out["origins"] = origins;
  out["offsets"] = offsets;
  out["noise_position_m"] = o.noise_position;
  out["noise_rotation_rad"] = o.noise_rotation;
  out["outlier_lines"] = outlier_lines;
  out["seed"] = o.seed;
  return out;
}

void run_synth(const SynthOptions& o) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = o.tip;
  const std::string xml = read_text_file(o.urdf, "URDF");
  const RobotModel nominal = load_urdf_string(xml, urdf_options, o.urdf);
  tools::warn("chasles_calibrate", o.urdf, nominal.warnings());
  Random random(o.seed);
  const KinematicCorrections truth = o.errors.empty() ? random_errors(nominal, o, random) : parse_errors(o.errors, nominal);
  const RobotModel truth_model = corrected_model(nominal, truth);

  std::vector<Measurement> rows(static_cast<size_t>(o.rows));
  for (size_t k = 0; k < rows.size(); ++k) {
    Measurement& m = rows[k];
    m.q = random_configuration(nominal, random);
    const Transform T = predict_marker(truth_model, truth, m.q);
    m.p_tracker_marker = T.translation() + o.noise_position * random.normal3();
    m.has_orientation = !o.position_only;
    m.R_tracker_marker = T.linear() * exp3(o.noise_rotation * random.normal3());
    m.line = static_cast<int>(k) + 2;  // after the header
  }
  // Gross errors on a seeded choice of rows: a marker seen through a reflection, a wrong target.
  const std::vector<bool> corrupt = holdout_split(o.rows, o.outliers, o.seed ^ 0x5eedull);
  std::vector<int> outlier_lines;
  for (size_t k = 0; k < rows.size(); ++k) {
    if (!corrupt[k]) continue;
    rows[k].p_tracker_marker += o.outlier_size * random.normal3().normalized();
    outlier_lines.push_back(rows[k].line);
  }

  std::vector<std::pair<std::string, std::string>> files{{o.out, format_dataset(nominal, rows, !o.position_only)}};
  if (!o.truth.empty()) {
    CorrectedUrdfOptions urdf_out;
    urdf_out.marker_link = o.marker_link;
    urdf_out.note = "Synthetic truth (chasles_calibrate synth, seed " + std::to_string(o.seed) + ").";
    files.emplace_back(o.truth, corrected_urdf(xml, nominal, truth, urdf_out));
  }
  if (!o.truth_report.empty()) files.emplace_back(o.truth_report, cli::dump(truth_json(nominal, truth, outlier_lines, o), true) + "\n");
  write_files_atomically(files);
  std::cout << "chasles_calibrate synth: " << rows.size() << " " << (o.position_only ? "positions" : "poses") << " of "
            << nominal.name() << " (" << nominal.base_link() << " -> " << nominal.tip_link() << "), noise "
            << o.noise_position << " m / " << o.noise_rotation << " rad, " << outlier_lines.size()
            << " outliers, errors " << (o.errors.empty() ? "random (seed " + std::to_string(o.seed) + ")" : o.errors)
            << "\nwrote " << o.out;
  if (!o.truth.empty()) std::cout << ", " << o.truth;
  if (!o.truth_report.empty()) std::cout << ", " << o.truth_report;
  std::cout << "\n";
}

}  // namespace

Command register_synth(CLI::App& app) {
  auto options = std::make_shared<SynthOptions>();
  SynthOptions& o = *options;
  CLI::App* synth = app.add_subcommand("synth", "Write a synthetic dataset measured on a perturbed copy of the robot");
  synth->add_option("--urdf", o.urdf, "Robot description (URDF file)")->required()->type_name("FILE");
  synth->add_option("--tip", o.tip, "Link the marker is mounted on; needed with several leaves")->type_name("LINK");
  synth->add_option("--errors", o.errors,
                    "The truth's errors, a JSON file or inline JSON: {\"origins\": {JOINT: [wx,wy,wz,vx,vy,vz]}, "
                    "\"offsets\": {JOINT: rad}, \"T_tracker_base\": 4x4, \"T_tip_marker\": 4x4}; what is not given "
                    "is zero or the identity. Without it the errors are random (--seed, --error-pos, --error-rot)")
      ->type_name("SPEC");
  synth->add_option("--seed", o.seed, "Seed of the random errors, configurations, noise and outliers")
      ->capture_default_str();
  synth->add_option("--error-pos", o.error_position, "Random origin and prismatic-offset errors, m per axis (1 sigma)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  synth->add_option("--error-rot", o.error_rotation, "Random origin and joint-offset errors, rad per axis (1 sigma)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  synth->add_option("--noise-pos", o.noise_position, "Tracker position noise, m per axis (1 sigma)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  synth->add_option("--noise-rot", o.noise_rotation, "Tracker orientation noise, rad per axis (1 sigma)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  synth->add_option("--n", o.rows, "Configurations to measure, uniform within the joint limits (5 % margin)")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  synth->add_flag("--position-only", o.position_only, "Positions only, as a laser tracker gives (no qw,qx,qy,qz)");
  synth->add_option("--outliers", o.outliers, "Fraction of rows given a gross position error")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  synth->add_option("--outlier-size", o.outlier_size, "Size of the gross errors (m)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  synth->add_option("--out", o.out, "Dataset CSV to write")->required()->type_name("CSV");
  synth->add_option("--truth", o.truth, "The truth as a corrected URDF (marker link included)")->type_name("FILE");
  synth->add_option("--truth-report", o.truth_report,
                    "The truth as JSON: T_tracker_base, T_tip_marker (4x4 rows), origins, offsets, outlier lines")
      ->type_name("FILE");
  synth->add_option("--marker-link", o.marker_link, "Name of the marker link in the truth URDF")->capture_default_str();
  synth->footer(
      "Measurements: T_tracker_marker = T_tracker_base * FK_truth(q) * T_tip_marker, plus Gaussian noise (position "
      "per axis; orientation as exp of a random rotation vector).\n"
      "Example:\n"
      "  chasles_calibrate synth --urdf panda.urdf --tip panda_hand --seed 3 --n 200 --noise-pos 1e-4 "
      "--noise-rot 1e-3 --out panda.csv --truth panda_truth.urdf --truth-report panda_truth.json");
  return {synth, [options]() { run_synth(*options); }};
}

}  // namespace chasles::calibrate_cli
