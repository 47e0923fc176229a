// No heap allocation on the evaluation path. The test binary's shared counter
// (alloc_counter.hpp) interposes glibc's malloc family, which Eigen's dynamic-size matrices
// use; operator new is replaced here as well so that it is counted even under the sanitizers,
// which own malloc (there only operator new is seen).
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <new>
#include <vector>

#include "alloc_counter.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/testing/generate.hpp"

namespace {
std::atomic<bool>& counting = alloc_counter::counting;
std::atomic<long>& allocations = alloc_counter::count;
void note_allocation() {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1);
}
// True when the shared malloc counter is in use (and so counts Eigen's allocations too).
bool malloc_is_counted() { return alloc_counter::available(); }
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
// The nothrow forms too (std::stable_sort's buffer uses them): every form that pairs with the
// deletes above must come from the same malloc, or the sanitizers see a mismatch.
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return allocate(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return allocate(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t size, std::align_val_t align, const std::nothrow_t&) noexcept {
  try {
    return allocate_aligned(size, align);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, std::align_val_t align, const std::nothrow_t&) noexcept {
  try {
    return allocate_aligned(size, align);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }

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
  // Eigen's dynamic-size matrices allocate with std::malloc: seen through the shared
  // malloc counter, which the sanitizers (owning malloc) replace.
  if (alloc_counter::kSanitizerOwnsMalloc)
    GTEST_SKIP() << "malloc is the sanitizer's here: Eigen's allocations are not counted";
  // Anywhere else a counter that sees no malloc would make every no-allocation test vacuous.
  ASSERT_TRUE(malloc_is_counted()) << "the interposed malloc is not the one in use";
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
    for (const Route method : {Route::recursive, Route::assembled}) {
      Data data(model, method == Route::assembled ? DataOptions{} : DataOptions::recursive_only());
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
    void apply(const Model&, const State&, const Kinematics& kin, Loads& loads) const override {
      loads.force[0] -= 0.5 * kin.v_G[0];
    }
  };
  const GeneratedSystem g = chain_model(12);
  std::vector<std::shared_ptr<const ForceElement>> forces = g.model.forces();
  forces.push_back(std::make_shared<Drag>());
  const Model model(g.model.bodies(), g.model.gravity(), forces);
  Data data(model, DataOptions::recursive_only());
  ASSERT_FALSE(data.single_pass());
  forward_dynamics(model, g.initial, data, Route::recursive);
  const long count = count_allocations([&] {
    for (int i = 0; i < 5; ++i) forward_dynamics(model, g.initial, data, Route::recursive);
  });
  EXPECT_EQ(count, 0);
}

TEST(NoAlloc, FrameJacobian) {
  // A chain of revolute joints under a free root, with a frame on its tip.
  const GeneratedSystem g = chain_model(12);
  std::vector<Joint> joints(12);
  for (size_t k = 1; k < joints.size(); ++k) joints[k].type = JointType::revolute;
  const Model model(g.model.bodies(), g.model.gravity(), g.model.forces(), "", joints,
                    {Frame{"tip", 11, Vector3(0.1, 0, 0), Vector4(0, 0, 0, 1)}});
  VectorX q = VectorX::Zero(model.num_coordinates()), z = VectorX::Ones(model.num_speeds());
  q[3] = 1.0;  // the root's identity rotation
  State state(model);
  joint_state(model, q, z, state);
  Data data(model, DataOptions::recursive_only());
  compute_kinematics(model, state, data);
  MatrixX Jv(3, model.num_speeds()), Jw(3, model.num_speeds());
  const long count = count_allocations([&] {
    for (int i = 0; i < 5; ++i) frame_jacobian(model, 0, q, data.kinematics, Jv, Jw);
  });
  EXPECT_EQ(count, 0);
  EXPECT_TRUE(Jv.allFinite());
}

}  // namespace
}  // namespace kanedyn
