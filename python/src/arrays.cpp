// Arguments in, numpy arrays out: every check that stands between a Python value and the
// library, with the argument's name in each message.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

#include "bindings.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn::python {

namespace {

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i > 0 ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// "x", or "X[12]" for a row of a batch.
std::string label(const char* name, py::ssize_t row) {
  return row < 0 ? std::string(name) : std::string(name) + "[" + std::to_string(row) + "]";
}

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

constexpr int kNpyFloat64 = 12;  // NPY_DOUBLE

}  // namespace

bool is_float64(const py::array& a) {
  // The descriptor's fields directly: a.dtype() would make a new reference on every call of
  // derivatives()'s fast path.
  const auto* descr = py::detail::array_descriptor_proxy(py::detail::array_proxy(a.ptr())->descr);
  return descr->type_num == kNpyFloat64 && descr->byteorder != '>';
}

void copy_vector(const py::array& a, VectorX& v) {
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = doubles(a)[i * stride(a, 0)];
}

py::array float64_array(py::handle obj, const char* name, const std::vector<py::ssize_t>& shape,
                        const std::string& what) {
  py::array array;
  if (py::isinstance<py::array>(obj)) {
    array = py::reinterpret_borrow<py::array>(obj);
    if (!is_float64(array))
      throw py::type_error(std::string(name) + " must be a float64 array, got dtype " +
                           std::string(py::str(static_cast<py::handle>(array.dtype()))) +
                           "; convert it with " + name + ".astype(numpy.float64)");
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
  return array;
}

bool plain_vector(py::handle obj, py::ssize_t size, const double*& data, py::ssize_t& stride) {
  if (!py::isinstance<py::array>(obj)) return false;
  const auto& a = py::reinterpret_borrow<py::array>(obj);
  if (!is_float64(a) || a.ndim() != 1 || a.shape(0) != size ||
      a.strides(0) % static_cast<py::ssize_t>(sizeof(double)) != 0 ||
      reinterpret_cast<std::uintptr_t>(a.data()) % alignof(double) != 0)
    return false;
  data = static_cast<const double*>(a.data());
  stride = a.strides(0) / static_cast<py::ssize_t>(sizeof(double));
  return true;
}

namespace {

/// Copies n doubles from values (stride in doubles) into out; returns the index of the first
/// that is not finite, or -1.
Eigen::Index copy_finite(const double* values, py::ssize_t stride, Eigen::Index n, double* out) {
  if (stride == 1) {
    std::memcpy(out, values, sizeof(double) * static_cast<size_t>(n));
  } else {
    for (Eigen::Index i = 0; i < n; ++i) out[i] = values[i * stride];
  }
  if (Eigen::Map<const VectorX>(out, n).allFinite()) return -1;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!std::isfinite(out[i])) return i;
  return -1;
}

}  // namespace

std::string copy_coordinates(const Model& model, const double* values, py::ssize_t stride,
                             VectorX& x, const char* name, py::ssize_t row) {
  const int n = model.num_bodies();
  if (const Eigen::Index i = copy_finite(values, stride, 7 * n, x.data()); i >= 0)
    return label(name, row) + "[" + std::to_string(i) + "] is " + number(x[i]) + " (" +
           describe_state_component(model, static_cast<int>(i)) + ")";
  for (int k = 0; k < n; ++k) {
    const double norm = x.segment<4>(4 * k).norm();
    if (!(std::abs(norm - 1.0) <= kUnitTolerance))
      return label(name, row) + ": the Euler parameters of body '" + model.body(k).name + "' (" +
             label(name, row) + "[" + std::to_string(4 * k) + ":" + std::to_string(4 * k + 4) +
             "]) have norm " + number(norm) +
             "; they must be a unit quaternion (within 1e-6): divide them by their norm";
  }
  return "";
}

std::string copy_speeds(const Model& model, const double* values, py::ssize_t stride, VectorX& y,
                        const char* name, py::ssize_t row) {
  const int n = model.num_bodies();
  if (const Eigen::Index i = copy_finite(values, stride, 6 * n, y.data()); i >= 0)
    return label(name, row) + "[" + std::to_string(i) + "] is " + number(y[i]) + " (" +
           describe_state_component(model, 7 * n + static_cast<int>(i)) + ")";
  return "";
}

