// chasles_calibrate dynamics: an LCM log of the arm moving in, its identified URDF and a JSON report
// out, a summary on stdout (chasles::identification's identify_dynamics, calibration's
// identified_urdf). chasles_calibrate payload: a log of the arm moving with a load in, the arm
// known, the load `chasles payload` sends out (identify_payload). chasles_calibrate check: a URDF's
// torque RMS on a log it was not identified from (prediction_rms).
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <iostream>

#include "core/calibration/urdf_writer.hpp"
#include "core/identification/dynamic_fit.hpp"
#include "core/model/urdf.hpp"
#include "tools/cli/messages.hpp"
#include "tools/cli/state_log.hpp"
#include "tools/error_line.hpp"
#include "commands.hpp"

namespace chasles::calibrate_cli {

namespace {

struct DynamicsOptions {
  std::string urdf, tip, log, out, report;
  std::string channel = "CHASLES_STATE";
  DynamicFitOptions fit;
};

const char* const kIdentifiedUrdfContents =
    "The identified URDF is the input URDF with (1) the <inertial> of each link that starts a body (the child of "
    "each movable joint between the base and the tip) holding the identified body less the links riding on it "
    "(a flange, a hand, fingers keep their <inertial>s): mass, centre of mass as origin xyz, inertia about it in "
    "the link's axes (rpy 0); (2) each movable joint's <dynamics damping friction> the viscous and Coulomb "
    "friction; (3) the armature as Drake's drake:rotor_inertia (times drake:gear_ratio squared) in the joint's "
    "<transmission>, a new one with gear ratio 1 where there was none. The originals stay in a comment beside each.";

// The log's states as the fit's samples: times from the sender's utime, relative to the first.
JointSamples samples_of(const cli::StateLog& log) {
  const Eigen::Index n = log.joints, N = static_cast<Eigen::Index>(log.utime.size());
  JointSamples samples;
  samples.t.resize(N);
  for (Eigen::Index k = 0; k < N; ++k) samples.t[k] = 1e-6 * static_cast<double>(log.utime[size_t(k)] - log.utime[0]);
  samples.q = Eigen::Map<const Eigen::MatrixXd>(log.position.data(), n, N);
  samples.qd = Eigen::Map<const Eigen::MatrixXd>(log.velocity.data(), n, N);
  samples.tau = Eigen::Map<const Eigen::MatrixXd>(log.effort.data(), n, N);
  return samples;
}

Json optional_number(bool present, double x) { return present ? cli::number(x) : Json(nullptr); }

Json moving_share(const RobotModel& model, const LogUse& use) {
  Json shares = Json::object();
  for (int i = 0; i < model.dof(); ++i) shares[model.joint(i).name] = use.moving_share[i];
  return shares;
}

Json report_json(const DynamicsOptions& o, const RobotModel& nominal, const cli::StateLog& log,
                 const DynamicFitResult& r) {
  const int n = nominal.dof();
  const ParameterLayout layout = parameter_layout(nominal);
  const BaseParameters& base = r.base;
  Json report = report_header(nominal, o.urdf);
  report["log"] = o.log;
  report["channel"] = o.channel;
  report["model"] =
      "tau = Y(q, qd, qdd) pi: RNEA of the bodies (m, h = m c, I about the body frame's origin, in the frame of "
      "the link that starts each body) plus viscous * qd + coulomb * sign(qd) + armature * qdd per joint; SI units";
  report["samples"] = {{"states", r.log.samples},
                       {"repeated_states_left_out", log.repeated},
                       {"damaged_or_undecodable_left_out", static_cast<int>(log.problems.size())},
                       {"rate_hz", r.log.sample_rate_hz},
                       {"duration_s", r.log.duration_s},
                       {"motion_s", r.log.motion_seconds},
                       {"rest_s", r.log.rest_seconds},
                       {"moving_share", moving_share(nominal, r.log)},
                       {"segments", r.log.segments},
                       {"in_segments_too_short", r.log.dropped_samples},
                       {"decimation", r.log.decimation},
                       {"fit", r.log.fit_samples},
                       {"fit_torques", r.log.fit_torques},
                       {"held_out", r.log.holdout_samples},
                       {"held_out_s", r.log.holdout_seconds},
                       {"held_out_blocks", r.log.holdout_blocks},
                       {"blocks", o.fit.holdout_blocks},
                       {"note",
                        "a joint's torque counts, in the fit and the held-out RMS, where the joint moves at "
                        "min_speed or faster and did so 1 / cutoff s either side (moving_share: of the motion); "
                        "samples where no joint moves are rest, left out whole; the motion is cut into 'blocks' "
                        "equal blocks and the last ones ('held_out_blocks') are held out whole; the fit uses every "
                        "'decimation'-th sample of the others (2.5 x the cut-off); each segment between gaps loses "
                        "2 / cutoff s at either end, where the filter sees its own reflection"}};
  report["filter"] = {{"type", "Butterworth low-pass, run forwards and backwards (zero phase)"},
                      {"order", o.fit.filter_order},
                      {"cutoff_hz", o.fit.cutoff_hz},
                      {"applied_to", "velocity (then differentiated for acceleration), torque, Coulomb's column"}};

  Json combinations = Json::array();
  for (int k = 0; k < base.count; ++k) {
    combinations.push_back({{"expression", base_parameter_expression(nominal, base, k)},
                            {"nominal", r.beta_nominal[k]},
                            {"least_squares", r.beta_wls[k]},
                            {"identified", r.beta[k]},
                            {"standard_error", cli::number(r.beta_standard_error[k])}});
  }
  report["base_parameters"] = {
      {"count", base.count},
      {"theory", base.count},
      {"inertial", base.inertial_count},
      {"data_rank", r.rank},
      {"theory_note",
       "the combinations of the 13 n parameters joint torques can tell apart (column-pivoted QR of the regressor at "
       "random states): 10 n - 9 - 3 (n - 1) inertial for a revolute chain with a vertical first axis (Khalil and "
       "Dombre), fewer where axes meet; 2 n friction; the rotors of joints whose inertia folds into a body's less"},
      {"condition_number", r.condition_number},
      {"condition_number_scaled", r.condition_number_scaled},
      {"condition_note",
       "of the stacked base regressor of the fitted samples, as it is in SI units; scaled: weighted by each "
       "joint's residual sigma and with unit columns"},
      {"combinations", combinations}};

  // Each base column's standard error belongs to the parameter that heads its combination.
  Eigen::VectorXd standard_error = Eigen::VectorXd::Constant(layout.size(), -1.0);
  for (int k = 0; k < base.count; ++k) standard_error[base.independent[size_t(k)]] = r.beta_standard_error[k];
  Json parameters = Json::array();
  for (int j = 0; j < layout.size(); ++j) {
    const bool identifiable = standard_error[j] >= 0.0;
    parameters.push_back({{"name", parameter_name(nominal, j)},
                          {"unit", parameter_unit(nominal, j)},
                          {"nominal", r.pi_nominal[j]},
                          {"identified", r.pi[j]},
                          {"identifiable", identifiable},
                          {"standard_error", optional_number(identifiable, standard_error[j])}});
  }
  report["parameters"] = parameters;
  report["parameters_note"] =
      "identifiable: the parameter heads a base combination (base_parameters.combinations), whose standard error "
      "it carries - its own, given the others in the combination; the others are settled by the prior, which holds "
      "each body's log-Cholesky coordinates to the nominal body's. Friction of the URDF is taken as zero.";

  Json torques = Json::array();
  for (int i = 0; i < n; ++i) {
    const bool held = r.log.holdout_samples > 0;
    torques.push_back({{"joint", nominal.joint(i).name},
                       {"unit", nominal.joint(i).type == JointType::Prismatic ? "N" : "N*m"},
                       {"nominal", optional_number(held, r.holdout_rms_nominal[i])},
                       {"identified", optional_number(held, r.holdout_rms[i])},
                       {"identified_every_sample", optional_number(held, r.holdout_rms_every_sample[i])},
                       {"fit_sigma", r.sigma[i]}});
  }
  report["held_out_torque_rms"] = torques;
  report["held_out_note"] =
      "RMS of the logged effort less each model's prediction of the torque applied over each step, at every "
      "held-out sample (the last blocks of the motion) where the joint moves (identified_every_sample: at every "
      "one, the joint slow or stuck included, where static friction holds what no model tells); "
      "fit_sigma is the identified model's residual on the filtered, decimated torques it was "
      "fitted to";
  report["options"] = {{"holdout", o.fit.holdout},
                       {"huber_sigma", o.fit.huber},
                       {"prior_weight", o.fit.prior_weight},
                       {"prior_length_m", o.fit.prior_length},
                       {"max_condition", o.fit.max_condition},
                       {"min_range", o.fit.min_range},
                       {"min_speed", o.fit.min_speed},
                       {"seed", o.fit.seed}};
  report["solver"] = {{"converged", r.converged},
                      {"termination", r.termination},
                      {"iterations", r.iterations},
                      {"solver_seconds", r.solver_seconds},
                      {"fit_seconds", r.seconds}};
  report["identified_urdf"] = {{"path", o.out}, {"contents", kIdentifiedUrdfContents}};
  return report;
}

void print_summary(const DynamicsOptions& o, const RobotModel& nominal, const DynamicFitResult& r) {
  char line[160];
  std::cout << "chasles_calibrate dynamics: " << nominal.name() << " (" << nominal.base_link() << " -> "
            << nominal.tip_link() << "), " << r.log.samples << " states on " << o.channel;
  std::snprintf(line, sizeof line, " at %.0f Hz over %.1f s: %d fitted (every %d), %d held out\n", r.log.sample_rate_hz,
                r.log.duration_s, r.log.fit_samples, r.log.decimation, r.log.holdout_samples);
  std::cout << line;
  std::snprintf(line, sizeof line, "motion %.1f s, rest %.1f s left out; joints moving in %.0f-%.0f %% of the motion\n",
                r.log.motion_seconds, r.log.rest_seconds, 100.0 * r.log.moving_share.minCoeff(),
                100.0 * r.log.moving_share.maxCoeff());
  std::cout << line;
  std::snprintf(line, sizeof line,
                "base parameters: %d of %d (theory), condition number %.3g (%.3g with unit columns)\n", r.rank,
                r.base.count, r.condition_number, r.condition_number_scaled);
  std::cout << line;
  if (r.log.holdout_samples == 0) std::cout << "no data held out: nothing to judge the fit on\n";
  if (r.log.holdout_samples > 0) std::cout << "held-out torque RMS   nominal -> identified\n";
  for (int i = 0; i < nominal.dof() && r.log.holdout_samples > 0; ++i) {
    std::snprintf(line, sizeof line, "  %-18s %9.4f -> %.4f\n", nominal.joint(i).name.c_str(), r.holdout_rms_nominal[i],
                  r.holdout_rms[i]);
    std::cout << line;
  }
  std::snprintf(line, sizeof line, "solver: %s, %d iterations, %.3f s (fit %.3f s)\n",
                r.converged ? "converged" : "NOT converged", r.iterations, r.solver_seconds, r.seconds);
  std::cout << line << "wrote " << o.out << " and " << o.report << "\n";
}

// The URDF's model and the log's states, checked against each other.
struct Inputs {
  std::string xml;
  RobotModel model;
  cli::StateLog log;
};

Inputs read_inputs(const DynamicsOptions& o) {
  UrdfOptions urdf_options;
  urdf_options.tip_link = o.tip;
  std::string xml = read_text_file(o.urdf, "URDF");
  RobotModel model = load_urdf_string(xml, urdf_options, o.urdf);
  tools::warn("chasles_calibrate", o.urdf, model.warnings());
  cli::StateLog log = cli::read_states(o.log, o.channel);
  if (log.joints != model.dof()) {
    throw InputError(o.log + ": the states on " + o.channel + " carry " + std::to_string(log.joints) +
                     " joints; the chain of " + o.urdf + " from '" + model.base_link() + "' to '" +
                     model.tip_link() + "' has " + std::to_string(model.dof()) + " (another robot, or another tip?)");
  }
  tools::warn("chasles_calibrate", o.log, log.problems);
  return {std::move(xml), std::move(model), std::move(log)};
}

void run_dynamics(const DynamicsOptions& o) {
  const Inputs in = read_inputs(o);
  const std::string& xml = in.xml;
  const RobotModel& nominal = in.model;
  const cli::StateLog& log = in.log;
  const DynamicFitResult result = identify_dynamics(nominal, samples_of(log), o.fit);
  const ParameterLayout layout = parameter_layout(nominal);
  const std::string urdf_text =
      identified_urdf(xml, identified_model(nominal, result.pi), result.pi.segment(layout.viscous(0), layout.n),
                      result.pi.segment(layout.coulomb(0), layout.n), "Log: " + o.log + "; report: " + o.report + ".");
  const std::string report_text = cli::dump(report_json(o, nominal, log, result), true) + "\n";
  write_files_atomically({{o.out, urdf_text}, {o.report, report_text}});
  print_summary(o, nominal, result);
}

// ---- payload ----

std::string list(std::initializer_list<double> values) {
  std::string text;
  for (const double v : values) text += (text.empty() ? "" : ",") + cli::number_text(v);
  return text;
}

void run_payload(const DynamicsOptions& o) {
  const Inputs in = read_inputs(o);
  const JointFriction friction = joint_friction_from_urdf(in.xml, in.model);
  const Eigen::VectorXd& viscous = friction.viscous;
  const Eigen::VectorXd& coulomb = friction.coulomb;
  const PayloadFitResult r = identify_payload(in.model, viscous, coulomb, samples_of(in.log), o.fit);
  const Payload& p = r.payload;
  const std::string command = "chasles payload --mass " + cli::number_text(p.mass) + " --com " +
                              list({p.centre.x(), p.centre.y(), p.centre.z()}) + " --inertia " +
                              list({p.inertia(0, 0), p.inertia(1, 1), p.inertia(2, 2), p.inertia(0, 1),
                                    p.inertia(0, 2), p.inertia(1, 2)});
  Json out;
  out["tool"] = std::string("chasles_calibrate ") + CHASLES_VERSION;
  out["mass"] = p.mass;
  out["centre_of_mass"] = cli::vector_json(p.centre);
  out["inertia"] = cli::rows_json(p.inertia);
  out["frame"] = "the tip frame of the chain '" + in.model.base_link() + "' -> '" + in.model.tip_link() +
                 "'; inertia about the centre of mass, as payload_t and chasles payload take them";
  out["command"] = command;
  out["mass_standard_error"] = r.mass_standard_error;
  Json parameters = Json::array();
  for (int k = 0; k < 10; ++k) {
    parameters.push_back({{"name", kInertialParameterNames[k]},
                          {"identified", r.pi[k]},
                          {"least_squares", r.pi_ls[k]},
                          {"standard_error", r.standard_error[k]}});
  }
  out["parameters_in_last_body_frame"] = parameters;
  out["condition_number_scaled"] = r.condition_number;
  Json torques = Json::array();
  for (int i = 0; i < in.model.dof(); ++i) {
    const bool held = r.log.holdout_samples > 0;
    torques.push_back({{"joint", in.model.joint(i).name},
                       {"without_payload", optional_number(held, r.holdout_rms_without[i])},
                       {"with_payload", optional_number(held, r.holdout_rms[i])},
                       {"fit_sigma", r.sigma[i]}});
  }
  out["held_out_torque_rms"] = torques;
  out["arm"] = {{"urdf", o.urdf},
                {"friction", "from each joint's <dynamics damping friction> (0 where absent)"},
                {"viscous", cli::vector_json(viscous)},
                {"coulomb", cli::vector_json(coulomb)}};
  out["samples"] = {{"log", o.log},   {"channel", o.channel}, {"states", r.log.samples},
                    {"rate_hz", r.log.sample_rate_hz}, {"fit", r.log.fit_samples}, {"held_out", r.log.holdout_samples}};
  out["solver"] = {{"converged", r.converged}, {"iterations", r.iterations}, {"fit_seconds", r.seconds}};
  write_files_atomically({{o.out, cli::dump(out, true) + "\n"}});
  char line[200];
  std::snprintf(line, sizeof line,
                "payload: %.4g kg (standard error %.2g), centre of mass (%.4g, %.4g, %.4g) m in '%s'\n", p.mass,
                r.mass_standard_error, p.centre.x(), p.centre.y(), p.centre.z(), in.model.tip_link().c_str());
  std::cout << line;
  if (r.log.holdout_samples > 0) {
    double without = 0.0, with = 0.0;
    for (int i = 0; i < in.model.dof(); ++i) {
      without += r.holdout_rms_without[i] * r.holdout_rms_without[i];
      with += r.holdout_rms[i] * r.holdout_rms[i];
    }
    std::snprintf(line, sizeof line, "held-out torque RMS over the joints: %.4f without it -> %.4f with it\n",
                  std::sqrt(without / in.model.dof()), std::sqrt(with / in.model.dof()));
    std::cout << line;
  }
  std::cout << "send it: " << command << "\nwrote " << o.out << "\n";
}

// ---- check ----

// A URDF's torques against a log it was not identified from, judged as dynamics judges its held-out
// blocks: what its report's held-out RMS claims, measured on another motion.
void run_check(const DynamicsOptions& o) {
  const Inputs in = read_inputs(o);
  const int n = in.model.dof();
  const JointFriction friction = joint_friction_from_urdf(in.xml, in.model);
  const ParameterLayout layout = parameter_layout(in.model);
  Eigen::VectorXd pi = model_parameters(in.model);
  pi.segment(layout.viscous(0), n) = friction.viscous;
  pi.segment(layout.coulomb(0), n) = friction.coulomb;
  const Eigen::VectorXd rms = prediction_rms(in.model, pi, samples_of(in.log), o.fit);
  std::cout << "torque RMS of " << o.urdf << " on " << o.log << ", each joint where it moves:\n";
  char line[160];
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    std::snprintf(line, sizeof line, "  %-18s %.4f\n", in.model.joint(i).name.c_str(), rms[i]);
    std::cout << line;
    sum += rms[i] * rms[i];
  }
  std::snprintf(line, sizeof line, "over the joints: %.4f\n", std::sqrt(sum / n));
  std::cout << line;
}

// What the commands read of the log and how they filter and judge it.
void add_log_options(CLI::App& command, std::string& channel, DynamicFitOptions& fit) {
  command.add_option("--state-channel", channel, "The channel of its chasles.robot_state_t messages")
      ->type_name("CHANNEL")
      ->capture_default_str();
  command.add_option("--holdout", fit.holdout, "Fraction of the log held out, in whole blocks, to judge the fit")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  command.add_option("--cutoff", fit.cutoff_hz, "Cut-off of the zero-phase low-pass on velocity and torque (Hz)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command
      .add_option("--min-speed", fit.min_speed,
                  "A joint's torque is left out where it moves slower (rad/s or m/s) and 1 / cutoff s around: at "
                  "rest or stuck, static friction holds a torque no model tells")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

}  // namespace

Command register_payload(CLI::App& app) {
  auto options = std::make_shared<DynamicsOptions>();
  DynamicsOptions& o = *options;
  CLI::App* command = app.add_subcommand(
      "payload", "Identify the load at the tip from a log of the arm moving with it, the arm known; write what "
                 "`chasles payload` sends");
  command->add_option("--urdf", o.urdf, "The arm's URDF, as identified (chasles_calibrate dynamics): bodies, rotors, "
                                        "<dynamics> friction")
      ->required()
      ->type_name("FILE");
  command->add_option("--tip", o.tip, "Link that ends the chain, where the load is held")->type_name("LINK");
  command->add_option("--log", o.log, "LCM log of the arm moving with the load")->required()->type_name("LOG");
  add_log_options(*command, o.channel, o.fit);
  command->add_option("--out", o.out, "JSON to write: the payload (mass, centre_of_mass, inertia, as payload_t), the "
                                      "chasles payload command, standard errors, held-out torques")
      ->required()
      ->type_name("FILE");
  command->footer(
      "The arm's torques are taken off the logged ones and the ten parameters of one more body on the last are "
      "fitted (least squares, then physically consistent under a Huber loss), as `dynamics` fits the arm.\n"
      "Example:\n"
      "  chasles_calibrate payload --urdf identified.urdf --tip panda_hand --log with_box.lcmlog --out box.json");
  return {command, [options]() { run_payload(*options); }};
}

Command register_check(CLI::App& app) {
  auto options = std::make_shared<DynamicsOptions>();
  DynamicsOptions& o = *options;
  CLI::App* command = app.add_subcommand(
      "check", "How well a URDF (as dynamics identified it) predicts the torques of a log it was not fitted to");
  command->add_option("--urdf", o.urdf, "The arm's URDF: bodies, rotors, <dynamics> friction")
      ->required()
      ->type_name("FILE");
  command->add_option("--tip", o.tip, "Link that ends the chain; needed with several leaves")->type_name("LINK");
  command->add_option("--log", o.log, "LCM log of the arm moving, another than the one identified")
      ->required()
      ->type_name("LOG");
  add_log_options(*command, o.channel, o.fit);
  command->footer(
      "Prints each joint's RMS of the logged effort less the URDF's prediction of the torque applied over each "
      "step, where the joint moves (--min-speed), as dynamics reports its held-out blocks. Refuses the logs "
      "dynamics refuses for what they hold.\n"
      "Example:\n"
      "  chasles_calibrate check --urdf identified.urdf --tip panda_hand --log another_run.lcmlog");
  return {command, [options]() { run_check(*options); }};
}

Command register_dynamics(CLI::App& app) {
  auto options = std::make_shared<DynamicsOptions>();
  DynamicsOptions& o = *options;
  CLI::App* command = app.add_subcommand(
      "dynamics", "Identify the arm's inertias, friction and rotors from a log of it moving; write them into its URDF");
  command->add_option("--urdf", o.urdf, "Robot description (URDF file): the nominal model")
      ->required()
      ->type_name("FILE");
  command->add_option("--tip", o.tip, "Link that ends the chain; needed with several leaves")->type_name("LINK");
  command->add_option("--log", o.log, "LCM log of the arm moving (lcm-logger's), with its states")
      ->required()
      ->type_name("LOG");
  add_log_options(*command, o.channel, o.fit);
  command->add_option("--out", o.out, "Identified URDF to write")->required()->type_name("FILE");
  command->add_option("--report", o.report, "JSON report to write")->required()->type_name("FILE");
  command->footer(
      std::string("Fits every body's ten inertial parameters (physically consistent: log-Cholesky coordinates), "
                  "each joint's viscous and Coulomb friction and its rotor's armature to the torques the log's states "
                  "carry (robot_state_t.effort, applied over each step), by Ceres under a Huber loss; velocity and "
                  "torque are low-passed without phase and acceleration is the velocity's derivative. The report "
                  "gives each parameter nominal and identified, the standard errors of what the torques determine, "
                  "their count against theory, the held-out torque RMS per joint before and after, the condition "
                  "number and the time taken. ") +
      kIdentifiedUrdfContents +
      "\nRun an excitation trajectory first (every joint moving, fast and far): a log that leaves a parameter "
      "combination undetermined is refused, naming it or the joints that barely move.\n"
      "Files are written atomically (temporary file, fsync, rename); on any error nothing is written.\n"
      "Example:\n"
      "  chasles_calibrate dynamics --urdf panda.urdf --tip panda_hand --log run.lcmlog --out identified.urdf "
      "--report identified.json");
  return {command, [options]() { run_dynamics(*options); }};
}

}  // namespace chasles::calibrate_cli
