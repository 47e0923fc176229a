// The motion: {x dot}, {y dot} at one state or a batch of states (the O(N) route, no Python
// in the loop), simulate() with its trajectory in numpy arrays and optionally a CSV file, and
// writing a stored trajectory as the CSV the command-line tool writes.
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/inputs.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/threads.hpp"

namespace kanedyn::python {

namespace {

std::string sizes(const char* what, int n, int per_body) {
  return std::string("(") + what + ",) = (" + std::to_string(per_body * n) +
         ",) for N = " + std::to_string(n);
}

/// Runs forward_dynamics without the GIL for models large enough that releasing it pays
/// (it costs about 0.1 us).
constexpr int kReleaseGilBodies = 32;

/// The notes' rates of an all-free model at work.state, into work.data.xdot and ydot. The
/// notes' O(N) kernel, except for a model with constraints: the free tree knows nothing of
/// them, so its rates go through Dynamics (the constrained dynamics), (q, z) body by body
/// mapped to and from the layout of Eq. (1).
void notes_rates(const PyModel& m, PyModel::Workspace& work) {
  const Model& model = m.model();
  if (model.num_constraints() == 0) {
    forward_dynamics(model, work.state, work.data, Route::recursive);
    return;
  }
  const int n = m.N();
  VectorX q(7 * n), z(6 * n);
  for (int k = 0; k < n; ++k) {
    q.segment<4>(7 * k) = work.state.euler_parameters(k);
    q.segment<3>(7 * k + 4) = work.state.translation(k);
    z.segment<3>(6 * k) = work.state.angular_velocity(k);
    z.segment<3>(6 * k + 3) = work.state.translation_rate(k);
  }
  Dynamics& dynamics = *work.dynamics;
  dynamics.set_inputs(work.data.inputs);
  dynamics.pack(q, z, work.v);
  dynamics.derivative(work.v, work.dv);
  VectorX& xdot = work.data.xdot;
  VectorX& ydot = work.data.ydot;
  for (int k = 0; k < n; ++k) {
    xdot.segment<4>(4 * k) = work.dv.segment<4>(7 * k);
    xdot.segment<3>(4 * n + 3 * k) = work.dv.segment<3>(7 * k + 4);
    ydot.segment<3>(3 * k) = work.dv.segment<3>(7 * n + 6 * k);
    ydot.segment<3>(3 * n + 3 * k) = work.dv.segment<3>(7 * n + 6 * k + 3);
  }
}

/// The rates of a model with joints at its checked state (q, z): what simulate() integrates
/// (Dynamics::derivative), by the recursive route.
py::tuple joint_rates(const PyModel& m, const VectorX& q, const VectorX& z, py::handle u) {
  PyModel::Lease work(m);
  work->use_inputs(m, u);
  Dynamics& dynamics = *work->dynamics;
  dynamics.pack(q, z, work->v);
  if (m.N() >= kReleaseGilBodies) {
    py::gil_scoped_release release;
    dynamics.derivative(work->v, work->dv);
  } else {
    dynamics.derivative(work->v, work->dv);
  }
  const int nq = m.model().num_coordinates();
  return py::make_tuple(to_numpy(VectorX(work->dv.head(nq))),
                        to_numpy(VectorX(work->dv.tail(m.model().num_speeds()))));
}

py::tuple derivatives(const PyModel& m, py::handle x, py::handle y, double t, py::handle u) {
  if (!std::isfinite(t)) throw py::value_error("t must be finite");
  if (y.ptr() == nullptr) {  // derivatives(state)
    if (m.notes_layout()) {
      const State state = notes_state(m, x);
      PyModel::Lease work(m);
      work->use_inputs(m, u);
      work->state = state;
      notes_rates(m, *work);
      return py::make_tuple(to_numpy(work->data.xdot), to_numpy(work->data.ydot));
    }
    VectorX q, z;
    model_state(m, x, q, z);
    return joint_rates(m, q, z, u);
  }
  if (!m.notes_layout()) {
    VectorX q, z;
    model_state(m, py::none(), x, y, q, z);
    return joint_rates(m, q, z, u);
  }
  const int n = m.N();
  const double *x_data = nullptr, *y_data = nullptr;
  py::ssize_t x_stride = 1, y_stride = 1;
  py::array xa, ya;  // converted copies, when the arguments are not plain float64 vectors
  if (!plain_vector(x, 7 * n, x_data, x_stride)) {
    xa = float64_array(x, "x", {7 * n}, sizes("7N", n, 7));
    x_data = doubles(xa);
    x_stride = stride(xa, 0);
  }
  if (!plain_vector(y, 6 * n, y_data, y_stride)) {
    ya = float64_array(y, "y", {6 * n}, sizes("6N", n, 6));
    y_data = doubles(ya);
    y_stride = stride(ya, 0);
  }
  PyModel::Lease work(m);
  work->use_inputs(m, u);
  std::string problem = copy_coordinates(m.model(), x_data, x_stride, work->state.x, "x");
  if (problem.empty()) problem = copy_speeds(m.model(), y_data, y_stride, work->state.y, "y");
  if (!problem.empty()) throw py::value_error(problem);
  if (n >= kReleaseGilBodies) {
    py::gil_scoped_release release;
    notes_rates(m, *work);
  } else {
    notes_rates(m, *work);
  }
  return py::make_tuple(to_numpy(work->data.xdot), to_numpy(work->data.ydot));
}

/// derivatives() as a plain CPython method (METH_FASTCALL): pybind11's general dispatcher
/// (argument vectors on the heap, a type lookup per argument) would double the call's cost
/// for small models. The arguments and errors are those of the pybind11 functions.
PyObject* derivatives_fastcall(PyObject* self, PyObject* const* args, Py_ssize_t nargs,
                               PyObject* kwnames) {
  try {
    PyObject* given[4] = {nullptr, nullptr, nullptr, nullptr};
    static const char* const names[4] = {"x", "y", "t", "u"};
    if (nargs > 4) throw py::type_error("derivatives() takes x, y, t and u, got more arguments");
    for (Py_ssize_t i = 0; i < nargs; ++i) given[i] = args[i];
    const Py_ssize_t keywords = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
    for (Py_ssize_t i = 0; i < keywords; ++i) {
      const char* key = PyUnicode_AsUTF8(PyTuple_GET_ITEM(kwnames, i));
      if (!key) throw py::error_already_set();
      int slot = -1;
      for (int j = 0; j < 4; ++j)
        if (std::strcmp(key, names[j]) == 0) slot = j;
      if (slot < 0)
        throw py::type_error("derivatives() got an unexpected keyword argument '" +
                             std::string(key) + "'");
      if (given[slot])
        throw py::type_error("derivatives() got multiple values for argument '" + std::string(key) +
                             "'");
      given[slot] = args[nargs + i];
    }
    if (!given[0]) throw py::type_error("derivatives() needs a state, or x and y (q and z)");
    if (!given[1] && !PyObject_TypeCheck(
                         given[0], reinterpret_cast<PyTypeObject*>(py::type::of<PyState>().ptr())))
      throw py::type_error("derivatives() needs x and y (q and z), or a kanedyn.State");
    double t = 0.0;
    if (given[2] && given[2] != Py_None) {
      t = PyFloat_AsDouble(given[2]);
      if (t == -1.0 && PyErr_Occurred()) {
        // An int too large for a double is a number, just not a finite time.
        const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError);
        PyErr_Clear();
        if (overflow) throw py::value_error("t must be finite");
        throw py::type_error("t must be a number");
      }
    }
    auto* model =
        reinterpret_cast<py::detail::instance*>(self)->get_value_and_holder().value_ptr<PyModel>();
    if (!model) throw py::type_error("derivatives() called on an uninitialized Model");
    return derivatives(*model, py::handle(given[0]), py::handle(given[1]), t,
                       given[3] ? py::handle(given[3]) : py::handle(Py_None))
        .release()
        .ptr();
  } catch (...) {
    set_python_error();
  }
  return nullptr;
}

PyMethodDef derivatives_method = {
    "derivatives",
    reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(derivatives_fastcall)),
    METH_FASTCALL | METH_KEYWORDS,
    "derivatives($self, x, y=None, t=0.0, u=None)\n--\n\n"
    "The rates of the state the model integrates, by the O(N) recursive route. An all-free "
    "model: (xdot, ydot) at (x, y), {x dot} (Eqs. 39-40, 7N) and {y dot} (Eq. 36, 6N). A model "
    "with joints: (qdot, zdot) at its joint coordinates q and speeds z (Model.joint_layout), "
    "the derivative simulate() integrates. Either as two float64 arrays (or sequences of "
    "numbers), finite, with unit Euler parameters, or as one kanedyn.State. t is the time, for "
    "the signature f(t, x, y) of ODE solvers: the model's force laws do not depend on it. u: "
    "the values of the model's inputs (Model.inputs; None: all 0). A model with constraints: "
    "the constrained rates (those simulate() integrates, [B]{z dot} + {b} = 0), not the free "
    "tree's."};

