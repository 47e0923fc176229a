// Analysis from Python (include/kanedyn/analysis.hpp): the derivatives of forward and inverse
// dynamics, the tangent maps, linearization and static equilibrium. The results of
// linearization and equilibrium go to Python as dicts, which python/kanedyn/_analysis.py wraps
// in its Linearization and Equilibrium classes (their JSON object, their reading).
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/reduce.hpp"
#include "kanedyn/terms.hpp"

namespace kanedyn::python {

namespace {

/// Models from this many bodies compute without the GIL (as derivatives() does).
constexpr int kReleaseGilBodies = 32;

/// A C-contiguous complex128 copy.
py::array_t<std::complex<double>> complex_numpy(const Eigen::VectorXcd& v) {
  py::array_t<std::complex<double>> out(v.size());
  std::copy(v.data(), v.data() + v.size(), out.mutable_data());
  return out;
}
py::array_t<std::complex<double>> complex_numpy(const Eigen::MatrixXcd& m) {
  py::array_t<std::complex<double>> out({m.rows(), m.cols()});
  auto o = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) o(i, j) = m(i, j);
  return out;
}

/// The joint coordinates q of an argument: a State of the model, or an array q (checked as
/// model_state() checks them: size, finite, unit Euler parameters), named `name`.
VectorX coordinates(const PyModel& m, py::handle obj, const char* name) {
  VectorX q, z;
  if (py::isinstance<PyState>(obj)) {
    model_state(m, obj, q, z);
    return q;
  }
  if (obj.is_none())
    throw py::type_error(std::string(name) + " must be a kanedyn.State or the joint coordinates q");
  model_state(m, py::none(), obj, py::none(), q, z);
  return q;
}

/// A tangent deviation dx: n finite numbers, in the order of z.
VectorX tangent_vector(const PyModel& m, py::handle obj, const char* name) {
  const int n = m.model().num_speeds();
  VectorX v(n);
  copy_vector(float64_array(obj, name, {n},
                            "(n,) = (" + std::to_string(n) +
                                ",), one per tangent coordinate (Model.tangent_state_names[:n])"),
              v);
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      throw py::value_error(std::string(name) + "[" + std::to_string(i) + "] is not finite");
  return v;
}

/// The Derivatives of the workspace's model, made on first use and kept with the workspace.
Derivatives& derivatives_of(const PyModel& m, PyModel::Workspace& work) {
  if (!work.derivatives) work.derivatives = std::make_unique<Derivatives>(m.model());
  return *work.derivatives;
}

/// Runs f without the GIL for large models.
template <class F>
void maybe_released(const PyModel& m, const F& f) {
  if (m.N() >= kReleaseGilBodies) {
    py::gil_scoped_release release;
    f();
  } else {
    f();
  }
}

py::tuple forward_derivatives(const PyModel& m, py::object state, py::object u_obj,
                              py::object q_obj, py::object z_obj) {
  VectorX q, z, u;
  model_state(m, state, q_obj, z_obj, q, z);
  input_values(m, u_obj, u);
  const int n = m.model().num_speeds();
  MatrixX dq(n, n), dz(n, n), du(n, m.model().num_inputs());
  PyModel::Lease work(m);
  maybe_released(m, [&] { derivatives_of(m, *work).forward(q, z, u, dq, dz, du); });
  return py::make_tuple(to_numpy(dq), to_numpy(dz), to_numpy(du));
}

py::tuple inverse_derivatives(const PyModel& m, py::object state, py::object zdot_obj,
                              py::object u_obj, py::object q_obj, py::object z_obj) {
  if (zdot_obj.is_none())
    throw py::type_error("inverse_derivatives() needs zdot, the speeds' rates (n values)");
  VectorX q, z, zdot, u;
  model_state(m, state, q_obj, z_obj, q, z);
  speed_vector(m, zdot_obj, zdot, "zdot");
  input_values(m, u_obj, u);
  const int n = m.model().num_speeds();
  MatrixX dq(n, n), dz(n, n), du(n, m.model().num_inputs());
  PyModel::Lease work(m);
  Derivatives& d = derivatives_of(m, *work);
  if (!d.analytic())  // a C++ subclass of ForceElement: not reachable from a model file
    throw py::value_error(
        "inverse_derivatives(): the model has a force element of a type the library does not "
        "define; forward_derivatives() differentiates it by central differences");
  maybe_released(m, [&] { d.inverse(q, z, zdot, u, dq, dz, du); });
  return py::make_tuple(to_numpy(dq), to_numpy(dz), to_numpy(du));
}

py::dict linearization_dict(const Linearization& lin) {
  py::dict d;
  d["n"] = lin.n;
  d["m"] = lin.m;
  d["state"] = lin.state;
  d["inputs"] = lin.inputs;
  d["q"] = to_numpy(lin.q);
  d["z"] = to_numpy(lin.z);
  d["u"] = to_numpy(lin.u);
  d["zdot"] = to_numpy(lin.zdot);
  d["A"] = to_numpy(lin.A);
  d["B"] = to_numpy(lin.B);
  d["eigenvalues"] = complex_numpy(lin.eigenvalues);
  d["modes"] = lin.modes.size() > 0 ? py::object(complex_numpy(lin.modes)) : py::none();
  d["periodic"] = lin.periodic;
  return d;
}

/// The reduced linearization (include/kanedyn/reduce.hpp) as a dict for _analysis.py's Reduced.
py::dict reduced_dict(const ReducedLinearization& red) {
  py::list dropped;
  for (const DroppedCoordinate& d : red.dropped) {
    py::dict e;
    e["index"] = d.index;
    e["name"] = d.name;
    e["kind"] = d.kind;
    dropped.append(e);
  }
  py::dict d;
  d["dropped"] = dropped;
  d["kept"] = red.kept;
  d["state"] = red.state;
  d["A"] = to_numpy(red.A);
  d["B"] = to_numpy(red.B);
  d["eigenvalues"] = complex_numpy(red.eigenvalues);
  d["modes"] = red.modes.size() > 0 ? py::object(complex_numpy(red.modes)) : py::none();
  d["steady"] = red.steady;
  d["reduced_rate"] = red.reduced_rate;
  d["rates"] = red.rates;
  d["lift"] = to_numpy(red.lift);
  return d;
}

py::dict linearize_model(const PyModel& m, py::object state, py::object u_obj, bool modes,
                         py::object q_obj, py::object z_obj, bool reduced) {
  VectorX q, z, u;
  model_state(m, state, q_obj, z_obj, q, z);
  input_values(m, u_obj, u);
  Linearization lin;
  ReducedLinearization red;
  try {
    py::gil_scoped_release release;
    lin = linearize(m.model(), q, z, u, modes);
    if (reduced) red = reduce(m.model(), lin, modes);
  } catch (const std::invalid_argument& e) {
    // The sizes are checked above: what is left is an A that overflowed.
    throw py::value_error(
        std::string("linearize(): the derivatives at this state are not finite (") + e.what() +
        ")");
  }
  py::dict d = linearization_dict(lin);
  d["reduced"] = reduced ? py::object(reduced_dict(red)) : py::none();
  return d;
}

/// The tangent coordinates (0..n-1, sorted, each once) that `free` names: body names (all of
/// the body's coordinates), coordinate names of Model.tangent_state_names (NAME.j1, NAME.r2,
/// NAME.s3), or indices 0..n-1. ValueError naming the entry, with the closest name.
std::vector<int> free_coordinates(const Model& model, py::handle free) {
  const int n = model.num_speeds();
  const std::vector<std::string> names = tangent_state_names(model);
  std::vector<py::object> items;
  if (py::isinstance<py::str>(free) || py::isinstance<py::int_>(free))
    items.push_back(py::reinterpret_borrow<py::object>(free));
  else if (py::isinstance<py::iterable>(free))
    for (py::handle item : free) items.push_back(py::reinterpret_borrow<py::object>(item));
  else
    throw py::type_error(
        "free must be a list of body names, coordinate names (Model.tangent_state_names) or "
        "indices, got " +
        std::string(py::str(free.get_type().attr("__name__"))));
  if (items.empty())
    throw py::value_error("free is empty: give the bodies or coordinates Newton moves (None: all)");
  std::vector<int> out;
  for (const py::object& item : items) {
    if (py::isinstance<py::str>(item)) {
      const std::string name = item.cast<std::string>();
      if (const int k = model.body_index(name); k >= 0) {
        const int count = speed_count(model.joint(k).type);
        if (count == 0)
          throw py::value_error("free: body '" + io::printable(name, 60) +
                                "' has no coordinates (its joint is a weld)");
        for (int c = 0; c < count; ++c) out.push_back(model.speed_offset(k) + c);
        continue;
      }
      const auto at = std::find(names.begin(), names.end(), name);
      const int i = static_cast<int>(at - names.begin());
      if (i < n) {
        out.push_back(i);
        continue;
      }
      if (at != names.end())
        throw py::value_error("free: '" + io::printable(name, 60) + "' is a speed; free takes " +
                              "coordinates ('" + names[static_cast<size_t>(i - n)] +
                              "') or body names");
      std::vector<std::string> choices(names.begin(), names.begin() + n);
      for (const BodySpec& b : model.bodies()) choices.push_back(b.name);
      const std::string near = io::closest_word(name, choices);
      throw py::value_error("free: no body or coordinate named '" + io::printable(name, 60) + "'" +
                            (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                            "; Model.tangent_state_names lists the coordinates");
    }
    if (py::isinstance<py::bool_>(item))
      throw py::type_error("free: expected names or indices, got a bool");
    if (n == 0) throw py::value_error("free: the model has no coordinates to free");
    out.push_back(static_cast<int>(integer_argument(item, "free: index", 0, n - 1)));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// The most Newton iterations equilibrium() takes: the tool's --max-iterations range.
constexpr long long kMaxIterations = 10000;

py::dict equilibrium_of(const PyModel& m, py::object free, py::object u_obj, py::object state,
                        py::object tolerance_obj, py::object max_iterations, py::object q_obj) {
  const Model& model = m.model();
  EquilibriumOptions options;
  const double tolerance = positive_setting(tolerance_obj, "tolerance");
  options.tolerance = tolerance;
  options.max_iterations =
      static_cast<int>(integer_argument(max_iterations, "max_iterations", 1, kMaxIterations));
  if (!free.is_none()) options.free = free_coordinates(model, free);
  VectorX q, z, u;
  model_state(m, state, q_obj, py::none(), q, z);
  input_values(m, u_obj, u);
  EquilibriumResult result;
  Linearization lin;
  bool linearized = false;
  {
    py::gil_scoped_release release;
    result = equilibrium(model, q, u, options);
    // The eigenvalues say whether the rest pose is stable; a pose that is not one has none,
    // nor one whose derivatives overflow (sorted_eigenvalues refuses a non-finite A).
    try {
      if (result.converged) {
        lin = options.free.empty()
                  ? linearize(model, result.q, VectorX::Zero(model.num_speeds()), u)
                  : linearize_at_rest(model, result.q, u, options.free);
        linearized = true;
      }
    } catch (const std::invalid_argument&) {
    }
  }
  const std::vector<std::string> names = tangent_state_names(model);
  std::vector<std::string> free_names, unrestrained;
  for (const int i : result.free) free_names.push_back(names[static_cast<size_t>(i)]);
  for (const int i : result.unrestrained) unrestrained.push_back(names[static_cast<size_t>(i)]);
  py::dict d;
  d["converged"] = result.converged;
  d["iterations"] = result.iterations;
  d["q"] = to_numpy(result.q);
  d["u"] = to_numpy(u);
  d["free"] = free_names;
  d["residual"] = to_numpy(result.residual);
  d["residual_norm"] = result.residual_norm;
  d["scale"] = result.scale;
  d["tolerance"] = tolerance;
  d["message"] = result.message;
  d["unrestrained"] = unrestrained;
  d["linearization"] = linearized ? py::object(linearization_dict(lin)) : py::none();
  return d;
}

}  // namespace

void register_analysis(py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  cls.def("forward_derivatives", &forward_derivatives, py::arg("state") = py::none(),
          py::arg("u") = py::none(), py::kw_only(), py::arg("q") = py::none(),
          py::arg("z") = py::none(),
          "(dq, dz, du): the derivatives of forward dynamics z dot = F(q, z, u) at a state "
          "(default: the initial state; or q= and z=) and inputs u (None: all 0): d(z dot)/dq "
          "(n x n, columns in tangent coordinates: a rotation vector for each set of Euler "
          "parameters, Model.tangent_state_names[:n]), d(z dot)/dz (n x n) and d(z dot)/du "
          "(n x m). Analytic: dual numbers through the inverse dynamics (docs/analysis.md).")
      .def("inverse_derivatives", &inverse_derivatives, py::arg("state") = py::none(),
           py::arg("zdot") = py::none(), py::arg("u") = py::none(), py::kw_only(),
           py::arg("q") = py::none(), py::arg("z") = py::none(),
           "(dq, dz, du): the derivatives of inverse dynamics Q(q, z, zdot, u) "
           "(Model.inverse_dynamics) at a state (or q= and z=) and the speeds' rates zdot "
           "(required): dQ/dq (n x n, tangent columns), dQ/dz (n x n) and dQ/du (n x m). dQ/dzdot "
           "is the mass matrix.")
      .def(
          "retract",
          [](const PyModel& m, py::object q0, py::object dx) {
            const VectorX q = coordinates(m, q0, "q0");
            const VectorX d = tangent_vector(m, dx, "dx");
            return to_numpy(retract(m.model(), q, d));
          },
          py::arg("q0"), py::arg("dx"),
          "q0 (+) dx: the joint coordinates at the tangent deviation dx (n) from q0 (a State or "
          "joint coordinates q), exactly: each rotation vector through the exponential map, "
          "[R] = exp(-[r~]) [R0]; every other coordinate plus its entry.")
      .def(
          "tangent_difference",
          [](const PyModel& m, py::object q0, py::object q) {
            return to_numpy(
                tangent_difference(m.model(), coordinates(m, q0, "q0"), coordinates(m, q, "q")));
          },
          py::arg("q0"), py::arg("q"),
          "q (-) q0: the tangent deviation dx (n) with retract(q0, dx) = q (rotation vectors of "
          "at most pi). q0 and q are States or joint coordinates.")
      .def_property_readonly(
          "tangent_state_names", [](const PyModel& m) { return tangent_state_names(m.model()); },
          "the names of the linearized state, 2n (docs/model-format.md, \"Linearization "
          "output\"): every body's tangent coordinates (NAME.r1..r3 and NAME.s1..s3 of a free "
          "body, NAME.r1..r3 of a spherical joint, NAME.j1.. of any other), then its speeds "
          "(NAME.w1..w3, NAME.sd1..sd3, NAME.jd1..)")
      .def("_linearize", &linearize_model, py::arg("state"), py::arg("u"), py::arg("modes"),
           py::arg("q"), py::arg("z"), py::arg("reduce"))
      .def("_equilibrium", &equilibrium_of, py::arg("free"), py::arg("u"), py::arg("state"),
           py::arg("tolerance"), py::arg("max_iterations"), py::arg("q"));
}

}  // namespace kanedyn::python
