#include "kanedyn/dynamics.hpp"

#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"

#include "assembled.hpp"
#include "equations.hpp"
#include "recursive/fused.hpp"
#include "staged.hpp"
#include "workspace.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

// The staged O(N) route, from the kinematics and loads in w, into ydot.
void recursive_accelerations(const Model& model, const State& state, detail::Workspace& w,
                             VectorX& ydot) {
  const int n = model.num_bodies();
  const Kinematics& kin = w.kinematics;
  // Every body is free (no constraint acts), so [V] in [A] = [V]^T[M][V] is invertible and
  // Eq. (36) is equivalent to Newton-Euler per body: m a_G = F, I alpha + w x I w = M; the
  // equations of the fused route (src/equations.inc), a_O in body-K components.
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const BodySpec& b = model.body(k);
    const eq::Vec3<double> wk = eq::vec(state.angular_velocity(k));
    const eq::Vec3<double> alpha = eq::angular_acceleration(
        eq::sym(b.inertia), eq::sym(model.inverse_inertia(k)), eq::vec(w.loads.moment_b[i]), wk);
    const double inverse_mass = 1.0 / b.mass;
    eq::store(w.a_O[i].data(),
              eq::origin_acceleration(inverse_mass, eq::mat(kin.R[i]) * eq::vec(w.loads.force[i]),
                                      alpha, wk, eq::vec(b.com)));
    eq::store(w.alpha_b[i].data(), alpha);
    eq::store(ydot.data() + 3 * k, alpha);  // Eq. (10)
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
    const eq::Vec3<double> qs = eq::vec(kin.qs_b[i]);
    const eq::Vec3<double> before_j = eq::translation_acceleration_before_j(
        eq::transpose_times(R, eq::vec(w.a_O[i])), root ? zero : eq::vec(state.angular_velocity(j)),
        eq::vec(state.translation_rate(k)), qs);
    const eq::Vec3<double> sdd = eq::translation_acceleration(
        before_j, root ? zero : eq::vec(w.a_O[jj]), root ? zero : eq::vec(w.alpha_b[jj]), qs);
    eq::store(ydot.data() + 3 * n + 3 * k, sdd);
  }
}

}  // namespace

std::string to_string(Route route) { return route == Route::assembled ? "assembled" : "recursive"; }

Route parse_route(const std::string& text) {
  if (text == "assembled" || text == "kane") return Route::assembled;  // kane: older spelling
  if (text == "recursive") return Route::recursive;
  throw std::invalid_argument("unknown route '" + text + "' (expected 'recursive' or 'assembled')");
}

void detail::staged_forward_dynamics(const Model& model, const State& state, Data& data,
                                     Route route) {
  detail::Workspace& w = workspace(data);
  if (route == Route::assembled && !data.options().kane_terms)
    throw std::invalid_argument("Route::assembled needs a Data made with DataOptions::kane_terms");
  compute_kinematics(model, state, w.kinematics);
  compute_resultants(model, state, w.kinematics, data.inputs, w.loads);
  if (route == Route::assembled) {
    assembled::mass_matrix(model, w.kinematics, w.assembled);
    assembled::force_vector(model, state, w.kinematics, w.loads, w.assembled, w.load_sum,
                            data.ydot);
    assembled::solve_in_place(model, w.assembled, data.ydot);
  } else {
    recursive_accelerations(model, state, w, data.ydot);
  }
  compute_xdot(model, state, data.xdot);
}

void forward_dynamics(const Model& model, const State& state, Data& data, Route route) {
  if (route == Route::recursive && workspace(data).plan)
    fused::forward_dynamics(model, state, data);  // the pass also evaluates Eqs. (39)-(41)
  else
    detail::staged_forward_dynamics(model, state, data, route);
}

}  // namespace kanedyn
