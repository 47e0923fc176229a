// The fused O(N) route of forward_dynamics(Route::recursive) as a compiled plan. Private to
// the library.
//
// The kernel (src/recursive/fused_kernel.inc) evaluates kLanes bodies at once with GCC vector
// extensions. It is compiled once per SIMD width: 2 lanes (SSE2, any x86-64; or the
// generic 16-byte vectors elsewhere), 4 (AVX) and 8 (AVX-512F), the wider ones under
// `#pragma GCC target`, each in its own translation unit (src/recursive/fused_lanes2.cpp,
// fused_lanes4.cpp, fused_lanes8.cpp, through src/recursive/fused_lanes.inc), and compile()
// picks the widest the running CPU has.
// The kernel uses no FMA and no reassociation, so every width gives the same bits (tested).
// The layout of the plan's tables depends on the width chosen (Plan::lanes).
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::fused {

/// The fused route compiled from a Model for one SIMD width: per-body constants with the loads
/// grouped per body, the body order of the passes and the shape of the scratch. Built once by
/// compile(), never changed after; a Data keeps it in its private workspace (src/workspace.hpp)
/// with the scratch the evaluations write (scratch_size doubles).
struct Plan {
  int lanes = 2;  // bodies per SIMD pass
  /// The plan numbers the bodies depth first (each body's subtree follows it) when the Model's
  /// numbering is not that already and the model is large (kRenumberFrom): then user[k] is the
  /// Model's number of the plan's body k, and the evaluation copies the state into the plan's
  /// numbering and the derivatives back. Empty when the two numberings are the same.
  std::vector<int> user;
  std::vector<int> lower;  // L(K) per body, padded to whole SIMD groups
  std::vector<int> ready;  // per group: the last group holding a child
  /// The constants: each distinct field of a group (its kLanes doubles, equal bit for bit) once
  std::vector<double> params;
  /// per distinct group of constants: where in params each of its kParamFields fields starts
  std::vector<int> param_rows;
  std::vector<int> param_group;  // per group of bodies: its group of constants in param_rows
  /// pass 1 keeps its results for pass 2 (small models, chain-like large ones), or pass 2
  /// redoes them (large bushy trees)
  bool keep = false;
  int scratch_mask = 0;     // group g's scratch is slot g & scratch_mask (a ring, 2^k slots)
  size_t scratch_size = 0;  // doubles of scratch the evaluations need
  /// Where in the scratch a renumbered plan keeps the state and its derivatives in its own
  /// numbering (26 N doubles); the kernel's scratch comes before.
  size_t copies_at = 0;

  size_t memory_bytes() const;
};

/// The widest kernel that max_simd_lanes allows and the CPU runs: 2, 4 or 8.
int chosen_lanes(int max_simd_lanes);

/// The plan of the model for that many lanes; null when a force element is not a Bushing,
/// ConstantForce or ConstantTorque (the staged route is then taken).
std::shared_ptr<const Plan> compile(const Model& model, int lanes);
/// The same, renumbering from renumber_from bodies on instead of kRenumberFrom (for tests).
std::shared_ptr<const Plan> compile(const Model& model, int lanes, int renumber_from);

/// {y dot} and {x dot} into data.ydot, data.xdot. Needs the plan in data's workspace.
void forward_dynamics(const Model& model, const State& state, Data& data);

/// Up to this many bodies pass 1 keeps its intermediate results for pass 2 (Plan::keep);
/// beyond, it does so when no group's pass 2 comes more than kKeepLag bodies after its pass 1.
constexpr int kKeepLimit = 16384;
constexpr int kKeepLag = 64;

/// From this many bodies on, a model not numbered depth first is renumbered so (Plan::user).
/// The copies into and out of the plan's numbering cost about what the locality saves while the
/// model's arrays fit in the last-level cache (docs/performance-internal.md, "Random trees").
constexpr int kRenumberFrom = 65536;

/// The widest kernel this CPU runs (lanes: 2, 4 or 8).
int widest_supported_lanes();

// ---- Shared with the kernels (no kanedyn or Eigen types cross this line, so that the kernels'
// translation units include nothing compiled for a different target). ----

// Per-body constants, one field after the other, each kLanes doubles (one per body of the
// group). Body-K components unless stated.
enum Param : int {
  kInvMass = 0,        // 1 / m_K
  kInertia = 1,        // [I'_GK]: xx, yy, zz, xy, xz, yz
  kInvInertia = 7,     // its inverse, same order
  kCom = 13,           // r'_K
  kJoint = 16,         // q'_K, body J
  kArm = 19,           // q'_K - r'_J, body J (q'_K for a root): Q_K from G_J
  kForce = 22,         // m_K g + constant forces, inertial
  kMoment = 25,        // constant torques
  kStiffness = 28,     // bushing k, body-J axes, summed over K's bushings
  kDamping = 31,       // bushing c
  kRotStiffness = 34,  // kr
  kRotDamping = 35,    // cr
  kParamFields = 36
};
// Per-body results of passes 1 and 2, same layout.
enum Scratch : int {
  kLoadForce = 0,    // force at G_K, body K: K's own loads plus its children's reactions
  kLoadMoment = 3,   // moment about G_K, body K
  kAccelO = 6,       // a_O_K, body K
  kAccelFields = 9,  // the scratch of a large model stops here
  // Kept by pass 1 for pass 2 when the tables fit in cache (loaded as whole vectors, not
  // gathered and recomputed again):
  kEuler = 9,    // epsilon_K
  kRot = 13,     // [R] = [R_K][R_J]^T, row by row
  kOmega = 22,   // w'_K
  kRate = 25,    // s'_K dot
  kShift = 28,   // s'_K
  kOmegaJ = 31,  // w'_J
  kScratchFields = 34
};

/// What one kernel call reads and writes: plain pointers into the State and Data.
struct Args {
  int n;                   // bodies
  const double* x;         // State::x (7N)
  const double* y;         // State::y (6N)
  const int* lower;        // L(K) per body, padded to whole groups (kGround = -1)
  const int* ready;        // per group: the last group holding a child
  const double* params;    // the distinct fields of the groups of constants, kLanes doubles each
  const int* param_rows;   // per group of constants: kParamFields offsets into params
  const int* param_group;  // per group of bodies: its group of constants in param_rows
  double* scratch;         // Scratch fields per group
  int scratch_stride;      // doubles per group: kScratchFields or kAccelFields times the lanes
  int scratch_mask;        // group g's scratch is slot g & scratch_mask (a ring, 2^k slots)
  double* ydot;            // 6N
  double* xdot;            // 7N
};

namespace lanes2 {
void evaluate(const Args& args);
}
namespace lanes4 {
void evaluate(const Args& args);
}
namespace lanes8 {
void evaluate(const Args& args);
}

}  // namespace kanedyn::fused