std::string path_argument(py::handle obj, const char* name) {
  const py::module_ os = py::module_::import("os");
  py::object path;
  try {
    path = os.attr("fspath")(obj);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_TypeError)) throw;
    throw py::type_error(std::string(name) + " must be a path (str, bytes or os.PathLike), not " +
                         std::string(py::str(obj.get_type().attr("__name__"))));
  }
  const auto bytes = py::reinterpret_borrow<py::bytes>(
      py::isinstance<py::bytes>(path) ? path : os.attr("fsencode")(path));
  std::string out = bytes;
  if (out.find('\0') != std::string::npos) throw py::value_error("embedded null byte");
  return out;
}

py::str path_str(const std::string& path) {
  PyObject* s = PyUnicode_DecodeFSDefaultAndSize(path.data(), static_cast<Py_ssize_t>(path.size()));
  if (!s) throw py::error_already_set();
  return py::reinterpret_steal<py::str>(s);
}

long long integer_argument(py::handle obj, const std::string& name, long long lo, long long hi) {
  const auto type_name = [&] { return std::string(py::str(obj.get_type().attr("__name__"))); };
  if (PyBool_Check(obj.ptr())) throw py::type_error(name + " must be an integer, got a bool");
  PyObject* index = PyNumber_Index(obj.ptr());
  if (!index) {
    PyErr_Clear();
    throw py::type_error(name + " must be an integer, got " + type_name());
  }
  const auto value = py::reinterpret_steal<py::int_>(index);
  int overflow = 0;
  const long long v = PyLong_AsLongLongAndOverflow(value.ptr(), &overflow);
  if (overflow == 0 && v >= lo && v <= hi) return v;
  // str() of an int of thousands of digits raises (Python 3.11's limit); a huge one is
  // shown by its first digits.
  std::string text;
  try {
    text = py::str(static_cast<py::handle>(value));
  } catch (py::error_already_set&) {
    text = "(an integer of more than 4300 digits)";
  }
  if (text.size() > 40)
    text = text.substr(0, 20) + "... (" + std::to_string(text.size()) + " digits)";
  throw py::value_error(name + " " + text + " is not in " + std::to_string(lo) + ".." +
                        std::to_string(hi));
}

long long index_argument(py::handle obj, const std::string& name, long long lo, long long hi) {
  try {
    return integer_argument(obj, name, lo, hi);
  } catch (const py::value_error& e) {
    throw py::index_error(e.what());
  }
}

namespace {

std::string type_name(py::handle obj) { return py::str(obj.get_type().attr("__name__")); }

}  // namespace

std::shared_ptr<PyModel> model_argument(py::handle obj, const char* name) {
  if (!py::isinstance<PyModel>(obj))
    throw py::type_error(std::string(name) + " must be a kanedyn.Model (kanedyn.load(...)), got " +
                         type_name(obj));
  return obj.cast<std::shared_ptr<PyModel>>();
}

std::string shown_value(py::handle value) {
  std::string shown;
  try {
    shown = py::repr(value);
  } catch (py::error_already_set&) {  // str() of an int of more than 4300 digits raises
    return "an integer of more than 4300 digits";
  }
  if (shown.size() > 40)
    shown = shown.substr(0, 20) + "... (" + std::to_string(shown.size()) + " characters)";
  return shown;
}

double number_argument(py::handle obj, const char* name) {
  if (PyFloat_Check(obj.ptr())) return PyFloat_AS_DOUBLE(obj.ptr());
  const auto refuse = [&] {
    return py::type_error(std::string(name) + " must be a number, got " + type_name(obj));
  };
  // A bool is a number to Python, but True for a time or a tolerance is a mistake.
  if (PyBool_Check(obj.ptr()) || PyUnicode_Check(obj.ptr()) || PyBytes_Check(obj.ptr()))
    throw refuse();
  const double v = PyFloat_AsDouble(obj.ptr());
  if (v == -1.0 && PyErr_Occurred()) {
    // An int beyond the range of a double is a number, just not a finite one.
    const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError) && PyIndex_Check(obj.ptr());
    PyErr_Clear();
    if (!overflow) throw refuse();
    const int negative = PyObject_RichCompareBool(obj.ptr(), py::int_(0).ptr(), Py_LT);
    if (negative < 0) throw py::error_already_set();
    return negative ? -std::numeric_limits<double>::infinity()
                    : std::numeric_limits<double>::infinity();
  }
  return v;
}

