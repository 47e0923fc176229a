// The files kanedyn reads and writes, by one set of rules (docs/cli.md, "Files"):
// - an output is a regular file or does not exist: a directory, a device, a FIFO, a socket or
//   a symbolic link in its place is refused before any work, never replaced;
// - no output may be an input of the same command (compared by device and inode, so another
//   name for the same file is caught too);
// - an output is written to OUTPUT.partial and renamed to OUTPUT only when whole;
// - an input is opened without blocking and read only when it is a regular file.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace kanedyn::io {

/// Throws std::runtime_error (one line, naming the path and the problem) unless `path` may be
/// written as an output: not empty, not ending in '/', in an existing writable folder, a
/// regular file or nothing (a directory, device, FIFO, socket or symbolic link is refused),
/// and neither `path` nor PATH.partial is one of `inputs` (empty names in `inputs` are
/// skipped). Nothing is created.
void check_output_path(const std::string& path, const std::vector<std::string>& inputs = {});

/// Creates PATH.partial for writing and returns its descriptor: a leftover regular file of
/// that name (from an interrupted run) is removed first; a symbolic link or anything else
/// there is refused; O_EXCL | O_NOFOLLOW then refuses whatever appears in between.
int create_partial_file(const std::string& partial);

/// Writes `text` to PATH.partial and renames it to PATH, after check_output_path(path,
/// inputs). On failure removes the partial file (a file cut short is of no use), leaves PATH
/// as it was and throws std::runtime_error naming the file.
void write_file_atomically(const std::string& path, std::string_view text,
                           const std::vector<std::string>& inputs = {});

/// Writes one piece of an output (write_file_atomically's `produce` calls it in order).
using PieceWriter = std::function<void(std::string_view)>;
/// The same with the text made in pieces by `produce(write)`, so that a large output (a
/// study's results) is never held whole. An exception from `produce` removes the partial file
/// and propagates.
void write_file_atomically(const std::string& path,
                           const std::function<void(const PieceWriter&)>& produce,
                           const std::vector<std::string>& inputs = {});

/// Writes `text` to standard output whole (the "-" output of `view` and `import`); throws
/// std::runtime_error when it cannot (a closed pipe, a full disk).
void write_to_stdout(std::string_view text);

/// Opens `path` for reading without blocking on a FIFO or a device, and returns the
/// descriptor (O_CLOEXEC) only if it is a regular file. Otherwise throws
/// std::runtime_error whose message is the problem alone ("cannot open: No such file or
/// directory", "is a directory", "not a regular file (a character device)"): the caller
/// adds the file's name in its own error type.
int open_regular_file(const std::string& path);

/// Reads a file opened by open_regular_file whole, up to `limit` bytes; closes `fd`. Throws
/// std::runtime_error with the problem alone (as open_regular_file) when the file is larger
/// than `limit` ("the file is larger than 256 MiB, the limit for `kind`") or cannot be read.
std::string read_whole_file(int fd, std::size_t limit, const std::string& kind);

/// Reads a regular file line by line through a descriptor, with a bound on the length of a
/// line (so that a file without line breaks cannot fill the memory): the trajectory reader.
class LineReader {
 public:
  /// Opens `path` by open_regular_file (throws as it does).
  explicit LineReader(const std::string& path);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// The next line without its '\n' (and without a '\r' before it, or a UTF-8 byte order
  /// mark before the first line); false at the end of the file. Throws std::runtime_error when the
  /// line is longer than `max_length` bytes or the file cannot be read.
  bool next(std::string& line, std::size_t max_length);

 private:
  int fd_ = -1;
  std::string buffer_;
  std::size_t begin_ = 0;
  bool eof_ = false;
  bool first_line_ = true;
};

}  // namespace kanedyn::io
