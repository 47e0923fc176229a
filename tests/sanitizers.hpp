// Which sanitizer a test program is built with, for tests that must run differently under it:
// KANEDYN_TEST_ADDRESS_SANITIZER and KANEDYN_TEST_THREAD_SANITIZER (1 or 0) for the
// preprocessor, kAddressSanitizer and kThreadSanitizer for code. g++ says so by
// __SANITIZE_ADDRESS__ and __SANITIZE_THREAD__, clang by __has_feature. Header-only
// (tests/CMakeLists.txt globs only tests/test_*.cpp).
#pragma once

#if defined(__has_feature)
#define KANEDYN_TEST_HAS_FEATURE(x) __has_feature(x)
#else
#define KANEDYN_TEST_HAS_FEATURE(x) 0
#endif

#if defined(__SANITIZE_ADDRESS__) || KANEDYN_TEST_HAS_FEATURE(address_sanitizer)
#define KANEDYN_TEST_ADDRESS_SANITIZER 1
#else
#define KANEDYN_TEST_ADDRESS_SANITIZER 0
#endif
#if defined(__SANITIZE_THREAD__) || KANEDYN_TEST_HAS_FEATURE(thread_sanitizer)
#define KANEDYN_TEST_THREAD_SANITIZER 1
#else
#define KANEDYN_TEST_THREAD_SANITIZER 0
#endif

namespace kanedyn::test {
inline constexpr bool kAddressSanitizer = KANEDYN_TEST_ADDRESS_SANITIZER == 1;
inline constexpr bool kThreadSanitizer = KANEDYN_TEST_THREAD_SANITIZER == 1;
}  // namespace kanedyn::test
