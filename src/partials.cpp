#include "kanedyn/partials.hpp"

#include <stdexcept>

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }

template <typename D>
auto& partials_of(D& data) {
  if (!data.options().partials)
    throw std::invalid_argument(
        "the partial velocity matrices need a Data made with DataOptions::partials");
  return data.partials;
}
}  // namespace

void compute_partials_recursive(const Model& model, const State& /*state*/, Data& data) {
  Partials& p = partials_of(data);
  const Kinematics& kin = data.kinematics;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const int j = model.lower_body(k);
    const size_t o = at(model.chain_offset(k));  // entry r = 0 is K itself
    if (j == kGround) {
      p.vO_w[o].setZero();
      p.vO_s[o].setIdentity();  // {v_O_root} = {s'_root dot}
    } else {
      // Eq. (18): [v_O_K,y] = [v_O_J,y] - [R_J]^T([q~'_K] + [s~'_K])[w'_J,y] + [R_J]^T[J v'_O_K,y].
      // K's chain is K followed by J's chain, so entries r >= 1 start as J's blocks.
      const size_t oj = at(model.chain_offset(j));
      const int len = model.depth(j) + 1;
      for (int r = 0; r < len; ++r) {
        p.vO_w[o + 1 + at(r)] = p.vO_w[oj + at(r)];
        p.vO_s[o + 1 + at(r)] = p.vO_s[oj + at(r)];
      }
      const Matrix3 RjT = kin.R[at(j)].transpose();
      p.vO_w[o + 1] -= RjT * skew(kin.qs_b[at(k)]);  // block of w'_J
      p.vO_w[o].setZero();
      p.vO_s[o] = RjT;  // Eqs. (19)-(20): block of s'_K dot
    }
    // Eq. (21): [v_G_K,y] = [v_O_K,y] - [R_K]^T [r~'_K][w'_K,y].
    const int len = model.depth(k) + 1;
    for (int r = 0; r < len; ++r) {
      p.vG_w[o + at(r)] = p.vO_w[o + at(r)];
      p.vG_s[o + at(r)] = p.vO_s[o + at(r)];
    }
    p.vG_w[o] -= kin.R[at(k)].transpose() * skew(model.body(k).com);
  }
}

void compute_partials_direct(const Model& model, const State& /*state*/, Data& data) {
  Partials& p = partials_of(data);
  const Kinematics& kin = data.kinematics;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    const int u = model.depth(k);
    // Eqs. (26)-(27): walk r = 0 .. u_K - 1 with c = L^r(K), its lower body L^{r+1}(K).
    p.vO_w[o].setZero();
    for (int r = 0; r < u; ++r) {
      const int c = chain[r];
      const int l = chain[r + 1];
      const Matrix3 RlT = kin.R[at(l)].transpose();
      p.vO_w[o + at(r) + 1] = -RlT * skew(kin.qs_b[at(c)]);
      p.vO_s[o + at(r)] = RlT;
    }
    p.vO_s[o + at(u)].setIdentity();  // L^{u_K}(K) is the root: block [I]
    for (int r = 0; r <= u; ++r) {
      p.vG_w[o + at(r)] = p.vO_w[o + at(r)];
      p.vG_s[o + at(r)] = p.vO_s[o + at(r)];
    }
    p.vG_w[o] -= kin.R[at(k)].transpose() * skew(model.body(k).com);  // Eq. (26), last block
  }
}

void compute_partial_rates(const Model& model, const State& state, Data& data) {
  Partials& p = partials_of(data);
  const Kinematics& kin = data.kinematics;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const int j = model.lower_body(k);
    const size_t o = at(model.chain_offset(k));
    if (j == kGround) {
      p.vO_w_dot[o].setZero();
      p.vO_s_dot[o].setZero();
    } else {
      const size_t oj = at(model.chain_offset(j));
      const int len = model.depth(j) + 1;
      for (int r = 0; r < len; ++r) {
        p.vO_w_dot[o + 1 + at(r)] = p.vO_w_dot[oj + at(r)];
        p.vO_s_dot[o + 1 + at(r)] = p.vO_s_dot[oj + at(r)];
      }
      // Eq. (30), with [s'dot~_K] where the text prints [s~'_K]:
      //   - [R_J]^T([w~'_J]([q~'_K] + [s~'_K]) + [s'dot~_K])[w'_J,y] + [R_J]^T[w~'_J][J v'_O_K,y]
      const Matrix3 RjT = kin.R[at(j)].transpose();
      const Matrix3 wj = skew(state.angular_velocity(j));
      p.vO_w_dot[o + 1] -= RjT * (wj * skew(kin.qs_b[at(k)]) + skew(state.translation_rate(k)));
      p.vO_w_dot[o].setZero();
      p.vO_s_dot[o] = RjT * wj;
    }
    // Eq. (29): [v_G_K,y dot] = [v_O_K,y dot] - [R_K]^T [w~'_K][r~'_K][w'_K,y].
    const int len = model.depth(k) + 1;
    for (int r = 0; r < len; ++r) {
      p.vG_w_dot[o + at(r)] = p.vO_w_dot[o + at(r)];
      p.vG_s_dot[o + at(r)] = p.vO_s_dot[o + at(r)];
    }
    p.vG_w_dot[o] -=
        kin.R[at(k)].transpose() * skew(state.angular_velocity(k)) * skew(model.body(k).com);
  }
}

namespace {
MatrixX dense(const Model& model, int k, const std::vector<Matrix3>& w,
              const std::vector<Matrix3>& s) {
  const int n = model.num_bodies();
  MatrixX m = MatrixX::Zero(3, 6 * n);
  const Model::Chain chain = model.chain(k);
  const size_t o = at(model.chain_offset(k));
  for (int r = 0; r < chain.size; ++r) {
    m.block<3, 3>(0, 3 * chain[r]) = w[o + at(r)];
    m.block<3, 3>(0, 3 * n + 3 * chain[r]) = s[o + at(r)];
  }
  return m;
}
}  // namespace

MatrixX partial_velocity(const Model& model, const Data& data, int k, Point point) {
  const Partials& p = partials_of(data);
  return point == Point::O ? dense(model, k, p.vO_w, p.vO_s) : dense(model, k, p.vG_w, p.vG_s);
}

MatrixX partial_velocity_rate(const Model& model, const Data& data, int k, Point point) {
  const Partials& p = partials_of(data);
  return point == Point::O ? dense(model, k, p.vO_w_dot, p.vO_s_dot)
                           : dense(model, k, p.vG_w_dot, p.vG_s_dot);
}

}  // namespace kanedyn
