// Inputs and control: Model.inputs, forward dynamics with inputs (Model.forward), the terms of
// the equations of motion (inverse dynamics, mass matrix, bias and gravity forces, centre of
// mass), and kanedyn.Simulator, the step API whose step() is a plain CPython method so that a
// control loop in Python pays little over the C++ step.
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulator.hpp"
#include "kanedyn/terms.hpp"

namespace kanedyn::python {

namespace {

/// Simulators from this many bodies on step without the GIL (releasing it costs about 0.1 us).
constexpr int kReleaseGilBodies = 32;

/// The model's joint coordinates q of a Python argument: a State, an array q, or None (the
/// initial state), checked as model_state() checks them.
VectorX coordinates_of(const PyModel& m, py::handle obj) {
  VectorX q, z;
  if (obj.is_none() || py::isinstance<PyState>(obj))
    model_state(m, obj, q, z);
  else
    model_state(m, py::none(), obj, py::none(), q, z);
  return q;
}

/// Model.forward(state, u) or Model.forward(q, z, u): z dot = F(q, z, u).
py::array_t<double> forward(const PyModel& m, py::object first, py::object second,
                            py::object u_obj) {
  VectorX q, z;
  py::object u = u_obj;
  if (py::isinstance<PyState>(first)) {
    if (!second.is_none() && !u_obj.is_none())
      throw py::type_error("forward(state, u) takes a State and u, or q, z and u");
    if (!second.is_none()) u = second;
    model_state(m, first, q, z);
  } else {
    model_state(m, py::none(), first, second, q, z);
  }
  PyModel::Lease work(m);
  work->use_inputs(m, u);
  Dynamics& dynamics = work->any_dynamics(m.model());
  dynamics.set_inputs(work->u);
  VectorX zdot(m.model().num_speeds());
  dynamics.evaluate(q, z, zdot);
  return to_numpy(zdot);
}

/// A generalized force of the terms (n values) at a state, in a pooled workspace.
template <class Compute>
py::array_t<double> generalized(const PyModel& m, const Compute& compute) {
  VectorX out(m.model().num_speeds());
  PyModel::Lease work(m);
  compute(work->terms_of(m.model()), out);
  return to_numpy(out);
}

void register_terms(py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  cls.def(
         "inverse_dynamics",
         [](const PyModel& m, py::object state, py::object zdot_obj, py::object u_obj) {
           VectorX q, z, zdot, u;
           model_state(m, state, q, z);
           speed_vector(m, zdot_obj, zdot, "zdot");
           input_values(m, u_obj, u);
           return generalized(m,
                              [&](Terms& t, VectorX& Q) { t.inverse_dynamics(q, z, zdot, Q, &u); });
         },
         py::arg("state"), py::arg("zdot"), py::arg("u") = py::none(),
         "The generalized forces Q (n, in the order of z and dual to it) that, added to the "
         "model's own loads and its inputs' (u; None: all 0), give the motion zdot at the state: "
         "M zdot = f_z + Q, so that forward() of the model with Q added returns zdot. O(N).")
      .def(
          "mass_matrix",
          [](const PyModel& m, py::object state) {
            const VectorX q = coordinates_of(m, state);
            const int n = m.model().num_speeds();
            MatrixX M(n, n);
            PyModel::Lease work(m);
            work->terms_of(m.model()).mass_matrix(q, M);
            return to_numpy(M);
          },
          py::arg("state") = py::none(),
          "The mass matrix M(q) = [C]^T [A] [C] (n x n), at a State or joint coordinates q "
          "(default: the initial state): eom()'s A_z for a model with joints.")
      .def(
          "bias_forces",
          [](const PyModel& m, py::object state, py::object u_obj) {
            VectorX q, z, u;
            model_state(m, state, q, z);
            input_values(m, u_obj, u);
            return generalized(m, [&](Terms& t, VectorX& b) { t.bias_forces(q, z, b, &u); });
          },
          py::arg("state") = py::none(), py::arg("u") = py::none(),
          "The bias forces b(q, z) = inverse_dynamics(state, 0, u): the velocity terms minus the "
          "model's own loads (and its inputs'), so that M zdot + b = Q.")
      .def(
          "gravity_forces",
          [](const PyModel& m, py::object state) {
            const VectorX q = coordinates_of(m, state);
            return generalized(m, [&](Terms& t, VectorX& g) { t.gravity_forces(q, g); });
          },
          py::arg("state") = py::none(),
          "The gravity forces g(q): minus the generalized force of gravity alone (Pinocchio's "
          "sign), at a State or joint coordinates q.")
      .def(
          "centre_of_mass",
          [](const PyModel& m, py::object state) {
            VectorX q, z;
            model_state(m, state, q, z);
            PyModel::Lease work(m);
            Terms& t = work->terms_of(m.model());
            const Vector3 p = t.centre_of_mass(q);
            const Vector3 v = t.centre_of_mass_velocity(q, z);
            return py::make_tuple(to_numpy(p), to_numpy(v));
          },
          py::arg("state") = py::none(),
          "(position, velocity) of the system's centre of mass, inertial components.")
      .def(
          "centre_of_mass_jacobian",
          [](const PyModel& m, py::object state) {
            const VectorX q = coordinates_of(m, state);
            MatrixX J(3, m.model().num_speeds());
            PyModel::Lease work(m);
            work->terms_of(m.model()).centre_of_mass_jacobian(q, J);
            return to_numpy(J);
          },
          py::arg("state") = py::none(),
          "The 3 x n Jacobian J of the centre of mass (its velocity is J @ state.z), inertial "
          "components, at a State or joint coordinates q.")
      .def("forward", &forward, py::arg("state"), py::arg("z") = py::none(),
           py::arg("u") = py::none(),
           "Forward dynamics with inputs, as Pinocchio's aba(q, v, tau) with u for tau: "
           "forward(state, u) or forward(q, z, u) -> zdot (n), the rates of the speeds z at the "
           "state with the inputs at u (None: all 0). The articulated-body recursion (the fused "
           "pass of the notes for an all-free model), the Euler parameters as given. For a model "
           "with constraints, the constrained z dot ([B]{z dot} + {b} = 0, what simulate() "
           "integrates; constrained_forward() adds the multipliers and reactions).");
}

// --- kanedyn.Simulator --------------------------------------------------------------------

/// Python's kanedyn.Simulator: a Simulator of a model that it keeps alive.
struct PySimulator {
  std::shared_ptr<PyModel> model;
  std::unique_ptr<Simulator> sim;
  double dt = std::numeric_limits<double>::quiet_NaN();  ///< step()'s default dt, if given
  VectorX u;  ///< u read through its strides, when not contiguous
  /// Set while a call runs without the GIL (models of kReleaseGilBodies or more, _time_steps),
  /// so that another thread's step() or set_state() is refused rather than racing it.
  std::atomic<bool> busy{false};
  /// What the simulator's on_step asks between dopri5's steps within one step() (Ctrl-C), or
  /// null: set by step() for its call.
  StepHook* hook = nullptr;
};

/// Holds PySimulator::busy for a call; RuntimeError when another thread holds it.
class Busy {
 public:
  explicit Busy(PySimulator& s) : s_(s) {
    if (s_.busy.exchange(true))
      throw std::runtime_error("Simulator: another thread is stepping this simulator");
  }
  ~Busy() { s_.busy = false; }
  Busy(const Busy&) = delete;
  Busy& operator=(const Busy&) = delete;

