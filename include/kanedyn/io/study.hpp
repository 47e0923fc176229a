// Studies (docs/studies.md, format kanedyn-study/1): one model file run many times, some of its
// numbers changed by grids and random draws, the results gathered into one table. The model
// file is parsed once; each run builds its model from the document tree with its numbers.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn::io {

/// A study file that cannot be read or is not valid: one line, "FILE:LINE:COL: KEY.PATH:
/// problem", as ModelFileError.
class StudyFileError : public ModelFileError {
 public:
  using ModelFileError::ModelFileError;
};

/// How a varied number takes its values: drawn once per run, or every value of a list (a grid).
enum class Draw { normal, uniform, lognormal, choice, grid };

/// One entry of `vary`.
struct StudyVary {
  std::string key;  ///< the key path as written: the results table's column
  Draw draw = Draw::grid;
  /// normal: (mean, std); uniform: (low, high); lognormal: (mu, sigma) of the log
  double a = 0.0, b = 0.0;
  std::vector<double> values;  ///< choice and grid (`grid` or `values`)
  int input = -1;              ///< `inputs[...]`: the input's index; -1 for a number of the file
  uint32_t node = 0;           ///< a number of the file: its ModelDocument handle
};

enum class Statistic { final, max, min, mean, rms };

/// What a `linearize` output reads of its eigenvalue (docs/studies.md, "Linearize outputs").
enum class ModeValue { real, imag, frequency, damping };

/// A `linearize` output: read from the eigenvalues of A, the linearization about the run's
/// initial state (docs/studies.md, "Linearize outputs").
struct StudyLinearize {
  /// Empty: `max_real`, the largest real part of A's eigenvalues (of the block `of`, if
  /// given). Else the name of the mode ranked `rank` among the block's modes (a complex pair
  /// or a real eigenvalue each one mode), ranked by decreasing |imaginary part|, then by
  /// decreasing real part.
  std::string mode;
  int rank = 1;
  /// Names of the linearization's state (Linearization::state) whose rows and columns of A
  /// make the block; empty: all of A. Its rows must not depend on the other entries.
  std::vector<std::string> of;
  ModeValue value = ModeValue::real;  ///< of the mode; `max_real` reads the real part
};

/// One entry of `outputs`: a statistic of one trajectory column over the rows of a run, or a
/// reading of the linearization's eigenvalues.
struct StudyOutput {
  Statistic statistic = Statistic::final;
  std::string column;  ///< a column of the trajectory CSV ("head.z", "energy")
  int column_index = 0;
  std::string name;                         ///< "max:head.z", "linearize:weave.real"
  std::optional<StudyLinearize> linearize;  ///< set for a `linearize` output (no column)
};

/// A study file, checked: every key path resolved, every setting valid for the model.
struct Study {
  std::string path;        ///< as given ("<dict>" and the like for a text)
  std::string text;        ///< the study file's text
  std::string model_path;  ///< the model file: `model:` taken from the study file's folder
  ModelDocument model;     ///< parsed once; its messages name the file as `model:` gives it
  std::uint64_t seed = 0;
  long runs_per_point = 1;  ///< `runs`
  std::vector<StudyVary> vary;
  SimulationSection simulate;  ///< the study's `simulate:` section
  std::vector<StudyOutput> outputs;
  long keep_every = 0;   ///< trajectories: 0 none, 1 all, N every N-th run (runs 0, N, 2N...)
  long grid_points = 1;  ///< the product of the grids' sizes
  long runs = 1;         ///< grid_points * runs_per_point, at most kMaxStudyRuns
  std::uint64_t fingerprint = 0;  ///< of the study's and the model's texts
  /// The names of the outputs of a caller's function (StudyFunction): columns after the
  /// file's outputs. Set by set_function_outputs().
  std::vector<std::string> function_outputs;

