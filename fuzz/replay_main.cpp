// Replays files through a fuzz target's LLVMFuzzerTestOneInput, without libFuzzer (linked with
// the model loader's target as kanedyn_fuzz_replay, with the URDF import's as
// kanedyn_fuzz_urdf_replay, and as kanedyn_fuzz_inputs_table_replay and kanedyn_fuzz_study_replay):
// the seed and regression corpora run in every build (and under the sanitizer builds) as ctest
// tests.
//
//   kanedyn_fuzz_replay [-v] [--known-failures FILE] [--timeout SECONDS] PATH...
//
// PATH is a file or a directory (its regular files, recursively, in sorted order; names
// starting with '.' and the known-failures file itself are left out). A file whose name starts
// with "valid_" must also be accepted (check_input). The known-failures file lists, one per
// line, "NAME REASON" for inputs that break an invariant with the current loader: these run in
// a child process (so that a crash or hang cannot stop the replay), with a time limit, and are
// reported, but do not fail the run. Everything else runs in this process: a broken invariant
// aborts with the input's name. -v prints each input's name and what the loader made of it.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "loader_invariants.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;

// For the SIGABRT handler: which input was running when the process aborted.
char g_current[4096] = "";

extern "C" void on_abort(int signal) {
  const char prefix[] = "kanedyn_fuzz_replay: aborted while replaying ";
  [[maybe_unused]] ssize_t n = write(STDERR_FILENO, prefix, sizeof prefix - 1);
  n = write(STDERR_FILENO, g_current, std::strlen(g_current));
  n = write(STDERR_FILENO, "\n", 1);
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

[[noreturn]] void usage_error(const std::string& problem) {
  std::fprintf(stderr,
               "kanedyn_fuzz_replay: %s\nusage: kanedyn_fuzz_replay [-v] [--known-failures FILE] "
               "[--timeout SECONDS] PATH...\n",
               problem.c_str());
  std::exit(2);
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) usage_error("cannot read " + path.string());
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// NAME -> REASON; '#' starts a comment line.
std::map<std::string, std::string> read_known_failures(const fs::path& path) {
  std::map<std::string, std::string> known;
  std::istringstream lines(read_file(path));
  std::string line;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t end = line.find_first_of(" \t");
    const std::string name = line.substr(0, end);
    const size_t reason = end == std::string::npos ? end : line.find_first_not_of(" \t", end);
    known[name] = reason == std::string::npos ? "" : line.substr(reason);
  }
  return known;
}

bool is_input(const fs::path& path, const fs::path& known_failures) {
  if (path.filename().string().starts_with(".")) return false;
  std::error_code ec;
  return known_failures.empty() || !fs::equivalent(path, known_failures, ec);
}

/// `text` with control bytes written as \xNN, for a terminal.
std::string escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", u);
      out += hex;
    } else {
      out += c;
    }
  }
  return out;
}

/// One input through the fuzz target, then the "valid_" check. Aborts on a broken invariant.
void replay(const fs::path& path, const std::string& bytes) {
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  if (path.filename().string().starts_with("valid_")) {
    const kanedyn::fuzz::LoaderVerdict verdict = kanedyn::fuzz::check_input(bytes);
    if (!verdict.accepted) {
      std::fprintf(stderr, "kanedyn fuzz: a valid_ input was refused: %s\n", verdict.error.c_str());
      std::fflush(stderr);
      std::abort();
    }
  }
}