double finite_argument(py::handle obj, const char* name) {
  const double v = number_argument(obj, name);
  if (!std::isfinite(v))
    throw py::value_error(std::string(name) + " must be finite, got " + shown_value(obj));
  return v;
}

double positive_setting(py::handle obj, const char* name) {
  const double v = number_argument(obj, name);
  if (!(std::isfinite(v) && v > 0.0))
    throw py::value_error(std::string(name) + " must be a finite number > 0, got " +
                          shown_value(obj));
  return v;
}

std::string string_argument(py::handle obj, const char* name) {
  if (!PyUnicode_Check(obj.ptr()))
    throw py::type_error(std::string(name) + " must be a str, got " + type_name(obj));
  return obj.cast<std::string>();
}

bool bool_argument(py::handle obj, const char* name) {
  if (PyBool_Check(obj.ptr())) return obj.ptr() == Py_True;
  if (py::isinstance(obj, py::module_::import("numpy").attr("bool_"))) return obj.cast<bool>();
  throw py::type_error(std::string(name) + " must be True or False, got " + type_name(obj));
}

namespace {

/// The notes' x, y of a Python State of the notes, checked for this model: N, finite, unit
/// Euler parameters.
State checked_notes(const PyModel& m, const State& given) {
  if (given.num_bodies() != m.N() || given.x.size() != 7 * m.N())
    throw py::value_error("state is of " + std::to_string(given.num_bodies()) +
                          (given.num_bodies() == 1 ? " body" : " bodies") +
                          "; the model has N = " + std::to_string(m.N()));
  State state(m.model());
  std::string problem = copy_coordinates(m.model(), given.x.data(), 1, state.x, "state.x");
  if (problem.empty()) problem = copy_speeds(m.model(), given.y.data(), 1, state.y, "state.y");
  if (!problem.empty()) throw py::value_error(problem);
  return state;
}

}  // namespace

std::string model_state_problem(const PyModel& m, const VectorX& q, const VectorX& z,
                                const std::string& qname, const std::string& zname) {
  const Model& model = m.model();
  for (Eigen::Index i = 0; i < q.size(); ++i)
    if (!std::isfinite(q[i])) return qname + "[" + std::to_string(i) + "] is " + number(q[i]);
  for (Eigen::Index i = 0; i < z.size(); ++i)
    if (!std::isfinite(z[i])) return zname + "[" + std::to_string(i) + "] is " + number(z[i]);
  for (int k = 0; k < m.N(); ++k) {
    const JointType type = model.joint(k).type;
    const VectorX slice = q.segment(model.coordinate_offset(k), coordinate_count(type));
    if (const std::string problem = check_joint_coordinates(type, slice); !problem.empty())
      return qname + ": body '" + model.body(k).name + "': " + problem;
  }
  return "";
}

namespace {

void check_model_state(const PyModel& m, const VectorX& q, const VectorX& z, const char* qname,
                       const char* zname) {
  if (const std::string problem = model_state_problem(m, q, z, qname, zname); !problem.empty())
    throw py::value_error(problem);
}

/// obj as a vector of n doubles into v.
void read_vector(py::handle obj, const char* name, int n, VectorX& v) {
  const auto a = float64_array(obj, name, {n}, "(" + std::to_string(n) + ",)");
  v.resize(n);
  copy_vector(a, v);
}

}  // namespace

void model_state(const PyModel& m, py::handle obj, VectorX& q, VectorX& z) {
  const Model& model = m.model();
  if (obj.is_none()) {
    q = m.file().q;
    z = m.file().z;
    return;
  }
  if (!py::isinstance<PyState>(obj))
    throw py::type_error("state must be a kanedyn.State (e.g. model.initial_state()), got " +
                         std::string(py::str(obj.get_type().attr("__name__"))));
  const PyState& given = obj.cast<const PyState&>();
  if (!given.jointed()) {
    const State notes = checked_notes(m, given.notes);
    try {
      joint_coordinates(model, notes, q, z);
    } catch (const std::invalid_argument& e) {
      throw py::value_error(e.what());
    }
    return;
  }
  const Model& other = given.model->model();
  bool same = other.num_bodies() == model.num_bodies();
  for (int k = 0; same && k < model.num_bodies(); ++k)
    same = other.joint(k).type == model.joint(k).type;
  if (!same)
    throw py::value_error(
        "state holds the joint coordinates of another model (its joints differ from this "
        "model's)");
  q = given.q;
  z = given.z;
  check_model_state(m, q, z, "state.q", "state.z");
}