 private:
  PySimulator& s_;
};

[[noreturn]] void raise_simulation_error(const std::string& message) {
  const py::object type = py::module_::import("kanedyn._kanedyn").attr("SimulationError");
  PyErr_SetString(type.ptr(), message.c_str());
  throw py::error_already_set();
}

/// One step with u held; C++ errors as Python's (ValueError; SimulationError for a failure; a
/// Python exception raised between dopri5's steps, KeyboardInterrupt for Ctrl-C, as it is).
void step_with(PySimulator& s, py::handle u_obj, double dt) {
  const Busy busy(s);  // before s.u is touched
  const int count = s.model->model().num_inputs();
  const double* data = nullptr;
  py::ssize_t stride = 1;
  // A list, or an array of another dtype or alignment: converted (and checked) into s.u.
  if (!plain_vector(u_obj, count, data, stride)) {
    input_values(*s.model, u_obj, s.u);
    data = s.u.data();
  } else if (stride != 1) {
    s.u.resize(count);
    for (int i = 0; i < count; ++i) s.u[i] = data[i * stride];
    data = s.u.data();
  }
  const Eigen::Map<const VectorX> u(data, count);
  // dopri5 may take any number of steps to cover dt (1e6 s takes minutes): it runs without the
  // GIL and looks at Python's signals between its steps, as simulate() does. rk4 is one step,
  // held under the GIL for small models (releasing it costs about 0.1 us).
  std::optional<StepHook> hook;
  if (s.sim->settings().integrator == Integrator::dopri5) hook.emplace(py::none(), 0.0);
  s.hook = hook ? &*hook : nullptr;
  struct Unhook {  // before the hook goes, however the step ends
    PySimulator& s;
    ~Unhook() { s.hook = nullptr; }
  } unhook{s};
  try {
    if (hook || s.model->N() >= kReleaseGilBodies) {
      py::gil_scoped_release release;
      s.sim->step(u, dt);
    } else {
      s.sim->step(u, dt);
    }
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  } catch (const std::runtime_error& e) {
    if (hook && hook->failed()) {
      hook->restore();
      throw py::error_already_set();
    }
    raise_simulation_error(e.what());
  }
}

/// step(u, dt=None) as a plain CPython method (METH_FASTCALL): pybind11's dispatcher would
/// cost about as much as a small model's step.
PyObject* step_fastcall(PyObject* self, PyObject* const* args, Py_ssize_t nargs,
                        PyObject* kwnames) {
  try {
    PyObject* given[2] = {nullptr, nullptr};
    static const char* const names[2] = {"u", "dt"};
    if (nargs > 2) throw py::type_error("step() takes u and dt, got more arguments");
    for (Py_ssize_t i = 0; i < nargs; ++i) given[i] = args[i];
    const Py_ssize_t keywords = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
    for (Py_ssize_t i = 0; i < keywords; ++i) {
      const char* key = PyUnicode_AsUTF8(PyTuple_GET_ITEM(kwnames, i));
      if (!key) throw py::error_already_set();
      int slot = -1;
      for (int j = 0; j < 2; ++j)
        if (std::strcmp(key, names[j]) == 0) slot = j;
      if (slot < 0)
        throw py::type_error("step() got an unexpected keyword argument '" + std::string(key) +
                             "'");
      if (given[slot])
        throw py::type_error("step() got multiple values for argument '" + std::string(key) + "'");
      given[slot] = args[nargs + i];
    }
    auto* s = reinterpret_cast<py::detail::instance*>(self)
                  ->get_value_and_holder()
                  .value_ptr<PySimulator>();
    if (!s || !s->sim) throw py::type_error("step() called on an uninitialized Simulator");
    if (!given[0]) throw py::type_error("step() needs u, the inputs' values over the step");
    double dt = s->dt;
    if (given[1] && given[1] != Py_None) {
      dt = PyFloat_AsDouble(given[1]);
      if (dt == -1.0 && PyErr_Occurred()) {
        const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError);
        PyErr_Clear();
        if (overflow) throw py::value_error("dt must be a finite number > 0");
        throw py::type_error("dt must be a number");
      }
    } else if (std::isnan(dt)) {
      throw py::type_error("step() needs dt (or a Simulator made with dt=)");
    }
    step_with(*s, py::handle(given[0]), dt);
    Py_RETURN_NONE;
  } catch (...) {
    set_python_error();
  }
  return nullptr;
}

PyMethodDef step_method = {
    "step", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(step_fastcall)),
    METH_FASTCALL | METH_KEYWORDS,
    "step($self, u, dt=None)\n--\n\n"
    "Holds the inputs at u (a float64 array of Model.inputs' length, read in place; a sequence "
    "of numbers is converted) over [t, t + dt] and advances to t + dt: rk4, one step; dopri5, "
    "error-controlled steps landing on t + dt, restarted at t. Returns None. dt defaults to the "
    "Simulator's dt=. ValueError for a wrong u or dt; kanedyn.SimulationError when the state "
    "becomes non-finite or dopri5's step underflows (the simulator then keeps the time and "
    "state it had). dopri5 runs without the GIL, and Ctrl-C stops it between its steps "
    "within about 50 ms: KeyboardInterrupt, the simulator keeping the time and state it had."};

