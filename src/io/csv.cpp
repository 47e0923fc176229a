#include "kanedyn/io/csv.hpp"

#include "kanedyn/io/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "kanedyn/constraints.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/threads.hpp"

namespace kanedyn::io {

namespace {

/// The longest number std::to_chars writes for a double in its shortest round-trip form:
/// "-1.2345678901234567e-308".
constexpr std::size_t kMaxNumberChars = 24;

/// value at p in the shortest form that reads back as the same double.
char* put_number(char* p, double value) { return std::to_chars(p, p + kMaxNumberChars, value).ptr; }

constexpr size_t kFlushBytes = 1 << 16;  // write to the file in pieces of about this size

std::string system_error(const std::string& what, const std::string& file) {
  return what + " '" + file + "': " + std::strerror(errno);
}

std::string quoted(const std::string& path) { return "'" + path + "'"; }

}  // namespace

namespace {

/// Throws for the row text [row, ...) whose number at `bad` is not finite, naming its column.
[[noreturn]] void throw_non_finite(const Model& model, const char* row, const char* bad, double t) {
  const char* start = bad;
  while (start > row && start[-1] != ',') --start;
  const char* end = bad;
  while (*end != ',' && *end != '\n') ++end;
  const auto column = static_cast<size_t>(std::count(row, start, ','));
  const auto columns = trajectory_columns(model);
  char time[32];
  std::snprintf(time, sizeof time, "%.10g", t);
  throw std::runtime_error("non-finite output at t = " + std::string(time) + ": column " +
                           quoted(column < columns.size() ? columns[column] : "?") + " is " +
                           std::string(start, end) + " (the first such column of the row)");
}

}  // namespace

namespace {
/// The model when its rows carry joint coordinates (some joint is not free), else null.
const Model* rows_with_joints(const Model& model) { return model.all_free() ? nullptr : &model; }

/// The joint columns of body k: 0 for free and weld joints (and without joints).
bool has_joint_columns(const Model* joints, int k) {
  if (!joints) return false;
  const JointType t = joints->joint(k).type;
  return joint_type_info(t).coordinates > 0 && !joint_type_info(t).absolute;
}

std::vector<std::string> trajectory_columns(const Model& model, const Model* joints);
}  // namespace

std::vector<std::string> trajectory_columns(const Model& model) {
  return trajectory_columns(model, rows_with_joints(model));
}

std::vector<std::string> trajectory_body_columns(const Model& model) {
  return trajectory_columns(model, nullptr);
}

namespace {
std::vector<std::string> trajectory_columns(const Model& model, const Model* joints) {
  static const char* const kSuffixes[] = {"x",  "y",  "z",  "e1", "e2", "e3",  "e4",  "s1",
                                          "s2", "s3", "w1", "w2", "w3", "sd1", "sd2", "sd3"};
  std::vector<std::string> columns{"t"};
  for (int k = 0; k < model.num_bodies(); ++k) {
    const std::string& name = model.body(k).name;
    for (const char* suffix : kSuffixes) columns.push_back(name + "." + suffix);
    if (!has_joint_columns(joints, k)) continue;
    const JointType t = joints->joint(k).type;
    for (int i = 1; i <= coordinate_count(t); ++i)
      columns.push_back(name + ".j" + std::to_string(i));
    for (int i = 1; i <= speed_count(t); ++i) columns.push_back(name + ".jd" + std::to_string(i));
  }
  columns.emplace_back("energy");
  for (const Input& in : model.inputs()) columns.push_back("input." + in.name);
  for (const Constraint& c : model.constraints()) {
    for (const char* f : {".f1", ".f2", ".f3"}) columns.push_back(c.name + f);
    if (c.type == ConstraintType::hinge)
      for (const char* m : {".m1", ".m2", ".m3"}) columns.push_back(c.name + m);
  }
  return columns;
}
}  // namespace

TrajectoryWriter::TrajectoryWriter(const Model& model, std::string path)
    : model_(model), joints_(rows_with_joints(model)), path_(std::move(path)) {
  const Model* joints = joints_;
  if (joints && joints->num_bodies() != model.num_bodies())
    throw std::invalid_argument("TrajectoryWriter: the joint tree is not the model's");
  check_output_path(path_);
  fd_ = create_partial_file(partial_path());
  // A row holds 2 + 16N numbers (and the joint columns, 7 a body at most, the inputs and the
  // reactions), each followed by ',' or the newline.
  const size_t row_bytes =
      (kMaxNumberChars + 1) *
      (2 + (16 + (joints ? 7 : 0)) * static_cast<size_t>(model.num_bodies()) +
       static_cast<size_t>(model.num_inputs()) + static_cast<size_t>(reaction_count(model)));
  buffer_ = std::make_unique_for_overwrite<char[]>(kFlushBytes + row_bytes);
  std::string header;
  const auto columns = trajectory_columns(model);
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) header += ',';
    header += columns[i];
  }
  header += '\n';
  try {
    write_out(header.data(), header.size());  // at once: the file shows the run has begun
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

TrajectoryWriter::~TrajectoryWriter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; the partial file keeps what was written
  }
}

