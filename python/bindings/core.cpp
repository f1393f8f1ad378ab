// chasles._core: the model, its kinematics and dynamics, the momentum observer, and the exception
// hierarchy. Every array argument is read by read_array (arrays.hpp); every result is a new numpy
// array. A method given one configuration (n,) answers for it; given a batch (N, n) it answers
// for each row, stacked, computed with the GIL released into the result array itself.
#define CHASLES_PYTHON_IMPORT_ARRAY
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/variant.h>
#include <nanobind/stl/vector.h>

#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "bindings.hpp"
#include "core/calibration/calibration.hpp"
#include "core/contact/observer.hpp"
#include "core/dynamics/dynamics.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/lie/so3.hpp"
#include "core/model/payload.hpp"
#include "core/model/urdf.hpp"
// Only LawBounds's and LawDefaults' constants: nothing of the controller library is linked.
#include "controller/law_settings.hpp"

namespace chasles::python {

std::string take_python_error() {
  PyObject *type = nullptr, *value = nullptr, *traceback = nullptr;
  PyErr_Fetch(&type, &value, &traceback);
  PyErr_NormalizeException(&type, &value, &traceback);
  nb::object t = nb::steal(type), v = nb::steal(value), tb = nb::steal(traceback);
  std::string text = t.is_valid() ? nb::cast<std::string>(t.attr("__name__")) : std::string("error");
  if (v.is_valid()) text += ": " + nb::cast<std::string>(nb::str(v));
  return text;
}

void check_finite(const InArray& a, const char* name) {
  const npy_intp size = a.size();
  for (npy_intp k = 0; k < size; ++k) {
    if (!std::isfinite(a.data[k])) {
      std::string where;
      npy_intp rest = k;
      for (int d = a.ndim - 1; d >= 0; --d) {
        where = std::to_string(rest % a.shape[d]) + (where.empty() ? "" : ", ") + where;
        rest /= a.shape[d];
      }
      throw ArgumentError(std::string(name) + "[" + where + "] is " + std::to_string(a.data[k]) +
                          "; every entry must be finite");
    }
  }
}

Eigen::MatrixXd read_matrix(nb::handle object, const char* name, Eigen::Index rows, Eigen::Index cols) {
  const InArray a = read_array(object, name);
  if (a.ndim != 2 || a.shape[0] != rows || a.shape[1] != cols) {
    throw ArgumentError(std::string(name) + " has shape " + shape_text(a) + ", expected (" + std::to_string(rows) +
                        ", " + std::to_string(cols) + ")");
  }
  check_finite(a, name);
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(a.data, rows, cols);
}

Eigen::VectorXd read_vector(nb::handle object, const char* name, Eigen::Index size) {
  const InArray a = read_array(object, name);
  if (a.ndim != 1 || a.shape[0] != size) {
    throw ArgumentError(std::string(name) + " has shape " + shape_text(a) + ", expected (" + std::to_string(size) + ",)");
  }
  check_finite(a, name);
  return Eigen::Map<const Eigen::VectorXd>(a.data, size);
}

namespace {

// The joint-space arguments of one call: all one configuration (n,) or all a batch (N, n) with
// the same N, every entry finite. Throws ArgumentError naming the argument at fault.
template <size_t K>
struct JointArguments {
  std::array<InArray, K> in;
  bool batch = false;
  npy_intp rows = 1;

