#include "kanedyn/kane.hpp"

#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"

#include "assembled.hpp"
#include "equations.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

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
template <typename LoadsOf>
void inward_pass(const Model& model, const Kinematics& kin, LoadsOf loads,
                 std::vector<Vector3>& load_sum, VectorX& out) {
  const int n = model.num_bodies();
  out.setZero();
  for (int k = 0; k < n; ++k) load_sum[at(k)].setZero();
  for (int k = n - 1; k >= 0; --k) {
    const int j = model.lower_body(k);
    Vector3 g, m;
    loads(k, g, m);
    const Vector3 sum = load_sum[at(k)] + g;
    out.segment<3>(3 * k) += model.body(k).com.cross(kin.R[at(k)] * g) + m;
    const Vector3 fs = j == kGround ? sum : Vector3(kin.R[at(j)] * sum);
    out.segment<3>(3 * n + 3 * k) = fs;
    if (j != kGround) {
      load_sum[at(j)] += sum;
      out.segment<3>(3 * j) += kin.qs_b[at(k)].cross(fs);
    }
  }
}

}  // namespace

namespace assembled {

void mass_matrix(const Model& model, const Kinematics& kin, detail::AssembledScratch& a) {
  const int n = model.num_bodies();
  // Subtree sums, leaves first: mass M_K, first moment h_K = sum m x about O_K (body K) and the
  // composite inertia about O_K, which is the (w'_K, w'_K) part of the diagonal block.
  for (int k = 0; k < n; ++k) {
    const BodySpec& b = model.body(k);
    a.subtree_mass[at(k)] = b.mass;
    a.h_b[at(k)] = b.mass * b.com;
    a.A_blocks[at(model.chain_offset(k))].topLeftCorner<3, 3>() =
        b.inertia + b.mass * point_inertia(b.com);
  }
  for (int k = n - 1; k >= 0; --k) {
    const int j = model.lower_body(k);
    const size_t o = at(model.chain_offset(k));
    const double mass = a.subtree_mass[at(k)];
    const Vector3& h = a.h_b[at(k)];
    const Matrix3& Rk = kin.R[at(k)];
    const Matrix3 RjT =
        j == kGround ? Matrix3(Matrix3::Identity()) : Matrix3(kin.R[at(j)].transpose());
    // Diagonal block: sum m [v_G,y]_K^T [v_G,y]_K + inertia, with [v_G,y]_K = [-R_K^T [x~], R_J^T]
    // and x = r'_K for K itself, q'_D + s'_D for the bodies below child D.
    Matrix6& d = a.A_blocks[o];
    d.topRightCorner<3, 3>() = skew(h) * (Rk * RjT);
    d.bottomLeftCorner<3, 3>() = d.topRightCorner<3, 3>().transpose();
    d.bottomRightCorner<3, 3>() = mass * Matrix3::Identity();
    // S_K = sum over K's subtree of m [v_G,y]_K (3 x 6, inertial).
    Matrix36& s = a.composite[at(k)];
    s.leftCols<3>() = -Rk.transpose() * skew(h);
    s.rightCols<3>() = mass * RjT;
    // Block (K, I), I = L^r(K), c = L^{r-1}(K): S_K^T [v_G,y]_I with the partial blocks of
    // Eqs. (26)-(27) at I, [-R_I^T [(q'_c + s'_c)~], R_{L(I)}^T]:
    //   [ ([(q'_c + s'_c)~] R_I S_K)^T, (R_{L(I)} S_K)^T ].
    const Model::Chain chain = model.chain(k);
    const int u = chain.size - 1;
    Matrix36 t = u >= 1 ? Matrix36(kin.R[at(chain[1])] * s) : s;  // R_I S_K
    for (int r = 1; r <= u; ++r) {
      const Matrix36 t_next = r < u ? Matrix36(kin.R[at(chain[r + 1])] * s) : s;
      const Vector3& qs = kin.qs_b[at(chain[r - 1])];
      Matrix6& block = a.A_blocks[o + at(r)];
      for (int c = 0; c < 6; ++c) block.block<1, 3>(c, 0) = qs.cross(t.col(c)).transpose();
      block.rightCols<3>() = t_next.transpose();
      t = t_next;
    }
    if (j != kGround) {
      a.subtree_mass[at(j)] += mass;
      a.h_b[at(j)] += mass * kin.qs_b[at(k)];
      a.A_blocks[at(model.chain_offset(j))].topLeftCorner<3, 3>() +=
          mass * point_inertia(kin.qs_b[at(k)]);
    }
  }
}

void force_vector(const Model& model, const State& state, const Kinematics& kin, const Loads& loads,
                  detail::AssembledScratch& a, std::vector<Vector3>& load_sum, VectorX& f) {
  const int n = model.num_bodies();
  // [v_O_K,y dot]{y} (Eqs. 30 and 28), outwards: the acceleration of O_K at y dot = 0,
  // a_O_J + [R_J]^T(2 w'_J x s'_K dot + w'_J x (w'_J x (q'_K + s'_K))).
  for (int k = 0; k < n; ++k) {
    const int j = model.lower_body(k);
    if (j == kGround) {
      a.bias_O[at(k)].setZero();
      continue;
    }
    const Vector3 wj = state.angular_velocity(j);
    const Vector3 rel = eq::eigen(eq::transport_acceleration(
        eq::vec(wj), eq::vec(state.translation_rate(k)), eq::vec(kin.qs_b[at(k)])));
    a.bias_O[at(k)] = a.bias_O[at(j)] + kin.R[at(j)].transpose() * rel;
  }
  // Eq. (38): the loads less m [v_G,y dot]{y} (Eq. 29) and the gyroscopic moment.
  inward_pass(
      model, kin,
      [&](int k, Vector3& g, Vector3& m) {
        const BodySpec& b = model.body(k);
        const Vector3 w = state.angular_velocity(k);
        const Vector3 bias_g =
            a.bias_O[at(k)] + kin.R[at(k)].transpose() * eq::eigen(eq::centripetal_acceleration(
                                                             eq::vec(w), eq::vec(b.com)));
        g = loads.force[at(k)] - b.mass * bias_g;
        m = loads.moment_b[at(k)] - w.cross(b.inertia * w);
      },
      load_sum, f);
}

void generalized_forces(const Model& model, const Kinematics& kin, const Loads& loads,
                        std::vector<Vector3>& load_sum, VectorX& F_y) {
  inward_pass(
      model, kin,
      [&](int k, Vector3& g, Vector3& m) {
        g = loads.force[at(k)];
        m = loads.moment_b[at(k)];
      },
      load_sum, F_y);
}

void solve_in_place(const Model& model, detail::AssembledScratch& a, VectorX& b) {
  a.factor.compute(model, a.A_blocks);  // [A] is symmetric positive definite
  a.factor.solve_in_place(model, b);    // Eq. (36)
}

void to_dense(const Model& model, const std::vector<Matrix6>& blocks, MatrixX& A) {
  const int n = model.num_bodies();
  A.setZero(6 * n, 6 * n);
  const auto place = [&](int row_body, int col_body, const Matrix6& b) {
    for (int p = 0; p < 2; ++p)
      for (int q = 0; q < 2; ++q)
        A.block<3, 3>(3 * n * p + 3 * row_body, 3 * n * q + 3 * col_body) =
            b.block<3, 3>(3 * p, 3 * q);
  };
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    place(k, k, blocks[o]);
    for (int r = 1; r < chain.size; ++r) {
      place(k, chain[r], blocks[o + at(r)]);
      place(chain[r], k, blocks[o + at(r)].transpose());
    }
  }
}

}  // namespace assembled

