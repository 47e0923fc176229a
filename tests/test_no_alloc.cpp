// Issue 4: no heap allocation on the evaluation path. The global allocation functions of this
// test binary count the allocations made while `counting` is set (the binary is shared by
// every test, so only inside the measured region). operator new is replaced. Eigen allocates
// its dynamic-size matrices with std::malloc, so on glibc malloc is interposed too (forwarding
// to glibc's own __libc_* functions) - as weak definitions, because another test file of this
// binary (test_integrate.cpp) interposes malloc for its own count and a strong definition wins.
// Whether this file's malloc is the one in use is checked at run time; under AddressSanitizer,
// which owns malloc, only operator new is counted.
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <new>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/generate.hpp"
#include "kanedyn/kane.hpp"

#if defined(__SANITIZE_ADDRESS__)
#define KANEDYN_COUNT_MALLOC 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define KANEDYN_COUNT_MALLOC 0
#endif
#endif
#if !defined(KANEDYN_COUNT_MALLOC)
#if defined(__GLIBC__)
#define KANEDYN_COUNT_MALLOC 1
#else
#define KANEDYN_COUNT_MALLOC 0
#endif
#endif

namespace {
std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
std::atomic<bool> malloc_counted{false};  // this file's malloc has been called
void note_allocation() {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1);
}
void note_malloc() {
  malloc_counted.store(true, std::memory_order_relaxed);
  note_allocation();
}
}  // namespace

#if KANEDYN_COUNT_MALLOC
extern "C" {
void* __libc_malloc(std::size_t size) noexcept;
void* __libc_calloc(std::size_t count, std::size_t size) noexcept;
void* __libc_realloc(void* p, std::size_t size) noexcept;
void* __libc_memalign(std::size_t align, std::size_t size) noexcept;
void __libc_free(void* p) noexcept;

__attribute__((weak)) void* malloc(std::size_t size) noexcept {
  note_malloc();
  return __libc_malloc(size);
}
__attribute__((weak)) void* calloc(std::size_t count, std::size_t size) noexcept {
  note_allocation();
  return __libc_calloc(count, size);
}
__attribute__((weak)) void* realloc(void* p, std::size_t size) noexcept {
  note_allocation();
  return __libc_realloc(p, size);
}
__attribute__((weak)) void* aligned_alloc(std::size_t align, std::size_t size) noexcept {
  note_allocation();
  return __libc_memalign(align, size);
}
__attribute__((weak)) void* memalign(std::size_t align, std::size_t size) noexcept {
  note_allocation();
  return __libc_memalign(align, size);
}
__attribute__((weak)) int posix_memalign(void** out, std::size_t align, std::size_t size) noexcept {
  note_allocation();
  void* p = __libc_memalign(align, size);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
__attribute__((weak)) void free(void* p) noexcept { __libc_free(p); }
}
#endif

namespace {
// True when this file's malloc is the one in use (and so counts Eigen's allocations too).
bool malloc_is_counted() {
  malloc_counted = false;
  void* p = std::malloc(16);
  std::free(p);
  return malloc_counted.load();
}
void* allocate(std::size_t size) {
  note_allocation();  // malloc may count it again: the tests only ask for zero or not
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* allocate_aligned(std::size_t size, std::align_val_t align) {
  note_allocation();
  const auto a = static_cast<std::size_t>(align);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void* operator new(std::size_t size, std::align_val_t align) {
  return allocate_aligned(size, align);
}
void* operator new[](std::size_t size, std::align_val_t align) {
  return allocate_aligned(size, align);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace kanedyn {
namespace {

// Allocations made by `work` while counting.
template <typename Work>
long count_allocations(Work work) {
  allocations = 0;
  counting = true;
  work();
  counting = false;
  return allocations.load();
}

TEST(NoAlloc, CounterSeesOperatorNew) {
  EXPECT_GE(count_allocations([] {
              std::vector<double> v(10);
              v[3] = 1.0;
              EXPECT_EQ(v[3], 1.0);
            }),
            1);
}

TEST(NoAlloc, CounterSeesEigenAllocations) {
  // Eigen's dynamic-size matrices allocate with std::malloc: seen only through this file's
  // malloc (see the top of the file).
  if (!malloc_is_counted())
    GTEST_SKIP() << "malloc in this binary is not this file's (a sanitizer's, or another test "
                    "file's): Eigen's allocations are not counted here";
  EXPECT_GE(count_allocations([] { EXPECT_EQ(MatrixX::Identity(7, 7).eval().trace(), 7.0); }), 1);
}

// A model with a force element of every kind (the generator gives bushings and gravity).
Model with_constant_loads(const Model& base) {
  std::vector<std::shared_ptr<const ForceElement>> forces = base.forces();
  forces.push_back(std::make_shared<ConstantForce>(0, Vector3(1.0, -2.0, 0.5)));
  forces.push_back(std::make_shared<ConstantTorque>(base.num_bodies() - 1, Vector3(0.1, 0, 0)));
  return Model(base.bodies(), base.gravity(), forces);
}

TEST(NoAlloc, ForwardDynamicsBothMethods) {
  for (const GeneratedSystem& g : {chain_model(40), random_tree_model(57, 3)}) {
    const Model model = with_constant_loads(g.model);
    State state = g.initial;
    for (const Method method : {Method::recursive, Method::kane}) {
      Data data(model, method == Method::kane ? DataOptions{} : DataOptions{false, false});
      forward_dynamics(model, state, data, method);  // the first call may allocate
      const long count = count_allocations([&] {
        for (int i = 0; i < 20; ++i) {
          state.y[i % state.y.size()] += 1e-3;  // a different state each time
          forward_dynamics(model, state, data, method);
        }
      });
      EXPECT_EQ(count, 0) << to_string(method) << ", N " << model.num_bodies();
      EXPECT_TRUE(data.ydot.allFinite());
    }
  }
}

TEST(NoAlloc, KaneEquationsWithEveryOutput) {
  // kane_equations with the partials, F_y and the dense [A] (the `eom` path).
  const GeneratedSystem g = random_tree_model(20, 4);
  const Model model = with_constant_loads(g.model);
  Data data(model);
  kane_equations(model, g.initial, data);
  const long count = count_allocations([&] {
    for (int i = 0; i < 5; ++i) kane_equations(model, g.initial, data);
  });
  EXPECT_EQ(count, 0);
}

TEST(NoAlloc, StagedRecursiveRouteForAnUnknownElement) {
  // An element type the fused pass does not know sends the recursive route through
  // compute_kinematics / compute_resultants / recursive_accelerations: no allocation there
  // either.
  class Drag final : public ForceElement {
   public:
    std::string type() const override { return "test-drag"; }
    int body() const override { return 0; }
    void apply(const Model&, const State&, Data& data) const override {
      data.force[0] -= 0.5 * data.v_G[0];
    }
  };
  const GeneratedSystem g = chain_model(12);
  std::vector<std::shared_ptr<const ForceElement>> forces = g.model.forces();
  forces.push_back(std::make_shared<Drag>());
  const Model model(g.model.bodies(), g.model.gravity(), forces);
  Data data(model, DataOptions{false, false});
  ASSERT_FALSE(data.fused_loads);
  forward_dynamics(model, g.initial, data, Method::recursive);
  const long count = count_allocations([&] {
    for (int i = 0; i < 5; ++i) forward_dynamics(model, g.initial, data, Method::recursive);
  });
  EXPECT_EQ(count, 0);
}

}  // namespace
}  // namespace kanedyn
