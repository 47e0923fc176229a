// The extension module kanedyn._kanedyn; the package kanedyn (python/kanedyn/__init__.py)
// re-exports it with the Python-side helpers (load, loads, Result).
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "bindings.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/version.hpp"

namespace kanedyn::python {

namespace {

/// kanedyn.ModelError, created at import. A handle that is never released: a static
/// py::object would be destroyed after the interpreter.
py::handle& model_error_type() {
  static py::handle type;
  return type;
}

}  // namespace

void raise_model_error(const io::ModelFileError& e) {
  py::gil_scoped_acquire acquire;
  py::object error = model_error_type()(e.what());
  error.attr("file") = e.file();
  error.attr("line") = e.line();
  error.attr("column") = e.column();
  error.attr("key_path") = e.key_path();
  error.attr("problem") = e.problem();
  PyErr_SetObject(model_error_type().ptr(), error.ptr());
  throw py::error_already_set();
}

void register_errors(py::module_& m) {
  model_error_type() = py::handle(PyErr_NewExceptionWithDoc(
      "kanedyn.ModelError",
      "A model that cannot be read or is not valid. str(e) is the line the command-line tool "
      "prints, FILE:LINE:COL: KEY.PATH: problem; the parts are e.file, e.line, e.column "
      "(1-based, 0 if unknown), e.key_path and e.problem.",
      PyExc_ValueError, nullptr));
  m.attr("ModelError") = model_error_type();  // the module holds a reference of its own
  m.attr("SimulationError") = py::reinterpret_steal<py::object>(PyErr_NewExceptionWithDoc(
      "kanedyn.SimulationError",
      "A simulation that failed (non-finite state, step size underflow): str(e) says when and "
      "which body; e.result holds the rows computed before (or None), e.stats the statistics.",
      PyExc_RuntimeError, nullptr));
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const io::ModelFileError& e) {
      raise_model_error(e);
    } catch (const ModelError& e) {
      PyErr_SetString(model_error_type().ptr(), e.what());
    }
  });
}