  JointArguments(const RobotModel& model, const std::array<nb::handle, K>& objects,
                 const std::array<const char*, K>& names) {
    const npy_intp n = model.dof();
    for (size_t i = 0; i < K; ++i) {
      in[i] = read_array(objects[i], names[i]);
      const InArray& a = in[i];
      if (i == 0) batch = a.ndim == 2;
      if (i > 0 && (a.ndim == 2) != batch && (a.ndim == 1 || a.ndim == 2)) {
        throw ArgumentError(std::string(names[i]) + " has shape " + shape_text(a) + " but " + names[0] + " has shape " +
                            shape_text(in[0]) + ": give every argument for one configuration or all for a batch");
      }
      if (a.ndim == 1) {
        check_joint_vector(model, Eigen::Map<const Eigen::VectorXd>(a.data, a.shape[0]), names[i]);
      } else if (a.ndim == 2 && a.shape[1] == n) {
        if (i == 0) rows = a.shape[0];
        if (a.shape[0] != rows) {
          throw ArgumentError(std::string(names[i]) + " has " + std::to_string(a.shape[0]) + " rows, " + names[0] +
                              " has " + std::to_string(rows));
        }
      } else {
        throw ArgumentError(std::string(names[i]) + " has shape " + shape_text(a) + ", expected (" + std::to_string(n) +
                            ",) for one configuration or (N, " + std::to_string(n) + ") for N of them");
      }
      check_finite(a, names[i]);
    }
  }
};

// One quantity for one configuration (the Model's Data, GIL held) or for each row of a batch (a
// Data of its own, GIL released), written by `kernel(data, inputs, out)` into a new array of
// shape row_shape, or (N, *row_shape).
template <size_t K, typename Kernel>
Array evaluate(Model& self, const std::array<nb::handle, K>& objects, const std::array<const char*, K>& names,
               std::initializer_list<npy_intp> row_shape, Kernel kernel) {
  const RobotModel& model = *self.robot;
  const JointArguments<K> args(model, objects, names);
  std::array<const double*, K> row;
  for (size_t i = 0; i < K; ++i) row[i] = args.in[i].data;
  if (!args.batch) {
    Array out = new_array(row_shape);
    kernel(self.data, row, data(out));
    return out;
  }
  std::vector<npy_intp> shape{args.rows};
  npy_intp row_size = 1;
  for (npy_intp extent : row_shape) {
    shape.push_back(extent);
    row_size *= extent;
  }
  PyObject* result = PyArray_SimpleNew(static_cast<int>(shape.size()), shape.data(), NPY_DOUBLE);
  if (result == nullptr) throw nb::python_error();
  Array out{nb::steal(result)};
  double* o = data(out);
  const npy_intp n = model.dof();
  {
    nb::gil_scoped_release release;
    Data data(model);
    for (npy_intp r = 0; r < args.rows; ++r) {
      kernel(data, row, o + r * row_size);
      for (size_t i = 0; i < K; ++i) row[i] += n;
    }
  }
  return out;
}

using ConstVector = Eigen::Map<const Eigen::VectorXd>;
using Energy = std::variant<double, Array>;

// A scalar per configuration: a float for one, an (N,) array for a batch.
Energy scalar_result(Array&& a) {
  if (PyArray_NDIM(reinterpret_cast<PyArrayObject*>(a.object.ptr())) == 0) return *data(a);
  return std::move(a);
}

Array limits(const RobotModel& model, double JointLimits::*field) {
  Array a = new_array({model.dof()});
  for (int i = 0; i < model.dof(); ++i) data(a)[i] = model.joint(i).limits.*field;
  return a;
}

UrdfOptions urdf_options(const std::optional<std::string>& tip, const std::optional<ArrayArg>& gravity) {
  UrdfOptions options;
  if (tip) options.tip_link = *tip;
  if (gravity) options.gravity = read_vector(gravity->object, "gravity", 3);
  return options;
}

// The Python exception classes, one per chasles::Error subclass core throws.
struct ExceptionClasses {
  PyObject *error, *model, *tip_not_chosen, *argument, *dynamics, *observer, *calibration;
};
ExceptionClasses exceptions;

PyObject* add_exception(nb::module_& m, const char* name, const char* doc, nb::object bases) {
  const std::string qualified = std::string("chasles._core.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw nb::python_error();
  m.attr(name) = nb::handle(type);
  return type;
}

void bind_errors(nb::module_& m) {
  nb::handle base(PyExc_Exception), value_error(PyExc_ValueError);
  auto& e = exceptions;
  e.error = add_exception(m, "Error", "Every error chasles raises; str() is the C++ library's message.",
                          nb::make_tuple(base));
  e.model = add_exception(m, "ModelError", "An invalid or unreadable robot description (URDF); names the file and joint or link.",
                          nb::make_tuple(nb::handle(e.error)));
  e.tip_not_chosen = add_exception(m, "TipNotChosenError", "The URDF tree has several leaves and no tip was named; lists them.",
                                   nb::make_tuple(nb::handle(e.model)));
  e.argument = add_exception(m, "ArgumentError",
                             "An argument a function cannot take: wrong shape, not float64-readable, not finite, "
                             "not a rigid transform, a setting out of range. Also a ValueError.",
                             nb::make_tuple(nb::handle(e.error), value_error));
  e.dynamics = add_exception(m, "DynamicsError", "Dynamics the model cannot give at this state (a singular mass matrix).",
                             nb::make_tuple(nb::handle(e.error)));
  e.observer = add_exception(m, "ObserverError", "Gains, damping or friction that cannot make a momentum observer.",
                             nb::make_tuple(nb::handle(e.error)));
  e.calibration = add_exception(m, "CalibrationError", "Bad calibration input: a dataset, too few rows, bad options.",
                                nb::make_tuple(nb::handle(e.error)));
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const TipNotChosenError& x) {
      PyErr_SetString(exceptions.tip_not_chosen, x.what());
    } catch (const ModelError& x) {
      PyErr_SetString(exceptions.model, x.what());
    } catch (const ArgumentError& x) {
      PyErr_SetString(exceptions.argument, x.what());
    } catch (const DynamicsError& x) {
      PyErr_SetString(exceptions.dynamics, x.what());
    } catch (const ObserverError& x) {
      PyErr_SetString(exceptions.observer, x.what());
    } catch (const CalibrationError& x) {
      PyErr_SetString(exceptions.calibration, x.what());
    } catch (const Error& x) {
      PyErr_SetString(exceptions.error, x.what());
    }
  });
}

