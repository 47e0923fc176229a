// kanedyn.Model: loading, the model's description, the state, and the equations at one state
// (eom, inspect, energy), each a thin call of the library's public API.
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/inspect.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"

namespace kanedyn::python {

PyModel::Workspace::Workspace(const Model& model)
    : data(model, DataOptions::recursive_only()), state(model) {
  // An all-free model runs the notes' kernels, unless constraints join its bodies: the free
  // tree does not know them, Dynamics does.
  if (model.all_free() && model.num_constraints() == 0) return;
  dynamics = std::make_unique<Dynamics>(model, Route::recursive);
  v.resize(dynamics->size());
  dv.resize(dynamics->size());
}

Dynamics& PyModel::Workspace::any_dynamics(const Model& model) {
  if (!dynamics) dynamics = std::make_unique<Dynamics>(model, Route::recursive);
  return *dynamics;
}

void PyModel::Workspace::use_inputs(const PyModel& owner, py::handle u_obj) {
  input_values(owner, u_obj, u);
  data.inputs = u;
  if (dynamics) dynamics->set_inputs(u);
}

Terms& PyModel::Workspace::terms_of(const Model& model) {
  if (!terms) terms = std::make_unique<Terms>(model);
  return *terms;
}

PyModel::Lease::Lease(const PyModel& owner) : owner_(owner) {
  {
    const std::lock_guard<std::mutex> lock(owner_.pool_mutex_);
    if (!owner_.pool_.empty()) {
      work_ = std::move(owner_.pool_.back());
      owner_.pool_.pop_back();
    }
  }
  if (!work_) work_ = std::make_unique<Workspace>(owner_.model());
}

PyModel::Lease::~Lease() {
  const std::lock_guard<std::mutex> lock(owner_.pool_mutex_);
  owner_.pool_.push_back(std::move(work_));
}

namespace {

/// [A], {f}, {y dot}, {x dot} and {F_y} at one state, as numpy arrays.
struct Equations {
  int N = 0;
  py::array_t<double> A, f, ydot, xdot, F_y;
  /// Jointed models: the projected equations (else None).
  py::object n = py::none(), C = py::none(), A_z = py::none(), f_z = py::none(), zdot = py::none();
};

Equations equations_of_motion(const PyModel& m, py::object state_obj, py::object u_obj) {
  VectorX q, z, u;
  model_state(m, state_obj, q, z);
  input_values(m, u_obj, u);
  if (m.N() > kMaxEomBodies)
    throw py::value_error("eom() forms the dense 6N x 6N [A], and N = " + std::to_string(m.N()) +
                          " is more than " + std::to_string(kMaxEomBodies) +
                          "; derivatives() and simulate() run models of any size");
  Equations e;
  {
    py::gil_scoped_release release;
    State state(m.model());
    joint_state(m.model(), q, z, state);
    Data data(m.model(), DataOptions{.partials = false});  // [A] dense, as eom --json prints it
    data.inputs = u;
    kane_equations(m.model(), state, data);
    py::gil_scoped_acquire acquire;
    e.N = m.N();
    e.A = to_numpy(data.kane.A);
    e.f = to_numpy(data.kane.f);
    e.ydot = to_numpy(data.ydot);
    e.xdot = to_numpy(data.xdot);
    e.F_y = to_numpy(data.kane.F_y);
    // The projected equations are printed for models with joints (docs/model-format.md).
    if (!m.notes_layout()) {
      py::gil_scoped_release again;
      const ProjectedEquations p = projected_equations(m.model(), q, z, data);
      py::gil_scoped_acquire with;
      e.n = py::int_(p.zdot.size());
      e.C = to_numpy(p.C);
      e.A_z = to_numpy(p.A_z);
      e.f_z = to_numpy(p.f_z);
      e.zdot = to_numpy(p.zdot);
    }
  }
  return e;
}

/// A frame or a body's own frame (origin O_K, body-K axes), named as either.
struct Target {
  int frame = -1, body = -1;
};

/// The frame or body named `name`; KeyError with the closest name otherwise.
Target frame_argument(const PyModel& p, const std::string& name) {
  if (const int f = p.model().frame_index(name); f >= 0) return {f, -1};
  if (const int k = p.model().body_index(name); k >= 0) return {-1, k};
  std::vector<std::string> names;
  for (const Frame& frame : p.model().frames()) names.push_back(frame.name);
  for (const BodySpec& b : p.model().bodies()) names.push_back(b.name);
  const std::string near = io::closest_word(name, names);
  throw py::key_error("no frame or body named '" + io::printable(name, 60) + "'" +
                      (near.empty() ? "" : " (did you mean '" + near + "'?)"));
}

/// The notes' state of (q, z) and its kinematics, in a pooled workspace.
void kinematics_at(const PyModel& p, const VectorX& q, const VectorX& z, PyModel::Workspace& work) {
  joint_state(p.model(), q, z, work.state);
  compute_kinematics(p.model(), work.state, work.data);
}

/// The joint coordinates of the zero pose: identity rotations (e4 = 1 in a free body's eps_K
/// and a spherical joint's q), every other coordinate 0.
VectorX zero_coordinates(const Model& model) {
  VectorX q = VectorX::Zero(model.num_coordinates());
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    if (joint_type_info(type).euler) q[model.coordinate_offset(k) + 3] = 1.0;
  }
  return q;
}

/// Model.state(q=, z=, x=, y=): see its docstring.
PyState make_model_state(const std::shared_ptr<PyModel>& p, py::object q_obj, py::object z_obj,
                         py::object x_obj, py::object y_obj) {
  const Model& model = p->model();
  const int n = p->N();
  if ((!x_obj.is_none() || !y_obj.is_none()) && (!q_obj.is_none() || !z_obj.is_none()))
    throw py::value_error("give q and z or x and y, not both");
  if (!x_obj.is_none() || !y_obj.is_none()) {
    PyState notes;
    notes.notes = State(model);
    if (!x_obj.is_none())
      copy_vector(float64_array(x_obj, "x", {7 * n}, "(7N,) = (" + std::to_string(7 * n) + ",)"),
                  notes.notes.x);
    if (!y_obj.is_none())
      copy_vector(float64_array(y_obj, "y", {6 * n}, "(6N,) = (" + std::to_string(6 * n) + ",)"),
                  notes.notes.y);
    VectorX q, z;
    model_state(*p, py::cast(notes), q, z);  // checked, and through the joints
    return make_state(p, q, z);
  }
  VectorX q = zero_coordinates(model), z = VectorX::Zero(model.num_speeds());
  model_state(*p, py::none(), q_obj.is_none() ? py::object(to_numpy(q)) : q_obj,
              z_obj.is_none() ? py::object(to_numpy(z)) : z_obj, q, z);
  return make_state(p, q, z);
}

/// True for an integer of another type than int (numpy.int64, ...): what has __index__ and
/// is neither a bool nor an array (a numpy array has __index__ too, and is a list here).
bool is_integer(py::handle obj) {
  if (PyBool_Check(obj.ptr()) || !PyIndex_Check(obj.ptr()) || py::isinstance<py::array>(obj))
    return false;
  return !py::isinstance(obj, py::module_::import("numpy").attr("bool_"));
}

/// 0-based indices of the bodies named by 1-based numbers or by names.
std::vector<int> body_indices(const Model& model, py::handle bodies) {
  std::vector<int> out;
  if (bodies.is_none()) return out;
  std::vector<py::object> items;
  if (py::isinstance<py::str>(bodies) || py::isinstance<py::int_>(bodies) || is_integer(bodies) ||
      !py::isinstance<py::iterable>(bodies))
    items.push_back(py::reinterpret_borrow<py::object>(bodies));  // refused below unless a body
  else
    for (py::handle item : bodies) items.push_back(py::reinterpret_borrow<py::object>(item));
  for (const py::object& item : items) {
    int k = -1;
    if (py::isinstance<py::bool_>(item)) {
      throw py::type_error("bodies: expected body numbers K (1..N) or names, got a bool");
    } else if (py::isinstance<py::int_>(item) || is_integer(item)) {
      k = static_cast<int>(integer_argument(item, "bodies: body number", 1, model.num_bodies())) -
          1;
    } else if (py::isinstance<py::str>(item)) {
      const std::string name = item.cast<std::string>();
      k = model.body_index(name);
      if (k < 0) {
        std::vector<std::string> names;
        for (const BodySpec& b : model.bodies()) names.push_back(b.name);
        const std::string near = io::closest_word(name, names);
        throw py::value_error("bodies: no body named '" + io::printable(name, 60) + "'" +
                              (near.empty() ? "" : " (did you mean '" + near + "'?)"));
      }
    } else {
      throw py::type_error("bodies: expected body numbers K (1..N) or names, got " +
                           std::string(py::str(item.get_type().attr("__name__"))));
    }
    out.push_back(k);
  }
  return out;
}

Point point_argument(const std::string& point) {
  if (point == "O") return Point::O;
  if (point == "G") return Point::G;
  throw py::value_error("point must be 'O' or 'G', got '" + io::printable(point, 20) + "'");
}

template <class T>
py::list to_list(const std::vector<T>& values) {
  py::list out;
  for (const T& v : values) out.append(v);
  return out;
}

void register_inspection(py::module_& m) {
  py::class_<BodyInspection>(m, "BodyInspection",
                             "One body's quantities at a state (kanedyn inspect --json, one "
                             "entry of 'bodies'). Inertial components unless said; "
                             "3 x 6N matrices have their columns in the order of {y}.")
      .def_readonly("K", &BodyInspection::K, "body number of the notes (1-based)")
      .def_readonly("name", &BodyInspection::name)
      .def_readonly("L", &BodyInspection::L, "L(K), 0 for the inertial frame")
      .def_readonly("u", &BodyInspection::u, "u_K, bodies between K and the inertial frame")
      .def_readonly("chain", &BodyInspection::chain, "K, L(K), ..., 0")
#define KANEDYN_FIELD(field, doc) \
  .def_property_readonly(         \
      #field, [](const BodyInspection& b) { return to_numpy(b.field); }, doc)
          KANEDYN_FIELD(R, "[R_K] (Eqs. 3-4), 3x3: inertial -> body-K components") KANEDYN_FIELD(
              p_O, "{p_O_K} (Eq. 12), position of O_K")
              KANEDYN_FIELD(p_G, "{p_G_K} (Eq. 13), position of the mass centre G_K") KANEDYN_FIELD(
                  v_O, "{v_O_K} (Eq. 15)") KANEDYN_FIELD(v_G, "{v_G_K} (Eq. 17)")
                  KANEDYN_FIELD(w, "{w'_K}, body-K components") KANEDYN_FIELD(
                      w_y, "[w'_K,y] (Eq. 8), 3 x 6N")
                      KANEDYN_FIELD(v_O_y, "[v_O_K,y] (Eqs. 18-19, 22-24), 3 x 6N") KANEDYN_FIELD(
                          v_G_y, "[v_G_K,y] (Eqs. 20-21, 25-27), 3 x 6N")
                          KANEDYN_FIELD(v_O_y_dot, "d/dt [v_O_K,y] (Eq. 29), 3 x 6N") KANEDYN_FIELD(
                              v_G_y_dot, "d/dt [v_G_K,y] (Eq. 30), 3 x 6N")
                              KANEDYN_FIELD(F, "{F_K}: resultant force at G_K (Eq. 31)")
                                  KANEDYN_FIELD(
                                      M, "{M'_K}: resultant moment about G_K, body-K components")
                                      KANEDYN_FIELD(F_y, "K's term of {F_y} (Eq. 31), 6N")
                                          KANEDYN_FIELD(F_y_star,
                                                        "K's generalized inertia force at the "
                                                        "solved {y dot}, 6N")
#undef KANEDYN_FIELD
      .def("__repr__", [](const BodyInspection& b) {
        return "<kanedyn.BodyInspection K=" + std::to_string(b.K) + " '" + b.name + "'>";
      });

  py::class_<JointBodyInspection>(m, "JointBodyInspection",
                                  "One body's joint at the inspected (q, z) (kanedyn inspect "
                                  "--json, one entry of joints.bodies).")
      .def_readonly("K", &JointBodyInspection::K, "body number of the notes (1-based)")
      .def_property_readonly(
          "type", [](const JointBodyInspection& b) { return std::string(to_string(b.type)); },
          "the joint type as the model format spells it")
      .def_property_readonly(
          "q", [](const JointBodyInspection& b) { return to_numpy(b.q); }, "the body's q slice")
      .def_property_readonly(
          "z", [](const JointBodyInspection& b) { return to_numpy(b.z); }, "the body's z slice")
      .def_property_readonly(
          "C_w", [](const JointBodyInspection& b) { return to_numpy(b.C_w); },
          "its rows of [C] for w'_K, 3 x n")
      .def_property_readonly(
          "C_sd", [](const JointBodyInspection& b) { return to_numpy(b.C_sd); },
          "its rows of [C] for s'_K dot, 3 x n")
      .def("__repr__", [](const JointBodyInspection& b) {
        return "<kanedyn.JointBodyInspection K=" + std::to_string(b.K) + " " + to_string(b.type) +
               ">";
      });

  py::class_<JointInspection>(m, "JointInspection",
                              "The joints at (q, z): y = [C] z and [C]^T [A] [C] {z dot} = "
                              "[C]^T ({f} - [A][C dot]{z}) + Q (kanedyn inspect --json, joints).")
      .def_readonly("n", &JointInspection::n, "independent speeds")
#define KANEDYN_FIELD(field, doc) \
  .def_property_readonly(         \
      #field, [](const JointInspection& j) { return to_numpy(j.field); }, doc)
          KANEDYN_FIELD(q, "joint coordinates") KANEDYN_FIELD(z, "independent speeds")
              KANEDYN_FIELD(C, "[C], 6N x n") KANEDYN_FIELD(Cdot_z, "[C dot]{z}, 6N")
                  KANEDYN_FIELD(A_z, "[C]^T [A] [C], n x n")
                      KANEDYN_FIELD(f_z, "[C]^T ({f} - [A][C dot]{z}) + the joint loads, n")
                          KANEDYN_FIELD(zdot, "{z dot}, n")
                              KANEDYN_FIELD(ydot, "the jointed {y dot} = [C]{z dot} + [C dot]{z}")
#undef KANEDYN_FIELD
      .def_readonly("bodies", &JointInspection::bodies, "the selected bodies' joints")
      .def("__repr__", [](const JointInspection& j) {
        return "<kanedyn.JointInspection n=" + std::to_string(j.n) + ">";
      });

  py::class_<Inspection>(m, "Inspection",
                         "Every quantity of the notes at one state (kanedyn inspect --json). "
                         "Index by body number K or name: q[8], q['head'].")
      .def_readonly("N", &Inspection::N)
      .def_readonly("t", &Inspection::t)
      .def_property_readonly(
          "F_y", [](const Inspection& q) { return to_numpy(q.F_y); },
          "{F_y} (Eq. 31), 6N: the sum over every body")
      .def_property_readonly(
          "F_y_star", [](const Inspection& q) { return to_numpy(q.F_y_star); },
          "the generalized inertia forces, 6N: {F_y} + {F_y*} = 0 at the solution")
      .def_property_readonly(
          "ydot", [](const Inspection& q) { return to_numpy(q.ydot); }, "{y dot} (Eq. 36), 6N")
      .def_readonly("bodies", &Inspection::bodies, "the selected bodies, in numbering order")
      .def_readonly("joints", &Inspection::joints,
                    "a jointed model's JointInspection ([C], the projected equations), else None")
      .def(
          "__getitem__",
          [](const Inspection& q, py::object key) -> const BodyInspection& {
            // A number K compared as a Python int, so that one beyond 64 bits is only absent.
            const bool number = py::isinstance<py::int_>(key) && !py::isinstance<py::bool_>(key);
            for (const BodyInspection& b : q.bodies)
              if ((number && key.equal(py::int_(b.K))) ||
                  (py::isinstance<py::str>(key) && key.cast<std::string>() == b.name))
                return b;
            throw py::key_error("no body " + std::string(py::repr(key)) + " in this inspection");
          },
          py::return_value_policy::reference_internal)
      .def("__len__", [](const Inspection& q) { return q.bodies.size(); })
      .def("__repr__", [](const Inspection& q) {
        return "<kanedyn.Inspection N=" + std::to_string(q.N) + " t=" + std::to_string(q.t) + ", " +
               std::to_string(q.bodies.size()) + (q.bodies.size() == 1 ? " body>" : " bodies>");
      });
}

py::array_t<int> int_array(const std::vector<int>& values) {
  py::array_t<int> out(static_cast<py::ssize_t>(values.size()));
  for (size_t i = 0; i < values.size(); ++i) out.mutable_data()[i] = values[i];
  return out;
}

/// One 3-vector of every body's spec, (N, 3).
py::array_t<double> per_body(const PyModel& p, Vector3 BodySpec::*field) {
  std::vector<double> v;
  for (const BodySpec& b : p.model().bodies())
    v.insert(v.end(), (b.*field).begin(), (b.*field).end());
  return to_numpy(v, p.N(), 3);
}

py::dict simulation_section(const io::SimulationSection& s) {
  py::dict d;
  if (s.t_end) d["t_end"] = *s.t_end;
  if (s.dt_out) d["dt_out"] = *s.dt_out;
  if (s.integrator) d["integrator"] = *s.integrator;
  if (s.rtol) d["rtol"] = *s.rtol;
  if (s.atol) d["atol"] = *s.atol;
  if (s.step) d["step"] = *s.step;
  if (s.route) d["route"] = to_string(parse_route(*s.route));
  return d;
}

}  // namespace

void register_model(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  py::class_<Equations>(m, "EquationsOfMotion",
                        "Kane's equations [A]{y dot} = {f} (Eq. 36) at one state, as "
                        "kanedyn eom --json prints them.")
      .def_readonly("N", &Equations::N)
      .def_readonly("A", &Equations::A, "[A] (Eq. 37), 6N x 6N, symmetric positive definite")
      .def_readonly("f", &Equations::f, "{f} (Eq. 38), 6N")
      .def_readonly("ydot", &Equations::ydot, "{y dot}, the solution of Eq. (36), 6N")
      .def_readonly("xdot", &Equations::xdot, "{x dot} (Eqs. 39-40), 7N")
      .def_readonly("F_y", &Equations::F_y, "{F_y}, the generalized active forces (Eq. 31), 6N")
      .def_readonly("n", &Equations::n, "jointed models: the number of independent speeds z")
      .def_readonly("C", &Equations::C, "jointed models: [C], y = [C] z, 6N x n")
      .def_readonly("A_z", &Equations::A_z, "jointed models: [C]^T [A] [C], n x n")
      .def_readonly("f_z", &Equations::f_z,
                    "jointed models: [C]^T ({f} - [A][C dot]{z}) + the joint loads, n")
      .def_readonly("zdot", &Equations::zdot, "jointed models: {z dot}, n")
      .def("__repr__", [](const Equations& e) {
        return "<kanedyn.EquationsOfMotion N=" + std::to_string(e.N) + ">";
      });
  register_inspection(m);

  m.def(
      "_load_file",
      [](py::handle path_obj) {
        const std::string path = path_argument(path_obj, "path");
        try {
          py::gil_scoped_release release;
          return std::make_shared<PyModel>(io::load_model_file(path));
        } catch (const io::ModelFileError& e) {
          raise_model_error(e);
        }
      },
      py::arg("path"));
  m.def(
      "_load_text",
      [](const std::string& text, py::handle name_obj) {
        // The name stands for a file's in messages and Model.path, which later writes
        // compare with their outputs: a NUL byte would cut it, as it would a path.
        const std::string name = string_argument(name_obj, "name");
        if (name.find('\0') != std::string::npos) throw py::value_error("embedded null byte");
        try {
          py::gil_scoped_release release;
          return std::make_shared<PyModel>(io::parse_model_file(text, name));
        } catch (const io::ModelFileError& e) {
          raise_model_error(e);
        }
      },
      py::arg("text"), py::arg("name"));

  cls.def_property_readonly("N", &PyModel::N, "N, the number of bodies")
      .def_property_readonly(
          "name", [](const PyModel& p) { return p.model().name(); }, "the model's name")
      .def_property_readonly(
          "path", [](const PyModel& p) { return path_str(p.file().path); },
          "the file it was loaded from ('<string>' or '<dict>' otherwise)")
      .def_property_readonly(
          "L",
          [](const PyModel& p) {
            std::vector<int> L;
            for (int k = 0; k < p.N(); ++k) L.push_back(p.model().lower_body(k) + 1);
            return int_array(L);
          },
          "L(K) for K = 1..N as the notes print it (1-based; 0 is the inertial frame), "
          "array (N,)")
      .def_property_readonly(
          "u",
          [](const PyModel& p) {
            std::vector<int> u;
            for (int k = 0; k < p.N(); ++k) u.push_back(p.model().depth(k));
            return int_array(u);
          },
          "u_K, the number of bodies below K, array (N,)")
      .def_property_readonly(
          "body_names",
          [](const PyModel& p) {
            std::vector<std::string> names;
            for (const BodySpec& b : p.model().bodies()) names.push_back(b.name);
            return names;
          },
          "the bodies' names, in numbering order (body K is body_names[K-1])")
      .def_property_readonly(
          "total_mass", [](const PyModel& p) { return p.model().total_mass(); }, "sum of m_K")
      .def_property_readonly(
          "gravity", [](const PyModel& p) { return to_numpy(p.model().gravity()); },
          "{g}, inertial components, (3,)")
      .def_property_readonly(
          "mass",
          [](const PyModel& p) {
            VectorX v(p.N());
            for (int k = 0; k < p.N(); ++k) v[k] = p.model().body(k).mass;
            return to_numpy(v);
          },
          "m_K, (N,)")
      .def_property_readonly(
          "inertia",
          [](const PyModel& p) {
            py::array_t<double> out({p.N(), 3, 3});
            auto o = out.mutable_unchecked<3>();
            for (int k = 0; k < p.N(); ++k)
              for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) o(k, i, j) = p.model().body(k).inertia(i, j);
            return out;
          },
          "[I'_G_K] about G_K, body-K components, (N, 3, 3)")
      .def_property_readonly(
          "com", [](const PyModel& p) { return per_body(p, &BodySpec::com); },
          "{r'_K}: O_K to G_K, body-K components, (N, 3)")
      .def_property_readonly(
          "joint", [](const PyModel& p) { return per_body(p, &BodySpec::joint); },
          "{q'_K}: O_J to Q_K, body-J components (inertial for a root), (N, 3)")
      .def_property_readonly(
          "columns", [](const PyModel& p) { return io::trajectory_columns(p.model()); },
          "the trajectory CSV's columns: t, NAME.x .. NAME.sd3 per body (and NAME.j*, "
          "NAME.jd* of a jointed body), energy")
      .def_property_readonly(
          "jointed", [](const PyModel& p) { return !p.notes_layout(); },
          "True when some body's joint is not free (docs/model-format.md, Joints)")
      .def_property_readonly(
          "joint_types",
          [](const PyModel& p) {
            std::vector<std::string> out;
            for (int k = 0; k < p.N(); ++k) out.emplace_back(to_string(p.model().joint(k).type));
            return out;
          },
          "each body's joint type, in numbering order ('free' for every body of a free tree)")
      .def_property_readonly(
          "joint_layout",
          [](const PyModel& p) {
            py::dict d;
            const Model& t = p.model();
            for (int k = 0; k < p.N(); ++k)
              d[py::str(t.body(k).name)] =
                  py::make_tuple(t.coordinate_offset(k), coordinate_count(t.joint(k).type),
                                 t.speed_offset(k), speed_count(t.joint(k).type));
            return d;
          },
          "each body's slices of the state: name -> (offset in q, count, offset in z, count)")
      .def_property_readonly(
          "initial_joint_coordinates", [](const PyModel& p) { return to_numpy(p.file().q); },
          "the initial joint coordinates q (a free body's slice is eps_K, s'_K)")
      .def_property_readonly(
          "initial_joint_speeds", [](const PyModel& p) { return to_numpy(p.file().z); },
          "the initial independent speeds z (a free body's slice is w'_K, s'_K dot)")
      .def_property_readonly(
          "simulation", [](const PyModel& p) { return simulation_section(p.file().simulation); },
          "the file's simulation: section (only the keys it sets)")
      .def_property_readonly(
          "frames",
          [](const PyModel& p) {
            std::vector<std::string> names;
            for (const Frame& f : p.model().frames()) names.push_back(f.name);
            return names;
          },
          "the names of the model's frames (the file's frames:, and a URDF's massless links on "
          "fixed joints)")
      .def(
          "frame",
          [](const PyModel& p, py::handle name, py::object state_obj) {
            const Target f = frame_argument(p, string_argument(name, "name"));
            VectorX q, z;
            model_state(p, state_obj, q, z);
            PyModel::Lease work(p);
            kinematics_at(p, q, z, *work);
            const FrameState s =
                f.frame >= 0
                    ? frame_state(p.model(), f.frame, work->state, work->data.kinematics)
                    : body_frame_state(p.model(), f.body, work->state, work->data.kinematics);
            py::dict out;
            out["position"] = to_numpy(s.position);
            out["R"] = to_numpy(s.R);
            out["velocity"] = to_numpy(s.velocity);
            out["angular_velocity"] = to_numpy(s.angular_velocity);
            return out;
          },
          py::arg("name"), py::arg("state") = py::none(),
          "The frame (or a body's own frame: O_K and its axes, by the body's name) at a state "
          "(default: the initial state), inertial components: a dict of "
          "its origin's 'position' and 'velocity', its 'angular_velocity', and 'R' (inertial "
          "to frame components, as a body's [R_K]).")
      .def(
          "jacobian",
          [](const PyModel& p, py::handle name, py::object state_obj) {
            const Target f = frame_argument(p, string_argument(name, "name"));
            VectorX q, z;
            model_state(p, state_obj, q, z);
            const int n = p.model().num_speeds();
            MatrixX Jv(3, n), Jw(3, n);
            {
              PyModel::Lease work(p);
              kinematics_at(p, q, z, *work);
              if (f.frame >= 0)
                frame_jacobian(p.model(), f.frame, q, work->data.kinematics, Jv, Jw);
              else
                body_jacobian(p.model(), f.body, q, work->data.kinematics, Jv, Jw);
            }
            return py::make_tuple(to_numpy(Jv), to_numpy(Jw));
          },
          py::arg("name"), py::arg("state") = py::none(),
          "(Jv, Jw), each 3 x n: the partial velocities of the frame's origin and of its "
          "angular velocity with respect to the speeds z (inertial components), so that "
          "velocity = Jv @ state.z and angular_velocity = Jw @ state.z. In the notes' terms "
          "[v_P,y][C] and [R_K]^T [w'_K,y][C] (docs/theory.md, \"Frames and Jacobians\").")
      .def(
          "frame_acceleration",
          [](const PyModel& p, py::handle name, py::object state_obj, py::object zdot_obj) {
            const Target f = frame_argument(p, string_argument(name, "name"));
            VectorX q, z, zdot;
            model_state(p, state_obj, q, z);
            speed_vector(p, zdot_obj, zdot, "zdot");
            PyModel::Lease work(p);
            kinematics_at(p, q, z, *work);
            const FrameAcceleration a = f.frame >= 0
                                            ? frame_acceleration(p.model(), f.frame, q, z, zdot,
                                                                 work->state, work->data.kinematics)
                                            : body_acceleration(p.model(), f.body, q, z, zdot,
                                                                work->state, work->data.kinematics);
            py::dict out;
            out["linear"] = to_numpy(a.linear);
            out["angular"] = to_numpy(a.angular);
            return out;
          },
          py::arg("name"), py::arg("state"), py::arg("zdot"),
          "The frame's acceleration at a state and the speeds' rates zdot (n; e.g. "
          "forward(state, u)), inertial components: a dict of its origin's 'linear' "
          "acceleration and its 'angular' acceleration.")
      .def(
          "body_number",
          [](const PyModel& p, py::handle name_obj) {
            const std::string name = string_argument(name_obj, "name");
            const int k = p.model().body_index(name);
            if (k < 0) throw py::key_error("no body named '" + io::printable(name, 60) + "'");
            return k + 1;
          },
          py::arg("name"), "K (1-based) of the body with this name")
      .def(
          "initial_state",
          [](const std::shared_ptr<PyModel>& p) {
            if (!p->notes_layout()) return make_state(p, p->file().q, p->file().z);
            PyState s;
            s.notes = p->file().initial;
            return s;
          },
          "The model file's initial state (Euler parameters normalized), a new kanedyn.State: "
          "the notes' x, y of an all-free model, the joint coordinates q, z of a model with "
          "joints.")
      .def("state", &make_model_state, py::kw_only(), py::arg("q") = py::none(),
           py::arg("z") = py::none(), py::arg("x") = py::none(), py::arg("y") = py::none(),
           "A state of this model: from its joint coordinates q and speeds z (Model.joint_layout "
           "gives each body's slices; None: the zero pose, identity rotations, or zero speeds), "
           "or from the notes' x and y (None: identity rotations and zero translations, or zero "
           "speeds) where the joints allow it (every body free, or welded; ValueError naming "
           "the body otherwise: an angle is not read back from x, where it loses its turns). "
           "Checked: finite, unit Euler parameters. With no argument, the zero state.")
      .def("eom", &equations_of_motion, py::arg("state") = py::none(), py::arg("u") = py::none(),
           "Kane's equations at a state (default: the initial state): [A] (Eq. 37), {f} (Eq. "
           "38), {y dot} (Eq. 36), {x dot} (Eqs. 39-40) and {F_y} (Eq. 31), and for a model "
           "with joints the projected equations; the same numbers as `kanedyn eom --json`. u: the "
           "inputs' values (None: all 0), as eom's --input NAME=VALUE. At most 300 bodies (the "
           "dense [A]).")
      .def(
          "inspect",
          [](const PyModel& p, py::object state_obj, py::object t_obj, py::object bodies,
             py::object q_obj, py::object z_obj, py::object u_obj) {
            const double t = finite_argument(t_obj, "t");
            const std::vector<int> selected = body_indices(p.model(), bodies);
            VectorX q, z, u;
            model_state(p, state_obj, q_obj, z_obj, q, z);
            input_values(p, u_obj, u);
            try {
              py::gil_scoped_release release;
              return inspect(p.model(), q, z, t, selected, u);
            } catch (const ModelError& e) {
              throw py::value_error(e.what());
            }
          },
          py::arg("state") = py::none(), py::arg("t") = 0.0, py::arg("bodies") = py::none(),
          py::kw_only(), py::arg("q") = py::none(), py::arg("z") = py::none(),
          py::arg("u") = py::none(),
          "Every quantity of the notes at a state (default: the initial state; or q= and z=; "
          "u= the inputs' values, None: all 0), "
          "as `kanedyn inspect --json` gives them: bodies is None (all), a body number K, a "
          "name, or a list of them; t is only reported. For a model with joints the result's "
          "joints holds [C] and the projected equations.")
      .def(
          "symbolic_partial",
          [](const PyModel& p, py::object body, py::handle point, py::handle rate_obj) {
            if (body.is_none())
              throw py::type_error("body must be a body number K (1..N) or a name, got None");
            const std::vector<int> k = body_indices(p.model(), body);
            if (k.size() != 1) throw py::value_error("body: give one body number K or name");
            const Point pt = point_argument(string_argument(point, "point"));
            const bool rate = bool_argument(rate_obj, "rate");
            return format_symbolic(p.model(), k[0], pt, rate, 1) + "\n" +
                   format_symbolic(p.model(), k[0], pt, rate, 2);
          },
          py::arg("body"), py::arg("point") = "G", py::arg("rate") = false,
          "The notes' block form of [v_P_K,y] (Eqs. 22-27), or of its time derivative with "
          "rate=True (Eqs. 29-30), for P = 'O' or 'G': two lines, the y1 and y2 parts.")
      .def(
          "energy",
          [](const PyModel& p, py::object state_obj, py::object q_obj, py::object z_obj) {
            VectorX q, z;
            model_state(p, state_obj, q_obj, z_obj, q, z);
            const Model& model = p.model();
            PyModel::Lease work(p);  // a pooled Data: no workspace built per call
            Data& data = work->data;
            return py::make_tuple(kinetic_energy(model, q, z, data),
                                  potential_energy(model, q, z, data),
                                  total_energy(model, q, z, data));
          },
          py::arg("state") = py::none(), py::kw_only(), py::arg("q") = py::none(),
          py::arg("z") = py::none(),
          "(kinetic, potential, total) energy at a state (default: the initial state), given as "
          "a State or as the joint coordinates q= and speeds z=. The potential includes the joint "
          "springs'; total is "
          "the CSV's energy column.")
      .def(
          "momentum",
          [](const PyModel& p, py::object state_obj, py::object q_obj, py::object z_obj) {
            VectorX q, z;
            model_state(p, state_obj, q_obj, z_obj, q, z);
            const Model& model = p.model();
            PyModel::Lease work(p);
            Data& data = work->data;
            return py::make_tuple(to_numpy(linear_momentum(model, q, z, data)),
                                  to_numpy(angular_momentum(model, q, z, data)));
          },
          py::arg("state") = py::none(), py::kw_only(), py::arg("q") = py::none(),
          py::arg("z") = py::none(),
          "(linear momentum, angular momentum about the inertial origin), inertial components.")
      .def("__repr__", [](const PyModel& p) {
        return "<kanedyn.Model '" +
               io::printable(p.model().name().empty() ? p.file().path : p.model().name(), 60) +
               "' N=" + std::to_string(p.N()) + ">";
      });
}

}  // namespace kanedyn::python