std::unique_ptr<PySimulator> make_simulator(py::object model_obj, py::object initial,
                                            py::object integrator, py::object dt, py::object rtol,
                                            py::object atol, py::object max_step, py::object route,
                                            py::object t_obj, py::object project) {
  // The model first: None would reach the library as a null model.
  const std::shared_ptr<PyModel> model = model_argument(model_obj, "model");
  SimulationSettings s = io::simulation_settings(model->file().simulation);
  try {
    s.integrator = parse_integrator(string_argument(integrator, "integrator"));
    if (!route.is_none()) s.route = parse_route(string_argument(route, "route"));
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  // As simulate() and the tool take them: tolerances and steps finite and > 0.
  const auto set = [](py::handle value, const char* name, double& field) {
    if (!value.is_none()) field = positive_setting(value, name);
  };
  set(rtol, "rtol", s.rtol);
  set(atol, "atol", s.atol);
  set(max_step, "max_step", s.max_step);
  const double t = finite_argument(t_obj, "t");
  s.t_start = s.t_end = t;
  s.project_euler_parameters = bool_argument(project, "project_euler_parameters");
  auto out = std::make_unique<PySimulator>();
  out->model = model;
  set(dt, "dt", out->dt);
  // dopri5 asks between its steps (step_with sets the hook for its call).
  s.on_step = [p = out.get()](double t_reached) { return !p->hook || (*p->hook)(t_reached); };
  VectorX q, z;
  model_state(*model, initial, q, z);
  try {
    out->sim = std::make_unique<Simulator>(model->model(), q, z, s);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return out;
}

/// Seconds per step, looped in C++ with the same u: the baseline of the step overhead
/// benchmark (bench/python/bench_python.py). Advances the simulator.
double time_steps(PySimulator& s, py::handle u_obj, double dt, py::handle count_obj) {
  const long count =
      static_cast<long>(integer_argument(count_obj, "count", 1, std::numeric_limits<long>::max()));
  VectorX u;
  input_values(*s.model, u_obj, u);
  const Busy busy(s);
  try {
    py::gil_scoped_release release;
    const auto start = std::chrono::steady_clock::now();
    for (long i = 0; i < count; ++i) s.sim->step(u, dt);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() /
           static_cast<double>(count);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  } catch (const std::runtime_error& e) {
    raise_simulation_error(e.what());
  }
}

void register_simulator(py::module_& m) {
  py::class_<PySimulator> cls(
      m, "Simulator",
      "Steps a model one interval at a time with inputs held over each (MuJoCo's mj_step): "
      "sim = kanedyn.Simulator(model, initial=None, integrator='rk4', dt=None, *, rtol, atol, "
      "max_step, route, t=0.0); sim.step(u, dt); sim.t, sim.q, sim.z, sim.state. Steps with "
      "the values a controller of interval dt sets give simulate()'s rows bit for bit. Not for "
      "concurrent use from several threads.");
  cls.def(py::init(&make_simulator), py::arg("model"), py::arg("initial") = py::none(),
          py::arg("integrator") = "rk4", py::arg("dt") = py::none(), py::kw_only(),
          py::arg("rtol") = py::none(), py::arg("atol") = py::none(),
          py::arg("max_step") = py::none(), py::arg("route") = py::none(), py::arg("t") = 0.0,
          py::arg("project_euler_parameters") = true,
          "A simulator at `initial` (a State of the model; None: its initial state) at time t. "
          "integrator 'rk4' (one step per step()) or 'dopri5' (rtol, atol, max_step; defaults "
          "from the model file's simulation: section, else simulate()'s); dt: step()'s default "
          "interval.")
      .def_property_readonly(
          "t", [](const PySimulator& s) { return s.sim->time(); }, "the time reached")
      .def_property_readonly(
          "q", [](const PySimulator& s) { return to_numpy(s.sim->q()); },
          "the joint coordinates q at t (a copy; an all-free model's are the notes' x body by "
          "body)")
      .def_property_readonly(
          "z", [](const PySimulator& s) { return to_numpy(s.sim->z()); },
          "the independent speeds z at t (a copy)")
      .def_property_readonly(
          "state", [](const PySimulator& s) { return make_state(s.model, s.sim->q(), s.sim->z()); },
          "the state at t, a new kanedyn.State")
      .def_property_readonly(
          "inputs", [](const PySimulator& s) { return to_numpy(s.sim->inputs()); },
          "the inputs' values held over the last step (zeros before the first)")
      .def_property_readonly(
          "evaluations", [](const PySimulator& s) { return s.sim->evaluations(); },
          "evaluations of the derivative so far")
      .def_property_readonly(
          "steps", [](const PySimulator& s) { return s.sim->steps(); },
          "the integrator's accepted steps so far")
      .def_property_readonly(
          "model", [](const PySimulator& s) { return s.model; }, "the Model")
      .def_property_readonly(
          "dt",
          [](const PySimulator& s) {
            return std::isnan(s.dt) ? py::object(py::none()) : py::object(py::float_(s.dt));
          },
          "step()'s default dt, or None")
      .def(
          "set_state",
          [](PySimulator& s, py::object state, py::object t_obj) {
            VectorX q, z;
            model_state(*s.model, state, q, z);
            const double t = t_obj.is_none() ? s.sim->time() : finite_argument(t_obj, "t");
            const Busy busy(s);
            try {
              s.sim->set_state(q, z, t);
            } catch (const std::invalid_argument& e) {
              throw py::value_error(e.what());
            }
          },
          py::arg("state"), py::arg("t") = py::none(),
          "Restarts from a State of the model (None: its initial state) at time t (None: the "
          "current time).")
      .def("_time_steps", &time_steps, py::arg("u"), py::arg("dt"), py::arg("count"))
      .def("__repr__", [](const PySimulator& s) {
        return "<kanedyn.Simulator " + to_string(s.sim->settings().integrator) +
               " t=" + std::to_string(s.sim->time()) + ">";
      });
  cls.attr("step") = py::reinterpret_steal<py::object>(
      PyDescr_NewMethod(reinterpret_cast<PyTypeObject*>(cls.ptr()), &step_method));
}

}  // namespace

void register_control(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  cls.def_property_readonly(
      "inputs",
      [](const PyModel& p) {
        std::vector<std::string> names;
        for (const Input& in : p.model().inputs()) names.push_back(in.name);
        return names;
      },
      "the names of the model's inputs u_1 .. u_m, in order (docs/model-format.md, inputs): "
      "what u= of derivatives, forward, eom, simulate and Simulator.step holds");
  register_terms(cls);
  register_simulator(m);
}

}  // namespace kanedyn::python
