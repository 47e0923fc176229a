// Studies from Python (python/kanedyn/study.py builds kanedyn.Study on these): the checked
// study, its runs in chunks (what a dask worker computes), the output folder, and the threaded
// sweep of `kanedyn sweep`.
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/study.hpp"

namespace kanedyn::python {

namespace {

using StudyPtr = std::shared_ptr<io::Study>;

/// A finished run as it crosses to Python and back: (run, row, trajectory or None, status).
using RunTuple = std::tuple<long, std::string, std::optional<std::string>, std::string>;

StudyPtr parse(const std::string& text, const std::string& source_name, const std::string& base_dir,
               const std::optional<std::string>& model_text) {
  try {
    return std::make_shared<io::Study>(
        io::parse_study(text, source_name, base_dir, model_text ? &*model_text : nullptr));
  } catch (const io::ModelFileError& e) {
    raise_model_error(e);
  }
}

/// A run number of the study: an integer in 0..runs-1 (IndexError otherwise, however large).
long run_number(const io::Study& study, py::handle obj) {
  return static_cast<long>(index_argument(obj, "run", 0, study.runs - 1));
}

/// The study's function (kanedyn.study._Caller: called with a kanedyn.Model and the run, it
/// gives the outputs' values as a list of floats, or the message of the exception the user's
/// function raised, as a str) for the library's runs, which call it from threads without the
/// GIL. Nothing for None.
io::StudyFunction study_function(py::handle caller_obj) {
  if (caller_obj.is_none()) return {};
  if (!PyCallable_Check(caller_obj.ptr())) throw py::type_error("function must be callable");
  // Released with the GIL held, whichever thread drops the last copy.
  const std::shared_ptr<py::object> caller(
      new py::object(py::reinterpret_borrow<py::object>(caller_obj)), [](py::object* o) {
        py::gil_scoped_acquire acquire;
        delete o;
      });
  return [caller](io::ModelFile file, long run) -> std::vector<double> {
    py::gil_scoped_acquire acquire;
    try {
      const py::object result = (*caller)(std::make_shared<PyModel>(std::move(file)), run);
      if (py::isinstance<py::str>(result)) throw std::runtime_error(result.cast<std::string>());
      return result.cast<std::vector<double>>();
    } catch (py::error_already_set& e) {
      // What the caller does not catch (a BaseException that is no Exception), as a message
      // made while the GIL is held.
      throw std::runtime_error(e.what());
    }
  };
}

std::vector<RunTuple> run_chunk(const io::Study& study, py::handle runs_obj,
                                py::handle caller_obj) {
  std::vector<long> runs;
  for (py::handle r : runs_obj) runs.push_back(run_number(study, r));
  const io::StudyFunction function = study_function(caller_obj);
  std::vector<io::StudyRun> done;
  {
    py::gil_scoped_release release;
    for (const long r : runs) done.push_back(io::run_study_run(study, r, {}, function));
  }
  std::vector<RunTuple> out;
  for (io::StudyRun& r : done)
    out.emplace_back(
        r.run, std::move(r.row),
        study.keeps_trajectory(r.run) ? std::optional<std::string>(r.trajectory) : std::nullopt,
        std::move(r.status));
  return out;
}

/// The folder keeps a pointer to its study: the Python object holds the study too.
struct PyFolder {
  StudyPtr study;
  std::unique_ptr<io::StudyFolder> folder;
};

/// The most threads a sweep from Python starts: the tool's `sweep --jobs` range.
constexpr long long kMaxSweepThreads = 4096;

/// results.csv (or any table) as text, by the readers' rule: opened without blocking, read
/// only when it is a regular file (a FIFO or a device is refused, not waited on). ValueError
/// "PATH: problem".
py::str read_table_text(py::handle path_obj) {
  const std::string path = path_argument(path_obj, "path");
  std::string text;
  try {
    py::gil_scoped_release release;
    text =
        io::read_whole_file(io::open_regular_file(path), std::size_t{1} << 30, "a results table");
  } catch (const std::runtime_error& e) {
    throw py::value_error(path + ": " + e.what());
  }
  PyObject* decoded =
      PyUnicode_DecodeUTF8(text.data(), static_cast<Py_ssize_t>(text.size()), nullptr);
  if (!decoded) {
    PyErr_Clear();
    throw py::value_error(path + ": the file is not UTF-8 text (a results table is)");
  }
  return py::reinterpret_steal<py::str>(decoded);
}

}  // namespace

void register_study(py::module_& m) {
  m.def("_read_table_text", &read_table_text, py::arg("path"));
  py::class_<io::Study, StudyPtr>(m, "_Study",
                                  "A checked study file (docs/studies.md); kanedyn.Study wraps it.")
      .def_static(
          "load",
          [](py::handle path_obj) -> StudyPtr {
            const std::string path = path_argument(path_obj, "path");
            try {
              return std::make_shared<io::Study>(io::load_study(path));
            } catch (const io::ModelFileError& e) {
              raise_model_error(e);
            }
          },
          py::arg("path"))
      .def_static("parse", &parse, py::arg("text"), py::arg("source_name"), py::arg("base_dir"),
                  py::arg("model_text") = std::nullopt)
      .def_property_readonly("runs", [](const io::Study& s) { return s.runs; })
      .def_property_readonly("columns", &io::Study::columns)
      .def_property_readonly("text", [](const io::Study& s) { return s.text; })
      .def_property_readonly("path", [](const io::Study& s) { return path_str(s.path); })
      .def_property_readonly("model_text", [](const io::Study& s) { return s.model.text(); })
      .def_property_readonly("model_name", [](const io::Study& s) { return s.model.source_name(); })
      .def_property_readonly("fingerprint", [](const io::Study& s) { return s.fingerprint; })
      .def(
          "parameters",
          [](const io::Study& s, py::handle run) { return s.parameters(run_number(s, run)); },
          py::arg("run"))
      .def(
          "set_function_outputs",
          [](io::Study& s, const std::vector<std::string>& names) {
            try {
              s.set_function_outputs(names);
            } catch (const std::invalid_argument& e) {
              throw py::value_error(e.what());
            }
          },
          py::arg("names"),
          "Names the outputs of the study's function: columns after the file's outputs.")
      .def_property_readonly("function_outputs",
                             [](const io::Study& s) { return s.function_outputs; })
      .def(
          "run_chunk",
          [](const StudyPtr& s, py::handle runs, py::handle caller) {
            return run_chunk(*s, runs, caller);
          },
          py::arg("runs"), py::arg("caller") = py::none(),
          "Runs these runs one after the other (without the GIL but in the caller): a list of "
          "(run, row, trajectory or None, status).");

  py::class_<PyFolder>(m, "_StudyFolder", "A study's output folder (docs/studies.md).")
      .def(py::init([](py::handle study_obj, py::handle dir_obj) {
             // Checked before the folder is made: None would be a null study, and a name cut
             // at a NUL byte another folder.
             if (!py::isinstance<io::Study>(study_obj))
               throw py::type_error("study must be a kanedyn._Study, got " +
                                    std::string(py::str(study_obj.get_type().attr("__name__"))));
             const std::string dir = path_argument(dir_obj, "out");
             PyFolder f{study_obj.cast<StudyPtr>(), nullptr};
             f.folder = std::make_unique<io::StudyFolder>(*f.study, dir);
             return f;
           }),
           py::arg("study"), py::arg("dir"))
      .def_property_readonly("done", [](const PyFolder& f) { return f.folder->done(); })
      .def_property_readonly("total", [](const PyFolder& f) { return f.folder->total(); })
      .def_property_readonly("results_path",
                             [](const PyFolder& f) { return path_str(f.folder->results_path()); })
      .def("missing", [](const PyFolder& f) { return f.folder->missing(); })
      .def(
          "next_missing", [](const PyFolder& f, long from) { return f.folder->next_missing(from); },
          py::arg("start"),
          "The first run from `start` on that is not done; total when there is none.")
      .def("failures", [](const PyFolder& f) { return f.folder->failures(); })
      .def(
          "record",
          [](PyFolder& f, const std::vector<RunTuple>& runs) {
            std::vector<io::StudyRun> rs;
            for (const auto& [run, row, trajectory, status] : runs) {
              io::StudyRun r;
              r.run = run;
              r.row = row;
              r.trajectory = trajectory.value_or("");
              r.status = status;
              rs.push_back(std::move(r));
            }
            py::gil_scoped_release release;
            f.folder->record(rs);
          },
          py::arg("runs"))
      .def("write_results", [](const PyFolder& f) { f.folder->write_results(); })
      .def(
          "sweep",
          [](PyFolder& f, py::handle threads_obj, py::object progress_obj, py::handle caller_obj) {
            io::SweepOptions options;
            options.function = study_function(caller_obj);
            options.threads =
                static_cast<int>(integer_argument(threads_obj, "threads", 0, kMaxSweepThreads));
            if (!progress_obj.is_none() && !PyCallable_Check(progress_obj.ptr()))
              throw py::type_error("progress must be a callable(done, ran) or None");
            std::function<void(long, long)> progress;
            if (!progress_obj.is_none())
              progress = progress_obj.cast<std::function<void(long, long)>>();
            bool interrupted = false;
            // Ctrl-C reaches Python's handler, which only sets a flag: look at it from here.
            options.stop = [&interrupted] {
              py::gil_scoped_acquire acquire;
              if (PyErr_CheckSignals() != 0) {
                interrupted = true;
                PyErr_Clear();
              }
              return interrupted;
            };
            if (progress)
              options.progress = [&progress](long done, long ran) {
                py::gil_scoped_acquire acquire;
                progress(done, ran);
              };
            io::SweepResult result;
            {
              py::gil_scoped_release release;
              result = io::sweep(*f.study, *f.folder, options);
            }
            return std::make_tuple(result.ran, result.stopped, interrupted);
          },
          py::arg("threads"), py::arg("progress") = py::none(), py::arg("caller") = py::none(),
          "Runs the missing runs on threads (as `kanedyn sweep`): (runs done now, stopped, "
          "stopped by Ctrl-C).");
}

}  // namespace kanedyn::python
