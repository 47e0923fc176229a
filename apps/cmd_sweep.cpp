// `kanedyn sweep STUDY -o DIR [-j N]`: run a study (docs/studies.md) on this machine's cores.
// Each finished run is recorded in DIR's manifest; a stopped sweep started again with the same
// folder runs only the missing runs.
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "kanedyn/io/study.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/threads.hpp"
#include "options.hpp"
#include "stop_signals.hpp"

namespace kanedyn::cli {
namespace {

struct Options {
  std::string study;
  std::string out;
  int threads = 0;
};

using Clock = std::chrono::steady_clock;

std::string duration(double s) {
  char buf[32];
  if (s < 120.0)
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 7200.0)
    std::snprintf(buf, sizeof buf, "%.0f min", s / 60.0);
  else
    std::snprintf(buf, sizeof buf, "%.1f h", s / 3600.0);
  return buf;
}

/// A bar on stderr when it is a terminal: runs done, the rate and the time left.
class Progress {
 public:
  Progress(long total, long done_before)
      : total_(total), before_(done_before), tty_(::isatty(STDERR_FILENO) == 1) {}
  void update(long done, long ran) {
    if (!tty_) return;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    const double rate = elapsed > 0.0 ? static_cast<double>(ran) / elapsed : 0.0;
    const double fraction =
        total_ > 0 ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
    constexpr int kWidth = 30;
    char bar[kWidth + 1];
    for (int i = 0; i < kWidth; ++i) bar[i] = i < static_cast<int>(fraction * kWidth) ? '#' : '.';
    bar[kWidth] = '\0';
    const std::string left =
        rate > 0.0 ? duration(static_cast<double>(total_ - done) / rate) : std::string("?");
    std::fprintf(stderr, "\r[%s] %ld/%ld runs  %.1f runs/s  left ~%s \033[K", bar, done, total_,
                 rate, left.c_str());
    std::fflush(stderr);
    drawn_ = true;
  }
  void clear() {
    if (drawn_) std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  long before() const { return before_; }

 private:
  long total_, before_;
  bool tty_;
  bool drawn_ = false;
  Clock::time_point start_ = Clock::now();
};

int run(const Options& o) {
  const io::Study study = io::load_study(o.study);
  io::StudyFolder folder(study, o.out);
  const long before = folder.done();
  Progress progress(folder.total(), before);
  StopSignals signals;
  io::SweepOptions options;
  options.threads = o.threads;  // capped at the machine's threads by the sweep
  options.stop = [] { return StopSignals::received() != 0; };
  options.progress = [&](long done, long ran) { progress.update(done, ran); };
  const auto start = Clock::now();
  io::SweepResult result;
  try {
    result = io::sweep(study, folder, options);
  } catch (const ThreadStartError& e) {
    progress.clear();
    throw std::runtime_error(std::string(e.what()) + "; ask for fewer threads (-j)");
  } catch (const std::exception& e) {
    progress.clear();
    throw std::runtime_error(std::string(e.what()) + "; " + std::to_string(folder.done()) + " of " +
                             std::to_string(folder.total()) + " runs are kept in " +
                             io::printable(folder.dir()) + " (run the same command to resume)");
  }
  progress.clear();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  const auto failures = folder.failures();
  long failed = 0;
  for (const auto& [kind, count] : failures) failed += count;
  std::printf("study %s: %ld runs", io::printable(o.study).c_str(), folder.total());
  if (before > 0) std::printf(" (%ld done before, resumed)", before);
  std::printf("; %ld run now", result.ran);
  if (result.threads > 0)
    std::printf(" on %d thread%s", result.threads, result.threads == 1 ? "" : "s");
  std::printf(" in %.3g s (%.3g runs/s)\n", wall,
              wall > 0.0 ? static_cast<double>(result.ran) / wall : 0.0);
  std::printf("  done: %ld of %ld; ok: %ld; failed: %ld\n", folder.done(), folder.total(),
              folder.done() - failed, failed);
  for (const auto& [kind, count] : failures)
    std::printf("    %s: %ld\n", io::printable(kind).c_str(), count);
  if (result.stopped) {
    std::printf("  results: not written yet (%ld runs missing)\n", folder.total() - folder.done());
    std::fflush(stdout);
    const int sig = StopSignals::received() != 0 ? StopSignals::received() : SIGINT;
    std::fprintf(stderr,
                 "kanedyn: %s: stopped; the %ld finished runs are kept in %s; resume with: kanedyn "
                 "sweep %s -o %s\n",
                 signal_name(sig), folder.done(), io::printable(folder.dir()).c_str(),
                 io::printable(o.study).c_str(), io::printable(o.out).c_str());
    return 128 + sig;
  }
  std::printf("  results: %s\n", io::printable(folder.results_path()).c_str());
  std::fflush(stdout);
  if (failed == folder.total())
    throw std::runtime_error("every run of the study failed (" + std::to_string(failed) +
                             "); see the status column of " + io::printable(folder.results_path()));
  return 0;
}

void add_sweep(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "sweep", "Run a study (a grid or Monte Carlo of one model) on this machine's cores");
  auto o = std::make_shared<Options>();
  cmd->footer(
      "DIR gets study.yaml (a copy), manifest/ (the runs done), runs/ (kept trajectories) and, "
      "when every run is done, results.csv. Started again with the same DIR, it runs only the "
      "missing runs. Exit codes: 0 done (some runs may have failed: see their status); 1 error, "
      "or every run failed; 130/143 stopped by SIGINT/SIGTERM (finished runs kept).");
  add_input_file(cmd, "STUDY", o->study, "study file (YAML or JSON, docs/studies.md)")->required();
  cmd->add_option("--out,-o", o->out, "output folder (created; its parent must exist)")->required();
  cmd->add_option("--jobs,-j", o->threads,
                  "threads (default: all cores; more than the machine runs at once are capped)")
      ->check(CLI::Range(1, 4096));
  cmd->callback([o] {
    const int code = run(*o);
    if (code != 0) {
      std::fflush(nullptr);
      std::exit(code);
    }
  });
}

}  // namespace
KANEDYN_COMMAND(33, add_sweep);
}  // namespace kanedyn::cli
