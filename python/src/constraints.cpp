// Constraints from Python (include/kanedyn/constraints.hpp): the model's constraints, their
// equations at a state, the speed partition and [C_I], the projection of a state onto them,
// and the constrained forward dynamics with the reactions. Each a thin call of the library.
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"

namespace kanedyn::python {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

/// (q, z) from f(state) or f(q, z), as Model.forward takes them: a State (or None, the initial
/// state) alone, or the arrays q and z.
void state_arguments(const PyModel& m, py::handle first, py::handle second, VectorX& q, VectorX& z,
                     const char* what) {
  if (first.is_none() || py::isinstance<PyState>(first)) {
    if (!second.is_none()) throw py::type_error(std::string(what) + " takes a State, or q and z");
    model_state(m, first, q, z);
  } else {
    model_state(m, py::none(), first, second, q, z);
  }
}

/// The speeds' names in z order: the speeds half of tangent_state_names.
std::vector<std::string> speed_names(const Model& model) {
  const std::vector<std::string> all = tangent_state_names(model);
  return {all.begin() + model.num_speeds(), all.end()};
}

std::vector<std::string> pick(const std::vector<std::string>& names, const std::vector<int>& at_) {
  std::vector<std::string> out;
  for (const int i : at_) out.push_back(names[at(i)]);
  return out;
}

std::string body_name(const Model& model, int k) {
  return k == kGround ? std::string("ground") : model.body(k).name;
}

/// A library error of the constraints as Python's ValueError (the state is the problem).
template <class F>
auto constraint_call(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const ConstraintError& e) {
    throw py::value_error(e.what());
  }
}

py::dict constraint_dict(const Model& model, const Constraint& c) {
  py::dict d;
  d["name"] = c.name;
  d["type"] = to_string(c.type);
  d["body"] = body_name(model, c.body);
  d["at"] = to_numpy(c.at);
  d["axis"] = to_numpy(c.axis);
  d["radius"] = c.radius;
  d["plane_normal"] = to_numpy(c.plane_normal);
  d["plane_offset"] = c.plane_offset;
  d["other"] = body_name(model, c.other);
  d["other_at"] = to_numpy(c.other_at);
  d["other_axis"] = to_numpy(c.other_axis);
  d["length"] = c.length;
  d["equations"] = equation_count(c.type);
  return d;
}

/// The rows' names and kinds of a model's equations.
void describe_rows(const ConstraintEquations& eq, py::dict& d) {
  std::vector<std::string> rows;
  std::vector<bool> holonomic;
  for (int i = 0; i < eq.rows(); ++i) {
    rows.push_back(eq.row_name(i));
    holonomic.push_back(eq.holonomic(i));
  }
  d["rows"] = rows;
  d["holonomic"] = holonomic;
}

py::dict equations_at(const PyModel& m, py::object first, py::object second) {
  VectorX q, z;
  state_arguments(m, first, second, q, z, "constraint_equations()");
  ConstraintEquations eq(m.model());
  constraint_call([&] {
    eq.evaluate(q, z);
    return 0;
  });
  py::dict d;
  describe_rows(eq, d);
  d["B"] = to_numpy(eq.B());
  d["b"] = to_numpy(eq.b());
  d["errors"] = to_numpy(eq.errors());
  MatrixX points(m.model().num_constraints(), 3);
  for (int c = 0; c < m.model().num_constraints(); ++c) points.row(c) = eq.point(c).transpose();
  d["points"] = to_numpy(points);
  return d;
}

py::dict partition_at(const PyModel& m, py::object first, py::object second) {
  VectorX q, z;
  state_arguments(m, first, second, q, z, "partition_speeds()");
  ConstraintEquations eq(m.model());
  const SpeedPartition p = constraint_call([&] {
    eq.evaluate(q, z);
    return partition_speeds(m.model(), eq.B());
  });
  std::vector<std::string> rows;
  for (int i = 0; i < eq.rows(); ++i) rows.push_back(eq.row_name(i));
  const std::vector<std::string> speeds = speed_names(m.model());
  py::dict d;
  d["rank"] = p.rank;
  d["rows"] = pick(rows, p.rows);
  d["redundant_rows"] = pick(rows, p.redundant_rows);
  d["independent_speeds"] = pick(speeds, p.independent);
  d["dependent_speeds"] = pick(speeds, p.dependent);
  d["independent"] = p.independent;
  d["dependent"] = p.dependent;
  d["C_I"] = to_numpy(independent_basis(eq.B(), p));
  return d;
}

py::dict project_state(const PyModel& m, py::object first, py::object second,
                       py::object tolerance_obj) {
  const double tolerance = positive_setting(tolerance_obj, "tolerance");
  VectorX q, z;
  state_arguments(m, first, second, q, z, "project()");
  const Projection p = constraint_call([&] {
    py::gil_scoped_release release;
    return project_onto_constraints(m.model(), q, z, tolerance);
  });
  py::dict d;
  d["q"] = to_numpy(q);
  d["z"] = to_numpy(z);
  d["coordinate_change"] = p.coordinate_change;
  d["speed_change"] = p.speed_change;
  d["error_before"] = p.error_before;
  d["iterations"] = p.iterations;
  return d;
}

