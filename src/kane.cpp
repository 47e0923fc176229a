#include "kanedyn/kane.hpp"

#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

void require_blocks(const Data& data) {
  if (data.A_blocks.empty())
    throw std::invalid_argument(
        "the Kane route needs a Data made with DataOptions::mass_matrix = true");
}

// -[x~][x~] = |x|^2 [I] - {x}{x}^T: the inertia about the origin of a unit mass at x.
Matrix3 point_inertia(const Vector3& x) {
  return x.squaredNorm() * Matrix3::Identity() - x * x.transpose();
}

// The inward pass shared by Eqs. (31) and (38): generalized forces of per-body loads
// (force `g` at G_K, inertial; moment `m`, body K) into out (6N). With G_K the sum of the
// forces over K's subtree, the rows of body K are
//   w'_K:     r'_K x [R_K] g_K + {m_K} + sum over children D of (q'_D + s'_D) x [R_K] G_D,
//   s'_K dot: [R_J] G_K  (J = L(K); [I] for a root),
// because every body below a child D has the partial blocks of D at K (Eqs. 26-27).
template <typename Loads>
void generalized_forces(const Model& model, Data& data, Loads loads, VectorX& out) {
  const int n = model.num_bodies();
  out.setZero();
  for (int k = 0; k < n; ++k) data.load_sum[at(k)].setZero();
  for (int k = n - 1; k >= 0; --k) {
    const int j = model.lower_body(k);
    Vector3 g, m;
    loads(k, g, m);
    const Vector3 sum = data.load_sum[at(k)] + g;
    out.segment<3>(3 * k) += model.body(k).com.cross(data.R[at(k)] * g) + m;
    const Vector3 fs = j == kGround ? sum : Vector3(data.R[at(j)] * sum);
    out.segment<3>(3 * n + 3 * k) = fs;
    if (j != kGround) {
      data.load_sum[at(j)] += sum;
      out.segment<3>(3 * j) += data.qs_b[at(k)].cross(fs);
    }
  }
}

}  // namespace

void compute_mass_matrix(const Model& model, Data& data) {
  require_blocks(data);
  const int n = model.num_bodies();
  // Subtree sums, leaves first: mass M_K, first moment h_K = sum m x about O_K (body K) and the
  // composite inertia about O_K, which is the (w'_K, w'_K) part of the diagonal block.
  for (int k = 0; k < n; ++k) {
    const BodySpec& b = model.body(k);
    data.subtree_mass[at(k)] = b.mass;
    data.h_b[at(k)] = b.mass * b.com;
    data.A_blocks[at(model.chain_offset(k))].topLeftCorner<3, 3>() =
        b.inertia + b.mass * point_inertia(b.com);
  }
  for (int k = n - 1; k >= 0; --k) {
    const int j = model.lower_body(k);
    const size_t o = at(model.chain_offset(k));
    const double mass = data.subtree_mass[at(k)];
    const Vector3& h = data.h_b[at(k)];
    const Matrix3& Rk = data.R[at(k)];
    const Matrix3 RjT =
        j == kGround ? Matrix3(Matrix3::Identity()) : Matrix3(data.R[at(j)].transpose());
    // Diagonal block: sum m [v_G,y]_K^T [v_G,y]_K + inertia, with [v_G,y]_K = [-R_K^T [x~], R_J^T]
    // and x = r'_K for K itself, q'_D + s'_D for the bodies below child D.
    Matrix6& d = data.A_blocks[o];
    d.topRightCorner<3, 3>() = skew(h) * (Rk * RjT);
    d.bottomLeftCorner<3, 3>() = d.topRightCorner<3, 3>().transpose();
    d.bottomRightCorner<3, 3>() = mass * Matrix3::Identity();
    // S_K = sum over K's subtree of m [v_G,y]_K (3 x 6, inertial).
    Matrix36& s = data.composite[at(k)];
    s.leftCols<3>() = -Rk.transpose() * skew(h);
    s.rightCols<3>() = mass * RjT;
    // Block (K, I), I = L^r(K), c = L^{r-1}(K): S_K^T [v_G,y]_I with the partial blocks of
    // Eqs. (26)-(27) at I, [-R_I^T [(q'_c + s'_c)~], R_{L(I)}^T]:
    //   [ ([(q'_c + s'_c)~] R_I S_K)^T, (R_{L(I)} S_K)^T ].
    const Model::Chain chain = model.chain(k);
    const int u = chain.size - 1;
    Matrix36 t = u >= 1 ? Matrix36(data.R[at(chain[1])] * s) : s;  // R_I S_K
    for (int r = 1; r <= u; ++r) {
      const Matrix36 t_next = r < u ? Matrix36(data.R[at(chain[r + 1])] * s) : s;
      const Vector3& qs = data.qs_b[at(chain[r - 1])];
      Matrix6& block = data.A_blocks[o + at(r)];
      for (int c = 0; c < 6; ++c) block.block<1, 3>(c, 0) = qs.cross(t.col(c)).transpose();
      block.rightCols<3>() = t_next.transpose();
      t = t_next;
    }
    if (j != kGround) {
      data.subtree_mass[at(j)] += mass;
      data.h_b[at(j)] += mass * data.qs_b[at(k)];
      data.A_blocks[at(model.chain_offset(j))].topLeftCorner<3, 3>() +=
          mass * point_inertia(data.qs_b[at(k)]);
    }
  }
}

