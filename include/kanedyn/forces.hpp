// Loads: per-body resultants from gravity and force elements, and the generalized forces of
// Eq. (31). Force laws exactly as docs/model-format.md ("Force laws, exactly") states them.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

template <int N>
struct Dual;

namespace detail {
template <typename S>
class TreeLoads;
}  // namespace detail

/// The scalars of the library's generic passes (the analytic derivatives' dual numbers, and
/// double in the generic inverse dynamics), for the hooks below.
#define KANEDYN_FOR_EACH_TREE_SCALAR(X) \
  X(double)                             \
  X(::kanedyn::Dual<8>)                 \
  X(::kanedyn::Dual<12>)                \
  X(::kanedyn::Dual<16>)

/// The body load of the form of a bushing plus constant loads, which the all-free kernel
/// evaluates in its fused pass (src/recursive/fused.cpp): the laws are linear in these
/// coefficients, so the elements on one body add into one set.
struct LinearBodyLoad {
  Vector3 stiffness = Vector3::Zero(), damping = Vector3::Zero();  ///< a bushing's k, c
  double rotational_stiffness = 0.0, rotational_damping = 0.0;     ///< a bushing's kr, cr
  Vector3 force = Vector3::Zero();   ///< constant, at G_K, inertial components
  Vector3 moment = Vector3::Zero();  ///< constant, body-K components
};

/// One force element, acting on bodies, on joint coordinates, or both (docs/theory.md, "Adding
/// a force element"). An element is one class; the library asks it through these hooks and its
/// properties, never by its type.
///
/// The law for double: apply() adds its loads to loads.force (at G_K, inertial) and
/// loads.moment_b (body components) of the bodies it acts on. It may read the state and the
/// kinematics already in kin (R, p_O, p_G; see compute_kinematics). apply_joint() adds
/// generalized forces on the joint coordinates of the Model (in the order of z). Neither may
/// allocate.
///
/// The law for every scalar: the built-in elements write their law once, as a template over
/// the scalar, and give it to the generic passes through apply_generic() (one overload per
/// scalar of KANEDYN_FOR_EACH_TREE_SCALAR), which the analytic derivatives run in dual
/// numbers; any_scalar() says so. An element that gives only the double hooks (any_scalar()
/// false, the default) still works everywhere; its model's derivatives are then central
/// differences (Derivatives::method() says so).
class ForceElement {
 public:
  virtual ~ForceElement() = default;
  virtual std::string type() const = 0;  ///< as in model files: "bushing", "force", "torque"
  virtual int body() const = 0;          ///< the body K it is attached to
  /// Checks parameters against the model; returns "" or a message naming the problem.
  virtual std::string validate(const Model& model) const;
  virtual void apply(const Model& model, const State& state, const Kinematics& kin,
                     Loads& loads) const = 0;
  /// Whether apply() reads the positions or velocities in kin (p_O, p_G, qs_b, v_O, v_G) and
  /// not only the state and the rotations R. True unless an element says otherwise, so that
  /// an element written elsewhere is given all of them; the jointed route (Dynamics) computes
  /// them only when some element asks.
  virtual bool reads_positions() const { return true; }
  /// Potential energy stored in the element (0 for constant loads, which are not conservative
  /// in general and are left out of the energy).
  virtual double potential_energy(const Model& model, const State& state,
                                  const Kinematics& kin) const;
  /// Power removed from the system by the element's damping (>= 0).
  virtual double damping_power(const Model& model, const State& state, const Kinematics& kin) const;

  /// True for an element that acts on joint coordinates through apply_joint() and on no body
  /// through apply() (the Model keeps the two kinds apart, so that a model with only joint
  /// springs needs no body loads).
  virtual bool acts_on_joints() const { return false; }
  /// Adds the element's generalized forces at (q, z) to Q (size of z). Nothing by default.
  virtual void apply_joint(const Model& model, const VectorX& q, const VectorX& z,
                           Eigen::Ref<VectorX> Q) const;
  /// Potential energy stored on joint coordinates at q (0 by default).
  virtual double joint_potential_energy(const Model& model, const VectorX& q) const;
  /// Power removed by damping on joint speeds at z (>= 0; 0 by default).
  virtual double joint_damping_power(const Model& model, const VectorX& z) const;

