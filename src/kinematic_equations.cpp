#include "kanedyn/kinematic_equations.hpp"

#include "kanedyn/rotation.hpp"

namespace kanedyn {

void compute_xdot(const Model& model, const State& state, Eigen::Ref<VectorX> xdot) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k)  // Eqs. (39), (41)
    xdot.segment<4>(4 * k) =
        euler_parameter_rates(state.euler_parameters(k), state.angular_velocity(k));
  xdot.tail(3 * n) = state.y2();  // Eq. (40)
}

}  // namespace kanedyn