void TrajectoryWriter::write_row(double t, const State& state, const Data& data, double energy,
                                 const VectorX* q, const VectorX* z) {
  if (fd_ < 0) throw std::logic_error("TrajectoryWriter: write_row after close");
  if (joints_ &&
      (!q || !z || q->size() != joints_->num_coordinates() || z->size() != joints_->num_speeds()))
    throw std::invalid_argument(
        "TrajectoryWriter: a jointed row needs the joint coordinates "
        "and speeds of the joint tree");
  if (data.reactions.size() != reaction_count(model_))
    throw std::invalid_argument(
        "TrajectoryWriter: data.reactions is not the size of the model's reaction columns");
  if (used_ >= kFlushBytes) flush();  // only after a flush that threw: retry (or throw again)
  // Fewer than kFlushBytes are buffered now, so the row fits (see the constructor).
  char* const row = buffer_.get() + used_;
  char* p = put_number(row, t);
  auto put = [&p](const auto& v) {
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      *p++ = ',';
      p = put_number(p, v[i]);
    }
  };
  for (int k = 0; k < model_.num_bodies(); ++k) {
    put(data.kinematics.p_G[static_cast<size_t>(k)]);
    put(state.euler_parameters(k));
    put(state.translation(k));
    put(state.angular_velocity(k));
    put(state.translation_rate(k));
    if (has_joint_columns(joints_, k)) {
      const JointType type = joints_->joint(k).type;
      put(q->segment(joints_->coordinate_offset(k), coordinate_count(type)));
      put(z->segment(joints_->speed_offset(k), speed_count(type)));
    }
  }
  *p++ = ',';
  p = put_number(p, energy);
  if (model_.num_inputs() > 0) put(data.inputs);
  put(data.reactions);
  *p++ = '\n';
  // A row with "nan" or "inf" is no result: refuse it (the file keeps the rows before it).
  // Checked on the text, where a non-finite number is the only one holding 'n'.
  if (const char* bad =
          static_cast<const char*>(std::memchr(row, 'n', static_cast<size_t>(p - row))))
    throw_non_finite(model_, row, bad, t);
  used_ = static_cast<size_t>(p - buffer_.get());
  ++rows_;
  if (used_ >= kFlushBytes) flush();
}

void TrajectoryWriter::write_out(const char* bytes, size_t size) {
  const size_t total = size;
  while (size > 0) {
    const ssize_t n = ::write(fd_, bytes, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      const std::string message = system_error("cannot write", partial_path());
      // Cut a row written in part (e.g. disk full), so the file still ends with a whole row.
      if (::ftruncate(fd_, static_cast<off_t>(committed_)) == 0)
        ::lseek(fd_, static_cast<off_t>(committed_), SEEK_SET);
      throw std::runtime_error(message);
    }
    bytes += n;
    size -= static_cast<size_t>(n);
  }
  committed_ += total;
}

