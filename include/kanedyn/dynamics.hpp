// Forward dynamics: {y dot} and {x dot} at a state, by the route of the user's choice. Both
// routes solve Kane's equations (Eq. 36) for the same unconstrained tree.
#pragma once

#include <memory>
#include <string>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

class ConstraintEquations;

enum class Route {
  /// Assemble [A] and {f} (Eqs. 37-38) block-sparse and solve Eq. (36) by the tree-ordered
  /// block LDL^T (src/tree_ldlt.cpp); O(N d^2) for a tree of depth d.
  assembled,
  /// O(N): Newton-Euler per body, then s'' from the relative motion (docs/theory.md); one
  /// fused SIMD pass over the bodies when every force element is of a built-in type.
  recursive
};

/// "assembled" / "recursive".
std::string to_string(Route route);
/// Parses "assembled" / "recursive" (and "kane", the older spelling of "assembled"); throws
/// std::invalid_argument otherwise.
Route parse_route(const std::string& text);

/// {y dot} (Eq. 36) and {x dot} (Eqs. 39-40) at the state into data.ydot and data.xdot, and
/// nothing else of data's public parts: each route works in the Data's private scratch. No
/// heap allocation. Route::recursive runs with any Data; Route::assembled needs
/// DataOptions::kane_terms (throws std::invalid_argument otherwise). Both assume unit Euler
/// parameters; they agree to round-off there.
void forward_dynamics(const Model& model, const State& state, Data& data,
                      Route route = Route::recursive);

/// Forward dynamics of any model at its state (q, z), and the derivative a simulation
/// integrates: the one entry point, with the route dispatch of the library (docs/theory.md,
/// "One model, one state"). For an all-free model the route's kernel is forward_dynamics()
/// above (the fused SIMD pass when every force element is built in, else the staged O(N)
/// route; or the assembled Eqs. 37-38); for any other model the jointed kernel
/// (src/joint_dynamics.cpp: the articulated-body recursion; or the projected Kane equations,
/// factored in tree order). The model must outlive it; not for concurrent calls on one object.
class Dynamics {
 public:
  /// max_simd_lanes caps the fused pass's width (DataOptions::max_simd_lanes).
  explicit Dynamics(const Model& model, Route route = Route::recursive, int max_simd_lanes = 8);
  Dynamics(const Dynamics&) = delete;
  Dynamics& operator=(const Dynamics&) = delete;
  ~Dynamics();

  const Model& model() const;
  Route route() const;
  /// What evaluate() and derivative() run, for output: "fused O(N) pass, 8 bodies per SIMD
  /// pass", "staged O(N) route", "assembled [A] (Eqs. 37-38), tree LDL^T",
  /// "articulated-body recursion over the joints", "projected Kane equations, tree LDL^T".
  std::string kernel() const;
  /// What size() holds, for output: "({x}; {y}) of Eq. (1)" or "(q; z)".
  std::string layout() const;
  /// The fused pass's bodies per SIMD pass (2, 4 or 8), or 0 when another kernel runs.
  int simd_lanes() const;

  /// z dot and q dot at the model's state (q, z) (sizes num_speeds() and num_coordinates();
  /// Euler parameters in q as given, unit norm assumed). No heap allocation after the first
  /// call.
  void evaluate(const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> zdot,
                Eigen::Ref<VectorX> qdot);
  /// z dot alone (forward dynamics, as Pinocchio's aba(q, v, tau)): the same numbers, without
  /// the kinematic equations' q dot.
  void evaluate(const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> zdot);
  /// z dot = F(q, z, u): forward dynamics with the inputs at the values u (set_inputs(u), then
  /// evaluate(q, z, zdot)), as Pinocchio's aba(q, v, tau) with u in place of tau.
  void forward(const VectorX& q, const VectorX& z, const VectorX& u, Eigen::Ref<VectorX> zdot);
  /// The inputs' values u (size model().num_inputs(); docs/model-format.md, "Inputs") that
  /// every later evaluate() and derivative() uses: zero until set. Throws std::invalid_argument
  /// for a wrong size. No heap allocation.
  void set_inputs(const VectorX& u);
  const VectorX& inputs() const;
  /// The notes' state (x, y) of the last evaluation's (q, z), and its kinematics and loads
  /// (computed on request where the kernel did not need them).
  const State& state();
  Data& data();

  /// What an integrator advances, of size(): for an all-free model ({x}; {y}) in the layout
  /// of Eq. (1), for any other model (q; z). pack() and unpack() convert; unpack() also gives
  /// the notes' state, with the Euler parameters normalized when `normalize`.
  int size() const;
  void pack(const VectorX& q, const VectorX& z, VectorX& v) const;
  void unpack(const VectorX& v, bool normalize, VectorX& q, VectorX& z, State& state);
  /// dv/dt at v, with v's Euler parameters normalized first (the field keeps their norm, and
  /// equals the equations of motion on |e| = 1): what simulate() integrates.
  void derivative(const VectorX& v, VectorX& dv);
  /// The largest | |e| - 1 | of v's Euler parameters; rescales them to unit norm when apply.
  double project(VectorX& v, bool apply);
  /// With constraints: the largest holonomic constraint error that project() found before
  /// projecting, over the object's life (0 without constraints).
  double constraint_error() const;
  /// With constraints: the rows' multipliers and the equations at the last evaluation (empty
  /// and null without constraints); ConstraintEquations::force and moment give the reactions.
  const VectorX& constraint_multipliers() const;
  const ConstraintEquations* constraint_equations() const;
  /// "body 'NAME' (COLUMN)" for a component of v, COLUMN as the trajectory CSV names it;
  /// body (if not null) gets its index, -1 outside v.
  std::string describe(int component, int* body = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kanedyn
