#include "kanedyn/dynamics.hpp"

#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"

#include "fused.hpp"

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
  // Eq. (36) is equivalent to Newton-Euler per body: m a_G = F, I alpha + w x I w = M.
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const BodySpec& b = model.body(k);
    const Vector3 w = state.angular_velocity(k);
    data.a_G[i] = data.force[i] / b.mass;
    data.alpha_b[i] = model.inverse_inertia(k) * (data.moment_b[i] - w.cross(b.inertia * w));
    // Acceleration of O_K: a_G - d2/dt2([R_K]^T r').
    data.a_O[i] = data.a_G[i] -
                  data.R[i].transpose() * (data.alpha_b[i].cross(b.com) + w.cross(w.cross(b.com)));
    data.ydot.segment<3>(3 * k) = data.alpha_b[i];  // Eq. (10)
  }
  // s''_K from a_O_K = a_O_J + [R_J]^T(s'' + 2 w'_J x s'dot + alpha'_J x (q'+s')
  //                                    + w'_J x (w'_J x (q'+s'))).
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const int j = model.lower_body(k);
    auto sdd = data.ydot.segment<3>(3 * n + 3 * k);
    if (j == kGround) {
      sdd = data.a_O[i];
      continue;
    }
    const auto jj = at(j);
    const Vector3 wj = state.angular_velocity(j);
    const Vector3& qs = data.qs_b[i];
    sdd = data.R[jj] * (data.a_O[i] - data.a_O[jj]) - 2.0 * wj.cross(state.translation_rate(k)) -
          data.alpha_b[jj].cross(qs) - wj.cross(wj.cross(qs));
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