void compute_force_vector(const Model& model, const State& state, Data& data) {
  require_blocks(data);
  const int n = model.num_bodies();
  // [v_O_K,y dot]{y} (Eqs. 30 and 28), outwards: the acceleration of O_K at y dot = 0,
  // a_O_J + [R_J]^T(2 w'_J x s'_K dot + w'_J x (w'_J x (q'_K + s'_K))).
  for (int k = 0; k < n; ++k) {
    const int j = model.lower_body(k);
    if (j == kGround) {
      data.bias_O[at(k)].setZero();
      continue;
    }
    const Vector3 wj = state.angular_velocity(j);
    const Vector3 rel =
        2.0 * wj.cross(state.translation_rate(k)) + wj.cross(wj.cross(data.qs_b[at(k)]));
    data.bias_O[at(k)] = data.bias_O[at(j)] + data.R[at(j)].transpose() * rel;
  }
  // Eq. (38): the loads less m [v_G,y dot]{y} (Eq. 29) and the gyroscopic moment.
  generalized_forces(
      model, data,
      [&](int k, Vector3& g, Vector3& m) {
        const BodySpec& b = model.body(k);
        const Vector3 w = state.angular_velocity(k);
        const Vector3 bias_g =
            data.bias_O[at(k)] + data.R[at(k)].transpose() * w.cross(w.cross(b.com));
        g = data.force[at(k)] - b.mass * bias_g;
        m = data.moment_b[at(k)] - w.cross(b.inertia * w);
      },
      data.f);
}

void compute_generalized_forces(const Model& model, Data& data) {
  if (data.load_sum.empty())
    throw std::invalid_argument(
        "generalized forces need a Data made with DataOptions::partials or mass_matrix");
  generalized_forces(
      model, data,
      [&](int k, Vector3& g, Vector3& m) {
        g = data.force[at(k)];
        m = data.moment_b[at(k)];
      },
      data.F_y);
}

void dense_mass_matrix(const Model& model, Data& data) {
  require_blocks(data);
  const int n = model.num_bodies();
  data.A.setZero(6 * n, 6 * n);
  const auto place = [&](int row_body, int col_body, const Matrix6& b) {
    for (int p = 0; p < 2; ++p)
      for (int q = 0; q < 2; ++q)
        data.A.block<3, 3>(3 * n * p + 3 * row_body, 3 * n * q + 3 * col_body) =
            b.block<3, 3>(3 * p, 3 * q);
  };
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    place(k, k, data.A_blocks[o]);
    for (int r = 1; r < chain.size; ++r) {
      place(k, chain[r], data.A_blocks[o + at(r)]);
      place(chain[r], k, data.A_blocks[o + at(r)].transpose());
    }
  }
}

