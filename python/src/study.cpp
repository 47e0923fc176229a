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

std::vector<RunTuple> run_chunk(const io::Study& study, const std::vector<long>& runs) {
  for (const long r : runs)
    if (r < 0 || r >= study.runs)
      throw py::index_error("run " + std::to_string(r) + " is not one of the study's 0.." +
                            std::to_string(study.runs - 1));
  std::vector<io::StudyRun> done;
  {
    py::gil_scoped_release release;
    for (const long r : runs) done.push_back(io::run_study_run(study, r));
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

}  // namespace

void register_study(py::module_& m) {
  py::class_<io::Study, StudyPtr>(m, "_Study",
                                  "A checked study file (docs/studies.md); kanedyn.Study wraps it.")
      .def_static(
          "load",
          [](const std::string& path) -> StudyPtr {
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
      .def_property_readonly("path", [](const io::Study& s) { return s.path; })
      .def_property_readonly("model_text", [](const io::Study& s) { return s.model.text(); })
      .def_property_readonly("model_name", [](const io::Study& s) { return s.model.source_name(); })
      .def_property_readonly("fingerprint", [](const io::Study& s) { return s.fingerprint; })
      .def("parameters", &io::Study::parameters, py::arg("run"))
      .def(
          "run_chunk",
          [](const StudyPtr& s, const std::vector<long>& runs) { return run_chunk(*s, runs); },
          py::arg("runs"),
          "Runs these runs one after the other (without the GIL): a list of (run, row, "
          "trajectory or None, status).");

  py::class_<PyFolder>(m, "_StudyFolder", "A study's output folder (docs/studies.md).")
      .def(py::init([](StudyPtr study, const std::string& dir) {
             PyFolder f{study, nullptr};
             f.folder = std::make_unique<io::StudyFolder>(*study, dir);
             return f;
           }),
           py::arg("study"), py::arg("dir"))
      .def_property_readonly("done", [](const PyFolder& f) { return f.folder->done(); })
      .def_property_readonly("total", [](const PyFolder& f) { return f.folder->total(); })
      .def_property_readonly("results_path",
                             [](const PyFolder& f) { return f.folder->results_path(); })
      .def("missing", [](const PyFolder& f) { return f.folder->missing(); })
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
          [](PyFolder& f, int threads, std::function<void(long, long)> progress) {
            io::SweepOptions options;
            options.threads = threads;
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
          py::arg("threads"), py::arg("progress") = nullptr,
          "Runs the missing runs on threads (as `kanedyn sweep`): (runs done now, stopped, "
          "stopped by Ctrl-C).");
}

}  // namespace kanedyn::python