void model_state(const PyModel& m, py::handle state, py::handle q_obj, py::handle z_obj, VectorX& q,
                 VectorX& z) {
  if (!state.is_none() && (!q_obj.is_none() || !z_obj.is_none()))
    throw py::value_error("give the state or q and z, not both");
  model_state(m, state, q, z);
  if (!q_obj.is_none()) read_vector(q_obj, "q", m.model().num_coordinates(), q);
  if (!z_obj.is_none()) read_vector(z_obj, "z", m.model().num_speeds(), z);
  if (!q_obj.is_none() || !z_obj.is_none()) check_model_state(m, q, z, "q", "z");
}

State notes_state(const PyModel& m, py::handle obj) {
  if (!m.notes_layout())
    throw py::value_error(
        "this model has joints: its state is the joint coordinates q and "
        "speeds z, not the notes' x and y");
  if (obj.is_none()) return m.file().initial;
  if (!py::isinstance<PyState>(obj))
    throw py::type_error("state must be a kanedyn.State (e.g. model.initial_state()), got " +
                         std::string(py::str(obj.get_type().attr("__name__"))));
  const PyState& given = obj.cast<const PyState&>();
  if (given.jointed())
    throw py::value_error(
        "state holds the joint coordinates of another model (this one's joints are all free)");
  return checked_notes(m, given.notes);
}

void input_values(const PyModel& m, py::handle obj, VectorX& u, const char* name) {
  const Model& model = m.model();
  const int count = model.num_inputs();
  u.setZero(count);
  if (obj.is_none()) return;
  std::string names;
  for (const Input& in : model.inputs()) names += (names.empty() ? "" : ", ") + in.name;
  const py::array a =
      float64_array(obj, name, {count},
                    "(m,) = (" + std::to_string(count) + ",), one value per input of the model" +
                        (count > 0 ? " (" + names + ")" : " (it has none)"));
  copy_vector(a, u);
  for (int i = 0; i < count; ++i)
    if (!std::isfinite(u[i]))
      throw py::value_error(std::string(name) + "[" + std::to_string(i) + "] is " +
                            (std::isnan(u[i]) ? "nan" : "inf") + " (input '" +
                            model.inputs()[static_cast<size_t>(i)].name + "')");
}

void speed_vector(const PyModel& m, py::handle obj, VectorX& v, const char* name) {
  const int n = m.model().num_speeds();
  const py::array a =
      float64_array(obj, name, {n}, "(n,) = (" + std::to_string(n) + ",), one per speed z");
  v.resize(n);
  copy_vector(a, v);
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      throw py::value_error(
          std::string(name) + "[" + std::to_string(i) + "] is not finite (" +
          describe_joint_state_component(m.model(), m.model().num_coordinates() + i) + ")");
}

PyState make_state(const std::shared_ptr<const PyModel>& m, const VectorX& q, const VectorX& z) {
  PyState s;
  if (m->notes_layout()) {
    s.notes = State(m->model());
    joint_state(m->model(), q, z, s.notes);
  } else {
    s.q = q;
    s.z = z;
    s.model = m;
  }
  return s;
}

py::array_t<double> to_numpy(const VectorX& v) {
  // Straight through numpy's C API: py::array_t's shape and stride containers cost four heap
  // allocations, a fifth of derivatives()'s call overhead.
  auto& api = py::detail::npy_api::get();
  Py_intptr_t size = v.size();
  PyObject* out =
      api.PyArray_NewFromDescr_(api.PyArray_Type_, api.PyArray_DescrFromType_(kNpyFloat64), 1,
                                &size, nullptr, nullptr, 0, nullptr);
  if (!out) throw py::error_already_set();
  auto array = py::reinterpret_steal<py::array_t<double>>(out);
  if (size > 0)
    std::memcpy(array.mutable_data(), v.data(), sizeof(double) * static_cast<size_t>(size));
  return array;
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
