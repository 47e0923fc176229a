// Model files (docs/model-format.md, format kanedyn-model/1): YAML, or JSON as a subset of YAML.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kanedyn/constraints.hpp"
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

/// The `parameters` section and the numbers written as expressions (docs/model-format.md,
/// "Parameters"): what `info` prints and what the model writer keeps.
struct Parameters {
  struct Parameter {
    std::string name;
    std::string text;  ///< the expression as written (without '='); "" for a plain number
    double value = 0.0;
    uint32_t node = 0;  ///< its value's node in the document (ModelDocument)
  };
  /// A number of the file given as `= expression`, or a plain number in a list that holds one
  /// (a direction is written back from all its components).
  struct Number {
    std::string key_path;  ///< as messages spell it: `bodies[2].joint.at[0]`
    std::string text;      ///< the expression (without '='); "" for a plain number
    double value = 0.0;    ///< as evaluated, before any normalization
    uint32_t node = 0;
  };
  std::vector<Parameter> parameters;  ///< in the file's order
  std::vector<Number> numbers;        ///< in reading order
  /// The number at `key_path`, or nullptr.
  const Number* find(std::string_view key_path) const {
    for (const Number& n : numbers)
      if (n.key_path == key_path) return &n;
    return nullptr;
  }
};

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
  /// With constraints: what projecting the file's initial state onto them changed (q and z
  /// hold the projected state), and the independent speeds there.
  Projection projection;
  SpeedPartition partition;
  /// The file's parameters and expressions (empty for a file without them).
  Parameters parameters;
  /// True when some joint is not free (the file has the mapping form of `joint`).
  bool jointed() const { return !model.all_free(); }
};

/// Reads and validates a model file; throws ModelFileError.
ModelFile load_model_file(const std::string& path);

/// The same from text; `source_name` stands for the file name in error messages.
ModelFile parse_model_file(const std::string& text, const std::string& source_name);

/// A model file parsed once into its document tree, from which models with some numbers
/// changed are built without parsing the text again (a study's runs: docs/studies.md).
/// Copies share the tree; build() may run on several threads at once.
class ModelDocument {
 public:
  ModelDocument() = default;  ///< empty: load() and parse() give documents to use
  /// Reads and checks the model file at `path` (YAML or JSON; a URDF file is refused) as
  /// load_model_file does, throwing ModelFileError; `source_name` (default: path) stands for
  /// the file in every message, those of build() too.
  static ModelDocument load(const std::string& path, const std::string& source_name = "");
  /// The same from text.
  static ModelDocument parse(std::string text, const std::string& source_name);

  /// One number of the file.
  struct Number {
    uint32_t node = 0;         ///< its handle for build()
    double value = 0.0;        ///< as the file gives it
    int line = 0, column = 0;  ///< where it stands (1-based)
  };
  /// The number `key_path` names: `bodies[NAME]` or `bodies[K]` (K from 1), then the file's
  /// keys, list entries by 0-based index (`forces[2].stiffness`, `bodies[head].inertia[0]`).
  /// Throws std::invalid_argument with a one-line problem when it names nothing (with the
  /// closest key or body name the file has there) or something other than one number.
  Number find_number(std::string_view key_path) const;

  /// The model with each (node, value) of `changes` in place of that number, checked as
  /// load_model_file checks a file: a value that makes the model invalid throws ModelFileError
  /// at that number's line and column.
  ModelFile build(std::span<const std::pair<uint32_t, double>> changes) const;

  const ModelFile& base() const;  ///< the model as the file gives it
  const std::string& text() const;
  const std::string& source_name() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

}  // namespace kanedyn::io
