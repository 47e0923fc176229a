// Model files (docs/model-format.md, format kanedyn-model/1): YAML, or JSON as a subset of YAML.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>

#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::io {

/// A model file that cannot be read or is not valid. what() is one line:
/// "FILE:LINE:COL: KEY.PATH: problem" (line and column where the parser gives them).
class ModelFileError : public std::runtime_error {
 public:
  ModelFileError(const std::string& file, int line, int column, const std::string& key_path,
                 const std::string& problem);
  const std::string& file() const { return file_; }
  int line() const { return line_; }      ///< 1-based, 0 if unknown
  int column() const { return column_; }  ///< 1-based, 0 if unknown
  const std::string& key_path() const { return key_path_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_, key_path_, problem_;
  int line_, column_;
};

/// The optional `simulation:` section: defaults for `kanedyn simulate`. Unset fields take
/// the command's defaults; command-line flags win over the file.
struct SimulationSection {
  std::optional<double> t_end;
  std::optional<double> dt_out;
  std::optional<std::string> integrator;  ///< "dopri5" | "rk4"
  std::optional<double> rtol, atol;
  std::optional<double> step;  ///< fixed step for rk4
  /// "recursive" | "assembled" (key `route`; the older key `method` also gives "kane", the
  /// assembled route)
  std::optional<std::string> route;
};

/// The settings a run starts from: SimulationSettings' defaults (those of `kanedyn simulate`)
/// with every field the section sets taken from it. The CLI's flags and the Python module's
/// keywords then override single fields, so both start from the same numbers.
SimulationSettings simulation_settings(const SimulationSection& section);

/// What a model file holds.
struct ModelFile {
  Model model;
  /// The notes' (x, y) at the start: joint_state() of q and z (for an all-free model the
  /// `initial:` entries, Euler parameters normalized).
  State initial;
  SimulationSection simulation;
  std::string path;  ///< as given
  /// The initial state: joint coordinates q (`initial.joint`, and the v1 keys of free bodies)
  /// and speeds z (`initial.joint_rate`, v1 keys of free bodies), in the Model's layout.
  VectorX q, z;
  /// True when some joint is not free (the file has the mapping form of `joint`).
  bool jointed() const { return !model.all_free(); }
};

/// Reads and validates a model file; throws ModelFileError.
ModelFile load_model_file(const std::string& path);

/// The same from text; `source_name` stands for the file name in error messages.
ModelFile parse_model_file(const std::string& text, const std::string& source_name);

}  // namespace kanedyn::io
