// The extension module kanedyn._kanedyn; the package kanedyn (python/kanedyn/__init__.py)
// re-exports it with the Python-side helpers (load, loads, Result).
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "bindings.hpp"
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

/// The getter of State.x or State.y: a numpy view of the vector, keeping the State alive.
auto view(VectorX State::*field) {
  return [field](py::object self) {
    VectorX& v = self.cast<State&>().*field;
    return py::array_t<double>({v.size()}, {sizeof(double)}, v.data(), self);
  };
}

/// The setter: copies a float64 array of the vector's length in.
auto assign(VectorX State::*field, const char* name) {
  return [field, name](State& s, py::object value) {
    VectorX& v = s.*field;
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
  py::class_<State>(m, "State",
                    "The state of Eq. (1): x = (eps_1..eps_N, s'_1..s'_N), 7N, and y = "
                    "(w'_1..w'_N, s'_1 dot..s'_N dot), 6N. eps_K = (e1, e2, e3, e4) with e4 the "
                    "scalar part; w'_K in body-K components; s'_K and its rate in body-L(K) "
                    "components. x and y are numpy views: s.x[3] = 1.0 changes the state.")
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
             State s(static_cast<int>(n));
             copy_vector(xa, s.x);
             copy_vector(ya, s.y);
             return s;
           }),
           py::arg("x"), py::arg("y"), "A state from copies of x (7N,) and y (6N,).")
      .def_property("x", view(&State::x), assign(&State::x, "x"),
                    "{x}, 7N: Euler parameters eps_K then translations s'_K (a view)")
      .def_property("y", view(&State::y), assign(&State::y, "y"),
                    "{y}, 6N: angular velocities w'_K then translation rates s'_K dot (a view)")
      .def_property_readonly("N", &State::num_bodies, "the number of bodies")
      .def(
          "normalize",
          [](State& s) {
            refuse_unscalable(s);
            return s.normalize_euler_parameters();
          },
          "Rescales every eps_K to unit norm; returns the largest | |eps_K| - 1 | found. "
          "ValueError (and the state unchanged) when some eps_K has norm 0 or a non-finite "
          "one: no rotation is near it.")
      .def(
          "copy", [](const State& s) { return State(s); }, "An independent copy.")
      .def("__copy__", [](const State& s) { return State(s); })
      .def("__deepcopy__", [](const State& s, py::handle) { return State(s); })
      .def("__repr__", [](const State& s) {
        return "<kanedyn.State N=" + std::to_string(s.num_bodies()) + ">";
      });
}

}  // namespace kanedyn::python

PYBIND11_MODULE(_kanedyn, m) {
  using namespace kanedyn::python;
  m.doc() = "kanedyn's C++ core: the notes' equations for an unconstrained tree of rigid bodies.";
  m.attr("__version__") = KANEDYN_VERSION;
  register_errors(m);
  register_state(m);
  py::class_<PyModel, std::shared_ptr<PyModel>> model(
      m, "Model",
      "A multibody model loaded from a model file (kanedyn.load, kanedyn.loads). Immutable; "
      "safe to use from several threads at once.");
  register_model(m, model);
  register_run(m, model);
  register_view(model);
}