  // ---- Properties ----
  /// Whether every load of the element is accounted for in the energy: its work is minus the
  /// change of its potential energy, less the damping power it reports. False (the default)
  /// for constant loads and anything unknown: the energy then need not be conserved.
  virtual bool conservative() const { return false; }
  /// Whether the element dissipates (reports a damping power that can be nonzero).
  virtual bool dissipative() const { return false; }
  /// An estimate of the largest squared angular frequency (rad^2/s^2) the element gives the
  /// model, its body taken as a lone oscillator against the other end; 0 when it adds none
  /// (the explicit integrators' step limits: rk4_step_limit).
  virtual double frequency_squared_estimate(const Model& model) const;
  /// The element as a linear body load, when it is one (bushings, constant forces and
  /// torques): the all-free kernel then evaluates it in its fused pass. Empty by default.
  virtual std::optional<LinearBodyLoad> linear_body_load() const { return std::nullopt; }

  // ---- The law for every scalar ----
  /// Whether apply_generic() gives the element's law (the built-in elements).
  virtual bool any_scalar() const { return false; }
  /// What apply_generic() reads of the generic pass, beyond each body's state.
  struct Needs {
    bool euler = false;      ///< absolute Euler parameters (relative rotations)
    bool rotation = false;   ///< absolute rotations [R_K]
    bool positions = false;  ///< positions and velocities of points (O_K, inertial)
  };
  virtual Needs needs() const { return {}; }
#define KANEDYN_DECLARE_GENERIC_HOOK(S) \
  virtual void apply_generic(detail::TreeLoads<S>& loads) const;
  KANEDYN_FOR_EACH_TREE_SCALAR(KANEDYN_DECLARE_GENERIC_HOOK)
#undef KANEDYN_DECLARE_GENERIC_HOOK

  // ---- The model file ----
  /// One key of the element's entry in a model file: numbers, or a body's name.
  struct FileKey {
    std::string key;
    VectorX value;  ///< the numbers (one for a scalar key)
    bool scalar = false;
    int body = -2;  ///< for a key naming a body (kGround for ground); else -2
  };
  /// One entry of the forces list: its type and its keys after `body`.
  struct FileEntry {
    std::string type;
    std::vector<FileKey> keys;
  };
  /// The entries that write the element to a model file (one, or two for a joint load with
  /// both a spring and a force); empty for an element the model format cannot express.
  virtual std::vector<FileEntry> file_entries() const { return {}; }
};

/// Declares the overrides of the law for every scalar in a built-in element.
#define KANEDYN_GENERIC_LAW_OVERRIDE(S) \
  void apply_generic(detail::TreeLoads<S>& loads) const override;
#define KANEDYN_GENERIC_LAW                         \
  bool any_scalar() const override { return true; } \
  KANEDYN_FOR_EACH_TREE_SCALAR(KANEDYN_GENERIC_LAW_OVERRIDE)

/// Spring-damper between body K and J = L(K) (or the inertial frame).
/// Translational: {F'} = -diag(k){s'_K} - diag(c){s'_K dot} (body-J components) on K at O_K
/// and reversed on J at the point of J coinciding with O_K.
/// Rotational: M = -kr theta - cr (w_K - w_J) on K, -M on J; theta the rotation vector of K
/// relative to J.
class Bushing final : public ForceElement {
 public:
  Bushing(int body, Vector3 stiffness, Vector3 damping, double rotational_stiffness,
          double rotational_damping);
  std::string type() const override { return "bushing"; }
  int body() const override { return body_; }
  std::string validate(const Model& model) const override;
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  bool reads_positions() const override { return false; }  // R_J only
  double potential_energy(const Model& model, const State& state,
                          const Kinematics& kin) const override;
  double damping_power(const Model& model, const State& state,
                       const Kinematics& kin) const override;
  bool conservative() const override { return true; }
  bool dissipative() const override;
  double frequency_squared_estimate(const Model& model) const override;
  std::optional<LinearBodyLoad> linear_body_load() const override;
  Needs needs() const override { return {.euler = true}; }
  std::vector<FileEntry> file_entries() const override;
  KANEDYN_GENERIC_LAW

