// chasles._core's solvers, which link Ceres: inverse kinematics and kinematic calibration. Each
// solve releases the GIL; a solver is guarded by its own mutex, taken after the GIL is released,
// so that two Python threads sharing one solver take turns instead of racing.
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "core/calibration/calibration.hpp"
#include "core/calibration/dataset.hpp"
#include "core/calibration/urdf_writer.hpp"
#include "core/ik/ik.hpp"

namespace chasles::python {

namespace {

struct Solver {
  Solver(const Model& model, const IkOptions& options) : robot(model.robot), solver(*robot, options) {}
  std::shared_ptr<const RobotModel> robot;
  IkSolver solver;
  std::mutex mutex;
};

void bind_ik(nb::module_& m) {
  nb::class_<IkOptions>(m, "IkOptions", "Settings of IkSolver; see core/ik/ik.hpp. Checked when given to a solver.")
      .def(nb::init<>())
      .def_prop_rw(
          "weights", [](const IkOptions& o) { return to_array(o.weights); },
          [](IkOptions& o, ArrayArg w) { o.weights = read_vector(w.object, "weights", 6); },
          "Weights of the pose error components (ω, v): rotation in rad, position in m; positive.")
      .def_rw("position_only", &IkOptions::position_only, "Solve for the tip position only.")
      .def_rw("position_tolerance", &IkOptions::position_tolerance, "Converged when pos_err ≤ this, m.")
      .def_rw("rotation_tolerance", &IkOptions::rotation_tolerance, "Converged when rot_err ≤ this, rad.")
      .def_prop_rw(
          "time_budget", [](const IkOptions& o) { return std::chrono::duration<double>(o.time_budget).count(); },
          [](IkOptions& o, double seconds) {
            if (!(seconds > 0.0) || !std::isfinite(seconds)) {
              throw ArgumentError("time_budget must be a positive number of seconds, not " + std::to_string(seconds));
            }
            o.time_budget = std::chrono::microseconds(static_cast<std::int64_t>(std::llround(seconds * 1e6)));
          },
          "CPU-time budget of one solve, seeds and restarts together, in seconds (held in whole µs).")
      .def_rw("max_restarts", &IkOptions::max_restarts, "Random restarts after the attempt from the seed, at most.")
      .def_rw("max_iterations", &IkOptions::max_iterations, "Levenberg-Marquardt iterations per attempt.")
      .def_rw("regularization", &IkOptions::regularization, "λ of λ (q − q_seed) on redundant tasks; 0: off.")
      .def_rw("rng_seed", &IkOptions::rng_seed, "Seed of the random restarts.");

  nb::class_<IkResult>(m, "IkResult", "What IkSolver.solve found.")
      .def_prop_ro("q", [](const IkResult& r) { return to_array(r.q); },
                   "The solution, or the best pose found; within the limits.")
      .def_ro("converged", &IkResult::converged, "pos_err and rot_err within the tolerances.")
      .def_ro("pos_err", &IkResult::pos_err, "|p_sb(q) − p_sd|, m.")
      .def_ro("rot_err", &IkResult::rot_err, "Angle of R_sdᵀ R_sb(q), rad.")
      .def_ro("iterations", &IkResult::iterations, "Levenberg-Marquardt iterations, every attempt together.")
      .def_ro("restarts", &IkResult::restarts, "Random restarts after the attempt from the seed.")
      .def_ro("time_us", &IkResult::time_us, "Wall-clock time of the solve, µs.")
      .def("__repr__", [](const IkResult& r) {
        return std::string("IkResult(converged=") + (r.converged ? "True" : "False") + ", pos_err=" +
               std::to_string(r.pos_err) + ", rot_err=" + std::to_string(r.rot_err) + ", restarts=" +
               std::to_string(r.restarts) + ")";
      });

  nb::class_<Solver>(m, "IkSolver",
                     "Inverse kinematics by Levenberg-Marquardt (Ceres) with random restarts, for one model. An "
                     "unreachable target gives converged=False, not an exception.")
      .def(
          "__init__",
          [](Solver* self, const Model& model, std::optional<IkOptions> options) {
            new (self) Solver(model, options.value_or(IkOptions{}));
          },
          nb::arg("model"), nb::arg("options") = nb::none(), "Raises ArgumentError for options out of range.")
      .def_prop_rw(
          "options", [](Solver& self) { return self.solver.options(); },
          [](Solver& self, const IkOptions& options) {
            const std::lock_guard<std::mutex> lock(self.mutex);
            self.solver.set_options(options);
          },
          "A copy of the options; assign to change them.")
      .def(
          "solve",
          [](Solver& self, ArrayArg T_sd, ArrayArg q_seed) {
            const InArray T = read_array(T_sd.object, "target");
            if (T.ndim != 2 || T.shape[0] != 4 || T.shape[1] != 4) {
              throw ArgumentError("target has shape " + shape_text(T) + ", expected (4, 4)");
            }
            const Matrix4d target = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(T.data);
            const InArray seed = read_array(q_seed.object, "q_seed");
            if (seed.ndim != 1) throw ArgumentError("q_seed has shape " + shape_text(seed) + ", expected (n,)");
            const Eigen::VectorXd q0 = Eigen::Map<const Eigen::VectorXd>(seed.data, seed.shape[0]);
            nb::gil_scoped_release release;
            const std::lock_guard<std::mutex> lock(self.mutex);
            return self.solver.solve(target, q0);
          },
          nb::arg("T_sd"), nb::arg("q_seed"),
          "The q that puts the tip at T_sd (4×4, base frame) from q_seed. Raises ArgumentError for a target that "
          "is not a finite rigid transform or a seed of the wrong size or not finite.");
}

// A dataset's rows as arrays: q (N, n), p (N, 3), R (N, 3, 3).
Array dataset_q(const Dataset& d, int n) {
  Array a = new_array({static_cast<npy_intp>(d.rows.size()), n});
  for (size_t k = 0; k < d.rows.size(); ++k) Eigen::Map<Eigen::VectorXd>(data(a) + k * n, n) = d.rows[k].q;
  return a;
}

Dataset rows_of(const Dataset& d, const std::vector<bool>& held, bool want) {
  Dataset out;
  out.has_orientation = d.has_orientation;
  for (size_t k = 0; k < d.rows.size(); ++k) {
    if (held[k] == want) out.rows.push_back(d.rows[k]);
  }
  return out;
}

void bind_calibration(nb::module_& m) {
  nb::class_<Dataset>(m, "Dataset",
                      "Calibration measurements: joint positions and where a tracker saw the marker (position, "
                      "and orientation if measured). Read with read_dataset or made with Dataset.from_arrays.")
      .def_static(
          "from_arrays",
          [](const Model& model, ArrayArg q, ArrayArg p, std::optional<ArrayArg> R) {
            const InArray qa = read_array(q.object, "q");
            const int n = model.robot->dof();
            if (qa.ndim != 2 || qa.shape[1] != n) {
              throw ArgumentError("q has shape " + shape_text(qa) + ", expected (N, " + std::to_string(n) + ")");
            }
            const Eigen::Index rows = qa.shape[0];
            const Eigen::MatrixXd Q = read_matrix(q.object, "q", rows, n);
            const Eigen::MatrixXd P = read_matrix(p.object, "p", rows, 3);
            Dataset d;
            d.has_orientation = R.has_value();
            std::optional<InArray> Ra;
            if (R) {
              Ra = read_array(R->object, "R");
              if (Ra->ndim != 3 || Ra->shape[0] != rows || Ra->shape[1] != 3 || Ra->shape[2] != 3) {
                throw ArgumentError("R has shape " + shape_text(*Ra) + ", expected (" + std::to_string(rows) + ", 3, 3)");
              }
              check_finite(*Ra, "R");
            }
            for (Eigen::Index k = 0; k < rows; ++k) {
              Measurement row;
              row.q = Q.row(k).transpose();
              row.p_tracker_marker = P.row(k).transpose();
              row.has_orientation = d.has_orientation;
              if (Ra) row.R_tracker_marker = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(Ra->data + 9 * k);
              d.rows.push_back(std::move(row));
            }
            return d;
          },
          nb::arg("model"), nb::arg("q"), nb::arg("p"), nb::arg("R") = nb::none(),
          "Rows from arrays: q (N, n) joint positions in chain order, rad or m; p (N, 3) marker positions in the "
          "tracker frame, m; R (N, 3, 3) marker orientations, or None.")
      .def("__len__", [](const Dataset& d) { return d.rows.size(); })
      .def_ro("has_orientation", &Dataset::has_orientation)
      .def_prop_ro(
          "q",
          [](const Dataset& d) { return dataset_q(d, d.rows.empty() ? 0 : static_cast<int>(d.rows[0].q.size())); },
          "Joint positions, (N, n), chain order.")
      .def_prop_ro(
          "p",
          [](const Dataset& d) {
            Array a = new_array({static_cast<npy_intp>(d.rows.size()), 3});
            for (size_t k = 0; k < d.rows.size(); ++k) Eigen::Map<Vector3d>(data(a) + 3 * k) = d.rows[k].p_tracker_marker;
            return a;
          },
          "Marker positions in the tracker frame, (N, 3), m.")
      .def_prop_ro(
          "R",
          [](const Dataset& d) -> std::optional<Array> {
            if (!d.has_orientation) return std::nullopt;
            Array a = new_array({static_cast<npy_intp>(d.rows.size()), 3, 3});
            for (size_t k = 0; k < d.rows.size(); ++k) {
              Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(data(a) + 9 * k) = d.rows[k].R_tracker_marker;
            }
            return a;
          },
          "Marker orientations in the tracker frame, (N, 3, 3), or None.")
      .def_prop_ro(
          "lines",
          [](const Dataset& d) {
            std::vector<int> lines;
            for (const Measurement& row : d.rows) lines.push_back(row.line);
            return lines;
          },
          "Each row's line in its file (0: not from a file).")
      .def(
          "split",
          [](const Dataset& d, double holdout, std::uint64_t seed) {
            if (!(holdout >= 0.0 && holdout < 1.0)) {
              throw ArgumentError("holdout must be a fraction in [0, 1), not " + std::to_string(holdout));
            }
            const std::vector<bool> held = holdout_split(static_cast<int>(d.rows.size()), holdout, seed);
            return std::make_pair(rows_of(d, held, false), rows_of(d, held, true));
          },
          nb::arg("holdout"), nb::arg("seed") = 1,
          "(fit, held-out): round(holdout · N) rows held out by a seeded shuffle, as chasles_calibrate fit does.");

  m.def(
      "read_dataset", [](const std::string& path, const Model& model) { return read_dataset(path, *model.robot); },
      nb::arg("path"), nb::arg("model"),
      "A dataset CSV (header <joint>,...,x,y,z[,qw,qx,qy,qz]) for the model's chain. Raises CalibrationError "
      "naming the file and line.");
  m.def(
      "parse_dataset",
      [](const std::string& text, const Model& model, const std::string& source) {
        return parse_dataset(text, *model.robot, source);
      },
      nb::arg("text"), nb::arg("model"), nb::arg("source") = "<string>", "The same from CSV text.");

  nb::enum_<LossType>(m, "Loss", "Robust loss on each row's whitened residual norm.")
      .value("NONE", LossType::None)
      .value("HUBER", LossType::Huber)
      .value("CAUCHY", LossType::Cauchy);

  nb::class_<CalibrationOptions>(m, "CalibrationOptions", "Settings of calibrate(); see core/calibration/calibration.hpp.")
      .def(nb::init<>())
      .def_rw("sigma_position", &CalibrationOptions::sigma_position, "Expected position noise per axis, m.")
      .def_rw("sigma_rotation", &CalibrationOptions::sigma_rotation, "Expected rotation noise per axis, rad.")
      .def_rw("use_orientation", &CalibrationOptions::use_orientation, "Fit the orientation of rows that have one.")
      .def_rw("loss", &CalibrationOptions::loss)
      .def_rw("loss_scale", &CalibrationOptions::loss_scale, "Whitened norm (multiples of σ) beyond which a row is doubtful.")
      .def_rw("rank_tolerance", &CalibrationOptions::rank_tolerance, "Relative singular value below which a direction is unidentifiable.")
      .def_rw("max_iterations", &CalibrationOptions::max_iterations)
      .def_rw("covariance", &CalibrationOptions::covariance, "Compute standard deviations.")
      .def_rw("outlier_threshold", &CalibrationOptions::outlier_threshold, "Whitened norm beyond which a row is an outlier.");

  nb::class_<KinematicCorrections>(m, "KinematicCorrections", "What a calibration estimates, in the form a user applies it.")
      .def_prop_ro(
          "origin",
          [](const KinematicCorrections& c) {
            Array a = new_array({static_cast<npy_intp>(c.origin.size()), 6});
            for (size_t i = 0; i < c.origin.size(); ++i) Eigen::Map<Vector6d>(data(a) + 6 * i) = c.origin[i];
            return a;
          },
          "δξ_i per joint, (n, 6): M_{i−1,i} ← M_{i−1,i} exp([δξ_i]), a twist (ω, v) in joint frame i.")
      .def_prop_ro("offset", [](const KinematicCorrections& c) { return to_array(c.offset); },
                   "δθ_i per joint, (n,): the joint is at q_i + δθ_i when it reads q_i.")
      .def_prop_ro("T_tracker_base", [](const KinematicCorrections& c) { return to_array(c.T_tracker_base); },
                   "The robot's base frame in the tracker frame, 4×4.")
      .def_prop_ro("T_tip_marker", [](const KinematicCorrections& c) { return to_array(c.T_tip_marker); },
                   "The marker in the tip link's frame, 4×4.");

  nb::class_<ResidualStats>(m, "ResidualStats", "RMS and largest error over rows (outliers left out).")
      .def_ro("rows", &ResidualStats::rows)
      .def_ro("outliers", &ResidualStats::outliers)
      .def_ro("rms_position", &ResidualStats::rms_position, "m")
      .def_ro("max_position", &ResidualStats::max_position, "m")
      .def_ro("rms_rotation", &ResidualStats::rms_rotation, "rad; NaN without orientation")
      .def_ro("max_rotation", &ResidualStats::max_rotation, "rad; NaN without orientation");

  nb::class_<CalibrationResult>(m, "CalibrationResult", "What calibrate() found.")
      .def_ro("before", &CalibrationResult::before, "The nominal robot with its best base and tool.")
      .def_ro("after", &CalibrationResult::after, "The calibrated corrections.")
      .def_prop_ro("x", [](const CalibrationResult& r) { return to_array(r.x); },
                   "Estimates (parameter_names order) about `before`'s base and tool; fixed ones 0.")
      .def_prop_ro("stddev", [](const CalibrationResult& r) { return to_array(r.stddev); },
                   "Standard deviations of x (0 for fixed, NaN if not computed).")
      .def_prop_ro(
          "free", [](const CalibrationResult& r) { return r.identifiability.free; },
          "Indices of the identifiable parameters that were fitted.")
      .def_prop_ro("rank", [](const CalibrationResult& r) { return r.identifiability.rank; })
      .def_prop_ro("theoretical_rank", [](const CalibrationResult& r) { return r.identifiability.theoretical; },
                   "4R + 2P + 6 with orientation data, − 3 without.")
      .def_ro("pose_data", &CalibrationResult::pose_data)
      .def_ro("fit_before", &CalibrationResult::fit_before)
      .def_ro("fit_after", &CalibrationResult::fit_after)
      .def_ro("holdout_before", &CalibrationResult::holdout_before)
      .def_ro("holdout_after", &CalibrationResult::holdout_after)
      .def_ro("fit_outliers", &CalibrationResult::fit_outliers)
      .def_ro("holdout_outliers", &CalibrationResult::holdout_outliers)
      .def_ro("sigma0", &CalibrationResult::sigma0)
      .def_ro("covariance_ok", &CalibrationResult::covariance_ok)
      .def_ro("iterations", &CalibrationResult::iterations)
      .def_ro("converged", &CalibrationResult::converged)
      .def_ro("termination", &CalibrationResult::termination)
      .def_ro("seconds", &CalibrationResult::seconds);

  m.def(
      "calibrate",
      [](const Model& model, const Dataset& fit, std::optional<Dataset> holdout, std::optional<CalibrationOptions> options) {
        const std::vector<Measurement> none;
        nb::gil_scoped_release release;
        CalibrationResult r = calibrate(*model.robot, fit.rows, holdout ? holdout->rows : none,
                                        options.value_or(CalibrationOptions{}));
        return r;
      },
      nb::arg("model"), nb::arg("fit"), nb::arg("holdout") = nb::none(), nb::arg("options") = nb::none(),
      "Calibrates the model's joint origins, joint zero offsets, base and tool on `fit`, evaluates on `holdout`. "
      "Raises CalibrationError on bad options or too few rows.");
  m.def(
      "parameter_names",
      [](const Model& model) {
        const CalibrationLayout layout{model.robot->dof()};
        std::vector<std::string> names;
        for (int k = 0; k < layout.size(); ++k) names.push_back(layout.name(*model.robot, k));
        return names;
      },
      nb::arg("model"), "The names of CalibrationResult.x's entries: '<joint>.origin.wx', '<joint>.offset', 'base.vz', ...");
  m.def(
      "corrected_model",
      [](const Model& nominal, const KinematicCorrections& corrections) {
        return Model(corrected_model(*nominal.robot, corrections));
      },
      nb::arg("nominal"), nb::arg("corrections"), "The chain with the corrections applied: FK(q) is the calibrated arm's.");
  m.def(
      "corrected_urdf",
      [](const std::string& original_xml, const Model& nominal, const KinematicCorrections& corrections) {
        return corrected_urdf(original_xml, *nominal.robot, corrections);
      },
      nb::arg("original_xml"), nb::arg("nominal"), nb::arg("corrections"),
      "The URDF text `nominal` was loaded from with the corrections written in, and a `marker` link for the tool.");
}

}  // namespace

void bind_solvers(nb::module_& m) {
  bind_ik(m);
  bind_calibration(m);
}

}  // namespace chasles::python