void kane_equations(const Model& model, const State& state, Data& data) {
  if (!data.options().kane_terms)
    throw std::invalid_argument("kane_equations needs a Data made with DataOptions::kane_terms");
  detail::Workspace& w = workspace(data);
  compute_kinematics(model, state, data);
  if (data.options().partials) {
    compute_partials_recursive(model, state, data);
    compute_partial_rates(model, state, data);
  }
  compute_resultants(model, state, data);
  assembled::generalized_forces(model, data.kinematics, data.loads, w.load_sum, data.kane.F_y);
  assembled::mass_matrix(model, data.kinematics, w.assembled);
  assembled::force_vector(model, state, data.kinematics, data.loads, w.assembled, w.load_sum,
                          data.kane.f);
  data.ydot = data.kane.f;
  assembled::solve_in_place(model, w.assembled, data.ydot);
  if (data.options().dense_mass_matrix)
    assembled::to_dense(model, w.assembled.A_blocks, data.kane.A);
  compute_xdot(model, state, data.xdot);
}

void compute_generalized_forces(const Model& model, Data& data) {
  if (!data.options().kane_terms)
    throw std::invalid_argument(
        "compute_generalized_forces needs a Data made with DataOptions::kane_terms");
  assembled::generalized_forces(model, data.kinematics, data.loads, workspace(data).load_sum,
                                data.kane.F_y);
}

}  // namespace kanedyn
