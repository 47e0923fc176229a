// Arguments in, numpy arrays out: every check that stands between a Python value and the
// library, with the argument's name in each message.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "bindings.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn::python {

namespace {

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i > 0 ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

py::array_t<double> float64_array(py::handle obj, const char* name,
                                  const std::vector<py::ssize_t>& shape, const std::string& what) {
  py::array array;
  if (py::isinstance<py::array>(obj)) {
    if (!py::isinstance<py::array_t<double>>(obj)) {
      const std::string dtype = py::str(obj.attr("dtype"));
      throw py::type_error(std::string(name) + " must be a float64 array, got dtype " + dtype +
                           "; convert it with " + name + ".astype(numpy.float64)");
    }
    array = py::reinterpret_borrow<py::array>(obj);
  } else {
    if (obj.is_none() || py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj))
      throw py::type_error(std::string(name) + " must be a float64 array of shape " + what +
                           ", got " + std::string(py::str(obj.get_type().attr("__name__"))));
    try {
      array = py::module_::import("numpy").attr("asarray")(obj, "float64");
    } catch (py::error_already_set& e) {
      throw py::type_error(std::string(name) + " must be a float64 array of shape " + what +
                           "; numpy cannot convert it: " + e.what());
    }
  }
  bool ok = array.ndim() == static_cast<py::ssize_t>(shape.size());
  for (size_t i = 0; ok && i < shape.size(); ++i)
    ok = shape[i] < 0 || array.shape(static_cast<py::ssize_t>(i)) == shape[i];
  if (!ok)
    throw py::value_error(std::string(name) + " must have shape " + what + ", got " +
                          shape_text(array));
  // Strides that are not whole doubles, or an unaligned start (views into packed records),
  // are read from an aligned copy.
  bool aligned = reinterpret_cast<std::uintptr_t>(array.data()) % alignof(double) == 0;
  for (py::ssize_t i = 0; aligned && i < array.ndim(); ++i)
    aligned = array.strides(i) % static_cast<py::ssize_t>(sizeof(double)) == 0;
  if (!aligned) array = py::module_::import("numpy").attr("ascontiguousarray")(array);
  return py::array_t<double>(array);
}

std::string copy_coordinates(const Model& model, const double* values, py::ssize_t stride,
                             VectorX& x, const std::string& label) {
  const int n = model.num_bodies();
  for (int i = 0; i < 7 * n; ++i) {
    const double v = values[i * stride];
    if (!std::isfinite(v))
      return label + "[" + std::to_string(i) + "] is " + number(v) + " (" +
             describe_state_component(model, i) + ")";
    x[i] = v;
  }
  for (int k = 0; k < n; ++k) {
    const double norm = x.segment<4>(4 * k).norm();
    if (!(std::abs(norm - 1.0) <= kUnitTolerance))
      return label + ": the Euler parameters of body '" + model.body(k).name + "' (" + label + "[" +
             std::to_string(4 * k) + ":" + std::to_string(4 * k + 4) + "]) have norm " +
             number(norm) +
             "; they must be a unit quaternion (within 1e-6): divide them by their norm";
  }
  return "";
}

std::string copy_speeds(const Model& model, const double* values, py::ssize_t stride, VectorX& y,
                        const std::string& label) {
  const int n = model.num_bodies();
  for (int i = 0; i < 6 * n; ++i) {
    const double v = values[i * stride];
    if (!std::isfinite(v))
      return label + "[" + std::to_string(i) + "] is " + number(v) + " (" +
             describe_state_component(model, 7 * n + i) + ")";
    y[i] = v;
  }
  return "";
}

State state_argument(const PyModel& m, py::handle obj) {
  if (obj.is_none()) return m.file().initial;
  if (!py::isinstance<State>(obj))
    throw py::type_error("state must be a kanedyn.State (e.g. model.initial_state()), got " +
                         std::string(py::str(obj.get_type().attr("__name__"))));
  const State& given = obj.cast<const State&>();
  if (given.num_bodies() != m.N() || given.x.size() != 7 * m.N())
    throw py::value_error("state is of " + std::to_string(given.num_bodies()) +
                          " bodies; the model has N = " + std::to_string(m.N()));
  State state(m.model());
  std::string problem = copy_coordinates(m.model(), given.x.data(), 1, state.x, "state.x");
  if (problem.empty()) problem = copy_speeds(m.model(), given.y.data(), 1, state.y, "state.y");
  if (!problem.empty()) throw py::value_error(problem);
  return state;
}

py::array_t<double> to_numpy(const VectorX& v) {
  py::array_t<double> out(v.size());
  if (v.size() > 0)
    std::memcpy(out.mutable_data(), v.data(), sizeof(double) * static_cast<size_t>(v.size()));
  return out;
}

py::array_t<double> to_numpy(const MatrixX& m) {
  py::array_t<double> out({m.rows(), m.cols()});
  auto o = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) o(i, j) = m(i, j);
  return out;
}

py::array_t<double> to_numpy(const Vector3& v) {
  py::array_t<double> out(3);
  for (int i = 0; i < 3; ++i) out.mutable_data()[i] = v[i];
  return out;
}

py::array_t<double> to_numpy(const Matrix3& m) {
  py::array_t<double> out({3, 3});
  auto o = out.mutable_unchecked<2>();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) o(i, j) = m(i, j);
  return out;
}

py::array_t<double> to_numpy(const std::vector<double>& values, py::ssize_t rows,
                             py::ssize_t cols) {
  py::array_t<double> out({rows, cols});
  if (!values.empty())
    std::memcpy(out.mutable_data(), values.data(), sizeof(double) * values.size());
  return out;
}

}  // namespace kanedyn::python
