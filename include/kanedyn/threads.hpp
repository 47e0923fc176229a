// Starting threads, in one place for the whole project: every pool is capped at the threads the
// machine runs at once, and a thread that cannot be started (a limit on processes or on
// address space) is an exception once the threads already started have been joined, never
// std::terminate (which a std::thread destroyed while joinable calls).
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace kanedyn {

/// The threads this machine runs at once: std::thread::hardware_concurrency(), or 1 when it
/// cannot tell (it then says 0).
int hardware_threads();

/// A thread could not be started: "cannot start thread K of N (REASON)". Its parts are kept
/// for a caller that counts its threads otherwise (the calling thread as one of them).
class ThreadStartError : public std::runtime_error {
 public:
  ThreadStartError(int thread, int count, const std::string& reason);
  int thread() const { return thread_; }  ///< the one that failed, from 1
  int count() const { return count_; }    ///< the threads asked for (after the cap)
  const std::string& reason() const { return reason_; }

 private:
  int thread_, count_;
  std::string reason_;
};

/// Starts one thread running its argument. The default is std::thread's constructor; a test
/// gives one that fails, to see what a limit on threads does.
using ThreadStarter = std::function<std::thread(std::function<void()>)>;

/// Threads started together by start_threads() and joined together: by join(), or when the
/// group is destroyed or assigned to.
class ThreadGroup {
 public:
  ThreadGroup() = default;
  ThreadGroup(ThreadGroup&&) noexcept = default;
  ThreadGroup& operator=(ThreadGroup&& other) noexcept;
  ThreadGroup(const ThreadGroup&) = delete;
  ThreadGroup& operator=(const ThreadGroup&) = delete;
  ~ThreadGroup() { join(); }

  int size() const { return static_cast<int>(threads_.size()); }
  /// Waits for every thread of the group to end (their bodies must end by themselves).
  void join() noexcept;

 private:
  friend ThreadGroup start_threads(int, const std::function<void(int)>&,
                                   const std::function<void()>&, const ThreadStarter&);
  std::vector<std::thread> threads_;
};

/// Starts min(count, hardware_threads()) threads (none for count < 1); thread i, from 0, runs
/// body(i). Every signal is blocked in them: a signal is then delivered to one of the program's
/// own threads, whose handler sets the flag that the work polls.
/// When a thread cannot be started, calls `abandon` (which must make the bodies already
/// running end soon), joins them, and throws ThreadStartError. An exception leaving a body
/// calls std::terminate, as for any thread: a body catches what it throws.
ThreadGroup start_threads(int count, const std::function<void(int)>& body,
                          const std::function<void()>& abandon = {},
                          const ThreadStarter& starter = {});

}  // namespace kanedyn