/// An output array of derivatives_batch(out=...): float64, C-contiguous, writeable, of the
/// shape given, sharing no memory with the inputs.
py::array output_array(py::handle obj, const char* name, py::ssize_t rows, py::ssize_t cols,
                       const py::array& x, const py::array& y) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(std::string("out: ") + name + " must be a numpy array");
  auto a = py::reinterpret_borrow<py::array>(obj);
  if (!is_float64(a))
    throw py::type_error(std::string("out: ") + name + " must be a float64 array");
  if (a.ndim() != 2 || a.shape(0) != rows || a.shape(1) != cols)
    throw py::value_error(std::string("out: ") + name + " must have shape (" +
                          std::to_string(rows) + ", " + std::to_string(cols) + ")");
  if (!(a.flags() & py::array::c_style) || !a.writeable())
    throw py::value_error(std::string("out: ") + name +
                          " must be C-contiguous and writeable (numpy.empty((M, n)) is)");
  const py::object may_share = py::module_::import("numpy").attr("may_share_memory");
  if (may_share(a, x).cast<bool>() || may_share(a, y).cast<bool>())
    throw py::value_error(std::string("out: ") + name + " must not share memory with X or Y");
  return a;
}

/// The number of threads asked for, capped at the hardware's: more than that only share the
/// same cores, and each costs a stack of address space (enough of them fail to start).
py::ssize_t thread_count(py::handle obj, unsigned cores) {
  if (PyBool_Check(obj.ptr())) throw py::type_error("threads must be an integer, got a bool");
  PyObject* index = PyNumber_Index(obj.ptr());
  if (!index) {
    PyErr_Clear();
    throw py::type_error("threads must be an integer, got " +
                         std::string(py::str(obj.get_type().attr("__name__"))));
  }
  const auto value = py::reinterpret_steal<py::int_>(index);
  int overflow = 0;
  const long long asked = PyLong_AsLongLongAndOverflow(value.ptr(), &overflow);
  if (overflow < 0 || (overflow == 0 && asked < 0))
    throw py::value_error("threads must be >= 0 (0: one per core; more than the cores are " +
                          std::string("capped), got ") + shown_value(obj));
  if (overflow > 0 || asked == 0 || asked > static_cast<long long>(cores)) return cores;
  return static_cast<py::ssize_t>(asked);
}

