#include "kanedyn/io/csv.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>

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
}  // namespace

std::vector<std::string> trajectory_columns(const Model& model) {
  static const char* const kSuffixes[] = {"x",  "y",  "z",  "e1", "e2", "e3",  "e4",  "s1",
                                          "s2", "s3", "w1", "w2", "w3", "sd1", "sd2", "sd3"};
  std::vector<std::string> columns{"t"};
  for (const BodySpec& body : model.bodies())
    for (const char* suffix : kSuffixes) columns.push_back(body.name + "." + suffix);
  columns.emplace_back("energy");
  return columns;
}

TrajectoryWriter::TrajectoryWriter(const Model& model, std::string path)
    : model_(model), path_(std::move(path)) {
  const std::string partial = partial_path();
  fd_ = ::open(partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error(system_error("cannot create", partial));
  // A row holds 2 + 16N numbers, each followed by ',' or the newline.
  const size_t row_bytes =
      (kMaxNumberChars + 1) * (2 + 16 * static_cast<size_t>(model.num_bodies()));
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

void TrajectoryWriter::write_row(double t, const State& state, const Data& data, double energy) {
  if (fd_ < 0) throw std::logic_error("TrajectoryWriter: write_row after close");
  if (used_ >= kFlushBytes) flush();  // only after a flush that threw: retry (or throw again)
  // Fewer than kFlushBytes are buffered now, so the row fits (see the constructor).
  char* p = put_number(buffer_.get() + used_, t);
  auto put = [&p](const auto& v) {
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      *p++ = ',';
      p = put_number(p, v[i]);
    }
  };
  for (int k = 0; k < model_.num_bodies(); ++k) {
    put(data.p_G[static_cast<size_t>(k)]);
    put(state.euler_parameters(k));
    put(state.translation(k));
    put(state.angular_velocity(k));
    put(state.translation_rate(k));
  }
  *p++ = ',';
  p = put_number(p, energy);
  *p++ = '\n';
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
  if (std::rename(partial_path().c_str(), path_.c_str()) != 0)
    throw std::runtime_error(system_error("cannot rename '" + partial_path() + "' to", path_));
}

}  // namespace kanedyn::io
