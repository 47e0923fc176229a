// The test binary's allocation counter: see alloc_counter.hpp.
#include <cstddef>
#include <cstdlib>

#include "alloc_counter.hpp"

namespace alloc_counter {
std::atomic<bool> counting{false};
std::atomic<long> count{0};
std::atomic<bool> seen{false};

bool available() {
  seen = false;
  // Through a volatile: clang removes a malloc whose pointer goes only to free.
  static void* volatile escape = nullptr;
  escape = std::malloc(16);
  std::free(escape);
  return seen.load();
}
}  // namespace alloc_counter

#if defined(__GLIBC__) && !defined(KANEDYN_SANITIZER_OWNS_MALLOC)
namespace {
void note() {
  alloc_counter::seen.store(true, std::memory_order_relaxed);
  if (alloc_counter::counting.load(std::memory_order_relaxed)) ++alloc_counter::count;
}
}  // namespace

extern "C" {
void* __libc_malloc(std::size_t size) noexcept;
void* __libc_calloc(std::size_t count, std::size_t size) noexcept;
void* __libc_realloc(void* p, std::size_t size) noexcept;
void* __libc_memalign(std::size_t align, std::size_t size) noexcept;

void* malloc(std::size_t size) noexcept {
  note();
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) noexcept {
  note();
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t size) noexcept {
  note();
  return __libc_realloc(p, size);
}
void* aligned_alloc(std::size_t align, std::size_t size) noexcept {
  note();
  return __libc_memalign(align, size);
}
void* memalign(std::size_t align, std::size_t size) noexcept {
  note();
  return __libc_memalign(align, size);
}
int posix_memalign(void** out, std::size_t align, std::size_t size) noexcept {
  note();
  void* p = __libc_memalign(align, size);
  if (!p) return 12;  // ENOMEM
  *out = p;
  return 0;
}
}
#endif
