// numpy in and out of the extension chasles._core, through numpy's own C API rather than
// nanobind's ndarray: nanobind reads an argument through its __dlpack__ method and makes a result
// by calling numpy.asarray on a buffer object, two Python-level calls per array, where the C API
// checks an array's type and flags in a few loads and makes a result with PyArray_SimpleNew. At
// the few hundred nanoseconds an fk or an rnea of an arm costs, that is the difference between
// beating Pinocchio's Python call (eigenpy uses the C API too) and not.
//
// An argument arrives as it was passed (ArrayArg); read_array takes a float64 C-contiguous numpy
// array as it is and converts anything else numpy can read as float64 under its 'safe' rule
// (lists, integer or float32 arrays, strided views) or refuses it with chasles::ArgumentError.
#pragma once

#define PY_ARRAY_UNIQUE_SYMBOL chasles_python_ARRAY_API
#define NPY_NO_DEPRECATED_API NPY_2_0_API_VERSION
#ifndef CHASLES_PYTHON_IMPORT_ARRAY
#define NO_IMPORT_ARRAY
#endif

#include <nanobind/nanobind.h>
#include <numpy/arrayobject.h>

#include <initializer_list>
#include <string>

#include "core/lie/types.hpp"
#include "core/model/model.hpp"

namespace chasles::python {

namespace nb = nanobind;

/// An array-like argument as Python passed it; the stubs call it numpy.typing.ArrayLike.
struct ArrayArg {
  nb::handle object;
};

/// A new float64 numpy array returned to Python; the stubs call it numpy.typing.NDArray.
struct Array {
  nb::object object;
};

/// A float64, C-contiguous, aligned numpy array read from an argument, kept alive while it is read.
struct InArray {
  nb::object owner;
  const double* data = nullptr;
  int ndim = 0;
  const npy_intp* shape = nullptr;

  npy_intp size() const { return PyArray_SIZE(reinterpret_cast<PyArrayObject*>(owner.ptr())); }
};

/// The Python exception being raised, as "TypeError: what it says", cleared.
std::string take_python_error();

/// The argument `name` as float64 numbers, without a copy when it already is a float64
/// C-contiguous array. Throws ArgumentError with numpy's reason when it cannot be read so.
inline InArray read_array(nb::handle object, const char* name) {
  PyObject* o = object.ptr();
  InArray in;
  if (PyArray_CheckExact(o) && PyArray_TYPE(reinterpret_cast<PyArrayObject*>(o)) == NPY_DOUBLE &&
      PyArray_ISCARRAY_RO(reinterpret_cast<PyArrayObject*>(o))) {
    in.owner = nb::borrow(object);
  } else {
    // NPY_ARRAY_CARRAY_RO: C order, aligned, native byte order; no FORCECAST, so only the casts
    // numpy calls safe (bool, integers, float16/32) are made, and complex or text is refused.
    PyObject* converted = PyArray_FromAny(o, PyArray_DescrFromType(NPY_DOUBLE), 0, 0,
                                          NPY_ARRAY_CARRAY_RO | NPY_ARRAY_ENSUREARRAY, nullptr);
    if (converted == nullptr) {
      throw ArgumentError(std::string(name) + " cannot be read as float64 numbers: " + take_python_error());
    }
    in.owner = nb::steal(converted);
  }
  auto* array = reinterpret_cast<PyArrayObject*>(in.owner.ptr());
  in.data = static_cast<const double*>(PyArray_DATA(array));
  in.ndim = PyArray_NDIM(array);
  in.shape = PyArray_SHAPE(array);
  return in;
}

/// "(2, 3)", as numpy prints a shape.
inline std::string shape_text(const InArray& a) {
  std::string s = "(";
  for (int i = 0; i < a.ndim; ++i) s += (i ? ", " : "") + std::to_string(a.shape[i]);
  return s + (a.ndim == 1 ? ",)" : ")");
}

/// Throws ArgumentError naming the first entry of `a` that is NaN or infinite.
void check_finite(const InArray& a, const char* name);

/// A new uninitialised float64 array of this shape (C order).
inline Array new_array(std::initializer_list<npy_intp> shape) {
  PyObject* a = PyArray_SimpleNew(static_cast<int>(shape.size()), const_cast<npy_intp*>(shape.begin()), NPY_DOUBLE);
  if (a == nullptr) throw nb::python_error();
  return Array{nb::steal(a)};
}

inline double* data(Array& a) { return static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(a.object.ptr()))); }

using RowMajorMap = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

/// T as a row-major 4×4 at `out`.
inline void write_transform(const Transform& T, double* out) {
  Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> M(out);
  M.topLeftCorner<3, 3>() = T.linear();
  M.topRightCorner<3, 1>() = T.translation();
  M.row(3) << 0.0, 0.0, 0.0, 1.0;
}

inline Array to_array(const Transform& T) {
  Array a = new_array({4, 4});
  write_transform(T, data(a));
  return a;
}

/// Any Eigen matrix or vector (rows × cols, or a vector as (rows,)) as a new array.
template <typename Derived>
Array to_array(const Eigen::MatrixBase<Derived>& m) {
  if (Derived::ColsAtCompileTime == 1) {
    Array a = new_array({static_cast<npy_intp>(m.rows())});
    Eigen::Map<Eigen::VectorXd>(data(a), m.rows()) = m;
    return a;
  }
  Array a = new_array({static_cast<npy_intp>(m.rows()), static_cast<npy_intp>(m.cols())});
  RowMajorMap(data(a), m.rows(), m.cols()) = m;
  return a;
}

/// A (rows, cols) argument as a column-major matrix (ArgumentError for another shape or NaN).
Eigen::MatrixXd read_matrix(nb::handle object, const char* name, Eigen::Index rows, Eigen::Index cols);

/// A vector argument of `size` entries (ArgumentError for another shape or NaN).
Eigen::VectorXd read_vector(nb::handle object, const char* name, Eigen::Index size);

}  // namespace chasles::python

namespace nanobind::detail {

template <>
struct type_caster<chasles::python::ArrayArg> {
  NB_TYPE_CASTER(chasles::python::ArrayArg, const_name("numpy.typing.ArrayLike"))
  bool from_python(handle src, uint8_t, cleanup_list*) noexcept {
    value.object = src;
    return true;
  }
};

template <>
struct type_caster<chasles::python::Array> {
  NB_TYPE_CASTER(chasles::python::Array, const_name("numpy.typing.NDArray[numpy.float64]"))
  static handle from_cpp(chasles::python::Array&& a, rv_policy, cleanup_list*) noexcept {
    return a.object.release();
  }
  static handle from_cpp(const chasles::python::Array& a, rv_policy, cleanup_list*) noexcept {
    return a.object.inc_ref();
  }
};

}  // namespace nanobind::detail