namespace {

/// A numpy view of v, keeping `owner` (the Python State) alive.
py::array_t<double> view_of(VectorX& v, py::handle owner) {
  return py::array_t<double>({v.size()}, {sizeof(double)}, v.data(), owner);
}

/// A read-only copy of v: a computed array, whose change would change nothing.
py::array_t<double> computed(const VectorX& v) {
  py::array_t<double> out = to_numpy(v);
  py::detail::array_proxy(out.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return out;
}

/// The notes' state of a state of joint coordinates.
State notes_of(const PyState& s) {
  State notes(s.model->model());
  joint_state(s.model->model(), s.q, s.z, notes);
  return notes;
}

/// q and z of a notes' state, body by body: q_K = (eps_K, s'_K), z_K = (w'_K, s'_K dot).
void body_by_body(const State& s, VectorX& q, VectorX& z) {
  const int n = s.num_bodies();
  q.resize(7 * n);
  z.resize(6 * n);
  for (int k = 0; k < n; ++k) {
    q.segment<4>(7 * k) = s.x.segment<4>(4 * k);
    q.segment<3>(7 * k + 4) = s.x.segment<3>(4 * n + 3 * k);
    z.segment<3>(6 * k) = s.y.segment<3>(3 * k);
    z.segment<3>(6 * k + 3) = s.y.segment<3>(3 * n + 3 * k);
  }
}

/// The getter of State.x / .y (notes = true) or .q / .z: the stored vector as a view, or a
/// read-only copy of the computed one.
auto getter(bool notes, bool first) {
  return [notes, first](py::object self) -> py::array_t<double> {
    PyState& s = self.cast<PyState&>();
    if (notes != s.jointed()) {
      VectorX& stored = notes ? (first ? s.notes.x : s.notes.y) : (first ? s.q : s.z);
      return view_of(stored, self);
    }
    if (notes) {
      const State computed_notes = notes_of(s);
      return computed(first ? computed_notes.x : computed_notes.y);
    }
    VectorX q, z;
    body_by_body(s.notes, q, z);
    return computed(first ? q : z);
  };
}

/// The setter: copies a float64 array of the vector's length into the stored vector; the
/// computed ones are refused.
auto setter(bool notes, bool first, const char* name) {
  return [notes, first, name](PyState& s, py::object value) {
    if (notes == s.jointed())
      throw py::attribute_error(
          std::string(name) + " of this state is computed from " +
          (s.jointed() ? "its joint coordinates: set q and z" : "x and y: set x and y"));
    VectorX& v = notes ? (first ? s.notes.x : s.notes.y) : (first ? s.q : s.z);
    copy_vector(float64_array(value, name, {v.size()}, "(" + std::to_string(v.size()) + ",)"), v);
  };
}

/// The most bodies a State built from Python may have: 7N is an int in the library.
constexpr py::ssize_t kMaxStateBodies = std::numeric_limits<int>::max() / 7;

/// Throws ValueError naming the first body whose eps_K cannot be scaled to unit norm (norm 0,
/// or not finite), before any is changed. The library's normalize_euler_parameters would
/// divide by that norm and fill the state with nan: simulate() relies on that to report a
/// non-finite initial state in its statistics, but from Python it is a silent wrong state.
void refuse_unscalable(const State& s) {
  for (int k = 0; k < s.num_bodies(); ++k) {
    const double norm = s.euler_parameters(k).norm();
    if (std::isfinite(norm) && norm > 0.0) continue;
    char shown[32];
    std::snprintf(shown, sizeof shown, "%g", norm);
    throw py::value_error("normalize(): the Euler parameters of body " + std::to_string(k + 1) +
                          " (x[" + std::to_string(4 * k) + ":" + std::to_string(4 * k + 4) +
                          "]) have norm " + shown + "; they cannot be scaled to a unit quaternion");
  }
}

}  // namespace

void register_state(py::module_& m) {
  py::class_<PyState>(
      m, "State",
      "The state of a model. Of an all-free model (and State(x, y)): the notes' x = "
      "(eps_1..eps_N, s'_1..s'_N), 7N, and y = (w'_1..w'_N, s'_1 dot..s'_N dot), 6N (Eq. 1), "
      "eps_K = (e1, e2, e3, e4) with e4 the scalar part; w'_K in body-K components; s'_K and "
      "its rate in body-L(K) components. Of a model with joints (Model.state(q=, z=), "
      "Model.initial_state()): its joint coordinates q and speeds z. The stored arrays (x and y, "
      "or q and z) are numpy views: s.x[3] = 1.0 changes the state; the other two are computed "
      "from them, read-only.")
      .def(py::init([](py::object x, py::object y) {
             const auto xa = float64_array(x, "x", {-1}, "(7N,)");
             const py::ssize_t n = xa.shape(0) / 7;
             if (xa.shape(0) % 7 != 0 || n == 0)
               throw py::value_error("x must have shape (7N,) for some N >= 1, got (" +
                                     std::to_string(xa.shape(0)) + ",)");
             // A broadcast array can claim any length; 7N must fit the library's int.
             if (n > kMaxStateBodies)
               throw py::value_error("x must have shape (7N,) for N in 1.." +
                                     std::to_string(kMaxStateBodies) + ", got (" +
                                     std::to_string(xa.shape(0)) + ",)");
             const auto ya = float64_array(y, "y", {6 * n},
                                           "(6N,) = (" + std::to_string(6 * n) +
                                               ",) for N = " + std::to_string(n) + " (from x)");
             PyState s;
             s.notes = State(static_cast<int>(n));
             copy_vector(xa, s.notes.x);
             copy_vector(ya, s.notes.y);
             return s;
           }),
           py::arg("x"), py::arg("y"),
           "A state of the notes from copies of x (7N,) and y (6N,). A model with joints takes "
           "it where its joints allow (Model.state(x=, y=)).")
      .def_property("x", getter(true, true), setter(true, true, "x"),
                    "{x}, 7N: Euler parameters eps_K then translations s'_K")
      .def_property("y", getter(true, false), setter(true, false, "y"),
                    "{y}, 6N: angular velocities w'_K then translation rates s'_K dot")
      .def_property("q", getter(false, true), setter(false, true, "q"),
                    "the joint coordinates, body by body (Model.joint_layout); of an all-free "
                    "model q_K = (eps_K, s'_K)")
      .def_property("z", getter(false, false), setter(false, false, "z"),
                    "the independent speeds, body by body; of an all-free model z_K = (w'_K, "
                    "s'_K dot)")
      .def_property_readonly(
          "jointed", [](const PyState& s) { return s.jointed(); },
          "True when the state stores joint coordinates q, z (a model with joints), False when "
          "it stores the notes' x, y")
      .def_property_readonly(
          "N",
          [](const PyState& s) {
            return s.jointed() ? s.model->model().num_bodies() : s.notes.num_bodies();
          },
          "the number of bodies")
      .def(
          "normalize",
          [](PyState& s) {
            if (!s.jointed()) {
              refuse_unscalable(s.notes);
              return s.notes.normalize_euler_parameters();
            }
            const Model& model = s.model->model();
            for (int k = 0; k < model.num_bodies(); ++k) {
              const JointType type = model.joint(k).type;
              if (!joint_type_info(type).euler) continue;
              const double norm = s.q.segment<4>(model.coordinate_offset(k)).norm();
              if (std::isfinite(norm) && norm > 0.0) continue;
              throw py::value_error("normalize(): the Euler parameters of body '" +
                                    model.body(k).name +
                                    "' have a norm of 0 or not finite; they cannot be scaled "
                                    "to a unit quaternion");
            }
            return normalize_joint_coordinates(model, s.q);
          },
          "Rescales every set of Euler parameters (eps_K, or a spherical joint's) to unit norm; "
          "returns the largest | |e| - 1 | found. ValueError (and the state unchanged) when some "
          "has norm 0 or a non-finite one: no rotation is near it.")
      .def(
          "copy", [](const PyState& s) { return PyState(s); }, "An independent copy.")
      .def("__copy__", [](const PyState& s) { return PyState(s); })
      .def("__deepcopy__", [](const PyState& s, py::handle) { return PyState(s); })
      .def("__repr__", [](const PyState& s) {
        if (!s.jointed()) return "<kanedyn.State N=" + std::to_string(s.notes.num_bodies()) + ">";
        return "<kanedyn.State N=" + std::to_string(s.model->model().num_bodies()) +
               ", joint coordinates q (" + std::to_string(s.q.size()) + ",), z (" +
               std::to_string(s.z.size()) + ",)>";
      });
}

}  // namespace kanedyn::python

PYBIND11_MODULE(_kanedyn, m) {
  using namespace kanedyn::python;
  m.doc() = "kanedyn's C++ core: the notes' equations for an unconstrained tree of rigid bodies.";
  m.attr("__version__") = KANEDYN_VERSION;
  register_errors(m);
  register_state(m);
  register_study(m);
  py::class_<PyModel, std::shared_ptr<PyModel>> model(
      m, "Model",
      "A multibody model loaded from a model file (kanedyn.load, kanedyn.loads). Immutable; "
      "safe to use from several threads at once.");
  register_model(m, model);
  register_run(m, model);
  register_view(model);
  register_control(m, model);
  register_analysis(model);
  register_constraints(model);
}
