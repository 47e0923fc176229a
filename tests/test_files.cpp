// The rules every file kanedyn reads or writes follows (kanedyn/io/files.hpp): outputs are
// regular files or nothing and never an input, written whole or not at all; inputs are read
// only when they are regular files, without waiting on a FIFO. Device nodes are made in a
// temporary folder (as root; without the right to, those cases are skipped), never /dev.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using test::slurp;
using test::temp_dir;

/// The message check_output_path gives, or "(accepted)".
std::string output_problem(const std::string& path, const std::vector<std::string>& inputs = {}) {
  try {
    io::check_output_path(path, inputs);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(accepted)";
}

/// Makes a character device node like /dev/null (1, 3), /dev/zero (1, 5) or /dev/full (1, 7)
/// at `path`; false when this process may not (not root).
bool make_char_device(const fs::path& path, unsigned minor) {
  return ::mknod(path.c_str(), S_IFCHR | 0666, makedev(1, minor)) == 0;
}

/// A bound Unix socket at `path` (its descriptor, kept open by the caller), or -1.
int make_socket(const fs::path& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.string().size() >= sizeof addr.sun_path) {
    ::close(fd);
    return -1;
  }
  std::strcpy(addr.sun_path, path.c_str());
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

bool is_char_device(const fs::path& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

TEST(OutputFiles, OnlyARegularFileOrNothingIsAnOutput) {
  const fs::path dir = temp_dir("files_output_kinds");
  const std::string d = dir.string();
  std::ofstream(dir / "plain.csv") << "old\n";
  EXPECT_EQ(output_problem(d + "/new.csv"), "(accepted)");
  EXPECT_EQ(output_problem(d + "/plain.csv"), "(accepted)");

  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_NE(output_problem(d + "/fifo").find("is a FIFO (named pipe)"), std::string::npos);
  fs::create_directory(dir / "sub");
  EXPECT_NE(output_problem(d + "/sub").find("is a directory"), std::string::npos);
  // A link is refused whatever it points to: the rename would replace the link itself.
  fs::create_symlink(dir / "plain.csv", dir / "link.csv");
  EXPECT_NE(output_problem(d + "/link.csv").find("is a symbolic link"), std::string::npos);
  fs::create_symlink(dir / "nothing", dir / "dangling.csv");
  EXPECT_NE(output_problem(d + "/dangling.csv").find("is a symbolic link"), std::string::npos);
  const int sock = make_socket(dir / "sock");
  if (sock >= 0) {
    EXPECT_NE(output_problem(d + "/sock").find("is a socket"), std::string::npos);
    ::close(sock);
  }
  if (!make_char_device(dir / "null", 3)) GTEST_SKIP() << "cannot make device nodes (not root)";
  EXPECT_NE(output_problem(d + "/null").find("output '" + d + "/null' is a character device"),
            std::string::npos)
      << output_problem(d + "/null");
  ASSERT_TRUE(make_char_device(dir / "full", 7));
  EXPECT_NE(output_problem(d + "/full").find("is a character device"), std::string::npos);
}

TEST(OutputFiles, AWholeFileWriteNeverReplacesADeviceOrAFifo) {
  const fs::path dir = temp_dir("files_write_kinds");
  const std::string d = dir.string();
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_THROW(io::write_file_atomically(d + "/fifo", "text"), std::runtime_error);
  struct stat st {};
  ASSERT_EQ(::lstat((dir / "fifo").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_FALSE(fs::exists(dir / "fifo.partial"));

  io::write_file_atomically(d + "/page.html", "<p>whole</p>");
  EXPECT_EQ(slurp(dir / "page.html"), "<p>whole</p>");
  EXPECT_FALSE(fs::exists(dir / "page.html.partial"));

  if (!make_char_device(dir / "null", 3)) GTEST_SKIP() << "cannot make device nodes (not root)";
  EXPECT_THROW(io::write_file_atomically(d + "/null", "text"), std::runtime_error);
  EXPECT_TRUE(is_char_device(dir / "null"));
  EXPECT_FALSE(fs::exists(dir / "null.partial"));
}

TEST(OutputFiles, NoOutputIsAnInputByAnyName) {
  const fs::path dir = temp_dir("files_identity");
  const std::string d = dir.string();
  std::ofstream(dir / "model.yaml") << "format: kanedyn-model/1\n";
  std::ofstream(dir / "run.csv") << "t\n";
  ASSERT_EQ(::link((dir / "model.yaml").c_str(), (dir / "hard.html").c_str()), 0);
  const std::vector<std::string> inputs{d + "/model.yaml", d + "/run.csv"};
  EXPECT_EQ(output_problem(d + "/page.html", inputs), "(accepted)");
  // The same file by another name: a path through '..', a hard link.
  EXPECT_NE(output_problem(d + "/../" + dir.filename().string() + "/run.csv", inputs)
                .find("is the input file '" + d + "/run.csv'"),
            std::string::npos);
  EXPECT_NE(output_problem(d + "/hard.html", inputs).find("is the input file"), std::string::npos);
  // OUT.partial being an input would destroy it as well.
  EXPECT_EQ(output_problem(d + "/model", {d + "/model.yaml"}), "(accepted)");
  std::ofstream(dir / "x.partial") << "input\n";
  EXPECT_NE(output_problem(d + "/x", {d + "/x.partial"}).find("is the input file"),
            std::string::npos);
  // Empty and missing inputs are no inputs.
  EXPECT_EQ(output_problem(d + "/page.html", {"", d + "/missing.yaml"}), "(accepted)");
  EXPECT_THROW(io::write_file_atomically(d + "/hard.html", "x", inputs), std::runtime_error);
  EXPECT_EQ(slurp(dir / "model.yaml"), "format: kanedyn-model/1\n");
}

/// The problem open_regular_file gives, or "(opened)".
std::string open_problem(const std::string& path) {
  try {
    ::close(io::open_regular_file(path));
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(opened)";
}

TEST(InputFiles, OnlyRegularFilesAreRead) {
  const fs::path dir = temp_dir("files_input_kinds");
  const std::string d = dir.string();
  std::ofstream(dir / "plain.txt") << "text\n";
  EXPECT_EQ(open_problem(d + "/plain.txt"), "(opened)");
  EXPECT_NE(open_problem(d + "/missing").find("No such file"), std::string::npos);
  EXPECT_NE(open_problem(d).find("is a directory"), std::string::npos);
  // A FIFO with no writer: refused at once (a blocking open would hang this test).
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_NE(open_problem(d + "/fifo").find("is a FIFO"), std::string::npos);
  if (!make_char_device(dir / "zero", 5)) GTEST_SKIP() << "cannot make device nodes (not root)";
  EXPECT_NE(open_problem(d + "/zero").find("is a character device"), std::string::npos);
}

TEST(InputFiles, AWholeFileReadStopsAtItsLimit) {
  const fs::path dir = temp_dir("files_read_limit");
  std::ofstream(dir / "big.txt") << std::string(5000, 'x');
  EXPECT_EQ(io::read_whole_file(io::open_regular_file((dir / "big.txt").string()), 5000, "a test"),
            std::string(5000, 'x'));
  try {
    io::read_whole_file(io::open_regular_file((dir / "big.txt").string()), 4999, "a test file");
    ADD_FAILURE() << "read past the limit";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("the limit for a test file"), std::string::npos);
  }
}

TEST(InputFiles, LinesAreReadWithABoundOnTheirLength) {
  const fs::path dir = temp_dir("files_lines");
  std::ofstream(dir / "lines.txt", std::ios::binary) << "a,b\r\n\nlast";
  io::LineReader in((dir / "lines.txt").string());
  std::string line;
  std::vector<std::string> lines;
  while (in.next(line, 100)) lines.push_back(line);
  EXPECT_EQ(lines, (std::vector<std::string>{"a,b", "", "last"}));

  // Lines that span the reader's 64 KiB pieces come back whole.
  std::string text;
  for (int i = 0; i < 3000; ++i) text += std::string(static_cast<size_t>(i % 97), 'y') + "\n";
  std::ofstream(dir / "many.txt", std::ios::binary) << text;
  io::LineReader many((dir / "many.txt").string());
  int count = 0;
  while (many.next(line, 100)) {
    EXPECT_EQ(line, std::string(static_cast<size_t>(count % 97), 'y'));
    ++count;
  }
  EXPECT_EQ(count, 3000);

  // A file without line breaks is refused at the bound, not read whole.
  std::ofstream(dir / "one.txt", std::ios::binary) << std::string(200000, '0');
  io::LineReader one((dir / "one.txt").string());
  EXPECT_THROW(one.next(line, 1000), std::runtime_error);
}

// ---------------------------------------------------------------------------------------------
// The trajectory reader and the model loader follow the rules.

TEST(InputFiles, TheTrajectoryReaderRefusesWhatIsNotARegularFile) {
  const fs::path dir = temp_dir("files_trajectory_kinds");
  const std::string d = dir.string();
  const io::ModelFile file = io::load_model_file(test::kExamples + "/eight_body.yaml");
  const auto problem = [&](const std::string& path) {
    try {
      io::read_trajectory(file.model, path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(read)");
  };
  EXPECT_NE(problem(d).find(d + ": cannot read: it is a directory"), std::string::npos)
      << problem(d);
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_NE(problem(d + "/fifo").find("is a FIFO"), std::string::npos) << problem(d + "/fifo");
  EXPECT_THROW(io::read_trajectory_row(file.model, d + "/fifo", 0.0), std::runtime_error);
  // A regular file of 20 MB without a line break: refused after the longest header this
  // model can have, not read whole.
  std::ofstream(dir / "zeros.csv", std::ios::binary) << std::string(20 << 20, '\0');
  EXPECT_NE(problem(d + "/zeros.csv").find("longer than"), std::string::npos)
      << problem(d + "/zeros.csv");
  if (!make_char_device(dir / "zero", 5)) GTEST_SKIP() << "cannot make device nodes (not root)";
  EXPECT_NE(problem(d + "/zero").find("is a character device"), std::string::npos);
}

TEST(InputFiles, TheModelLoaderRefusesADeviceAtOnce) {
  const fs::path dir = temp_dir("files_model_device");
  if (!make_char_device(dir / "zero.yaml", 5))
    GTEST_SKIP() << "cannot make device nodes (not root)";
  try {
    io::load_model_file((dir / "zero.yaml").string());
    ADD_FAILURE() << "accepted";
  } catch (const io::ModelFileError& e) {
    EXPECT_NE(e.problem().find("is a character device, not a regular file"), std::string::npos)
        << e.what();
  }
}

}  // namespace
