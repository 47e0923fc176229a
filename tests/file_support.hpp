// Test support for files and the tool: reading CSV files back, fresh folders under the
// build folder, and running build/kanedyn as a user does. Header-only, as test_support.hpp.
#pragma once

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

#include "kanedyn/io/model_file.hpp"

namespace kanedyn::test {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!text.empty() && text.back() == sep) parts.emplace_back();
  return parts;
}

/// A number as the CSV writes it (the shortest round-trip form); the whole field must read.
inline double parse(const std::string& s) {
  double v = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  EXPECT_EQ(r.ec, std::errc()) << s;
  EXPECT_EQ(r.ptr, s.data() + s.size()) << s;
  return v;
}

/// Rows of a CSV file; checks that every line is complete (ends with '\n') and has as many
/// fields as the header.
inline std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  const std::string text = slurp(p);
  EXPECT_FALSE(text.empty());
  if (text.empty()) return {};
  EXPECT_EQ(text.back(), '\n') << p;
  std::vector<std::vector<std::string>> rows;
  for (const std::string& line : split(text.substr(0, text.size() - 1), '\n')) {
    rows.push_back(split(line, ','));
    EXPECT_EQ(rows.back().size(), rows.front().size()) << "row " << rows.size() - 1;
  }
  return rows;
}

/// A fresh folder for one test, under the build folder (reused by the next run, so nothing
/// piles up in /tmp).
inline fs::path temp_dir(const std::string& name) {
  const fs::path dir = fs::path(KANEDYN_BINARY_DIR) / "tests" / "tmp" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

inline const std::string kTool = std::string(KANEDYN_BINARY_DIR) + "/kanedyn";
inline const std::string kExamples = std::string(KANEDYN_SOURCE_DIR) + "/examples";

struct ToolRun {
  int exit_code;
  std::string out, err;
};

/// Runs `cd DIR && SHELL_PREFIX kanedyn ARGS` with no standard input; stdout and stderr are
/// kept in DIR.
inline ToolRun run_in(const fs::path& dir, const std::string& args,
                      const std::string& shell_prefix = "") {
  const std::string cmd = "cd '" + dir.string() + "' && " + shell_prefix + "'" + kTool + "' " +
                          args + " > stdout.txt 2> stderr.txt < /dev/null";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir / "stdout.txt"),
          slurp(dir / "stderr.txt")};
}

/// Starts `kanedyn ARGS...` in DIR (stdout.txt and stderr.txt there, no standard input) and
/// returns its process id at once, for tests that signal a running command; -1 if fork fails.
inline pid_t spawn_in(const fs::path& dir, std::initializer_list<std::string> args) {
  std::vector<std::string> words{"kanedyn"};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid != 0) return pid;
  // The child: only async-signal-safe calls until exec.
  if (chdir(dir.c_str()) != 0) _exit(99);
  const int in = open("/dev/null", O_RDONLY);
  const int out = open("stdout.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int err = open("stderr.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (in < 0 || out < 0 || err < 0 || dup2(in, 0) < 0 || dup2(out, 1) < 0 || dup2(err, 2) < 0)
    _exit(97);
  execv(kTool.c_str(), argv.data());
  _exit(98);
}

/// `text` with its one occurrence of `from` replaced by `to`.
inline std::string edit(const std::string& text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' not in the text";
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << "'" << from << "' not unique";
  if (at == std::string::npos) return text;
  return text.substr(0, at) + to + text.substr(at + from.size());
}

struct Location {
  int line = 0, column = 0;  // 1-based
};

/// Where `needle` (with '^' marking the spot; the '^' is not part of the text) occurs in
/// `text`, counted independently of the parser.
inline Location locate(const std::string& text, const std::string& needle) {
  const size_t caret = needle.find('^');
  std::string plain = needle;
  plain.erase(caret, 1);
  const size_t at = text.find(plain);
  EXPECT_NE(at, std::string::npos) << "'" << plain << "' not in the text";
  EXPECT_EQ(text.find(plain, at + 1), std::string::npos) << "'" << plain << "' not unique";
  const size_t pos = at + caret;
  Location loc;
  loc.line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + pos, '\n'));
  const size_t line_start = text.rfind('\n', pos == 0 ? 0 : pos - 1);
  loc.column = 1 + static_cast<int>(
                       pos - (line_start == std::string::npos || pos == 0 ? 0 : line_start + 1));
  return loc;
}

/// A model text that must be refused, and how.
struct BadCase {
  std::string label;
  std::string text;
  std::string at;        // where the error points ('^' marks the spot); "" for no location
  std::string key_path;  // "" when the error concerns the whole file
  std::vector<std::string> words;  // parts of the problem that must appear
};

/// Expects parse_model_file to refuse the case's text with one line naming the file, the
/// place (line and column of '^'), the key path and the problem's words.
inline void expect_refused(const BadCase& c) {
  SCOPED_TRACE(c.label);
  try {
    io::parse_model_file(c.text, "bad.yaml");
    ADD_FAILURE() << "accepted";
  } catch (const io::ModelFileError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    std::string prefix = "bad.yaml";
    if (!c.at.empty()) {
      const Location loc = locate(c.text, c.at);
      prefix += ":" + std::to_string(loc.line) + ":" + std::to_string(loc.column);
      EXPECT_EQ(e.line(), loc.line);
      EXPECT_EQ(e.column(), loc.column);
    } else {
      EXPECT_EQ(e.line(), 0);
      EXPECT_EQ(e.column(), 0);
    }
    prefix += ": ";
    if (!c.key_path.empty()) prefix += c.key_path + ": ";
    EXPECT_EQ(what.substr(0, prefix.size()), prefix) << what;
    EXPECT_EQ(e.file(), "bad.yaml");
    EXPECT_EQ(e.key_path(), c.key_path);
    for (const std::string& w : c.words)
      EXPECT_NE(e.problem().find(w), std::string::npos) << "'" << w << "' not in: " << what;
  }
}

}  // namespace kanedyn::test