void TrajectoryWriter::flush() {
  if (fd_ < 0 || used_ == 0) return;
  write_out(buffer_.get(), used_);
  used_ = 0;
  rows_in_file_ = rows_;
}

void TrajectoryWriter::close() {
  if (fd_ < 0) return;
  const int fd = fd_;
  try {
    flush();
  } catch (...) {
    ::close(fd);
    fd_ = -1;
    throw;
  }
  fd_ = -1;
  if (::close(fd) != 0) throw std::runtime_error(system_error("cannot close", partial_path()));
}

void TrajectoryWriter::finish() {
  close();
  // What was a regular file or nothing when the run started must still be one: a FIFO or a
  // link made there during the run is not replaced (the partial file stays).
  check_output_path(path_);
  if (std::rename(partial_path().c_str(), path_.c_str()) != 0)
    throw std::runtime_error(system_error("cannot rename '" + partial_path() + "' to", path_));
}

// ---------------------------------------------------------------------------------------------
// BackgroundTrajectoryWriter: one producer (write_row), one consumer (the thread), a ring of
// preallocated slots guarded by one mutex. The consumer sleeps until 32 rows (a quarter of a
// smaller ring) are queued, or a flush or the end is asked for, so the producer wakes it once
// per 32 rows rather than once per row (a wake-up is a system call, several times the copy of
// a row), and at the end at most that many rows are left to write after the last one comes.

struct BackgroundTrajectoryWriter::Impl {
  Impl(const Model& model, std::string path)
      : writer(model, std::move(path)),
        data(model, DataOptions::recursive_only()),
        state(model),
        nx(static_cast<size_t>(model.num_x())),
        ny(static_cast<size_t>(model.num_y())),
        nq(model.all_free() ? 0 : static_cast<size_t>(model.num_coordinates())),
        nz(model.all_free() ? 0 : static_cast<size_t>(model.num_speeds())),
        nu(static_cast<size_t>(model.num_inputs())),
        nr(static_cast<size_t>(reaction_count(model))),
        q(VectorX::Zero(static_cast<Eigen::Index>(nq))),
        z(VectorX::Zero(static_cast<Eigen::Index>(nz))) {
    const size_t slot_bytes = sizeof(double) * slot_size();
    capacity = std::clamp<size_t>((size_t{4} << 20) / slot_bytes, 2, 256);
    wake_at = std::clamp<size_t>(capacity / 4, 1, 32);
    ring.resize(capacity * slot_size());
    try {
      thread = start_threads(1, [this](int) { run(); });
    } catch (const ThreadStartError& e) {
      // A limit on threads or on address space. The run has not begun: the file, holding
      // only the header, goes (the caller gets an exception and nothing to clean up).
      const std::string partial = writer.partial_path();
      try {
        writer.close();
      } catch (...) {  // the thread's failure is the error to report
      }
      std::remove(partial.c_str());
      throw std::runtime_error("cannot start the thread that writes '" + partial +
                               "': " + e.reason());
    }
  }

  /// A slot of the ring: t, then {x}, then {y}, then (jointed) q and z, then the inputs, then
  /// the constraints' reactions.
  size_t slot_size() const { return 1 + nx + ny + nq + nz + nu + nr; }
  double* slot(size_t i) { return ring.data() + i * slot_size(); }

  /// The thread (its signals blocked by start_threads: they are for the program's own
  /// threads): writes rows.
  void run() {
    std::unique_lock lock(mutex);
    for (;;) {
      consumer_waiting = true;
      has_rows.wait(lock, [this] { return count >= wake_at || flush_requested || stopping; });
      consumer_waiting = false;
      const size_t first = head, n = count;
      const bool flush_now = flush_requested || stopping;
      flush_requested = false;
      const bool stop = stopping;
      const bool failed = error != nullptr;
      lock.unlock();
      // The slots [first, first + n) are the thread's until it gives them back below; after
      // an error the rows are dropped (the producer is told at its next call).
      std::exception_ptr e = failed ? nullptr : write_slots(first, n, flush_now);
      lock.lock();
      if (e) error = e;
      head = (first + n) % capacity;
      count -= n;
      if (producer_waiting) has_space.notify_one();  // room, or an error to report
      if (stop && count == 0) return;
    }
  }

