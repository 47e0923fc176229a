// The Python module's C++ side: the Model object that Python holds, the checks that turn
// Python arguments into the library's types, and the registration of each part.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/terms.hpp"

namespace kanedyn::python {

namespace py = pybind11;

/// A loaded model file as Python holds it: immutable, shared by every thread. derivatives()
/// takes a workspace (a Data and a State) from a pool for each call, so that calls from
/// several threads never share one, and no call allocates once the pool holds enough.
class PyModel {
 public:
  explicit PyModel(io::ModelFile file) : file_(std::move(file)) {}
  const io::ModelFile& file() const { return file_; }
  const Model& model() const { return file_.model; }
  int N() const { return file_.model.num_bodies(); }
  /// Whether the model integrates its state in the notes' layout ({x}; {y}) (every joint
  /// free) or as (q; z): what derivatives() and derivatives_batch() take and give.
  bool notes_layout() const { return file_.model.all_free(); }

  /// What one call works in: the notes' state and its Data for the free tree's kernel, and
  /// for any other model a Dynamics with its (q, z) and their rates.
  struct Workspace {
    explicit Workspace(const Model& model);
    Data data;
    State state;
    std::unique_ptr<Dynamics> dynamics;  // models with joints; others: made by any_dynamics()
    std::unique_ptr<Terms> terms;        // made on first use by terms_of()
    VectorX v, dv;                       // the packed (q; z) and its rate
    VectorX u;                           // the inputs' values of the call
    /// The analysis' derivatives (analysis.cpp), made on first use.
    std::unique_ptr<Derivatives> derivatives;
    /// The inputs' values every later evaluation in this workspace reads, from a Python
    /// argument (None: zero; input_values()): set by each call, since a pooled workspace keeps
    /// the values of its last one.
    void use_inputs(const PyModel& owner, py::handle u_obj);
    /// The workspace's Dynamics of any model (made on first use for an all-free model).
    Dynamics& any_dynamics(const Model& model);
    Terms& terms_of(const Model& model);
  };
  /// A workspace for the lifetime of the lease, returned to the pool after; safe without the
  /// GIL.
  class Lease {
   public:
    explicit Lease(const PyModel& owner);
    ~Lease();
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Workspace& operator*() { return *work_; }
    Workspace* operator->() { return work_.get(); }

   private:
    const PyModel& owner_;
    std::unique_ptr<Workspace> work_;
  };

