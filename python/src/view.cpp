// Result.view(): the page of `kanedyn view` for a trajectory held in Python, by the same code
// (the kanedyn_view library), so that it is the page the tool writes from the same rows.
#include <cmath>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/trajectory.hpp"
#ifdef KANEDYN_PYTHON_HAVE_VIEW
#include "page.hpp"
#endif

namespace kanedyn::python {

namespace {

size_t write_view(const PyModel& m, py::object path_obj, py::object table_obj,
                  const std::string& source, py::object input_obj) {
  // The arguments first, whatever the build: a path with a NUL byte is refused everywhere.
  const std::string path = path_argument(path_obj, "path");
  // The CSV the rows were streamed to ("" if none): an input the page must not replace.
  const std::string input = path_argument(input_obj, "input");
#ifdef KANEDYN_PYTHON_HAVE_VIEW
  view::require_available();
  const Model& model = m.model();
  io::Trajectory traj{io::trajectory_columns(model), {}};
  const auto columns = static_cast<py::ssize_t>(traj.columns.size());
  const py::array table =
      float64_array(table_obj, "table", {-1, columns}, "(T, " + std::to_string(columns) + ")");
  traj.values.reserve(static_cast<size_t>(table.shape(0) * columns));
  for (py::ssize_t r = 0; r < table.shape(0); ++r)
    for (py::ssize_t c = 0; c < columns; ++c) {
      const double v = doubles(table)[r * stride(table, 0) + c * stride(table, 1)];
      // `kanedyn view` reads its rows through the trajectory reader, which refuses a number
      // that is not finite: no page is drawn from one here either.
      if (!std::isfinite(v))
        throw py::value_error("view: row " + std::to_string(r) + ", column '" +
                              traj.columns[static_cast<size_t>(c)] + "' is " +
                              (std::isnan(v) ? "nan"
                               : v > 0       ? "inf"
                                             : "-inf") +
                              "; nothing was written");
      traj.values.push_back(v);
    }
  if (table.shape(0) == 0)
    throw py::value_error("view: the result has no rows; nothing was written");
  const std::string text = view::page(model, m.file().path, traj, source);
  io::write_file_atomically(path, text, {m.file().path, input});
  return text.size();
#else
  (void)m, (void)table_obj, (void)source, (void)path, (void)input;
  throw std::runtime_error(
      "this kanedyn module was built without the viewer (the kanedyn tool was not built)");
#endif
}

}  // namespace

void register_view(py::class_<PyModel, std::shared_ptr<PyModel>>& cls) {
  cls.def("_write_view", &write_view, py::arg("path"), py::arg("table"), py::arg("source"),
          py::arg("input"));
}

}  // namespace kanedyn::python