py::tuple derivatives_batch(const PyModel& m, py::object X, py::object Y, py::object threads_obj,
                            py::object out, py::object U) {
  const int n = m.N();
  const bool notes = m.notes_layout();
  // The widths of the two arrays: 7N and 6N of the notes' layout, or the model's q and z.
  const int nx = notes ? 7 * n : m.model().num_coordinates();
  const int ny = notes ? 6 * n : m.model().num_speeds();
  const auto xa =
      float64_array(X, "X", {-1, nx},
                    notes ? "(M, 7N) = (M, " + std::to_string(nx) + ") for N = " + std::to_string(n)
                          : "(M, " + std::to_string(nx) + "), the joint coordinates q of M states");
  const py::ssize_t rows = xa.shape(0);
  const auto ya =
      float64_array(Y, "Y", {rows, ny},
                    "(M, " + std::string(notes ? "6N" : "n") + ") = (" + std::to_string(rows) +
                        ", " + std::to_string(ny) + ") (M from X)");
  const int nu = m.model().num_inputs();
  py::array ua;
  const bool has_u = !U.is_none();
  if (has_u) {
    ua = float64_array(U, "U", {rows, nu},
                       "(M, m) = (" + std::to_string(rows) + ", " + std::to_string(nu) +
                           "), the inputs' values of each state");
    const double* p = doubles(ua);
    for (py::ssize_t r = 0; r < rows; ++r)
      for (int i = 0; i < nu; ++i)
        if (!std::isfinite(p[r * stride(ua, 0) + i * stride(ua, 1)]))
          throw py::value_error("U[" + std::to_string(r) + "][" + std::to_string(i) +
                                "] is not finite");
  }
  const auto cores = static_cast<unsigned>(hardware_threads());
  const py::ssize_t threads = thread_count(threads_obj, cores);
  py::array xd, yd;
  if (out.is_none()) {
    xd = py::array_t<double>({rows, static_cast<py::ssize_t>(nx)});
    yd = py::array_t<double>({rows, static_cast<py::ssize_t>(ny)});
  } else {
    if (!py::isinstance<py::tuple>(out) && !py::isinstance<py::list>(out))
      throw py::type_error("out must be a pair (Xd, Yd) of arrays");
    const auto pair = py::reinterpret_borrow<py::sequence>(out);
    if (pair.size() != 2) throw py::type_error("out must be a pair (Xd, Yd) of arrays");
    xd = output_array(pair[0], "Xd", rows, nx, xa, ya);
    yd = output_array(pair[1], "Yd", rows, ny, xa, ya);
    if (py::module_::import("numpy").attr("may_share_memory")(xd, yd).cast<bool>())
      throw py::value_error("out: Xd and Yd must not share memory");
  }
  const py::ssize_t workers = std::max<py::ssize_t>(1, std::min<py::ssize_t>(threads, rows));
  const double* x_in = doubles(xa);
  const double* y_in = doubles(ya);
  const py::ssize_t xs0 = stride(xa, 0), xs1 = stride(xa, 1);
  const py::ssize_t ys0 = stride(ya, 0), ys1 = stride(ya, 1);
  auto* x_out = static_cast<double*>(xd.mutable_data());
  auto* y_out = static_cast<double*>(yd.mutable_data());
  // Each worker records the first bad row of its share; the lowest row is reported.
  std::vector<py::ssize_t> bad_row(static_cast<size_t>(workers), -1);
  std::vector<std::string> bad(static_cast<size_t>(workers));
  // Set when a thread could not be started: the rest stop at their next row.
  std::atomic<bool> abandoned{false};
  const auto work = [&](py::ssize_t w) {
    PyModel::Lease lease(m);
    lease->data.inputs.setZero();  // a pooled workspace keeps its last call's inputs
    if (lease->dynamics) lease->dynamics->set_inputs(lease->data.inputs);
    const py::ssize_t first = rows * w / workers, last = rows * (w + 1) / workers;
    VectorX q(notes ? 0 : nx), z(notes ? 0 : ny);
    for (py::ssize_t r = first; r < last; ++r) {
      if (abandoned.load(std::memory_order_relaxed)) return;
      std::string problem;
      if (notes) {
        problem = copy_coordinates(m.model(), x_in + r * xs0, xs1, lease->state.x, "X", r);
        if (problem.empty())
          problem = copy_speeds(m.model(), y_in + r * ys0, ys1, lease->state.y, "Y", r);
      } else {
        for (int i = 0; i < nx; ++i) q[i] = x_in[r * xs0 + i * xs1];
        for (int i = 0; i < ny; ++i) z[i] = y_in[r * ys0 + i * ys1];
        const std::string row = "[" + std::to_string(r) + "]";
        problem = model_state_problem(m, q, z, "X" + row, "Y" + row);
      }
      if (!problem.empty()) {
        bad_row[static_cast<size_t>(w)] = r;
        bad[static_cast<size_t>(w)] = problem;
        return;
      }
      if (has_u) {
        const double* u_in = doubles(ua);
        for (int i = 0; i < nu; ++i)
          lease->data.inputs[i] = u_in[r * stride(ua, 0) + i * stride(ua, 1)];
        if (lease->dynamics) lease->dynamics->set_inputs(lease->data.inputs);
      }
      if (notes) {
        notes_rates(m, *lease);
        std::copy_n(lease->data.xdot.data(), nx, x_out + r * nx);
        std::copy_n(lease->data.ydot.data(), ny, y_out + r * ny);
      } else {
        lease->dynamics->pack(q, z, lease->v);
        lease->dynamics->derivative(lease->v, lease->dv);
        std::copy_n(lease->dv.data(), nx, x_out + r * nx);
        std::copy_n(lease->dv.data() + nx, ny, y_out + r * ny);
      }
    }
  };
  std::string start_failure;
  {
    py::gil_scoped_release release;
    // The calling thread is worker 0; the others are started by start_threads, which joins
    // those started when one cannot be (a limit on threads or on address space).
    try {
      ThreadGroup pool = start_threads(
          static_cast<int>(workers - 1), [&work](int i) { work(i + 1); },
          [&abandoned] { abandoned = true; });
      work(0);
    } catch (const ThreadStartError& e) {
      start_failure = "derivatives_batch(): cannot start thread " + std::to_string(e.thread() + 1) +
                      " of " + std::to_string(e.count() + 1) + " (" + e.reason() +
                      "); ask for fewer threads";
    }
  }
  if (!start_failure.empty()) throw std::runtime_error(start_failure);
  for (size_t w = 0; w < bad_row.size(); ++w)
    if (bad_row[w] >= 0) throw py::value_error(bad[w]);
  return py::make_tuple(xd, yd);
}

/// A (shape) float64 array that owns `values` without copying them.
py::array_t<double> adopt(std::vector<double>&& values, std::vector<py::ssize_t> shape) {
  auto* heap = new std::vector<double>(std::move(values));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<double>*>(p); });
  return py::array_t<double>(shape, heap->data(), owner);
}