  /// The header of results.csv: run, each varied key, each output's name, each function
  /// output's name, status, wall_s.
  std::vector<std::string> columns() const;
  /// Names the outputs of the function the runs will call, and makes them part of the
  /// fingerprint (a folder of the study without them, or with others, is another study's).
  /// Throws std::invalid_argument for an empty name, one with a control character, one given
  /// twice or one that is already a column.
  void set_function_outputs(std::vector<std::string> names);
  /// Whether a run simulates: unless every output is a `linearize` or a function output (and
  /// there is one) and no trajectory is kept.
  bool simulates() const;
  /// Run `run`'s value of each `vary` entry: the grids' values by the run's grid point
  /// (run / runs_per_point, the last grid varying fastest), the draws by (seed, run, entry).
  std::vector<double> parameters(long run) const;
  bool keeps_trajectory(long run) const { return keep_every > 0 && run % keep_every == 0; }
  /// The settings of run `run` for its model file (whose `simulation:` section the study's
  /// `simulate:` section overrides key by key).
  SimulationSettings settings(const ModelFile& file) const;
};

/// The most runs a study may have (`runs` times the grids' sizes): its folder holds the row of
/// every run done in memory, and results.csv is written from there (docs/studies.md, "Limits").
inline constexpr long kMaxStudyRuns = 10'000'000L;

/// Reads and checks a study file; throws StudyFileError (the study's own refusals) or
/// ModelFileError (its model file's).
Study load_study(const std::string& path);
/// The same from text: `source_name` stands for the file in messages, and `model:` is relative
/// to `base_dir` ("" for the current folder). With `model_text`, that is the model file's text
/// and no file is read (a worker on another machine, sent both texts).
Study parse_study(std::string text, const std::string& source_name, const std::string& base_dir,
                  const std::string* model_text = nullptr);

/// The uniform number in [0, 1) of draw k of entry `entry` of run `run`: a counter-based
/// generator, a function of its four arguments alone (docs/studies.md gives the formula).
double study_uniform(std::uint64_t seed, std::uint64_t run, std::uint64_t entry, std::uint64_t k);

/// What one run gave.
struct StudyRun {
  long run = 0;
  std::string row;           ///< its line of results.csv, without the line break
  std::string trajectory;    ///< its trajectory CSV when the study keeps it, else empty
  std::string status;        ///< "ok", or "KIND: message"
  bool interrupted = false;  ///< stopped by `stop`: no result, to be run again
};

/// A caller's outputs of one run (kanedyn.Study's function): their values, in the order of
/// Study::function_outputs, from the run's model file (the model with the run's numbers, given
/// to the function to keep) and its index. An exception fails the run; its status is
/// "function: " and its what(). Called from several threads at once by sweep().
using StudyFunction = std::function<std::vector<double>(ModelFile file, long run)>;

/// Runs run `run` of the study: builds its model, simulates (when simulates()), reduces the
/// outputs, linearizes (for `linearize` outputs) and calls `function` (when the study has
/// function outputs). A model made invalid by the run's values, invalid settings, a failed
/// simulation, a linearization or a function that fails are the run's status. `stop` (if set)
/// is polled at every step of the integration; when it returns true the run ends,
/// interrupted. Throws only for a run index out of range (std::out_of_range), and
/// std::logic_error for a study with function outputs and no function.
StudyRun run_study_run(const Study& study, long run, const std::function<bool()>& stop = {},
                       const StudyFunction& function = {});

/// The kind of a status ("ok", "invalid model", "non-finite state", ...): its text up to ": ".
std::string status_kind(const std::string& status);

/// A study's output folder (docs/studies.md): study.yaml (a copy), results.csv, runs/ (kept
/// trajectories) and manifest/ (the runs done, in parts). Every file is written under a
/// temporary name and renamed when whole.
class StudyFolder {
 public:
  /// Opens `dir` for `study`, creating it (its parent must exist) or finding there the runs of
  /// an earlier start of the same study (its study.yaml), which count as done. Throws
  /// std::runtime_error naming the file and the problem: `dir` is not a folder, holds another
  /// study, is not empty without holding this study (the first file in the way is named), or
  /// holds a manifest part that cannot be read. Leftover temporary files of a stopped run are
  /// removed.
  StudyFolder(const Study& study, std::string dir);

