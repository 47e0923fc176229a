// One allocation counter for the whole test binary (tests/test_alloc_counter.cpp): glibc's
// malloc family is interposed there and counts calls while `counting` is set. operator new
// and Eigen's aligned_malloc both end in malloc. Not under the sanitizers (address, thread),
// which own malloc: then available() is false and only what a test counts itself (operator
// new) is seen. Everywhere else (glibc) it must be available.
#pragma once

#include <atomic>

#include "sanitizers.hpp"

#if KANEDYN_TEST_ADDRESS_SANITIZER || KANEDYN_TEST_THREAD_SANITIZER
#define KANEDYN_SANITIZER_OWNS_MALLOC 1
#endif

namespace alloc_counter {
#if defined(KANEDYN_SANITIZER_OWNS_MALLOC)
inline constexpr bool kSanitizerOwnsMalloc = true;
#else
inline constexpr bool kSanitizerOwnsMalloc = false;
#endif
extern std::atomic<bool> counting;  ///< count while true
extern std::atomic<long> count;     ///< calls counted
extern std::atomic<bool> seen;      ///< set by every interposed call (counting or not)
/// True when the interposed malloc is the one in use (checked by calling it).
bool available();
}  // namespace alloc_counter