void bind_model(nb::module_& m) {
  nb::class_<Model>(m, "Model",
                    "A serial chain from a URDF: immutable, with the kinematics and dynamics of Modern Robotics ch. 4, "
                    "5 and 8. Twists and Jacobian rows are (ω, v), wrenches (m, f); SI units. Every method takes one "
                    "configuration, shape (n,), or a batch, shape (N, n), and answers for each row.")
      .def_static(
          "from_urdf",
          [](const std::string& path, std::optional<std::string> tip, std::optional<ArrayArg> gravity) {
            return Model(load_urdf_file(path, urdf_options(tip, gravity)));
          },
          nb::arg("path"), nb::arg("tip") = nb::none(), nb::arg("gravity") = nb::none(),
          "The chain from the URDF file's root to `tip` (a link name; None: the tree's single leaf). Fixed joints "
          "are merged, joints off the chain locked at 0. `gravity`: m/s² in the base frame, default (0, 0, -9.81). "
          "Raises ModelError naming the file and the joint or link at fault.")
      .def_static(
          "from_urdf_string",
          [](const std::string& xml, std::optional<std::string> tip, std::optional<ArrayArg> gravity) {
            return Model(load_urdf_string(xml, urdf_options(tip, gravity)));
          },
          nb::arg("xml"), nb::arg("tip") = nb::none(), nb::arg("gravity") = nb::none(),
          "The same from URDF text.")
      .def(
          "with_armature",
          [](const Model& self, ArrayArg armature) {
            return Model(with_armature(*self.robot, read_vector(armature.object, "armature", self.robot->dof())));
          },
          nb::arg("armature"),
          "This model with each joint's reflected rotor inertia (kg·m² or kg, ≥ 0) on the mass matrix's diagonal.")
      .def_prop_ro("nq", [](const Model& self) { return self.robot->dof(); }, "Number of movable joints n.")
      .def_prop_ro("name", [](const Model& self) { return self.robot->name(); })
      .def_prop_ro("base", [](const Model& self) { return self.robot->base_link(); }, "The chain's root link.")
      .def_prop_ro("tip", [](const Model& self) { return self.robot->tip_link(); }, "The link whose pose fk gives.")
      .def_prop_ro(
          "joint_names",
          [](const Model& self) {
            std::vector<std::string> names;
            for (const Joint& j : self.robot->joints()) names.push_back(j.name);
            return names;
          },
          "Movable joints, root to tip: the order of q.")
      .def_prop_ro(
          "joint_types",
          [](const Model& self) {
            std::vector<std::string> types;
            for (const Joint& j : self.robot->joints()) types.push_back(to_string(j.type));
            return types;
          },
          "'revolute', 'continuous' or 'prismatic' per joint.")
      .def_prop_ro(
          "link_names",
          [](const Model& self) {
            std::vector<std::string> names;
            for (const ChainLink& l : self.robot->links()) names.push_back(l.name);
            return names;
          },
          "Every link of the root → tip path: the order of link_poses.")
      .def_prop_ro("lower", [](const Model& self) { return limits(*self.robot, &JointLimits::lower); },
                   "Lower position limits, rad or m (−π for continuous joints).")
      .def_prop_ro("upper", [](const Model& self) { return limits(*self.robot, &JointLimits::upper); },
                   "Upper position limits, rad or m (π for continuous joints).")
      .def_prop_ro("velocity_limit", [](const Model& self) { return limits(*self.robot, &JointLimits::velocity); },
                   "rad/s or m/s; inf where the URDF gives none (or 0).")
      .def_prop_ro("effort_limit", [](const Model& self) { return limits(*self.robot, &JointLimits::effort); },
                   "N·m or N; inf where the URDF gives none (or 0).")
      .def_prop_ro("gravity_vector", [](const Model& self) { return to_array(self.robot->gravity()); },
                   "Gravity in the base frame, m/s².")
      .def_prop_ro("armature", [](const Model& self) { return to_array(self.robot->armature()); },
                   "Reflected rotor inertia per joint (kg·m² or kg), on M's diagonal.")
      .def_prop_ro("home", [](const Model& self) { return to_array(self.robot->home_tip()); },
                   "M: the tip pose at q = 0, 4×4.")
      .def_prop_ro("space_axes", [](const Model& self) { return to_array(self.robot->space_axes()); },
                   "S: the space screw axes at q = 0, 6×n, rows (ω, v).")
      .def_prop_ro("warnings", [](const Model& self) { return self.robot->warnings(); },
                   "Questionable but loadable data the loader met, one sentence each.")
      .def(
          "fk",
          [](Model& self, ArrayArg q) {
            return evaluate<1>(self, {q.object}, {"q"}, {4, 4}, [&](Data& d, const auto& in, double* out) {
              write_transform(forward_kinematics(*self.robot, d, ConstVector(in[0], self.robot->dof())), out);
            });
          },
          nb::arg("q"), "T_sb(q): the tip pose in the base frame, 4×4 (N×4×4 for a batch).")
      .def(
          "link_poses",
          [](Model& self, ArrayArg q) {
            const npy_intp k = static_cast<npy_intp>(self.robot->links().size());
            return evaluate<1>(self, {q.object}, {"q"}, {k, 4, 4}, [&](Data& d, const auto& in, double* out) {
              const auto& poses = link_poses(*self.robot, d, ConstVector(in[0], self.robot->dof()));
              for (size_t l = 0; l < poses.size(); ++l) write_transform(poses[l], out + 16 * l);
            });
          },
          nb::arg("q"), "The pose of every chain link (link_names order) in the base frame, k×4×4.")
      .def(
          "space_jacobian",
          [](Model& self, ArrayArg q) {
            const int n = self.robot->dof();
            return evaluate<1>(self, {q.object}, {"q"}, {6, n}, [&](Data& d, const auto& in, double* out) {
              RowMajorMap(out, 6, n) = space_jacobian(*self.robot, d, ConstVector(in[0], n));
            });
          },
          nb::arg("q"), "J_s(q), 6×n, rows (ω, v), in the base frame (MR eq. 5.11).")
      .def(
          "body_jacobian",
          [](Model& self, ArrayArg q) {
            const int n = self.robot->dof();
            return evaluate<1>(self, {q.object}, {"q"}, {6, n}, [&](Data& d, const auto& in, double* out) {
              RowMajorMap(out, 6, n) = body_jacobian(*self.robot, d, ConstVector(in[0], n));
            });
          },
          nb::arg("q"), "J_b(q), 6×n, rows (ω, v), in the tip frame (MR eq. 5.18).")
      .def(
          "rnea",
          [](Model& self, ArrayArg q, ArrayArg qd, ArrayArg qdd) {
            const int n = self.robot->dof();
            return evaluate<3>(self, {q.object, qd.object, qdd.object}, {"q", "qd", "qdd"}, {n},
                               [&](Data& d, const auto& in, double* out) {
                                 Eigen::Map<Eigen::VectorXd>(out, n) = inverse_dynamics(
                                     *self.robot, d, ConstVector(in[0], n), ConstVector(in[1], n), ConstVector(in[2], n));
                               });
          },
          nb::arg("q"), nb::arg("qd"), nb::arg("qdd"),
          "τ = M(q) q̈ + c(q, q̇) + g(q), N·m or N, by recursive Newton-Euler (MR §8.3.2).")
      .def(
          "gravity",
          [](Model& self, ArrayArg q) {
            const int n = self.robot->dof();
            return evaluate<1>(self, {q.object}, {"q"}, {n}, [&](Data& d, const auto& in, double* out) {
              Eigen::Map<Eigen::VectorXd>(out, n) = gravity_torques(*self.robot, d, ConstVector(in[0], n));
            });
          },
          nb::arg("q"), "g(q): the joint torques that hold the arm still against gravity.")
      .def(
          "coriolis",
          [](Model& self, ArrayArg q, ArrayArg qd) {
            const int n = self.robot->dof();
            return evaluate<2>(self, {q.object, qd.object}, {"q", "qd"}, {n}, [&](Data& d, const auto& in, double* out) {
              Eigen::Map<Eigen::VectorXd>(out, n) =
                  velocity_product(*self.robot, d, ConstVector(in[0], n), ConstVector(in[1], n));
            });
          },
          nb::arg("q"), nb::arg("qd"), "c = C(q, q̇) q̇: Coriolis and centripetal torques, no gravity.")
      .def(
          "mass_matrix",
          [](Model& self, ArrayArg q) {
            const int n = self.robot->dof();
            return evaluate<1>(self, {q.object}, {"q"}, {n, n}, [&](Data& d, const auto& in, double* out) {
              RowMajorMap(out, n, n) = mass_matrix(*self.robot, d, ConstVector(in[0], n));
            });
          },
          nb::arg("q"), "M(q), n×n, symmetric, armature on the diagonal (composite rigid bodies).")
      .def(
          "forward_dynamics",
          [](Model& self, ArrayArg q, ArrayArg qd, ArrayArg tau) {
            const int n = self.robot->dof();
            return evaluate<3>(self, {q.object, qd.object, tau.object}, {"q", "qd", "tau"}, {n},
                               [&](Data& d, const auto& in, double* out) {
                                 Eigen::Map<Eigen::VectorXd>(out, n) = forward_dynamics(
                                     *self.robot, d, ConstVector(in[0], n), ConstVector(in[1], n), ConstVector(in[2], n));
                               });
          },
          nb::arg("q"), nb::arg("qd"), nb::arg("tau"),
          "q̈ = M⁻¹(τ − c − g). Raises DynamicsError when M(q) is singular.")
      .def(
          "kinetic_energy",
          [](Model& self, ArrayArg q, ArrayArg qd) {
            const int n = self.robot->dof();
            return scalar_result(evaluate<2>(self, {q.object, qd.object}, {"q", "qd"}, {}, [&](Data& d, const auto& in, double* out) {
              *out = kinetic_energy(*self.robot, d, ConstVector(in[0], n), ConstVector(in[1], n));
            }));
          },
          nb::arg("q"), nb::arg("qd"), "½ q̇ᵀ M(q) q̇, J: a float, or an (N,) array for a batch.")
      .def(
          "potential_energy",
          [](Model& self, ArrayArg q) {
            const int n = self.robot->dof();
            return scalar_result(evaluate<1>(self, {q.object}, {"q"}, {}, [&](Data& d, const auto& in, double* out) {
              *out = potential_energy(*self.robot, d, ConstVector(in[0], n));
            }));
          },
          nb::arg("q"), "−Σ m_i gᵀ c_i, J: a float, or an (N,) array for a batch.");
}