  std::exception_ptr write_slots(size_t first, size_t n, bool flush_now) {
    try {
      const Model& model = writer.model();
      for (size_t i = 0; i < n; ++i) {
        const double* p = slot((first + i) % capacity);
        std::copy_n(p + 1, nx, state.x.data());
        std::copy_n(p + 1 + nx, ny, state.y.data());
        compute_kinematics(model, state, data);
        std::copy_n(p + 1 + nx + ny + nq + nz, nu, data.inputs.data());
        std::copy_n(p + 1 + nx + ny + nq + nz + nu, nr, data.reactions.data());
        if (writer.joints()) {
          std::copy_n(p + 1 + nx + ny, nq, q.data());
          std::copy_n(p + 1 + nx + ny + nq, nz, z.data());
          writer.write_row(p[0], state, data, total_energy_of_kinematics(model, state, q, data), &q,
                           &z);
        } else {
          writer.write_row(p[0], state, data, total_energy_of_kinematics(model, state, data));
        }
      }
      if (flush_now) writer.flush();
    } catch (...) {
      return std::current_exception();
    }
    return nullptr;
  }

  /// Under the mutex, or once the thread has ended: throws the thread's error, if any (every
  /// call but close() after the first report).
  void check(bool reporting_again) {
    if (error && (reporting_again || !reported)) {
      reported = true;
      std::rethrow_exception(error);
    }
  }

  /// Marks the writer closed, writes the queue out, stops the thread, and throws its error
  /// (as check), the file then closed without a new error of its own.
  void end(bool reporting_again) {
    closed = true;
    stop_thread();
    try {
      check(reporting_again);
    } catch (...) {
      try {
        writer.close();
      } catch (...) {  // the thread's error stays the one reported
      }
      throw;
    }
  }

  /// Writes the queue out and joins the thread (once); the TrajectoryWriter stays open.
  void stop_thread() {
    if (thread.size() == 0) return;
    {
      std::lock_guard lock(mutex);
      stopping = true;
    }
    has_rows.notify_one();
    thread.join();
  }

  TrajectoryWriter writer;
  Data data;    // the thread's kinematics
  State state;  // the thread's copy of the row being written
  size_t nx, ny, nq, nz, nu, nr;
  VectorX q, z;  // the thread's copy of the row's joint coordinates and speeds
  size_t capacity = 0, wake_at = 0;
  std::vector<double> ring;  // capacity slots
  std::mutex mutex;
  std::condition_variable has_rows, has_space;
  // Guarded by mutex. The slots [head, head + count) (mod capacity) are queued.
  size_t head = 0, count = 0;
  bool flush_requested = false, stopping = false;
  bool consumer_waiting = false, producer_waiting = false;
  std::exception_ptr error;
  bool reported = false;
  // The producer's own.
  long queued = 0;
  bool closed = false;
  ThreadGroup thread;  // one thread
};

BackgroundTrajectoryWriter::BackgroundTrajectoryWriter(const Model& model, std::string path)
    : impl_(std::make_unique<Impl>(model, std::move(path))) {}

BackgroundTrajectoryWriter::~BackgroundTrajectoryWriter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; the partial file keeps what was written
  }
}

void BackgroundTrajectoryWriter::write_row(double t, const State& state, const VectorX* inputs,
                                           const VectorX* reactions) {
  if (impl_->writer.joints())
    throw std::invalid_argument(
        "BackgroundTrajectoryWriter: a jointed model's rows need their joint coordinates");
  static const VectorX none;
  queue(t, state, none, none, inputs, reactions);
}

