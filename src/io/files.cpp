#include "kanedyn/io/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "kanedyn/io/text.hpp"

namespace kanedyn::io {

namespace {

std::string quoted(const std::string& path) { return "'" + printable(path) + "'"; }

std::string system_error(const std::string& what, const std::string& file) {
  return what + " " + quoted(file) + ": " + std::strerror(errno);
}

/// What a file that is not a regular one is, for messages.
const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISLNK(mode)) return "a symbolic link";
  return "not a regular file";
}

bool same_file(const struct stat& a, const struct stat& b) {
  return a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

}  // namespace

void check_output_path(const std::string& path, const std::vector<std::string>& inputs) {
  namespace fs = std::filesystem;
  if (path.empty()) throw std::runtime_error("the output file name is empty");
  if (path.back() == '/')
    throw std::runtime_error("output " + quoted(path) + " ends with '/': give a file name, e.g. " +
                             quoted(path + "run.csv"));
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    // Renaming the finished file onto OUT would replace the directory entry, whatever it is:
    // /dev/null itself, a FIFO another program reads, a link the user made.
    std::string hint = "; choose a regular file";
    if (S_ISDIR(st.st_mode))
      hint = ": give a file name, e.g. " + quoted((fs::path(path) / "run.csv").string());
    else if (S_ISLNK(st.st_mode))
      hint =
          ": kanedyn writes a new file and renames it into place, which would replace the "
          "link; give the path it points to";
    else if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode))
      hint =
          "; kanedyn writes only regular files (for no output, or for standard output, see "
          "the command's --help)";
    throw std::runtime_error("output " + quoted(path) + " is " + kind_of(st.st_mode) + hint);
  }
  std::error_code ec;
  const fs::path out(path);
  const fs::path folder = out.has_parent_path() ? out.parent_path() : fs::path(".");
  if (!fs::exists(folder, ec))
    throw std::runtime_error("cannot write " + quoted(path) + ": its folder " +
                             quoted(folder.string()) + " does not exist");
  if (!fs::is_directory(folder, ec))
    throw std::runtime_error("cannot write " + quoted(path) + ": " + quoted(folder.string()) +
                             " is not a directory");
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    throw std::runtime_error("cannot write " + quoted(path) + ": its folder " +
                             quoted(folder.string()) + " is not writable (" + std::strerror(errno) +
                             ")");
  for (const std::string& input : inputs) {
    struct stat in {};
    if (input.empty() || ::stat(input.c_str(), &in) != 0) continue;
    // The final file and the partial file both: either would destroy the input. stat follows
    // links, so a link to the input is caught too.
    for (const std::string& target : {path, path + ".partial"}) {
      struct stat t {};
      if (::stat(target.c_str(), &t) == 0 && same_file(t, in))
        throw std::runtime_error("output " + quoted(target) + " is the input file " +
                                 quoted(input) + "; choose another output (-o)");
    }
  }
}