// The observer with a Data of its own for the momentum terms of each sample.
struct Observer {
  Observer(const Model& model, const Eigen::VectorXd& gain, const Eigen::VectorXd& damping, const Eigen::VectorXd& coulomb)
      : robot(model.robot), data(*robot), observer(*robot, gain, damping, coulomb) {}
  std::shared_ptr<const RobotModel> robot;
  Data data;
  MomentumObserver observer;
};

Eigen::VectorXd optional_vector(const std::optional<ArrayArg>& v, const char* name, int n) {
  return v ? read_vector(v->object, name, n) : Eigen::VectorXd();
}

void bind_observer(nb::module_& m) {
  nb::class_<Observer>(m, "MomentumObserver",
                       "De Luca and Haddadin's generalized-momentum observer: the external joint torque τ̂_ext from "
                       "q, q̇ and the applied τ, through a first-order lag of bandwidth `gain` (1/s per joint).")
      .def(
          "__init__",
          [](Observer* self, const Model& model, ArrayArg gain, std::optional<ArrayArg> damping,
             std::optional<ArrayArg> coulomb) {
            const int n = model.robot->dof();
            new (self) Observer(model, read_vector(gain.object, "gain", n), optional_vector(damping, "damping", n),
                                optional_vector(coulomb, "coulomb", n));
          },
          nb::arg("model"), nb::arg("gain"), nb::arg("damping") = nb::none(), nb::arg("coulomb") = nb::none(),
          "`gain` K_O, 1/s per joint; `damping` the known viscous damping, N·m·s/rad or N·s/m; `coulomb` the known "
          "Coulomb friction, N·m or N (None: none). Raises ObserverError.")
      .def(
          "reset",
          [](Observer& self, ArrayArg q, ArrayArg qd) {
            const int n = self.robot->dof();
            const Eigen::VectorXd q_ = read_vector(q.object, "q", n), qd_ = read_vector(qd.object, "qd", n);
            momentum_terms(*self.robot, self.data, q_, qd_);
            self.observer.reset(self.data, qd_);
          },
          nb::arg("q"), nb::arg("qd"), "Starts again from the sample (q, q̇) with τ̂_ext = 0.")
      .def(
          "update",
          [](Observer& self, ArrayArg q, ArrayArg qd, ArrayArg tau, double dt) {
            const int n = self.robot->dof();
            const Eigen::VectorXd q_ = read_vector(q.object, "q", n), qd_ = read_vector(qd.object, "qd", n),
                                  tau_ = read_vector(tau.object, "tau", n);
            momentum_terms(*self.robot, self.data, q_, qd_);
            return to_array(self.observer.update(self.data, qd_, tau_, dt));
          },
          nb::arg("q"), nb::arg("qd"), nb::arg("tau"), nb::arg("dt"),
          "Takes the sample (q, q̇) reached dt seconds after the previous one, τ the joint torque applied over that "
          "step; returns τ̂_ext, N·m or N per joint. Before reset(), only starts. A dt that is not positive and finite "
          "is an ArgumentError.")
      .def_prop_ro("external_torque", [](const Observer& self) { return to_array(self.observer.external_torque()); },
                   "The latest τ̂_ext.")
      .def_prop_ro("started", [](const Observer& self) { return self.observer.started(); });

  m.def(
      "tip_wrench_from_torque",
      [](ArrayArg J_b, ArrayArg tau) {
        const InArray J = read_array(J_b.object, "J_b");
        if (J.ndim != 2 || J.shape[0] != 6) {
          throw ArgumentError("J_b has shape " + shape_text(J) + ", expected (6, n)");
        }
        const Eigen::Index n = J.shape[1];
        const Matrix6Xd J_ = read_matrix(J_b.object, "J_b", 6, n);
        return to_array(tip_wrench_from_torque(J_, read_vector(tau.object, "tau", n)));
      },
      nb::arg("J_b"), nb::arg("tau"),
      "F̂ = (J_bᵀ)⁺ τ: the tip wrench (m, f) in the tip frame whose joint torques best match τ, damped near "
      "singularities.");
}