py::dict constrained_forward(const PyModel& m, py::object first, py::object second,
                             py::object u_obj, py::object method_obj) {
  const std::string method = string_argument(method_obj, "method");
  if (method != "multipliers" && method != "projected")
    throw py::value_error("method must be 'multipliers' or 'projected', got '" + method + "'");
  VectorX q, z, u;
  if (py::isinstance<PyState>(first) && !second.is_none() && u_obj.is_none()) {
    u_obj = second;  // constrained_forward(state, u), as forward(state, u)
    second = py::none();
  }
  state_arguments(m, first, second, q, z, "constrained_forward()");
  input_values(m, u_obj, u);
  const Model& model = m.model();
  ConstrainedDynamics dynamics(model, method == "projected"
                                          ? ConstrainedDynamics::Method::projected
                                          : ConstrainedDynamics::Method::multipliers);
  VectorX zdot(model.num_speeds());
  constraint_call([&] {
    py::gil_scoped_release release;
    dynamics.evaluate(q, z, u, zdot);
    return 0;
  });
  const ConstraintEquations& eq = dynamics.equations();
  py::dict d;
  d["zdot"] = to_numpy(zdot);
  d["lambda"] = to_numpy(dynamics.lambda());
  d["rank"] = dynamics.rank();
  describe_rows(eq, d);
  py::list reactions;
  for (int c = 0; c < model.num_constraints(); ++c) {
    const Constraint& k = model.constraints()[at(c)];
    py::dict r;
    r["name"] = k.name;
    r["type"] = to_string(k.type);
    r["point"] = to_numpy(eq.point(c));
    r["force"] = to_numpy(eq.force(c, dynamics.lambda()));
    r["moment"] = to_numpy(eq.moment(c, dynamics.lambda()));
    reactions.append(r);
  }
  d["reactions"] = reactions;
  return d;
}

}  // namespace

void register_constraints(py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  cls.def_property_readonly(
         "constraints",
         [](const PyModel& p) {
           py::list out;
           for (const Constraint& c : p.model().constraints())
             out.append(constraint_dict(p.model(), c));
           return out;
         },
         "The model's constraints (docs/model-format.md, \"constraints\"), in order, each a "
         "dict of every field: name, type ('rolling_disc', 'ball', 'hinge', 'distance'), body "
         "(its name), at (the point of body, or a rolling disc's centre, from O_K, body-K "
         "components), axis (normalized), radius, plane_normal, plane_offset, other (a body's "
         "name or 'ground'), other_at, other_axis, length, and equations (its number of rows). "
         "Fields that do not apply to the type hold their defaults.")
      .def_property_readonly(
          "independent_speeds",
          [](const PyModel& p) {
            const std::vector<std::string> speeds = speed_names(p.model());
            if (p.model().num_constraints() == 0) return speeds;
            return pick(speeds, p.file().partition.independent);
          },
          "The names of the independent speeds z_I (the linearization's names, "
          "tangent_state_names): the file's independent_speeds, else those chosen at the "
          "initial state by pivoting on [B] (what `kanedyn info` prints). Every speed for a "
          "model without constraints.")
      .def("constraint_equations", &equations_at, py::arg("state") = py::none(),
           py::arg("z") = py::none(),
           "The constraint equations at a state, constraint_equations(state) or "
           "constraint_equations(q, z) (default: the initial state): a dict of B (c x n, "
           "[B]{z} = 0), b (c, [B dot]{z}, so that [B]{z dot} + {b} = 0), errors (c, the "
           "holonomic rows' position errors, 0 on the others), rows (their names, 'NAME.1' ..), "
           "holonomic (a bool per row) and points (one per constraint, inertial: a rolling "
           "disc's contact point, else the point `at` of its body). ValueError where the "
           "equations are not defined (a disc's axle along the plane's normal).")
      .def("partition_speeds", &partition_at, py::arg("state") = py::none(),
           py::arg("z") = py::none(),
           "The speed partition at a state, partition_speeds(state) or partition_speeds(q, z) "
           "(default: the initial state): a dict of rank (independent equations), rows and "
           "redundant_rows (row names), independent_speeds and dependent_speeds (names), "
           "independent and dependent (their indices in z), and C_I (n x (n - rank)): z = C_I "
           "z_I, the identity on the independent speeds and -B_D^-1 B_I on the dependent "
           "ones, so that B @ C_I = 0. The model's independent_speeds when the file names "
           "them, else chosen by pivoting on [B].")
      .def("project", &project_state, py::arg("state") = py::none(), py::arg("z") = py::none(),
           py::arg("tolerance") = 1e-12,
           "Projects a state onto the constraints, project(state) or project(q, z): the "
           "holonomic errors below `tolerance` by Gauss-Newton steps in the dependent "
           "coordinates only, then the speeds by least squares (the smallest change with "
           "[B]{z} = 0); what the loader does to the file's initial state. Returns a dict of "
           "the projected q and z and what the projection changed: coordinate_change, "
           "speed_change (the largest changes), error_before (the largest holonomic error "
           "before) and iterations. ValueError naming the constraint when it does not converge.")
      .def("constrained_forward", &constrained_forward, py::arg("state") = py::none(),
           py::arg("z") = py::none(), py::arg("u") = py::none(), py::arg("method") = "multipliers",
           "Forward dynamics with the constraints and their reactions: "
           "constrained_forward(state, u) or constrained_forward(q, z, u) (u: the inputs' "
           "values, None: all 0). A dict of zdot (n; the same as forward() and "
           "joint_derivatives() give), lambda (the rows' multipliers: M zdot + b = B^T "
           "lambda; minimum-norm over redundant rows), rank, rows, holonomic, and reactions: "
           "one dict per constraint, name, type, point (inertial), force (on its body, at "
           "point, inertial components) and moment (about point; a hinge's, zero for the "
           "others). method: 'multipliers' (the constraint-space solve) or 'projected' "
           "(Kane's equations in the independent speeds); equal to round-off.");
}

}  // namespace kanedyn::python