  /// {F'} in body-J components; theta of K relative to J.
  Vector3 translational_force_b(const State& state) const;
  Vector3 rotation_vector(const Model& model, const State& state) const;

  /// The law over any scalar (src/forces.cpp).
  template <typename Loads>
  void law(Loads& loads) const;

  Vector3 stiffness, damping;
  double rotational_stiffness, rotational_damping;

 private:
  int body_;
};

/// A constant force at G_K, inertial components.
class ConstantForce final : public ForceElement {
 public:
  ConstantForce(int body, Vector3 value) : value(std::move(value)), body_(body) {}
  std::string type() const override { return "force"; }
  int body() const override { return body_; }
  std::string validate(const Model& model) const override;
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  bool reads_positions() const override { return false; }
  bool conservative() const override { return value.isZero(0.0); }
  std::optional<LinearBodyLoad> linear_body_load() const override;
  Needs needs() const override { return {.rotation = true}; }
  std::vector<FileEntry> file_entries() const override;
  KANEDYN_GENERIC_LAW
  template <typename Loads>
  void law(Loads& loads) const;
  Vector3 value;

 private:
  int body_;
};

/// A constant moment on body K, body-K components.
class ConstantTorque final : public ForceElement {
 public:
  ConstantTorque(int body, Vector3 value) : value(std::move(value)), body_(body) {}
  std::string type() const override { return "torque"; }
  int body() const override { return body_; }
  std::string validate(const Model& model) const override;
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  bool reads_positions() const override { return false; }
  bool conservative() const override { return value.isZero(0.0); }
  std::optional<LinearBodyLoad> linear_body_load() const override;
  std::vector<FileEntry> file_entries() const override;
  KANEDYN_GENERIC_LAW
  template <typename Loads>
  void law(Loads& loads) const;
  Vector3 value;

 private:
  int body_;
};

/// A spring-damper between a point P fixed in body K (`at`, from O_K, body-K components) and a
/// point P' fixed in `other` (`other_at`, from its O; for the ground, inertial from the
/// origin), as docs/model-format.md ("Force laws, exactly") states: with d = P' - P, L = |d|
/// and u = d / L, the force (k (L - L0) + c dL/dt) u on K at P, its opposite on `other` at P'.
/// Potential energy 1/2 k (L - L0)^2. At L = 0 with L0 > 0 or c > 0 the direction is undefined:
/// apply() throws SpringLengthError naming the element's body; with L0 = c = 0 the force is k d.
class Spring final : public ForceElement {
 public:
  Spring(int body, Vector3 at, int other, Vector3 other_at, double stiffness, double damping,
         double rest_length);
  std::string type() const override { return "spring"; }
  int body() const override { return body_; }
  int other() const { return other_; }
  std::string validate(const Model& model) const override;
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  double potential_energy(const Model& model, const State& state,
                          const Kinematics& kin) const override;
  double damping_power(const Model& model, const State& state,
                       const Kinematics& kin) const override;
  bool conservative() const override { return true; }
  bool dissipative() const override { return damping != 0.0; }
  double frequency_squared_estimate(const Model& model) const override;
  Needs needs() const override { return {.positions = true}; }
  std::vector<FileEntry> file_entries() const override;
  KANEDYN_GENERIC_LAW
  template <typename Loads>
  void law(Loads& loads) const;

  Vector3 at, other_at;
  double stiffness, damping, rest_length;

 private:
  int body_, other_;
};