/// The input table of simulate(inputs=(t, U), inputs_hold=...): t (T,) increasing, U (T, m)
/// (or (T,) for a model of one input).
InputTable input_table(const PyModel& m, py::handle table, py::handle hold_obj) {
  const int count = m.model().num_inputs();
  if (count == 0) throw py::value_error("inputs: the model has no inputs");
  if (!py::isinstance<py::tuple>(table) && !py::isinstance<py::list>(table))
    throw py::type_error("inputs must be a pair (t, U) of arrays: t (T,), U (T, m)");
  const auto pair = py::reinterpret_borrow<py::sequence>(table);
  if (pair.size() != 2)
    throw py::type_error("inputs must be a pair (t, U) of arrays: t (T,), U (T, m)");
  const py::array t = float64_array(pair[0], "inputs t", {-1}, "(T,)");
  const py::ssize_t rows = t.shape(0);
  const std::string shape = "(T, m) = (" + std::to_string(rows) + ", " + std::to_string(count) +
                            "), one column per input (Model.inputs)";
  py::object values_obj = pair[1];
  if (count == 1 && py::isinstance<py::array>(values_obj) &&
      py::reinterpret_borrow<py::array>(values_obj).ndim() == 1)
    values_obj = values_obj.attr("reshape")(-1, 1);
  const py::array U = float64_array(values_obj, "inputs U", {rows, count}, shape);
  std::vector<double> times(static_cast<size_t>(rows));
  MatrixX values(rows, count);
  for (py::ssize_t r = 0; r < rows; ++r) {
    times[static_cast<size_t>(r)] = doubles(t)[r * stride(t, 0)];
    for (int c = 0; c < count; ++c) values(r, c) = doubles(U)[r * stride(U, 0) + c * stride(U, 1)];
  }
  InputHold hold = InputHold::zero_order;
  if (!hold_obj.is_none()) {
    if (!py::isinstance<py::str>(hold_obj))
      throw py::type_error("inputs_hold must be 'zero-order' or 'linear'");
    try {
      hold = parse_input_hold(hold_obj.cast<std::string>());
    } catch (const std::invalid_argument& e) {
      throw py::value_error(std::string("inputs_hold: ") + e.what());
    }
  }
  try {
    return InputTable(std::move(times), std::move(values), hold);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(std::string("inputs: ") + e.what());
  }
}

SimulationSettings settings_from(const PyModel& m, const py::dict& given) {
  SimulationSettings s = io::simulation_settings(m.file().simulation);
  const auto set = [&](const char* key, double& field) {
    if (given.contains(key) && !given[key].is_none()) field = positive_setting(given[key], key);
  };
  set("t_end", s.t_end);
  set("dt_out", s.dt_out);
  set("rtol", s.rtol);
  set("atol", s.atol);
  set("step", s.step);
  set("max_step", s.max_step);
  if (given.contains("integrator") && !given["integrator"].is_none())
    s.integrator = parse_integrator(string_argument(given["integrator"], "integrator"));
  if (given.contains("route") && !given["route"].is_none())
    s.route = parse_route(string_argument(given["route"], "route"));
  const auto given_object = [&](const char* key) {
    return given.contains(key) ? py::object(given[key]) : py::object(py::none());
  };
  const py::object table = given_object("inputs"), hold = given_object("inputs_hold");
  const py::object controller = given_object("controller");
  if (!hold.is_none() && table.is_none())
    throw py::value_error("inputs_hold applies to an input table: give inputs=(t, U) too");
  if (!table.is_none()) {
    if (!controller.is_none())
      throw py::value_error("give an input table (inputs=) or a controller, not both");
    s.inputs = std::make_shared<const InputTable>(input_table(m, table, hold));
  }
  if (!controller.is_none() && !PyCallable_Check(controller.ptr()))
    throw py::type_error("controller must be a callable(t, state) -> u");
  const py::object interval = given_object("control_interval");
  if (!interval.is_none()) {
    // 0 is allowed: the controller is then called at every evaluation.
    const bool zero = !py::isinstance<py::bool_>(interval) && interval.equal(py::int_(0));
    s.control_interval = zero ? 0.0 : positive_setting(interval, "control_interval");
    if (s.control_interval > 0.0 && controller.is_none())
      throw py::value_error("control_interval applies to a controller: give controller= too");
  }
  validate_settings(m.model(), s);
  return s;
}

py::dict stats_dict(const Model& model, const SimulationStats& st) {
  py::dict d;
  d["status"] = to_string(st.status);
  d["t_reached"] = st.t_reached;
  d["steps_accepted"] = st.steps_accepted;
  d["steps_rejected"] = st.steps_rejected;
  d["evaluations"] = st.evaluations;
  d["outputs"] = st.outputs;
  d["energy_initial"] = st.energy_initial;
  d["energy_final"] = st.energy_final;
  d["energy_change"] = st.energy_change();
  d["energy_scale"] = st.energy_scale;
  d["relative_energy_change"] = st.relative_energy_change();
  d["max_euler_drift"] = st.max_euler_drift;
  d["wall_seconds"] = st.wall_seconds;
  d["failed_body"] =
      st.failed_body >= 0 ? py::object(py::str(model.body(st.failed_body).name)) : py::none();
  d["message"] = st.message;
  if (model.num_constraints() > 0) {
    // The rolling discs that would have lifted: constraint name -> first output time.
    py::dict lifted;
    for (size_t k = 0; k < st.normal_force_negative_at.size(); ++k)
      if (!std::isnan(st.normal_force_negative_at[k]))
        lifted[py::str(model.constraints()[k].name)] = st.normal_force_negative_at[k];
    d["normal_force_negative_at"] = lifted;
  }
  return d;
}

}  // namespace

