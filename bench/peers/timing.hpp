// Timing and number formatting shared by kanedyn_peers' sections: interleaved batches of
// evaluations (docs/performance.md, "Timing") and the tables' number formats.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

namespace peers {

using Clock = std::chrono::steady_clock;

/// How long each column of a case is timed.
struct TimingBudget {
  int reps = 1000;              ///< timed batches per column, at most
  double max_seconds = 2.0;     ///< a column's own time, at most (at least one batch)
  double batch_seconds = 1e-3;  ///< length of one timed batch
};

struct Timing {
  double median_ns = 0, min_ns = 0;
  long evals = 0;
};

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// One column of one case while it is timed: its batch function and the samples so far.
// A batch lasts about opt.batch_seconds (at least one evaluation), so that the clock's own cost
// and the cache refill after the other engines' batches do not count.
struct Runner {
  std::function<void(long)> run_batch;  // runs that many evaluations
  double first = 0;                     // seconds of the first (untimed, cold) evaluation
  long batch = 1;
  std::vector<double> per_eval_ns;  // one sample per batch
  double spent = 0;                 // seconds
  bool active = true;
};

// Times all columns of a case in interleaved rounds, one batch of each per round, so that a
// slow spell of the shared machine hits every engine alike and the ratios stay fair. Each
// column first warms up (up to 0.05 s) and sizes its batch from the warm time per evaluation.
// A column stops after opt.reps batches or opt.max_seconds of its own time (at least one batch).
inline void time_interleaved(std::vector<Runner*>& runners, const TimingBudget& opt) {
  const double warm_up = std::min(0.05, 0.1 * opt.max_seconds);
  for (Runner* r : runners) {
    double per_eval = r->first;
    if (r->first < warm_up) {
      long count = 0;
      const auto t0 = Clock::now();
      while (seconds_since(t0) < warm_up) {
        r->run_batch(1);
        ++count;
      }
      per_eval = seconds_since(t0) / static_cast<double>(count);
    }
    r->batch = std::max(1L, std::lround(opt.batch_seconds / std::max(per_eval, 1e-9)));
  }
  for (bool any = true; any;) {
    any = false;
    for (Runner* r : runners) {
      if (!r->active) continue;
      const auto t0 = Clock::now();
      r->run_batch(r->batch);
      const double dt = seconds_since(t0);
      r->per_eval_ns.push_back(dt * 1e9 / static_cast<double>(r->batch));
      r->spent += dt;
      r->active = static_cast<int>(r->per_eval_ns.size()) < opt.reps && r->spent < opt.max_seconds;
      any = any || r->active;
    }
  }
}

inline Timing statistics(Runner& r) {
  Timing t;
  t.evals = r.batch * static_cast<long>(r.per_eval_ns.size());
  auto& v = r.per_eval_ns;
  t.min_ns = *std::min_element(v.begin(), v.end());
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  t.median_ns = v[v.size() / 2];
  return t;
}

inline std::string format_ns(double ns) {
  std::ostringstream s;
  if (ns >= 1e9) {
    s << std::setprecision(3) << ns * 1e-9 << "e9";
    return s.str();
  }
  const auto v = static_cast<long long>(std::llround(ns));
  std::string digits = std::to_string(v), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

inline std::string format_sci(double x) {
  std::ostringstream s;
  s << std::scientific << std::setprecision(1) << x;
  return s.str();
}

inline std::string format_ratio(double r) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(r < 10 ? 2 : (r < 100 ? 1 : 0)) << r;
  return s.str();
}

}  // namespace peers