// The bounds and defaults chasles.client checks and fills a command with before sending, read from
// the C++ the controller and the CLI use, so that no copy of them can drift: the quaternion norm
// tolerance (core/lie/so3.hpp), a law's bounds and defaults (controller/law_settings.hpp), the payload's
// bounds (core/model/payload.hpp).
void bind_limits(nb::module_& m) {
  using controller::LawBounds;
  using controller::LawDefaults;
  m.attr("QUATERNION_NORM_TOLERANCE") = kQuaternionNormTolerance;
  m.attr("MAX_JOINT_STIFFNESS") = LawBounds::kMaxJointStiffness;
  m.attr("MAX_ROTATIONAL_STIFFNESS") = LawBounds::kMaxRotationalStiffness;
  m.attr("MAX_TRANSLATIONAL_STIFFNESS") = LawBounds::kMaxTranslationalStiffness;
  m.attr("MAX_NULLSPACE_STIFFNESS") = LawBounds::kMaxNullspaceStiffness;
  m.attr("MIN_DAMPING_RATIO") = LawBounds::kMinDampingRatio;
  m.attr("MAX_DAMPING_RATIO") = LawBounds::kMaxDampingRatio;
  m.attr("MAX_FRAME_OFFSET") = LawBounds::kMaxFrameOffset;
  m.attr("DEFAULT_DAMPING_RATIO") = LawDefaults::kDampingRatio;
  m.attr("DEFAULT_ROTATIONAL_STIFFNESS") = LawDefaults::kRotationalStiffness;
  m.attr("DEFAULT_TRANSLATIONAL_STIFFNESS") = LawDefaults::kTranslationalStiffness;
  m.attr("DEFAULT_NULLSPACE_STIFFNESS") = LawDefaults::kNullspaceStiffness;
  m.attr("MAX_PAYLOAD_MASS") = kMaxPayloadMass;
  m.attr("MAX_PAYLOAD_REACH") = kMaxPayloadReach;
  m.attr("MAX_PAYLOAD_INERTIA") = kMaxPayloadInertia;
}

}  // namespace

}  // namespace chasles::python

NB_MODULE(_core, m) {
  using namespace chasles::python;
  if (_import_array() < 0) throw nb::python_error();
  m.doc() = "chasles's C++ core: the robot model, kinematics, dynamics, observer, IK and calibration.";
  bind_errors(m);
  bind_model(m);
  bind_observer(m);
  bind_solvers(m);
  bind_scene(m);
  bind_limits(m);
}