/// The failure of a spring whose two points meet where its direction is needed.
class SpringLengthError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A load on one body's joint coordinates (the model format's joint_spring and joint_force):
/// for coordinate i, Q_i = value_i - stiffness_i (q_i - rest_i) - damping_i dq_i/dt, potential
/// energy 1/2 stiffness_i (q_i - rest_i)^2. Revolute, prismatic, cylindrical and universal
/// joints only (there z = dq/dt). Each vector has coordinate_count() entries (a loader expands
/// scalars); a joint_force has zero stiffness and damping, a joint_spring zero value.
class JointLoad final : public ForceElement {
 public:
  /// kind: "joint_spring" or "joint_force", the type() the model file spells.
  JointLoad(int body, VectorX stiffness, VectorX damping, VectorX rest, VectorX value,
            std::string kind = "joint_spring");
  std::string type() const override { return kind_; }
  int body() const override { return body_; }
  /// Refuses a free, weld or spherical joint, and vectors of the wrong size.
  std::string validate(const Model& model) const override;
  void apply(const Model&, const State&, const Kinematics&, Loads&) const override {}
  bool reads_positions() const override { return false; }
  bool acts_on_joints() const override { return true; }
  void apply_joint(const Model& model, const VectorX& q, const VectorX& z,
                   Eigen::Ref<VectorX> Q) const override;
  double joint_potential_energy(const Model& model, const VectorX& q) const override;
  double joint_damping_power(const Model& model, const VectorX& z) const override;
  bool conservative() const override { return value.isZero(0.0); }
  bool dissipative() const override { return !damping.isZero(0.0); }
  std::vector<FileEntry> file_entries() const override;
  KANEDYN_GENERIC_LAW
  template <typename Loads>
  void law(Loads& loads) const;

  VectorX stiffness, damping, rest, value;

 private:
  int body_;
  std::string kind_;
};

/// Adds every element's generalized forces on the joint coordinates at (q, z) to Q.
void add_joint_forces(const Model& model, const VectorX& q, const VectorX& z,
                      Eigen::Ref<VectorX> Q);
/// Sum of the elements' potentials on joint coordinates at q (the joint springs').
double joint_potential_energy(const Model& model, const VectorX& q);
/// Power removed by the elements' damping on joint speeds at z (>= 0).
double joint_damping_power(const Model& model, const VectorX& z);

/// Per-body resultants {F_K} (at G_K, inertial) and {M'_K} (body) of gravity, every force
/// element and the inputs at data.inputs, into data.loads. Needs data.kinematics of the state
/// (compute_kinematics).
void compute_resultants(const Model& model, const State& state, Data& data);
/// The same into loads, from kin, without the inputs (all zero).
void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        Loads& loads);
/// The same with the inputs at the values u (size model.num_inputs()).
void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        const VectorX& u, Loads& loads);

/// Adds the body loads of the inputs at the values u (docs/model-format.md, "Inputs") to loads:
/// force and torque inputs, and joint inputs on free bodies (a moment u e_i on K for w'_K i; for
/// s'_K dot i a force u e_i, body-J components, on K at O_K and reversed on J at the point of J
/// coinciding with O_K, whose generalized force is u on that speed alone, as a bushing's). Reads
/// kin.R only. In input order, after the force elements.
void add_input_loads(const Model& model, const VectorX& u, const State& state,
                     const Kinematics& kin, Loads& loads);
/// Adds u_i to Q (in the order of z) for every joint input on a joint other than free.
void add_input_joint_forces(const Model& model, const VectorX& u, Eigen::Ref<VectorX> Q);

/// Eq. (31): {F_y} = sum_K [v_G_K,y]^T {F_K} + [w'_K,y]^T {M'_K}, into data.kane.F_y, O(N): by
/// subtree sums of the loads, the inward pass of Eq. (38). Needs data.kinematics and
/// data.loads of one state, and a Data with DataOptions::kane_terms (throws
/// std::invalid_argument otherwise).
void compute_generalized_forces(const Model& model, Data& data);

}  // namespace kanedyn