 private:
  io::ModelFile file_;
  mutable std::mutex pool_mutex_;
  mutable std::vector<std::unique_ptr<Workspace>> pool_;
};

/// Python's kanedyn.State. A state of the notes (State(x, y), and every state of an all-free
/// model) stores x and y; its q and z are computed from them (body by body: q_K = (eps_K,
/// s'_K), z_K = (w'_K, s'_K dot)). A state of a model with joints stores its joint
/// coordinates q and speeds z, and that model; its x and y are computed from them
/// (joint_state). The stored arrays are the writable ones.
struct PyState {
  State notes;
  VectorX q, z;
  std::shared_ptr<const PyModel> model;  // set for a state of joint coordinates
  bool jointed() const { return model != nullptr; }
};

// --- arrays.cpp: arguments in, numpy arrays out -------------------------------------------

/// `obj` as a float64 numpy array of the given shape (-1: any length), read through its
/// strides (so non-contiguous arrays are read correctly). A numpy array of another dtype
/// raises TypeError; a sequence of numbers is converted; a wrong shape raises ValueError.
/// `what` describes the expected shape in words, e.g. "(7N,) = (56,) for N = 8".
py::array float64_array(py::handle obj, const char* name, const std::vector<py::ssize_t>& shape,
                        const std::string& what);
/// True when obj is already what float64_array would return for shape (size,): a native
/// float64 1-d numpy array of that length, aligned; then sets data and stride (in doubles).
/// The per-call fast path of derivatives(): no conversion, no message built.
bool plain_vector(py::handle obj, py::ssize_t size, const double*& data, py::ssize_t& stride);

/// True for a numpy array of native-order float64 (NPY_DOUBLE), the only dtype read in place.
bool is_float64(const py::array& a);

/// Copies a 1-d float64_array into v (of the array's length), through its stride.
void copy_vector(const py::array& a, VectorX& v);

/// The first double of a float64_array and its strides in doubles.
/// Inside a catch block of a METH_FASTCALL function (no pybind11 dispatcher): sets the Python
/// error of the exception being handled as pybind11 would, for the caller to return nullptr.
inline void set_python_error() {
  try {
    throw;
  } catch (py::error_already_set& e) {
    e.restore();
  } catch (const py::builtin_exception& e) {
    e.set_error();
  } catch (const std::exception& e) {
    PyErr_SetString(PyExc_RuntimeError, e.what());
  }
}

inline const double* doubles(const py::array& a) { return static_cast<const double*>(a.data()); }
inline py::ssize_t stride(const py::array& a, int dim) {
  return a.strides(dim) / static_cast<py::ssize_t>(sizeof(double));
}

/// The 7N {x} or 6N {y} of one state from `values` (stride in doubles), checked: every
/// component finite, and every eps_K of unit norm within kUnitTolerance. Returns "" or the
/// problem ("x[3] is nan (body 'torso' e4)"), naming the array `name`, or its row `row` of a
/// batch ("X[4]") when row >= 0.
std::string copy_coordinates(const Model& model, const double* values, py::ssize_t stride,
                             VectorX& x, const char* name, py::ssize_t row = -1);
std::string copy_speeds(const Model& model, const double* values, py::ssize_t stride, VectorX& y,
                        const char* name, py::ssize_t row = -1);
constexpr double kUnitTolerance = 1e-6;

/// The model's state (q, z) of a Python argument, checked (shapes, finite, unit Euler
/// parameters: ValueError naming the body): None gives the initial state; a State of joint
/// coordinates is taken as it is when its model has the same joints; a State of the notes'
/// x, y goes through joint_coordinates (ValueError naming the body where the joints do not
/// allow it). TypeError for anything else.
void model_state(const PyModel& m, py::handle obj, VectorX& q, VectorX& z);
/// The same from either a State or the arguments q and z (None: the initial ones; an array
/// of the model's q or z); ValueError when both a state and q or z are given.
void model_state(const PyModel& m, py::handle state, py::handle q_obj, py::handle z_obj, VectorX& q,
                 VectorX& z);
/// The problem with (q, z) of the model, or "": a non-finite entry, a body's slice of q not
/// usable (Euler parameters off unit norm by more than 1e-6), naming the arrays and the body.
std::string model_state_problem(const PyModel& m, const VectorX& q, const VectorX& z,
                                const std::string& qname, const std::string& zname);
/// The notes' state of a Python argument for an all-free model (ValueError otherwise): None
/// gives the initial state; checked as copy_coordinates and copy_speeds check.
State notes_state(const PyModel& m, py::handle obj);
/// The inputs' values u (docs/model-format.md, "inputs") of a Python argument, into u (resized
/// to model.num_inputs()): None gives zeros; else m finite numbers (float64_array's rules;
/// ValueError naming the argument `name`, the model's input names, or the entry not finite).
void input_values(const PyModel& m, py::handle obj, VectorX& u, const char* name = "u");
/// The generalized speeds' rates z dot (or any vector over z) of a Python argument, n finite
/// numbers, into v (resized).
void speed_vector(const PyModel& m, py::handle obj, VectorX& v, const char* name);

/// A Python State of the model at (q, z), already checked: the notes' x, y for an all-free
/// model, else the joint coordinates with the model.
PyState make_state(const std::shared_ptr<const PyModel>& m, const VectorX& q, const VectorX& z);

/// A path argument as open() takes one: str, bytes or os.PathLike (by os.fspath), encoded as
/// os.fsencode does (so that a name os.listdir gave back round-trips). A NUL byte raises
/// ValueError("embedded null byte"), as open() does: the C library would end the name there
/// and read or write another file. `name` names the argument in the TypeError for a
/// non-path.
std::string path_argument(py::handle obj, const char* name);
/// A path for Python: a str decoded as os.fsdecode does, the inverse of path_argument.
py::str path_str(const std::string& path);

/// An integer argument: a Python int or anything with __index__ (numpy integers), not a
/// bool. TypeError otherwise; ValueError "NAME VALUE is not in LO..HI" when out of the range,
/// however large (pybind11's own conversion would raise TypeError for an int beyond 64 bits).
long long integer_argument(py::handle obj, const std::string& name, long long lo, long long hi);
/// integer_argument for an index (a run of a study): IndexError when out of the range.
long long index_argument(py::handle obj, const std::string& name, long long lo, long long hi);

/// The Model of a Python argument: TypeError "NAME must be a kanedyn.Model ..., got TYPE" for
/// anything else, None included (pybind11 would hand None to a holder argument as a null
/// pointer).
std::shared_ptr<PyModel> model_argument(py::handle obj, const char* name);
/// A number: a Python int or float or a numpy number, not a bool nor a str. TypeError "NAME
/// must be a number, got TYPE" otherwise; an int beyond the range of a double is inf.
double number_argument(py::handle obj, const char* name);
/// A finite number: ValueError "NAME must be finite, got VALUE" otherwise.
double finite_argument(py::handle obj, const char* name);
/// A finite number > 0 (a tolerance, a step, a time span): ValueError "NAME must be a finite
/// number > 0, got VALUE" otherwise.
double positive_setting(py::handle obj, const char* name);
/// A str: TypeError "NAME must be a str, got TYPE" otherwise (pybind11's own conversion would
/// raise its generic "incompatible function arguments").
std::string string_argument(py::handle obj, const char* name);
/// True or False (a bool or a numpy.bool_): TypeError naming the argument otherwise.
bool bool_argument(py::handle obj, const char* name);
/// repr(value) for a message, cut to its first characters when long (an int of 10**400).
std::string shown_value(py::handle value);

/// What a long computation without the GIL does between its steps (simulate()'s on_step,
/// Simulator.step's dopri5 steps): about every 50 ms it takes the GIL to let Python run its
/// signal handlers (Ctrl-C) and, every 0.1 s, the progress callback (None: none). An
/// exception of either stops the computation (operator() returns false) and is kept, to be
/// raised by restore() once the GIL is held again.
class StepHook {
 public:
  StepHook(py::object progress, double t_end);
  ~StepHook();
  StepHook(const StepHook&) = delete;
  StepHook& operator=(const StepHook&) = delete;