namespace {

/// (q dot, z dot) of any model at (q, z) (or a State; default: the initial state), by the
/// route.
py::tuple joint_derivatives(const PyModel& m, py::object q_obj, py::object z_obj,
                            py::object route_obj, py::object u_obj) {
  Route route = Route::recursive;
  try {
    route = parse_route(string_argument(route_obj, "route"));
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  VectorX q, z;
  if (py::isinstance<PyState>(q_obj))
    model_state(m, q_obj, z_obj, py::none(), q, z);
  else
    model_state(m, py::none(), q_obj, z_obj, q, z);
  const Model& model = m.model();
  VectorX u;
  input_values(m, u_obj, u);
  VectorX qdot(model.num_coordinates()), zdot(model.num_speeds());
  {
    py::gil_scoped_release release;
    Dynamics dynamics(model, route);
    dynamics.set_inputs(u);
    dynamics.evaluate(q, z, zdot, qdot);
  }
  return py::make_tuple(to_numpy(qdot), to_numpy(zdot));
}

/// The rows simulate() keeps: t, x, y, the mass centres and the energy of each output state
/// (and q, z of a jointed model).
struct Rows {
  std::vector<double> t, x, y, p_G, energy, q, z, u, reactions;
};

/// simulate(controller=f): f(t, state) -> u called from the run, which holds no GIL. Its
/// exception (or a value that is not m finite numbers, None included: elsewhere u=None means
/// zeros, but a controller that returns nothing has most likely forgotten its return) is
/// kept, to be raised (chained) when simulate() returns, and stops the run as the library's
/// controller_error.
class PythonController {
 public:
  PythonController(std::shared_ptr<PyModel> model, py::object f)
      : model_(std::move(model)), f_(std::move(f)) {}
  ~PythonController() {
    if (error_) {
      py::gil_scoped_acquire acquire;
      error_.reset();
    }
  }
  PythonController(const PythonController&) = delete;
  PythonController& operator=(const PythonController&) = delete;

  void operator()(double t, const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> u) {
    py::gil_scoped_acquire acquire;
    try {
      const py::object value = f_(t, py::cast(make_state(model_, q, z)));
      if (value.is_none())
        throw py::type_error(
            "the controller returned None; it must return u, " +
            std::to_string(model_->model().num_inputs()) +
            " finite numbers (one per input of Model.inputs); did it forget its return?");
      input_values(*model_, value, u_, "the controller's value");
      u = u_;
      return;
    } catch (py::error_already_set& e) {
      keep(std::move(e));
    } catch (const py::builtin_exception& e) {  // input_values' TypeError or ValueError
      e.set_error();
      keep(py::error_already_set());
    }
    throw std::runtime_error(message_);
  }
  /// The exception that stopped the run, or null.
  const std::unique_ptr<py::error_already_set>& error() const { return error_; }

 private:
  void keep(py::error_already_set&& e) {
    message_ =
        std::string(py::str(e.type().attr("__name__"))) + ": " + std::string(py::str(e.value()));
    if (!error_) error_ = std::make_unique<py::error_already_set>(std::move(e));
  }
  std::shared_ptr<PyModel> model_;
  py::object f_;
  VectorX u_;
  std::string message_;
  std::unique_ptr<py::error_already_set> error_;
};

std::string kept_note(const io::BackgroundTrajectoryWriter& writer) {
  return "partial trajectory (" + std::to_string(writer.rows()) +
         (writer.rows() == 1 ? " row) kept in " : " rows) kept in ") + writer.partial_path();
}

py::object simulate_model(const std::shared_ptr<PyModel>& self, const py::dict& given,
                          py::object initial_obj, py::object output, py::object store_obj,
                          py::object progress) {
  const PyModel& m = *self;
  const bool store = bool_argument(store_obj, "store");
  const Model& model = m.model();
  const SimulationSettings base = settings_from(m, given);
  VectorX q0, z0;
  model_state(m, initial_obj, q0, z0);
  std::unique_ptr<io::BackgroundTrajectoryWriter> writer;
  std::string out;
  if (!output.is_none()) {
    out = path_argument(output, "output");
    io::check_output_path(out, {m.file().path});
  }
  if (progress.is(py::bool_(true)))
    progress = py::module_::import("kanedyn._result").attr("ProgressBar")();
  else if (progress.is(py::bool_(false)))
    progress = py::none();
  else if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress must be True, False, None or a callable(t, t_end)");

  Rows rows;
  const int n = model.num_bodies();
  StepHook hook(progress, base.t_end);
  SimulationSettings settings = base;
  settings.observer_kinematics = store;
  settings.on_step = [&hook](double t) { return hook(t); };
  std::unique_ptr<PythonController> controller;
  if (given.contains("controller") && !given["controller"].is_none()) {
    controller = std::make_unique<PythonController>(self, given["controller"]);
    settings.controller = [c = controller.get()](double t, const VectorX& q, const VectorX& z,
                                                 Eigen::Ref<VectorX> u) { (*c)(t, q, z, u); };
  }
  const int m_inputs = model.num_inputs();
  const int m_reactions = reaction_count(model);
  SimulationStats stats;
  // The rows of a model with joints also keep q and z (the CSV's joint columns).
  const bool keep_joints = !m.notes_layout();
  // The file is created with the first row, once the initial state has passed simulate()'s
  // checks: a run refused at its start leaves no file.
  const auto open_writer = [&]() -> io::BackgroundTrajectoryWriter& {
    if (!writer) writer = std::make_unique<io::BackgroundTrajectoryWriter>(model, out);
    return *writer;
  };
  const auto keep = [&](double t, const State& state, Data& data) {
    rows.t.push_back(t);
    rows.x.insert(rows.x.end(), state.x.begin(), state.x.end());
    rows.y.insert(rows.y.end(), state.y.begin(), state.y.end());
    for (const Vector3& p : data.kinematics.p_G)
      rows.p_G.insert(rows.p_G.end(), p.begin(), p.end());
  };
  const Observer observer = [&](double t, const State& state, const VectorX& q, const VectorX& z,
                                Data& data) {
    if (!out.empty())
      open_writer().write_row(t, state, q, z, m_inputs > 0 ? &data.inputs : nullptr,
                              &data.reactions);
    if (!store) return;
    keep(t, state, data);
    rows.energy.push_back(total_energy_of_kinematics(model, state, q, data));
    rows.u.insert(rows.u.end(), data.inputs.begin(), data.inputs.end());
    rows.reactions.insert(rows.reactions.end(), data.reactions.begin(), data.reactions.end());
    if (!keep_joints) return;
    rows.q.insert(rows.q.end(), q.begin(), q.end());
    rows.z.insert(rows.z.end(), z.begin(), z.end());
  };
  try {
    py::gil_scoped_release release;
    stats = simulate(model, q0, z0, settings, observer);
    if (!hook.failed()) hook(stats.t_reached, true);  // the progress callback sees the end
  } catch (const std::exception& e) {
    const std::string kept = writer ? "; " + kept_note(*writer) : "";
    if (writer) try {
        writer->close();
      } catch (...) {  // e is the error to report
      }
    throw std::runtime_error(std::string(e.what()) + kept);
  }
  if (hook.failed()) {
    if (writer) writer->close();
    hook.restore();
    py::error_already_set error;
    if (writer) {
      py::object value = error.value();
      if (py::hasattr(value, "add_note")) value.attr("add_note")(kept_note(*writer));
    }
    throw error;
  }
  if (writer) {
    if (stats.ok())
      writer->finish();
    else
      writer->close();
  }
  const auto T = static_cast<py::ssize_t>(rows.t.size());
  const py::dict stats_out = stats_dict(model, stats);
  py::object result = py::none();
  if (store) {
    py::object q = py::none(), z = py::none(), u = py::none();
    if (keep_joints) {
      q = adopt(std::move(rows.q), {T, model.num_coordinates()});
      z = adopt(std::move(rows.z), {T, model.num_speeds()});
    }
    if (m_inputs > 0) u = adopt(std::move(rows.u), {T, m_inputs});
    py::object reactions = py::none();
    if (m_reactions > 0) reactions = adopt(std::move(rows.reactions), {T, m_reactions});
    result = py::module_::import("kanedyn._result")
                 .attr("Result")(
                     self, adopt(std::move(rows.t), {T}), adopt(std::move(rows.x), {T, 7 * n}),
                     adopt(std::move(rows.y), {T, 6 * n}), adopt(std::move(rows.p_G), {T, n, 3}),
                     adopt(std::move(rows.energy), {T}), stats_out,
                     out.empty() ? py::object(py::none()) : py::object(path_str(out)), q, z, u,
                     reactions);
  }
  if (!stats.ok()) {
    const std::string message =
        stats.message + (writer ? "; " + kept_note(*writer) : std::string());
    py::object type = py::module_::import("kanedyn._kanedyn").attr("SimulationError");
    py::object error = type(message);
    error.attr("result") = result;
    error.attr("stats") = stats_out;
    if (controller && controller->error()) {
      const py::object cause = controller->error()->value();
      // Not an Exception (KeyboardInterrupt, SystemExit): raised itself, as a signal would be.
      if (!PyObject_IsInstance(cause.ptr(), PyExc_Exception)) {
        if (writer && py::hasattr(cause, "add_note")) cause.attr("add_note")(kept_note(*writer));
        controller->error()->restore();
        throw py::error_already_set();
      }
      error.attr("__cause__") = cause;  // raise SimulationError(...) from the controller's
    }
    PyErr_SetObject(type.ptr(), error.ptr());
    throw py::error_already_set();
  }
  return store ? result : py::object(stats_out);
}

/// "NAME[r, c] is nan" (and what the column holds, when `what` is given) for the first
/// non-finite number of the (rows, cols) array a, or "".
template <class Describe>
std::string first_non_finite(const py::array& a, const char* name, py::ssize_t rows,
                             py::ssize_t cols, const Describe& what) {
  const bool vector = a.ndim() == 1;
  for (py::ssize_t r = 0; r < rows; ++r)
    for (py::ssize_t c = 0; c < cols; ++c) {
      const double v = doubles(a)[r * stride(a, 0) + (vector ? 0 : c * stride(a, 1))];
      if (std::isfinite(v)) continue;
      const std::string at =
          vector ? std::to_string(r) : std::to_string(r) + ", " + std::to_string(c);
      const std::string described = what(c);
      return std::string(name) + "[" + at + "] is " +
             (std::isnan(v) ? "nan"
              : v > 0       ? "inf"
                            : "-inf") +
             (described.empty() ? "" : " (" + described + ")");
    }
  return "";
}

/// The norm of 4 numbers as the trajectory reader computes it (check_row_state in
/// src/io/trajectory.cpp), so that a row passed here is never refused there.
double reader_norm(const double* values, py::ssize_t stride) {
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) sum += values[i * stride] * values[i * stride];
  return std::sqrt(sum);
}

/// Every reason the trajectory reader would refuse the CSV of these rows, as one ValueError
/// naming the array, the row and the column: a non-finite number, Euler parameters (or a
/// spherical joint's) not of unit norm within 1e-6, a time before the previous row's, no rows;
/// and a mass centre that overflows (the writer would refuse that row). Checked before any
/// file is created, so that a refused to_csv (or view, `caller`) leaves nothing behind.
void check_rows(const PyModel& m, const std::string& caller, const py::array& t, const py::array& x,
                const py::array& y, const py::array& energy, const py::array& qa,
                const py::array& za) {
  const Model& model = m.model();
  const int n = m.N();
  // A model with joints has joint columns (docs/model-format.md, "Trajectory CSV").
  const Model* tree = m.notes_layout() ? nullptr : &m.model();
  const py::ssize_t rows = t.shape(0);
  const auto fail = [&caller](const std::string& problem) {
    throw py::value_error(caller + ": " + problem + "; nothing was written");
  };
  if (rows == 0) fail("the result has no rows (a trajectory CSV has at least one)");
  const auto none = [](py::ssize_t) { return std::string(); };
  const auto body_of = [&](int component) { return describe_state_component(model, component); };
  std::string problem = first_non_finite(t, "t", rows, 1, none);
  if (problem.empty())
    problem = first_non_finite(x, "x", rows, 7 * n,
                               [&](py::ssize_t c) { return body_of(static_cast<int>(c)); });
  if (problem.empty())
    problem = first_non_finite(y, "y", rows, 6 * n,
                               [&](py::ssize_t c) { return body_of(7 * n + static_cast<int>(c)); });
  if (problem.empty()) problem = first_non_finite(energy, "energy", rows, 1, none);
  if (problem.empty() && tree) {
    problem = first_non_finite(qa, "q", rows, tree->num_coordinates(), none);
    if (problem.empty()) problem = first_non_finite(za, "z", rows, tree->num_speeds(), none);
  }
  if (!problem.empty()) fail(problem);
  const auto not_unit = [&](const char* name, py::ssize_t r, int first, int k, const char* what,
                            double norm) {
    char shown[32];
    std::snprintf(shown, sizeof shown, "%.17g", norm);
    fail(std::string(name) + "[" + std::to_string(r) + ", " + std::to_string(first) + ":" +
         std::to_string(first + 4) + "]: " + what + " of body '" + model.body(k).name +
         "' have norm " + shown + ", not 1 within 1e-6 (the trajectory reader refuses that)");
  };
  Data data(model, DataOptions::recursive_only());
  State state(model);
  for (py::ssize_t r = 0; r < rows; ++r) {
    const double* row = doubles(x) + r * stride(x, 0);
    for (int k = 0; k < n; ++k)
      if (const double norm = reader_norm(row + 4 * k * stride(x, 1), stride(x, 1));
          !(std::abs(norm - 1.0) <= kUnitTolerance))
        not_unit("x", r, 4 * k, k, "the Euler parameters", norm);
    if (tree)
      for (int k = 0; k < n; ++k) {
        if (!relative_euler_joint(tree->joint(k).type)) continue;
        const int first = tree->coordinate_offset(k);
        const double* q = doubles(qa) + r * stride(qa, 0) + first * stride(qa, 1);
        if (const double norm = reader_norm(q, stride(qa, 1));
            !(std::abs(norm - 1.0) <= kUnitTolerance))
          not_unit("q", r, first, k, "the spherical joint's Euler parameters", norm);
      }
    const double t_r = doubles(t)[r * stride(t, 0)];
    if (r > 0 && t_r < doubles(t)[(r - 1) * stride(t, 0)])
      fail("t[" + std::to_string(r) + "] is before t[" + std::to_string(r - 1) +
           "] (the trajectory reader needs the times in order)");
    // The CSV's NAME.x, .y, .z are computed from the state: finite states can still put a
    // mass centre beyond the range of a double.
    for (int i = 0; i < 7 * n; ++i) state.x[i] = row[i * stride(x, 1)];
    for (int i = 0; i < 6 * n; ++i) state.y[i] = doubles(y)[r * stride(y, 0) + i * stride(y, 1)];
    compute_kinematics(model, state, data);
    for (int k = 0; k < n; ++k)
      if (!data.kinematics.p_G[static_cast<size_t>(k)].allFinite())
        fail("row " + std::to_string(r) + ": the mass centre of body '" + model.body(k).name +
             "' is not finite (its position in x overflows)");
  }
}

/// A result's arrays, converted and checked (checked_rows).
struct StoredRows {
  py::array t, x, y, energy, q, z, u, reactions;
  bool has_u = false;  // u given (else every input is 0)
};

/// The arrays of a Result as float64 arrays of its model's shapes, checked as the trajectory
/// reader would check their CSV (check_rows), and the inputs' values and the reactions finite.
/// ValueError "CALLER: problem; nothing was written".
StoredRows checked_rows(const PyModel& m, const std::string& caller, py::handle t_obj,
                        py::handle x_obj, py::handle y_obj, py::handle energy_obj, py::handle q_obj,
                        py::handle z_obj, py::handle u_obj, py::handle reactions_obj) {
  const Model& model = m.model();
  const int n = m.N();
  StoredRows out;
  out.t = float64_array(t_obj, "t", {-1}, "(T,)");
  const py::ssize_t rows = out.t.shape(0);
  out.x = float64_array(x_obj, "x", {rows, 7 * n}, "(T, 7N)");
  out.y = float64_array(y_obj, "y", {rows, 6 * n}, "(T, 6N)");
  out.energy = float64_array(energy_obj, "energy", {rows}, "(T,)");
  // A model with joints has joint columns (docs/model-format.md, "Trajectory CSV").
  if (!m.notes_layout()) {
    const int nq = model.num_coordinates(), nz = model.num_speeds();
    out.q = float64_array(q_obj, "q", {rows, nq}, "(T, " + std::to_string(nq) + ")");
    out.z = float64_array(z_obj, "z", {rows, nz}, "(T, " + std::to_string(nz) + ")");
  }
  check_rows(m, caller, out.t, out.x, out.y, out.energy, out.q, out.z);
  const auto fail = [&caller](const std::string& problem) {
    throw py::value_error(caller + ": " + problem + "; nothing was written");
  };
  // A model with inputs has input columns: the values in force at each row (None: zero).
  const int nu = model.num_inputs();
  if (nu > 0 && !u_obj.is_none()) {
    out.u = float64_array(u_obj, "u", {rows, nu}, "(T, " + std::to_string(nu) + ")");
    out.has_u = true;
    const std::string problem = first_non_finite(out.u, "u", rows, nu, [&](py::ssize_t c) {
      return "input '" + model.inputs()[static_cast<size_t>(c)].name + "'";
    });
    if (!problem.empty()) fail(problem);
  }
  // A model with constraints has reaction columns: the stored reactions of each row (they are
  // the run's, at its output states; there is no default).
  const int nr = reaction_count(model);
  if (nr > 0) {
    if (reactions_obj.is_none())
      fail("this model has constraints and the result holds no reactions");
    out.reactions =
        float64_array(reactions_obj, "reactions", {rows, nr}, "(T, " + std::to_string(nr) + ")");
    const std::string problem =
        first_non_finite(out.reactions, "reactions", rows, nr,
                         [&](py::ssize_t) { return std::string("a constraint reaction"); });
    if (!problem.empty()) fail(problem);
  }
  return out;
}

/// Writes stored rows as the trajectory CSV: the kinematics of each row are computed again
/// (compute_kinematics gives the same bits as at run time), the energy is the stored one.
/// The rows are checked first (checked_rows): the file is written whole or not at all.
void write_csv(const PyModel& m, py::handle path_obj, py::handle t_obj, py::handle x_obj,
               py::handle y_obj, py::handle energy_obj, py::handle q_obj, py::handle z_obj,
               py::handle u_obj, py::handle reactions_obj) {
  const Model& model = m.model();
  const int n = m.N();
  const std::string path = path_argument(path_obj, "path");
  const StoredRows checked = checked_rows(m, "to_csv", t_obj, x_obj, y_obj, energy_obj, q_obj,
                                          z_obj, u_obj, reactions_obj);
  const py::array &t = checked.t, &x = checked.x, &y = checked.y, &energy = checked.energy;
  const py::array &qa = checked.q, &za = checked.z, &ua = checked.u, &ra = checked.reactions;
  const py::ssize_t rows = t.shape(0);
  const Model* tree = m.notes_layout() ? nullptr : &m.model();
  const int nq = tree ? tree->num_coordinates() : 0, nz = tree ? tree->num_speeds() : 0;
  const int nu = model.num_inputs(), nr = reaction_count(model);
  io::check_output_path(path, {m.file().path});
  io::TrajectoryWriter writer(model, path);
  Data data(model, DataOptions::recursive_only());
  State state(model);
  VectorX q(nq), z(nz);
  for (py::ssize_t r = 0; r < rows; ++r) {
    for (int i = 0; i < 7 * n; ++i) state.x[i] = doubles(x)[r * stride(x, 0) + i * stride(x, 1)];
    for (int i = 0; i < 6 * n; ++i) state.y[i] = doubles(y)[r * stride(y, 0) + i * stride(y, 1)];
    compute_kinematics(model, state, data);
    for (int i = 0; i < nq; ++i) q[i] = doubles(qa)[r * stride(qa, 0) + i * stride(qa, 1)];
    for (int i = 0; i < nz; ++i) z[i] = doubles(za)[r * stride(za, 0) + i * stride(za, 1)];
    if (checked.has_u) {
      for (int i = 0; i < nu; ++i)
        data.inputs[i] = doubles(ua)[r * stride(ua, 0) + i * stride(ua, 1)];
    }
    for (int i = 0; i < nr; ++i)
      data.reactions[i] = doubles(ra)[r * stride(ra, 0) + i * stride(ra, 1)];
    writer.write_row(doubles(t)[r * stride(t, 0)], state, data,
                     doubles(energy)[r * stride(energy, 0)], tree ? &q : nullptr,
                     tree ? &z : nullptr);
  }
  writer.finish();
}

/// A trajectory CSV of this model as its (T, 2 + 16N) table, by io::read_trajectory (the
/// reader of the tool's view and inspect --trajectory); its errors as ValueError.
py::array_t<double> read_csv(const PyModel& m, py::handle path_obj) {
  const std::string path = path_argument(path_obj, "path");
  io::Trajectory traj;
  try {
    py::gil_scoped_release release;
    traj = io::read_trajectory(m.model(), path);
  } catch (const std::runtime_error& e) {
    throw py::value_error(e.what());
  }
  const auto rows = static_cast<py::ssize_t>(traj.rows());
  const auto columns = static_cast<py::ssize_t>(traj.columns.size());
  return adopt(std::move(traj.values), {rows, columns});
}

/// Seconds per forward_dynamics call, looped in C++: the baseline of the call-overhead
/// benchmark (bench/python/bench_python.py).
double time_derivatives(const PyModel& m, py::object state_obj, py::handle calls_obj) {
  const long calls =
      static_cast<long>(integer_argument(calls_obj, "calls", 1, std::numeric_limits<long>::max()));
  const State state = notes_state(m, state_obj);
  PyModel::Lease work(m);
  work->use_inputs(m, py::none());
  work->state = state;
  py::gil_scoped_release release;
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < calls; ++i)
    forward_dynamics(m.model(), work->state, work->data, Route::recursive);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() /
         static_cast<double>(std::max(1L, calls));
}

}  // namespace

