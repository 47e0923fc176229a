#include "kanedyn/data.hpp"

namespace kanedyn {

Data::Data(const Model& model, DataOptions opts) : options(opts) {
  const auto n = static_cast<size_t>(model.num_bodies());
  const auto m = static_cast<Eigen::Index>(model.num_speeds());
  R.assign(n, Matrix3::Identity());
  p_O.assign(n, Vector3::Zero());
  p_G = v_O = v_G = qs_b = force = moment_b = a_G = a_O = alpha_b = p_O;
  if (options.partials) {
    const auto c = static_cast<size_t>(model.chain_entries());
    vO_w.assign(c, Matrix3::Zero());
    vO_s = vG_w = vG_s = vO_w_dot = vO_s_dot = vG_w_dot = vG_s_dot = vO_w;
  }
  F_y = VectorX::Zero(m);
  f = VectorX::Zero(m);
  ydot = VectorX::Zero(m);
  xdot = VectorX::Zero(7 * static_cast<Eigen::Index>(n));
  if (options.mass_matrix) {
    A = MatrixX::Zero(m, m);
    A_factor = Eigen::LLT<MatrixX>(m);
  }
}

}  // namespace kanedyn