  /// Called without the GIL; force: check now (and call the progress callback).
  bool operator()(double t, bool force = false);
  bool failed() const { return type_ != nullptr; }
  /// Sets the kept exception as Python's error (ownership passes to it).
  void restore();

 private:
  using Clock = std::chrono::steady_clock;
  bool stash();
  py::object progress_;
  double t_end_;
  Clock::time_point last_check_ = Clock::now(), last_progress_ = last_check_;
  PyObject *type_ = nullptr, *value_ = nullptr, *trace_ = nullptr;
};

/// C-contiguous float64 copies.
py::array_t<double> to_numpy(const VectorX& v);
py::array_t<double> to_numpy(const MatrixX& m);
py::array_t<double> to_numpy(const Vector3& v);
py::array_t<double> to_numpy(const Matrix3& m);
/// (rows, cols) C-order array over `values` (row-major), copied.
py::array_t<double> to_numpy(const std::vector<double>& values, py::ssize_t rows, py::ssize_t cols);

// --- the parts of the module ---------------------------------------------------------------
void register_study(py::module_& m);
void register_errors(py::module_& m);
void register_state(py::module_& m);
void register_model(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_run(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_view(py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_control(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_analysis(py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_constraints(py::class_<PyModel, std::shared_ptr<PyModel>>& cls);

/// Raises kanedyn.ModelError for a model-file error (with its parts as attributes).
[[noreturn]] void raise_model_error(const io::ModelFileError& e);

}  // namespace kanedyn::python
