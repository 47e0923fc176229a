// SIGINT and SIGTERM for the commands that run long (simulate, sweep): the handler only sets a
// flag, which their work polls (an integration after every step); a second signal stops the
// program at once.
#pragma once

#include <signal.h>

namespace kanedyn::cli {

/// Installs the handlers of SIGINT and SIGTERM for its lifetime, and ignores SIGXFSZ: past a
/// file size limit (ulimit -f) write() then fails with EFBIG, which the writers report like a
/// full disk, instead of the signal killing the process with a row half written.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  /// The signal received since the handlers were installed (SIGINT or SIGTERM), or 0.
  static int received();

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
  struct sigaction old_xfsz_ {};
};

/// "SIGINT" or "SIGTERM".
const char* signal_name(int sig);

}  // namespace kanedyn::cli