/// Runs replay() in a child process; returns "" if it passed, else what happened, with the
/// child's first line about the invariant (or its first line of output).
std::string replay_isolated(const fs::path& path, const std::string& bytes, int timeout) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return "pipe() failed";
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return "fork() failed";
  if (pid == 0) {
    close(pipe_fds[0]);
    dup2(pipe_fds[1], STDERR_FILENO);
    const int null_fd = open("/dev/null", O_WRONLY);
    if (null_fd >= 0) dup2(null_fd, STDOUT_FILENO);
    alarm(static_cast<unsigned>(timeout));
    replay(path, bytes);
    _exit(0);
  }
  close(pipe_fds[1]);
  std::string output;
  char buffer[4096];
  for (ssize_t n; (n = read(pipe_fds[0], buffer, sizeof buffer)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    output.append(buffer, static_cast<size_t>(n));
  }
  close(pipe_fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::string what;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return "";
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM)
    what = "timed out after " + std::to_string(timeout) + " s";
  else if (WIFSIGNALED(status))
    what = std::string("killed by signal ") + std::to_string(WTERMSIG(status));
  else
    what = "exit code " + std::to_string(WEXITSTATUS(status));
  std::istringstream lines(output);
  std::string line, first;
  while (std::getline(lines, line)) {
    if (first.empty()) first = line;
    if (line.find("kanedyn fuzz:") != std::string::npos ||
        line.find("ERROR: AddressSanitizer") != std::string::npos ||
        line.find("runtime error:") != std::string::npos) {
      first = line;
      break;
    }
  }
  if (first.size() > 300) first = first.substr(0, 300) + "...";
  return first.empty() ? what : what + ": " + first;
}

}  // namespace

int main(int argc, char** argv) {
  bool verbose = false;
  int timeout = 60;
  fs::path known_failures_path;
  std::vector<fs::path> roots;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-v") {
      verbose = true;
    } else if (arg == "--known-failures" || arg == "--timeout") {
      if (i + 1 == argc) usage_error(arg + " needs a value");
      const std::string value = argv[++i];
      if (arg == "--timeout") {
        timeout = std::atoi(value.c_str());
        if (timeout < 1) usage_error("--timeout needs a positive number of seconds");
      } else {
        known_failures_path = value;
      }
    } else if (arg.starts_with("-")) {
      usage_error("unknown option " + arg);
    } else {
      roots.emplace_back(arg);
    }
  }
  if (roots.empty()) usage_error("no inputs given");
  const std::map<std::string, std::string> known = known_failures_path.empty()
                                                       ? std::map<std::string, std::string>{}
                                                       : read_known_failures(known_failures_path);

  std::vector<fs::path> inputs;
  for (const fs::path& root : roots) {
    std::error_code ec;
    if (fs::is_directory(root, ec)) {
      for (const auto& entry : fs::recursive_directory_iterator(root))
        if (entry.is_regular_file() && is_input(entry.path(), known_failures_path))
          inputs.push_back(entry.path());
    } else if (fs::is_regular_file(root, ec)) {
      inputs.push_back(root);
    } else {
      usage_error("no such file or directory: " + root.string());
    }
  }
  std::sort(inputs.begin(), inputs.end());
  if (inputs.empty()) usage_error("no input files found");

  std::signal(SIGABRT, on_abort);
  int replayed = 0, known_failing = 0;
  std::vector<std::string> passing_now;
  std::map<std::string, bool> known_seen;
  for (const fs::path& path : inputs) {
    const std::string bytes = read_file(path);
    const std::string name = path.filename().string();
    std::snprintf(g_current, sizeof g_current, "%s", path.c_str());
    if (const auto it = known.find(name); it != known.end()) {
      known_seen[name] = true;
      const std::string failure = replay_isolated(path, bytes, timeout);
      if (failure.empty()) {
        passing_now.push_back(name);
        std::printf("known failure %s: passes now\n", name.c_str());
      } else {
        ++known_failing;
        std::printf("known failure %s (%s): %s\n", name.c_str(), it->second.c_str(),
                    failure.c_str());
      }
      continue;
    }
    if (verbose) std::printf("replaying %s\n", path.c_str());
    std::fflush(stdout);
    replay(path, bytes);
    ++replayed;
    if (verbose) {
      const kanedyn::fuzz::LoaderVerdict verdict = kanedyn::fuzz::check_input(bytes);
      std::printf("  %s\n", verdict.accepted ? "accepted" : escaped(verdict.error).c_str());
    }
  }
  for (const auto& [name, reason] : known)
    if (!known_seen.count(name))
      std::printf("note: known failure %s is not among the inputs\n", name.c_str());
  std::printf("kanedyn_fuzz_replay: replayed %d inputs, every invariant held", replayed);
  if (!known.empty())
    std::printf("; %d known failures still fail, %zu pass now%s", known_failing, passing_now.size(),
                passing_now.empty() ? "" : " (remove them from the list)");
  std::printf("\n");
  return 0;
}