void compute_mass_matrix_dense(const Model& model, Data& data) {
  const int n = model.num_bodies();
  MatrixX& A = data.A;
  A.setZero(6 * n, 6 * n);
  for (int k = 0; k < n; ++k) {
    const double m = model.body(k).mass;
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    // m_K [v_G_K,y]^T [v_G_K,y]: only pairs of blocks on K's chain are nonzero.
    for (int a = 0; a < chain.size; ++a) {
      const int ca = chain[a];
      const Matrix3& wa = data.vG_w[o + at(a)];
      const Matrix3& sa = data.vG_s[o + at(a)];
      for (int b = 0; b < chain.size; ++b) {
        const int cb = chain[b];
        const Matrix3& wb = data.vG_w[o + at(b)];
        const Matrix3& sb = data.vG_s[o + at(b)];
        A.block<3, 3>(3 * ca, 3 * cb).noalias() += m * wa.transpose() * wb;
        A.block<3, 3>(3 * ca, 3 * n + 3 * cb).noalias() += m * wa.transpose() * sb;
        A.block<3, 3>(3 * n + 3 * ca, 3 * cb).noalias() += m * sa.transpose() * wb;
        A.block<3, 3>(3 * n + 3 * ca, 3 * n + 3 * cb).noalias() += m * sa.transpose() * sb;
      }
    }
    // [w'_K,y]^T [I'_G_K] [w'_K,y]: the inertia in the w'_K, w'_K block.
    A.block<3, 3>(3 * k, 3 * k) += model.body(k).inertia;
  }
}

void compute_force_vector_dense(const Model& model, const State& state, Data& data) {
  const int n = model.num_bodies();
  data.f.setZero();
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    // [v_G_K,y dot]{y}: the velocity-dependent part of the acceleration of G_K.
    Vector3 bias = Vector3::Zero();
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      bias.noalias() += data.vG_w_dot[o + at(r)] * state.angular_velocity(c);
      bias.noalias() += data.vG_s_dot[o + at(r)] * state.translation_rate(c);
    }
    const Vector3 g = data.force[at(k)] - model.body(k).mass * bias;
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      data.f.segment<3>(3 * c).noalias() += data.vG_w[o + at(r)].transpose() * g;
      data.f.segment<3>(3 * n + 3 * c).noalias() += data.vG_s[o + at(r)].transpose() * g;
    }
    // [w'_K,y]^T ({M'_K} - [w~'_K][I'_G_K]{w'_K})
    const Vector3 w = state.angular_velocity(k);
    data.f.segment<3>(3 * k) += data.moment_b[at(k)] - w.cross(model.body(k).inertia * w);
  }
}

void kane_accelerations(const Model& model, const State& state, Data& data) {
  compute_mass_matrix(model, data);
  compute_force_vector(model, state, data);
  data.A_factor.compute(model, data.A_blocks);  // [A] is symmetric positive definite
  data.ydot = data.f;
  data.A_factor.solve_in_place(model, data.ydot);  // Eq. (36)
}

void kane_equations(const Model& model, const State& state, Data& data) {
  require_blocks(data);
  compute_kinematics(model, state, data);
  if (data.options.partials) {
    compute_partials_recursive(model, state, data);
    compute_partial_rates(model, state, data);
  }
  compute_resultants(model, state, data);
  compute_generalized_forces(model, data);
  kane_accelerations(model, state, data);
  if (data.options.dense_mass_matrix) dense_mass_matrix(model, data);
}

}  // namespace kanedyn
