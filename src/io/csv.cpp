#include "kanedyn/io/csv.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace kanedyn::io {

namespace {
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
  // One row holds 2 + 16N numbers of at most 24 characters each.
  buffer_.reserve(kFlushBytes + 25 * (2 + 16 * static_cast<size_t>(model.num_bodies())));
  const auto columns = trajectory_columns(model);
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) buffer_ += ',';
    buffer_ += columns[i];
  }
  buffer_ += '\n';
  flush();  // the header is there at once: the file shows the run has begun
}

TrajectoryWriter::~TrajectoryWriter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; the partial file keeps what was written
  }
}

void TrajectoryWriter::append(double value) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof buf, value);
  buffer_.append(buf, result.ptr);
}

void TrajectoryWriter::write_row(double t, const State& state, const Data& data, double energy) {
  if (fd_ < 0) throw std::logic_error("TrajectoryWriter: write_row after close");
  append(t);
  for (int k = 0; k < model_.num_bodies(); ++k) {
    auto put = [this](const auto& v) {
      for (Eigen::Index i = 0; i < v.size(); ++i) {
        buffer_ += ',';
        append(v[i]);
      }
    };
    put(data.p_G[static_cast<size_t>(k)]);
    put(state.euler_parameters(k));
    put(state.translation(k));
    put(state.angular_velocity(k));
    put(state.translation_rate(k));
  }
  buffer_ += ',';
  append(energy);
  buffer_ += '\n';
  ++rows_;
  if (buffer_.size() >= kFlushBytes) flush();
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
  if (fd_ < 0 || buffer_.empty()) return;
  write_out(buffer_.data(), buffer_.size());
  buffer_.clear();
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