void BackgroundTrajectoryWriter::write_row(double t, const State& state, const VectorX& jq,
                                           const VectorX& jz, const VectorX* inputs,
                                           const VectorX* reactions) {
  const Model& model = impl_->writer.model();
  if (jq.size() != model.num_coordinates() || jz.size() != model.num_speeds())
    throw std::invalid_argument(
        "BackgroundTrajectoryWriter: the joint coordinates are not the model's size");
  // An all-free model's rows are its notes' state: (q, z) hold the same numbers.
  static const VectorX none;
  if (impl_->writer.joints())
    queue(t, state, jq, jz, inputs, reactions);
  else
    queue(t, state, none, none, inputs, reactions);
}

void BackgroundTrajectoryWriter::queue(double t, const State& state, const VectorX& jq,
                                       const VectorX& jz, const VectorX* inputs,
                                       const VectorX* reactions) {
  Impl& q = *impl_;
  if (q.closed) throw std::logic_error("BackgroundTrajectoryWriter: write_row after close");
  if (inputs && static_cast<size_t>(inputs->size()) != q.nu)
    throw std::invalid_argument("BackgroundTrajectoryWriter: the inputs are not the model's size");
  // Reactions are no default: zeros would read as a constraint that carries nothing.
  if (q.nr > 0 && (!reactions || static_cast<size_t>(reactions->size()) != q.nr))
    throw std::invalid_argument(
        "BackgroundTrajectoryWriter: a model with constraints needs their reactions, of the "
        "model's size (Data::reactions)");
  if (static_cast<size_t>(state.x.size()) != q.nx || static_cast<size_t>(state.y.size()) != q.ny)
    throw std::invalid_argument("BackgroundTrajectoryWriter: the state is not the model's size");
  std::unique_lock lock(q.mutex);
  q.check(true);
  if (q.count == q.capacity) {
    q.producer_waiting = true;
    q.has_space.wait(lock, [&q] { return q.count < q.capacity || q.error; });
    q.producer_waiting = false;
    q.check(true);
  }
  double* p = q.slot((q.head + q.count) % q.capacity);  // not among the slots being written
  p[0] = t;
  std::copy_n(state.x.data(), q.nx, p + 1);
  std::copy_n(state.y.data(), q.ny, p + 1 + q.nx);
  std::copy_n(jq.data(), q.nq, p + 1 + q.nx + q.ny);
  std::copy_n(jz.data(), q.nz, p + 1 + q.nx + q.ny + q.nq);
  if (inputs)
    std::copy_n(inputs->data(), q.nu, p + 1 + q.nx + q.ny + q.nq + q.nz);
  else
    std::fill_n(p + 1 + q.nx + q.ny + q.nq + q.nz, q.nu, 0.0);
  if (q.nr > 0) std::copy_n(reactions->data(), q.nr, p + 1 + q.nx + q.ny + q.nq + q.nz + q.nu);
  ++q.count;
  ++q.queued;
  const bool wake = q.consumer_waiting && q.count >= q.wake_at;
  lock.unlock();
  if (wake) q.has_rows.notify_one();
}

void BackgroundTrajectoryWriter::flush() {
  Impl& q = *impl_;
  if (q.closed) return;
  {
    std::lock_guard lock(q.mutex);
    q.check(true);
    q.flush_requested = true;
  }
  q.has_rows.notify_one();
}

void BackgroundTrajectoryWriter::close() {
  Impl& q = *impl_;
  if (q.closed) return;
  q.end(false);
  q.writer.close();
}

void BackgroundTrajectoryWriter::finish() {
  Impl& q = *impl_;
  if (q.closed) throw std::logic_error("BackgroundTrajectoryWriter: finish after close");
  q.end(true);
  q.writer.finish();
}

const std::string& BackgroundTrajectoryWriter::path() const { return impl_->writer.path(); }
std::string BackgroundTrajectoryWriter::partial_path() const {
  return impl_->writer.partial_path();
}
long BackgroundTrajectoryWriter::rows() const {
  return impl_->closed ? impl_->writer.rows_in_file() : impl_->queued;
}

}  // namespace kanedyn::io