StepHook::StepHook(py::object progress, double t_end)
    : progress_(std::move(progress)), t_end_(t_end) {}

StepHook::~StepHook() {
  if (type_) {
    py::gil_scoped_acquire acquire;
    Py_XDECREF(type_);
    Py_XDECREF(value_);
    Py_XDECREF(trace_);
  }
}

bool StepHook::operator()(double t, bool force) {
  const auto now = Clock::now();
  if (!force && now - last_check_ < std::chrono::milliseconds(50)) return true;
  last_check_ = now;
  py::gil_scoped_acquire acquire;
  if (PyErr_CheckSignals() != 0) return stash();
  if (!progress_.is_none() && (force || now - last_progress_ >= std::chrono::milliseconds(100))) {
    last_progress_ = now;
    try {
      progress_(t, t_end_);
    } catch (py::error_already_set& e) {
      e.restore();
      return stash();
    }
  }
  return true;
}

void StepHook::restore() {
  PyErr_Restore(type_, value_, trace_);
  type_ = value_ = trace_ = nullptr;
}

bool StepHook::stash() {
  PyErr_Fetch(&type_, &value_, &trace_);
  PyErr_NormalizeException(&type_, &value_, &trace_);
  return false;
}

void register_run(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  // A method descriptor of the class, as a def() would make, without pybind11's dispatcher.
  cls.attr("derivatives") = py::reinterpret_steal<py::object>(
      PyDescr_NewMethod(reinterpret_cast<PyTypeObject*>(cls.ptr()), &derivatives_method));
  cls.def("derivatives_batch", &derivatives_batch, py::arg("X"), py::arg("Y"),
          py::arg("threads") = 0, py::arg("out") = py::none(), py::arg("U") = py::none(),
          "(Xd, Yd) for M states at once: X (M, 7N), Y (M, 6N) -> Xd (M, 7N), Yd (M, 6N), row "
          "i equal to derivatives(X[i], Y[i], u=U[i]) (U (M, m): the inputs' values; None: "
          "0). Runs on `threads` threads (0, or more than the "
          "hardware has: one per core) with the GIL released; RuntimeError if a thread cannot "
          "be started. out=(Xd, Yd): write into these float64 C-contiguous arrays instead of "
          "new ones (and return them); a loop that reuses them saves the first touch of new "
          "memory, which costs as much as the evaluations on small models.")
      .def("_simulate", &simulate_model, py::arg("settings"), py::arg("initial"), py::arg("output"),
           py::arg("store"), py::arg("progress"))
      .def("_read_csv", &read_csv, py::arg("path"))
      .def(
          "_check_rows",
          [](const PyModel& self, const std::string& caller, py::handle t, py::handle x,
             py::handle y, py::handle energy, py::handle q, py::handle z, py::handle u,
             py::handle reactions) {
            checked_rows(self, caller, t, x, y, energy, q, z, u, reactions);
          },
          py::arg("caller"), py::arg("t"), py::arg("x"), py::arg("y"), py::arg("energy"),
          py::arg("q"), py::arg("z"), py::arg("u"), py::arg("reactions"))
      .def("_write_csv", &write_csv, py::arg("path"), py::arg("t"), py::arg("x"), py::arg("y"),
           py::arg("energy"), py::arg("q") = py::none(), py::arg("z") = py::none(),
           py::arg("u") = py::none(), py::arg("reactions") = py::none())
      .def("joint_derivatives", &joint_derivatives, py::arg("q") = py::none(),
           py::arg("z") = py::none(), py::arg("route") = "recursive", py::arg("u") = py::none(),
           "(q dot, z dot) of a jointed model at its joint coordinates q and independent speeds "
           "z (default: the initial ones; model.joint_layout gives each body's slices): the "
           "kinematic equations and the projected equations, by route 'recursive' (O(N)) or "
           "'assembled'; u: the inputs' values (None: all 0). With constraints, the constrained "
           "z dot (multipliers on 'recursive', Kane's equations in the independent speeds on "
           "'assembled'), as constrained_forward() gives it.")
      .def("_time_derivatives", &time_derivatives, py::arg("state"), py::arg("calls"));
  (void)m;
}

}  // namespace kanedyn::python
