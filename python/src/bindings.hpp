// The Python module's C++ side: the Model object that Python holds, the checks that turn
// Python arguments into the library's types, and the registration of each part.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

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
  /// The model when some joint is not free, else nullptr (the notes' free tree).
  const Model* joints() const { return file_.jointed() ? &file_.model : nullptr; }

  struct Workspace {
    explicit Workspace(const Model& model)
        : data(model, DataOptions::recursive_only()), state(model) {}
    Data data;
    State state;
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

/// A State from a Python State, or the model's initial state when obj is None; ValueError
/// for a state of another model size or with a problem of copy_coordinates/copy_speeds.
State state_argument(const PyModel& m, py::handle obj);
/// (q; z) of any model from the arguments q and z (None: the initial ones), checked:
/// shapes, finite, unit Euler parameters (ValueError naming the body).
VectorX joint_arguments(const PyModel& m, py::object q, py::object z);
/// The model's state (q; z) from either a State (the notes' x, y, where the joints allow it:
/// joint_coordinates, ValueError naming the body otherwise) or the arguments q and z; all
/// None gives the initial state. ValueError when both a state and q or z are given.
VectorX model_state_argument(const PyModel& m, py::object state, py::object q, py::object z);

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

/// C-contiguous float64 copies.
py::array_t<double> to_numpy(const VectorX& v);
py::array_t<double> to_numpy(const MatrixX& m);
py::array_t<double> to_numpy(const Vector3& v);
py::array_t<double> to_numpy(const Matrix3& m);
/// (rows, cols) C-order array over `values` (row-major), copied.
py::array_t<double> to_numpy(const std::vector<double>& values, py::ssize_t rows, py::ssize_t cols);

// --- the parts of the module ---------------------------------------------------------------
void register_errors(py::module_& m);
void register_state(py::module_& m);
void register_model(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_run(py::module_& m, py::class_<PyModel, std::shared_ptr<PyModel>>& cls);
void register_view(py::class_<PyModel, std::shared_ptr<PyModel>>& cls);

/// Raises kanedyn.ModelError for a model-file error (with its parts as attributes).
[[noreturn]] void raise_model_error(const io::ModelFileError& e);

}  // namespace kanedyn::python
