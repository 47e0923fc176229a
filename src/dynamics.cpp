#include "kanedyn/dynamics.hpp"

#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"

#include "equations.hpp"
#include "recursive/fused.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

}  // namespace

std::string to_string(Method method) { return method == Method::kane ? "kane" : "recursive"; }

Method parse_method(const std::string& text) {
  if (text == "kane") return Method::kane;
  if (text == "recursive") return Method::recursive;
  throw std::invalid_argument("unknown method '" + text + "' (expected 'recursive' or 'kane')");
}

void recursive_accelerations(const Model& model, const State& state, Data& data) {
  const int n = model.num_bodies();
  // Every body is free (no constraint acts), so [V] in [A] = [V]^T[M][V] is invertible and
  // Eq. (36) is equivalent to Newton-Euler per body: m a_G = F, I alpha + w x I w = M; the
  // equations of the fused route (src/equations.inc), a_O in body-K components.
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const BodySpec& b = model.body(k);
    const eq::Vec3<double> w = eq::vec(state.angular_velocity(k));
    const eq::Vec3<double> alpha = eq::angular_acceleration(
        eq::sym(b.inertia), eq::sym(model.inverse_inertia(k)), eq::vec(data.moment_b[i]), w);
    const double inverse_mass = 1.0 / b.mass;
    data.a_G[i] = inverse_mass * data.force[i];
    eq::store(data.a_O[i].data(),
              eq::origin_acceleration(inverse_mass, eq::mat(data.R[i]) * eq::vec(data.force[i]),
                                      alpha, w, eq::vec(b.com)));
    eq::store(data.alpha_b[i].data(), alpha);
    eq::store(data.ydot.data() + 3 * k, alpha);  // Eq. (10)
  }
  // s''_K in body J from a_O_K and J's results.
  const eq::Vec3<double> zero{0.0, 0.0, 0.0};
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const int j = model.lower_body(k);
    const eq::Mat3<double> R =  // body J -> body K
        eq::rotation_matrix(eq::relative_euler(state.x.data(), j, k));
    const bool root = j == kGround;
    const auto jj = at(root ? k : j);
    const eq::Vec3<double> qs = eq::vec(data.qs_b[i]);
    const eq::Vec3<double> before_j = eq::translation_acceleration_before_j(
        eq::transpose_times(R, eq::vec(data.a_O[i])),
        root ? zero : eq::vec(state.angular_velocity(j)), eq::vec(state.translation_rate(k)), qs);
    const eq::Vec3<double> sdd = eq::translation_acceleration(
        before_j, root ? zero : eq::vec(data.a_O[jj]), root ? zero : eq::vec(data.alpha_b[jj]), qs);
    eq::store(data.ydot.data() + 3 * n + 3 * k, sdd);
  }
}

void forward_dynamics(const Model& model, const State& state, Data& data, Method method) {
  if (method == Method::kane) {
    compute_kinematics(model, state, data);
    compute_resultants(model, state, data);
    kane_accelerations(model, state, data);
  } else if (data.fused_loads) {
    fused::forward_dynamics(model, state, data);
    return;  // the pass also evaluates Eqs. (39)-(41)
  } else {
    compute_kinematics(model, state, data);
    compute_resultants(model, state, data);
    recursive_accelerations(model, state, data);
  }
  compute_xdot(model, state, data.xdot);
}

}  // namespace kanedyn
