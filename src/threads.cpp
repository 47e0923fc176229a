#include "kanedyn/threads.hpp"

#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <string>

namespace kanedyn {

ThreadStartError::ThreadStartError(int thread, int count, const std::string& reason)
    : std::runtime_error("cannot start thread " + std::to_string(thread) + " of " +
                         std::to_string(count) + " (" + reason + ")"),
      thread_(thread),
      count_(count),
      reason_(reason) {}

int hardware_threads() {
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

ThreadGroup& ThreadGroup::operator=(ThreadGroup&& other) noexcept {
  if (this != &other) {
    join();
    threads_ = std::move(other.threads_);
  }
  return *this;
}

void ThreadGroup::join() noexcept {
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

ThreadGroup start_threads(int count, const std::function<void(int)>& body,
                          const std::function<void()>& abandon, const ThreadStarter& starter) {
  const int n = std::min(count, hardware_threads());
  ThreadGroup group;
  if (n < 1) return group;
  group.threads_.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    std::function<void()> run = [body, i] {
      sigset_t all;
      sigfillset(&all);
      pthread_sigmask(SIG_BLOCK, &all, nullptr);
      body(i);
    };
    try {
      group.threads_.push_back(starter ? starter(std::move(run)) : std::thread(std::move(run)));
    } catch (const std::exception& e) {
      // The threads already started are joinable: leaving them so when this unwinds would
      // call std::terminate. They are told to end, then joined.
      if (abandon) abandon();
      group.join();
      throw ThreadStartError(i + 1, n, e.what());
    }
  }
  return group;
}

}  // namespace kanedyn