int create_partial_file(const std::string& partial) {
  struct stat st {};
  if (::lstat(partial.c_str(), &st) == 0) {
    if (!S_ISREG(st.st_mode))
      throw std::runtime_error("cannot create " + quoted(partial) + ": it exists and is " +
                               kind_of(st.st_mode) + "; remove it, or choose another output");
    if (::unlink(partial.c_str()) != 0 && errno != ENOENT)
      throw std::runtime_error(system_error("cannot replace", partial));
  }
  const int fd =
      ::open(partial.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error(system_error("cannot create", partial));
  return fd;
}

namespace {

/// Writes all of `text` to fd; false with errno set when it cannot.
bool write_all(int fd, std::string_view text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

void write_file_atomically(const std::string& path, std::string_view text,
                           const std::vector<std::string>& inputs) {
  write_file_atomically(
      path, [&](const PieceWriter& write) { write(text); }, inputs);
}

void write_file_atomically(const std::string& path,
                           const std::function<void(const PieceWriter&)>& produce,
                           const std::vector<std::string>& inputs) {
  check_output_path(path, inputs);
  const std::string partial = path + ".partial";
  const int fd = create_partial_file(partial);
  const auto fail = [&](const std::string& what, int err) {
    ::unlink(partial.c_str());
    return std::runtime_error(what + " " + quoted(partial) + ": " + std::strerror(err) +
                              "; nothing written to " + quoted(path));
  };
  try {
    produce([&](std::string_view piece) {
      if (!write_all(fd, piece)) throw fail("cannot write", errno);
    });
  } catch (...) {
    ::close(fd);
    ::unlink(partial.c_str());
    throw;
  }
  if (::close(fd) != 0) throw fail("cannot write", errno);
  // The check again, just before the rename: what was a regular file or nothing at the start
  // must still be one (a FIFO made meanwhile is not replaced).
  try {
    check_output_path(path, inputs);
  } catch (...) {
    ::unlink(partial.c_str());
    throw;
  }
  if (std::rename(partial.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(partial.c_str());
    throw std::runtime_error("cannot rename " + quoted(partial) + " to " + quoted(path) + ": " +
                             std::strerror(err));
  }
}

void write_to_stdout(std::string_view text) {
  std::fflush(stdout);
  if (!write_all(STDOUT_FILENO, text))
    throw std::runtime_error(std::string("cannot write to standard output: ") +
                             std::strerror(errno));
}

int open_regular_file(const std::string& path) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer forever.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw std::runtime_error(std::string("cannot open: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error(std::string("cannot open: ") + std::strerror(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw std::runtime_error(std::string("cannot read: it is ") + kind_of(st.st_mode) +
                             ", not a regular file");
  }
  // Reads of a regular file never block; the flag is cleared all the same so that reads
  // behave as ordinary blocking reads.
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  return fd;
}

std::string read_whole_file(int fd, std::size_t limit, const std::string& kind) {
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  const auto too_large = [&] {
    return std::runtime_error("the file is larger than " + std::to_string(limit >> 20) +
                              " MiB, the limit for " + kind);
  };
  struct stat st {};
  if (::fstat(fd, &st) != 0)
    throw std::runtime_error(std::string("cannot read: ") + std::strerror(errno));
  if (static_cast<std::uint64_t>(st.st_size) > limit) throw too_large();
  std::string text;
  // The size is a hint only: the file may change while it is read. The loop stops at the
  // limit whatever the file does.
  text.resize(static_cast<std::size_t>(st.st_size) + 1);
  std::size_t used = 0;
  for (;;) {
    if (used == text.size()) {
      if (text.size() > limit) throw too_large();
      text.resize(std::min(2 * text.size(), limit + 1));
    }
    const ssize_t got = ::read(fd, text.data() + used, text.size() - used);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(std::string("cannot read: ") + std::strerror(errno));
    }
    if (got == 0) break;
    used += static_cast<std::size_t>(got);
  }
  if (used > limit) throw too_large();
  text.resize(used);
  return text;
}

LineReader::LineReader(const std::string& path) : fd_(open_regular_file(path)) {}

LineReader::~LineReader() {
  if (fd_ >= 0) ::close(fd_);
}

bool LineReader::next(std::string& line, std::size_t max_length) {
  constexpr std::size_t kChunk = 1 << 16;
  std::size_t scanned = begin_;
  for (;;) {
    const std::size_t newline = buffer_.find('\n', scanned);
    if (newline != std::string::npos || (eof_ && begin_ < buffer_.size())) {
      const std::size_t end = newline == std::string::npos ? buffer_.size() : newline;
      if (end - begin_ > max_length)
        throw std::runtime_error("a line is longer than " + std::to_string(max_length) + " bytes");
      line.assign(buffer_, begin_, end - begin_);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      // A byte order mark before the first line (spreadsheets write one) is no part of it.
      if (first_line_ && line.starts_with("\xEF\xBB\xBF")) line.erase(0, 3);
      first_line_ = false;
      begin_ = newline == std::string::npos ? buffer_.size() : newline + 1;
      return true;
    }
    if (eof_) return false;
    if (buffer_.size() - begin_ > max_length)
      throw std::runtime_error("a line is longer than " + std::to_string(max_length) + " bytes");
    // Keep the unread part and read the next piece after it.
    buffer_.erase(0, begin_);
    begin_ = 0;
    scanned = buffer_.size();
    const std::size_t used = buffer_.size();
    buffer_.resize(used + kChunk);
    ssize_t got;
    do {
      got = ::read(fd_, buffer_.data() + used, kChunk);
    } while (got < 0 && errno == EINTR);
    if (got < 0) {
      const int err = errno;
      buffer_.resize(used);
      throw std::runtime_error(std::string("cannot read: ") + std::strerror(err));
    }
    buffer_.resize(used + static_cast<std::size_t>(got));
    if (got == 0) eof_ = true;
  }
}

}  // namespace kanedyn::io
