// Trajectory CSV (docs/model-format.md, "Trajectory output"), written safely: rows go to
// PATH.partial as whole lines and the file is renamed to PATH only by finish(), so PATH never
// holds an incomplete trajectory and PATH.partial always ends with a complete row.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::io {

/// The header: t, then per body NAME.x NAME.y NAME.z NAME.e1..e4 NAME.s1..s3 NAME.w1..w3
/// NAME.sd1..sd3 (16 columns per body), then energy: 2 + 16N columns. A body
/// whose joint is neither free nor weld adds NAME.j1..j<n> (its q) and NAME.jd1..jd<m> (its z)
/// right after its own columns. A model with inputs adds input.NAME per input after energy.
/// A model with constraints then adds, per constraint in order, NAME.f1 NAME.f2 NAME.f3 (its
/// force on its body, inertial) and for a hinge NAME.m1 NAME.m2 NAME.m3 (its moment about `at`).
std::vector<std::string> trajectory_columns(const Model& model);
/// The columns of trajectory_columns() without any body's joint columns: t, 16 per body,
/// energy.
std::vector<std::string> trajectory_body_columns(const Model& model);

/// Streams a trajectory to PATH.partial.
class TrajectoryWriter {
 public:
  /// Checks the path (check_output_path), creates PATH.partial and writes the header to it.
  /// A leftover regular PATH.partial is replaced; a symbolic link or anything else of that
  /// name is refused, and the file is opened with O_EXCL | O_NOFOLLOW, so that nothing is
  /// ever written through a link planted there. Throws std::runtime_error naming the file
  /// when it cannot be created.
  TrajectoryWriter(const Model& model, std::string path);
  /// Writes the buffered rows and closes the file; PATH.partial stays if finish() did not run.
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;

  /// Appends one row: t, per body the mass centre G_K (data.kinematics.p_G, inertial: needs
  /// compute_kinematics at this state), eps_K, s'_K, w'_K, s'_K dot, then energy, then the
  /// inputs' values data.inputs (a model with inputs), then the constraints' reactions
  /// data.reactions (a model with constraints: simulate() fills them). Numbers
  /// are written in the shortest form that reads back as the same double (std::to_chars).
  /// Rows are buffered and reach the file whole; throws std::runtime_error if writing fails,
  /// or if a number of the row is not finite (naming the time and the column; the row is
  /// not written).
  /// When some joint is not free, q and z (the joint coordinates and speeds of the row) are
  /// required and give the j and jd columns.
  void write_row(double t, const State& state, const Data& data, double energy,
                 const VectorX* q = nullptr, const VectorX* z = nullptr);
  /// Writes the buffered rows to the file (whole rows only).
  void flush();
  /// Flushes, closes and renames PATH.partial to PATH (replacing it). Throws on failure.
  void finish();
  /// Flushes and closes, leaving PATH.partial. Idempotent; the destructor does it too.
  void close();

  const std::string& path() const { return path_; }
  std::string partial_path() const { return path_ + ".partial"; }
  long rows() const { return rows_; }  ///< data rows written so far (header not counted)
  /// Data rows that have reached the file: rows() once flushed; fewer after a failed write.
  long rows_in_file() const { return rows_in_file_; }
  const Model& model() const { return model_; }
  /// The model when its rows have joint coordinates (some joint is not free), else null.
  const Model* joints() const { return joints_; }

 private:
  void write_out(const char* bytes, size_t size);

  const Model& model_;
  const Model* joints_;
  std::string path_;
  /// Rows waiting for the file: buffer_[0, used_). Sized at construction for the flush
  /// threshold plus one longest row, so a row is written into it without checks.
  std::unique_ptr<char[]> buffer_;
  size_t used_ = 0;
  int fd_ = -1;
  size_t committed_ = 0;  ///< bytes of whole rows in the file
  long rows_ = 0, rows_in_file_ = 0;
};

/// A TrajectoryWriter on a thread of its own, so that writing the output costs the
/// integrating thread only a copy of each state: write_row() puts (t, state) into a queue of
/// preallocated slots (waiting while it is full); the thread computes the kinematics and the
/// energy of each state (compute_kinematics, total_energy_of_kinematics), formats the rows and
/// writes them. The file is the same, byte for byte, and so is the PATH.partial protocol.
/// An error of the thread (e.g. disk full) is thrown, once, by the next call of write_row(),
/// flush(), finish() or close(). Not for concurrent use by several producer threads.
class BackgroundTrajectoryWriter {
 public:
  /// Creates PATH.partial with its header (throws as TrajectoryWriter) and starts the thread.
  /// A thread that cannot be started throws std::runtime_error, PATH.partial removed.
  /// The queue holds up to about 4 MB of states, at least 2 and at most 256.
  /// When some joint is not free, rows are queued by the (t, state, q, z) overload and their
  /// energy adds the joint springs' potentials.
  BackgroundTrajectoryWriter(const Model& model, std::string path);
  /// Writes what is queued and closes (as close()), swallowing errors; PATH.partial stays if
  /// finish() did not run.
  ~BackgroundTrajectoryWriter();
  BackgroundTrajectoryWriter(const BackgroundTrajectoryWriter&) = delete;
  BackgroundTrajectoryWriter& operator=(const BackgroundTrajectoryWriter&) = delete;

  /// Queues one row: t and a copy of the state (its Euler parameters as given). Throws
  /// std::invalid_argument for a state of another size than the model's.
  /// inputs: the values in force at t (model.num_inputs(); null: zero). reactions: a model
  /// with constraints must give theirs (Data::reactions, reaction_count(model) entries).
  void write_row(double t, const State& state, const VectorX* inputs = nullptr,
                 const VectorX* reactions = nullptr);
  /// The same with the model's state (q, z) (any model; queued when some joint is not free,
  /// whose rows have joint columns). Throws std::invalid_argument for q or z of the wrong size.
  void write_row(double t, const State& state, const VectorX& q, const VectorX& z,
                 const VectorX* inputs = nullptr, const VectorX* reactions = nullptr);
  /// Asks the thread to write the queued rows to the file now (returns at once).
  void flush();
  /// Writes every queued row, stops the thread, closes and renames PATH.partial to PATH.
  void finish();
  /// Writes every queued row, stops the thread and closes, leaving PATH.partial. Idempotent.
  void close();

  const std::string& path() const;
  std::string partial_path() const;
  /// Rows queued so far; after finish() or close(), the rows in the file (fewer than were
  /// queued after a write error).
  long rows() const;

 private:
  void queue(double t, const State& state, const VectorX& q, const VectorX& z,
             const VectorX* inputs, const VectorX* reactions);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kanedyn::io
