// The one helper that starts threads (kanedyn/threads.hpp): the cap at the machine's threads,
// a thread that cannot start, and the signals of the threads it starts.
#include <gtest/gtest.h>

#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <mutex>
#include <set>
#include <system_error>
#include <thread>

#include "kanedyn/threads.hpp"

namespace kanedyn::test {
namespace {

TEST(Threads, NoMoreThanTheMachineRunsAreStarted) {
  const int hardware = hardware_threads();
  EXPECT_GE(hardware, 1);
  std::mutex mutex;
  std::multiset<int> indices;
  ThreadGroup group = start_threads(600, [&](int i) {
    const std::lock_guard lock(mutex);
    indices.insert(i);
  });
  EXPECT_EQ(group.size(), hardware);
  group.join();
  EXPECT_EQ(group.size(), 0);
  std::multiset<int> expected;
  for (int i = 0; i < hardware; ++i) expected.insert(i);
  EXPECT_EQ(indices, expected);
  EXPECT_EQ(start_threads(0, [](int) {}).size(), 0);
  EXPECT_EQ(start_threads(-3, [](int) {}).size(), 0);
}

TEST(Threads, AStartThatFailsIsAnExceptionOnceTheStartedAreJoined) {
  // The last start fails, as std::thread's constructor does at a limit on threads or on
  // address space; the ones started wait until told to end.
  const int n = hardware_threads();
  int starts = 0;
  const ThreadStarter starter = [&](std::function<void()> body) {
    if (++starts == n)
      throw std::system_error(std::make_error_code(std::errc::resource_unavailable_try_again),
                              "pthread_create");
    return std::thread(std::move(body));
  };
  std::atomic<bool> abandoned{false};
  std::atomic<int> ended{0};
  const auto body = [&](int) {
    while (!abandoned) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ++ended;
  };
  try {
    start_threads(
        n, body, [&] { abandoned = true; }, starter);
    ADD_FAILURE() << "no exception";
  } catch (const ThreadStartError& e) {
    EXPECT_EQ(e.thread(), n);
    EXPECT_EQ(e.count(), n);
    EXPECT_NE(std::string(e.what()).find("cannot start thread " + std::to_string(n) + " of " +
                                         std::to_string(n) + " (pthread_create: "),
              std::string::npos)
        << e.what();
    EXPECT_TRUE(abandoned);
    EXPECT_EQ(ended, n - 1);  // every thread started has ended: joined before the throw
  }
}

TEST(Threads, TheirSignalsAreBlocked) {
  // A Ctrl-C goes to one of the program's own threads, whose handler sets the flag it polls.
  std::atomic<bool> blocked{false};
  start_threads(1, [&](int) {
    sigset_t set;
    pthread_sigmask(SIG_BLOCK, nullptr, &set);
    blocked = sigismember(&set, SIGINT) == 1 && sigismember(&set, SIGTERM) == 1;
  }).join();
  EXPECT_TRUE(blocked);
}

}  // namespace
}  // namespace kanedyn::test