  const std::string& dir() const { return dir_; }
  long total() const { return study_->runs; }
  long done() const { return static_cast<long>(index_.size()); }
  bool is_done(long run) const {
    return run >= 0 && static_cast<std::size_t>(run) < done_.size() &&
           done_[static_cast<std::size_t>(run)];
  }
  /// The first run from `from` on that is not done; total() when there is none. A walk over
  /// the runs not done that holds nothing per run.
  long next_missing(long from) const;
  std::vector<long> missing() const;  ///< the runs not done, in order

  /// Writes a finished run's kept trajectory (runs/run_NNNNNN.csv) now and frees it from `run`;
  /// record() then writes only its row. Nothing for an interrupted run, a run done, or one
  /// without a trajectory. Throws std::runtime_error naming the file when the write fails.
  void write_trajectory(StudyRun& run) const;
  /// Records finished runs: their kept trajectories not yet written (runs/run_NNNNNN.csv; none
  /// for a run refused before it began), then one manifest part with their rows. Runs already
  /// done are skipped. Throws std::runtime_error naming the file when a write fails (a full
  /// disk): what was recorded before stays.
  void record(const std::vector<StudyRun>& runs);
  /// Writes results.csv, the rows in run order; throws std::logic_error unless every run is done.
  void write_results();

  std::string results_path() const { return dir_ + "/results.csv"; }
  std::string trajectory_path(long run) const;
  /// The failed runs' count by status kind, over the runs done.
  std::map<std::string, long> failures() const;

 private:
  void read_manifest();
  /// Counts `row` (of manifest part lines, or of a run just recorded) as run `run`'s.
  void add_row(long run, std::string_view row, std::string_view status);
  const Study* study_;
  std::string dir_;
  // The rows of the runs done, by the bytes of their rows and no more: their text one after
  // the other (each with its '\n'), where each begins, and one bit per run of the study.
  std::vector<bool> done_;
  std::string rows_;
  std::vector<std::pair<long, std::size_t>> index_;  ///< (run, offset in rows_), as recorded
  std::map<std::string, long> failures_;             ///< failed runs by status kind
  long next_part_ = 1;
};

/// How sweep() runs.
struct SweepOptions {
  /// 0: hardware_threads() (kanedyn/threads.hpp); more than that are capped at it.
  int threads = 0;
  /// Polled by the calling thread about ten times a second, between the writes of kept
  /// trajectories too; true stops the sweep: the runs being simulated end (within a step), and
  /// every finished run is recorded.
  std::function<bool()> stop;
  /// Called by the calling thread about ten times a second and at the end: runs done (of
  /// folder.total()), and the runs done by this call so far.
  std::function<void(long done, long ran)> progress;
  double flush_seconds = 1.0;  ///< the longest time between manifest parts
  /// The function of a study with function outputs, called by the threads (concurrently).
  StudyFunction function;
};

struct SweepResult {
  long ran = 0;          ///< runs done by this call
  bool stopped = false;  ///< stopped before every run was done
  int threads = 0;       ///< the threads the runs ran on
};

/// Runs the study's missing runs on `threads` threads, recording them in the folder as they
/// finish; writes results.csv when every run is done. The threads hand finished runs to the
/// calling thread, which writes them, through a queue of bounded size: when writing trajectories
/// is slower than running, the threads wait for it, and the memory stays bounded. Throws what
/// folder.record() and write_trajectory() throw (the runs recorded before stay), and
/// ThreadStartError (kanedyn/threads.hpp) when a thread cannot be started (nothing ran).
SweepResult sweep(const Study& study, StudyFolder& folder, const SweepOptions& options);

}  // namespace kanedyn::io
