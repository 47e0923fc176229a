// The block LDL^T of a matrix with the sparsity of a tree (src/tree_ldlt.hpp) and its pivot
// solver (src/spd.hpp): a known factor recovered, the solve against Eigen's dense Cholesky for
// made-up matrices and for [A] of Eq. (37), blocks of every joint size (0, 1, 2, 3, 6) and of
// 6 rows only against a dense factor, the report of a matrix that is not positive definite, and
// its memory.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <limits>
#include <random>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/kane.hpp"
#include "test_support.hpp"

#include "../src/spd.hpp"
#include "../src/tree_ldlt.hpp"
#include "../src/workspace.hpp"

namespace kanedyn {
namespace {

using detail::TreeLdlt;

double relative_difference(const VectorX& a, const VectorX& b) {
  return test::max_abs(a - b) / (1.0 + test::max_abs(b));
}

TEST(TreeLdlt, RecoversAKnownFactorAndSolvesLikeCholesky) {
  // Build A = L^T D L from random unit block-lower L with the tree's sparsity and random SPD
  // D blocks: the factorization must return exactly these L and D (to round-off, relative to
  // the condition of the blocks, 1e-9), and the solution must equal a dense Cholesky solve.
  std::mt19937 rng(5);
  for (const Model& model : test::models_of_every_size(rng)) {
    const int n = model.num_bodies();
    MatrixX l = MatrixX::Identity(6 * n, 6 * n), d = MatrixX::Zero(6 * n, 6 * n);
    // Body-blocked index of speed i of body k in the layout of Eq. (1).
    const auto idx = [n](int k, int i) { return i < 3 ? 3 * k + i : 3 * n + 3 * k + i - 3; };
    std::vector<Matrix6> l_blocks(static_cast<size_t>(model.chain_entries()));
    for (int k = 0; k < n; ++k) {
      const Model::Chain chain = model.chain(k);
      const auto o = static_cast<size_t>(model.chain_offset(k));
      const Matrix6 g = Matrix6::Random();
      const Matrix6 dk = g * g.transpose() + Matrix6::Identity();
      for (int r = 0; r < chain.size; ++r) {
        const Matrix6 block = r == 0 ? dk : Matrix6(0.5 * Matrix6::Random());
        l_blocks[o + static_cast<size_t>(r)] = block;
        for (int p = 0; p < 6; ++p)
          for (int q = 0; q < 6; ++q) (r == 0 ? d : l)(idx(k, p), idx(chain[r], q)) = block(p, q);
      }
    }
    const MatrixX a = l.transpose() * d * l;
    std::vector<Matrix6> a_blocks(static_cast<size_t>(model.chain_entries()));
    for (int k = 0; k < n; ++k) {
      const Model::Chain chain = model.chain(k);
      for (int r = 0; r < chain.size; ++r)
        for (int p = 0; p < 6; ++p)
          for (int q = 0; q < 6; ++q)
            a_blocks[static_cast<size_t>(model.chain_offset(k) + r)](p, q) =
                a(idx(k, p), idx(chain[r], q));
    }
    TreeLdlt ldlt(model);
    ldlt.compute(model, a_blocks);
    ASSERT_EQ(ldlt.info(), Eigen::Success);
    for (int k = 0; k < n; ++k)
      for (int r = 1; r < model.chain(k).size; ++r) {
        const auto e = static_cast<size_t>(model.chain_offset(k) + r);
        const Eigen::Map<const Matrix6> factor(ldlt.block(k, r));
        EXPECT_LT((factor - l_blocks[e]).cwiseAbs().maxCoeff(), 1e-9) << k << " " << r;
      }
    const VectorX b = VectorX::Random(6 * n);
    VectorX x = b;
    ldlt.solve_in_place(model, x);
    const VectorX expected = Eigen::LLT<MatrixX>(a).solve(b);
    EXPECT_LT((x - expected).norm(), 1e-9 * expected.norm()) << "N " << n;
    EXPECT_LT((a * x - b).norm(), 1e-12 * (test::max_abs(a) * x.norm() + b.norm())) << "N " << n;
  }
}

TEST(TreeLdlt, ReportsAnIndefiniteMatrix) {
  std::mt19937 rng(6);
  const Model model = test::random_loaded_model(rng, 4);
  std::vector<Matrix6> blocks(static_cast<size_t>(model.chain_entries()), Matrix6::Zero());
  for (int k = 0; k < 4; ++k)
    blocks[static_cast<size_t>(model.chain_offset(k))] = Matrix6::Identity();
  TreeLdlt ldlt(model);
  ldlt.compute(model, blocks);
  EXPECT_EQ(ldlt.info(), Eigen::Success);
  blocks[static_cast<size_t>(model.chain_offset(2))](4, 4) = -1.0;
  ldlt.compute(model, blocks);
  EXPECT_EQ(ldlt.info(), Eigen::NumericalIssue);
}

TEST(TreeLdlt, SolvesTheMassMatrixLikeDenseCholesky) {
  // [A] of Eq. (37) for random forests and chains, factored from the chain-layout blocks of
  // the assembled route, against Eigen's dense LLT of data.kane.A. Both solves are backward
  // stable; their difference is the condition of [A] (below ~1e5 for these models, see
  // SpeedRoutes.RecursiveAndKaneRoutesAgreeOnLargeTreesAndDeepChains) times 6N eps: 1e-10
  // relative. The residual of the tree solve alone is held to 4 * 6N eps (|A| |x| + |b|).
  std::mt19937 rng(14);
  for (const Model& model : test::models_of_every_size(rng)) {
    const State state = test::random_state(model, rng, 0.05, 2.0, 0.5);
    Data data(model);
    kane_equations(model, state, data);
    TreeLdlt ldlt(model);
    ldlt.compute(model, workspace(data).assembled.A_blocks);
    ASSERT_EQ(ldlt.info(), Eigen::Success);
    const Eigen::LLT<MatrixX> llt(data.kane.A);
    ASSERT_EQ(llt.info(), Eigen::Success);
    for (int trial = 0; trial < 3; ++trial) {
      const VectorX b = trial == 0 ? data.kane.f : VectorX(VectorX::Random(model.num_y()));
      VectorX x = b;
      ldlt.solve_in_place(model, x);
      const VectorX expected = llt.solve(b);
      EXPECT_LE((x - expected).norm(), 1e-10 * expected.norm()) << "N " << model.num_bodies();
      const double tol = 4.0 * model.num_y() * std::numeric_limits<double>::epsilon() *
                         (test::max_abs(data.kane.A) * test::max_abs(x) + test::max_abs(b));
      EXPECT_LT(test::max_abs(data.kane.A * x - b), tol) << "N " << model.num_bodies();
      // The same factor and solve as kane_equations' own (Eq. 36): the same bits.
      if (trial == 0) {
        EXPECT_EQ(x, data.ydot);
      }
    }
  }
}

TEST(TreeLdlt, InfoReportsAnIndefiniteMatrixWithDefiniteDiagonalBlocks) {
  // A two-body chain with A = [[I, 2I], [2I, I]]: both diagonal blocks are positive definite
  // but A is not (eigenvalues 3 and -1); the Schur complement I - 4I of the elimination of
  // the leaf is the pivot that fails. Factoring a definite matrix afterwards reports success
  // again: info() describes the last compute().
  std::vector<BodySpec> bodies(2);
  for (int k = 0; k < 2; ++k) {
    bodies[static_cast<size_t>(k)].name = test::numbered_name("b", k + 1);
    bodies[static_cast<size_t>(k)].lower_body = k - 1;
    bodies[static_cast<size_t>(k)].mass = 1.0;
    bodies[static_cast<size_t>(k)].inertia = Matrix3::Identity();
  }
  const Model model(std::move(bodies));
  ASSERT_EQ(model.chain_entries(), 3);
  std::vector<Matrix6> blocks(3, Matrix6::Identity());
  blocks[static_cast<size_t>(model.chain_offset(1) + 1)] = 2.0 * Matrix6::Identity();  // (2, 1)
  TreeLdlt ldlt(model);
  ldlt.compute(model, blocks);
  EXPECT_EQ(ldlt.info(), Eigen::NumericalIssue);
  blocks[static_cast<size_t>(model.chain_offset(1) + 1)] = 0.5 * Matrix6::Identity();
  ldlt.compute(model, blocks);
  EXPECT_EQ(ldlt.info(), Eigen::Success);
  // ...and the solve is right: A = [[I, I/2], [I/2, I]] has inverse 4/3 [[I, -I/2], [-I/2, I]].
  VectorX x = VectorX::Ones(12);
  ldlt.solve_in_place(model, x);
  EXPECT_LT((x - VectorX::Constant(12, 2.0 / 3.0)).cwiseAbs().maxCoeff(), 1e-15);
}

// The variable-block tree LDL^T on matrices with a tree's sparsity: A = L^T D L built from a
// random unit block lower triangular L with blocks only at (node, node on its chain) and SPD
// diagonal blocks D, so A has exactly that sparsity; node sizes 0..6 mixed, and all 1 (the
// scalar rows' path). The solve must equal the dense LDL^T's: both are backward stable on
// these well-conditioned matrices (cond ~1e3), 1e-10 relative.
TEST(TreeLdlt, VariableBlocksSolveLikeTheDenseFactor) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 30; ++trial) {
    const int n = test::uniform_int(rng, 1, 25);
    const bool scalar = trial % 3 == 0, chain = trial % 2 == 0;
    std::vector<int> sizes, lower, offset{0};
    constexpr int kSizes[] = {0, 1, 2, 3, 6};
    for (int k = 0; k < n; ++k) {
      sizes.push_back(scalar ? 1 : kSizes[test::uniform_int(rng, 0, 4)]);
      lower.push_back(k == 0 ? -1 : (chain ? k - 1 : test::uniform_int(rng, -1, k - 1)));
      offset.push_back(offset.back() + sizes.back());
    }
    const int total = offset.back();
    if (total == 0) continue;
    auto on_chain = [&](int a, int k) {  // a is k or one of its ancestors
      for (int c = k; c >= 0; c = lower[static_cast<size_t>(c)])
        if (c == a) return true;
      return false;
    };
    MatrixX L = MatrixX::Identity(total, total), D = MatrixX::Zero(total, total);
    for (int k = 0; k < n; ++k) {
      const int mk = sizes[static_cast<size_t>(k)], ok = offset[static_cast<size_t>(k)];
      if (mk == 0) continue;
      const MatrixX r = MatrixX::Random(mk, mk);
      D.block(ok, ok, mk, mk) = r * r.transpose() + MatrixX::Identity(mk, mk);
      for (int a = 0; a < k; ++a)
        if (on_chain(a, k) && sizes[static_cast<size_t>(a)] > 0)
          L.block(ok, offset[static_cast<size_t>(a)], mk, sizes[static_cast<size_t>(a)]) =
              0.3 * MatrixX::Random(mk, sizes[static_cast<size_t>(a)]);
    }
    const MatrixX A = L.transpose() * D * L;
    TreeLdlt f(sizes, lower);
    for (int k = 0; k < n; ++k)
      for (int r = 0; r < f.row_length(k); ++r) {
        const int a = f.row_node(k, r);
        Eigen::Map<MatrixX>(f.block(k, r), f.size(k), f.size(a)) =
            A.block(f.offset(k), f.offset(a), f.size(k), f.size(a));
      }
    ASSERT_TRUE(f.compute());
    const VectorX b = VectorX::Random(total);
    VectorX x = b;
    f.solve_in_place(x);
    const VectorX expected = A.ldlt().solve(b);
    EXPECT_LT(relative_difference(x, expected), 1e-10) << "trial " << trial;
    EXPECT_LT(test::max_abs(A * x - b), 1e-10 * (1.0 + test::max_abs(b)));
  }
}

// Nodes of 6 rows only (every pair takes the fixed-size products) and 6 mixed with 1 and 0
// (pairs of 6 with other sizes take the loops), against the dense LDL^T as above; and the
// constructor from a Model (the assembled route's) gives the same bits as the one from sizes.
TEST(TreeLdlt, SixRowNodesSolveLikeTheDenseFactorAndAsTheModelsFactor) {
  std::mt19937 rng(12);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = test::uniform_int(rng, 1, 12);
    const bool mixed = trial % 2 == 1;
    std::vector<int> sizes, lower, offset{0};
    for (int k = 0; k < n; ++k) {
      const int pick = test::uniform_int(rng, 0, 3);
      sizes.push_back(mixed && pick < 2 ? pick : 6);
      lower.push_back(k == 0 ? -1 : test::uniform_int(rng, -1, k - 1));
      offset.push_back(offset.back() + sizes.back());
    }
    const int total = offset.back();
    if (total == 0) continue;
    MatrixX L = MatrixX::Identity(total, total), D = MatrixX::Zero(total, total);
    for (int k = 0; k < n; ++k) {
      const int mk = sizes[static_cast<size_t>(k)], ok = offset[static_cast<size_t>(k)];
      if (mk == 0) continue;
      const MatrixX r = MatrixX::Random(mk, mk);
      D.block(ok, ok, mk, mk) = r * r.transpose() + MatrixX::Identity(mk, mk);
      for (int a = lower[static_cast<size_t>(k)]; a >= 0; a = lower[static_cast<size_t>(a)])
        if (sizes[static_cast<size_t>(a)] > 0)
          L.block(ok, offset[static_cast<size_t>(a)], mk, sizes[static_cast<size_t>(a)]) =
              0.3 * MatrixX::Random(mk, sizes[static_cast<size_t>(a)]);
    }
    const MatrixX A = L.transpose() * D * L;
    TreeLdlt f(sizes, lower);
    for (int k = 0; k < n; ++k)
      for (int r = 0; r < f.row_length(k); ++r) {
        const int a = f.row_node(k, r);
        Eigen::Map<MatrixX>(f.block(k, r), f.size(k), f.size(a)) =
            A.block(f.offset(k), f.offset(a), f.size(k), f.size(a));
      }
    ASSERT_TRUE(f.compute());
    const VectorX b = VectorX::Random(total);
    VectorX x = b;
    f.solve_in_place(x);
    EXPECT_LT(relative_difference(x, A.ldlt().solve(b)), 1e-10) << "trial " << trial;
    EXPECT_LT(test::max_abs(A * x - b), 1e-10 * (1.0 + test::max_abs(b)));
    if (mixed) continue;
    // The same tree as a Model of N free bodies: its blocks in chain layout, its right side in
    // the layout of Eq. (1).
    std::vector<BodySpec> bodies(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      bodies[static_cast<size_t>(k)].name = test::numbered_name("b", k + 1);
      bodies[static_cast<size_t>(k)].lower_body = lower[static_cast<size_t>(k)];
      bodies[static_cast<size_t>(k)].mass = 1.0;
      bodies[static_cast<size_t>(k)].inertia = Matrix3::Identity();
    }
    const Model model(std::move(bodies));
    std::vector<Matrix6> blocks(static_cast<size_t>(model.chain_entries()));
    TreeLdlt g(sizes, lower);
    for (int k = 0; k < n; ++k)
      for (int r = 0; r < g.row_length(k); ++r) {
        const int a = g.row_node(k, r);
        ASSERT_EQ(a, model.chain(k)[r]);
        blocks[static_cast<size_t>(model.chain_offset(k) + r)] =
            A.block(g.offset(k), g.offset(a), 6, 6);
      }
    TreeLdlt by_model(model);
    by_model.compute(model, blocks);
    ASSERT_EQ(by_model.info(), Eigen::Success);
    VectorX y(total);
    for (int k = 0; k < n; ++k) {
      y.segment<3>(3 * k) = b.segment<3>(6 * k);
      y.segment<3>(3 * n + 3 * k) = b.segment<3>(6 * k + 3);
    }
    by_model.solve_in_place(model, y);
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(y.segment<3>(3 * k), x.segment<3>(6 * k)) << "trial " << trial;
      EXPECT_EQ(y.segment<3>(3 * n + 3 * k), x.segment<3>(6 * k + 3)) << "trial " << trial;
    }
  }
}

// The pivot solver of the LDL^T and of the articulated-body recursion: the inverse of an SPD
// matrix of 1, 2, 3 and 6 rows against Eigen's LU inverse (1e-12 relative on these
// well-conditioned matrices, cond < 1e3), both entry points the same bits, and false for a
// symmetric matrix that is not positive definite.
template <int M>
void check_invert_spd(std::mt19937& rng) {
  using Mat = Eigen::Matrix<double, M, M>;
  for (int trial = 0; trial < 20; ++trial) {
    Mat g;
    for (int i = 0; i < M * M; ++i) g.data()[i] = test::uniform(rng, -1.0, 1.0);
    const Mat a = g * g.transpose() + Mat::Identity();
    Mat inv = a;
    ASSERT_TRUE(detail::invert_spd<M>(inv));
    const Mat expected = a.inverse();
    EXPECT_LT((inv - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
    Mat by_pointer = a;
    ASSERT_TRUE(detail::invert_spd(by_pointer.data(), M));
    EXPECT_EQ(by_pointer, inv);
    Mat indefinite = a;
    indefinite(M - 1, M - 1) = -a(M - 1, M - 1);
    EXPECT_FALSE(detail::invert_spd<M>(indefinite)) << "M " << M;
  }
}

TEST(TreeLdlt, InvertsSmallSpdMatrices) {
  std::mt19937 rng(13);
  check_invert_spd<1>(rng);
  check_invert_spd<2>(rng);
  check_invert_spd<3>(rng);
  check_invert_spd<6>(rng);
}

TEST(TreeLdlt, MemoryBytesCountTheFactor) {
  // The factor holds one 6x6 block per chain entry: at least that many bytes, and none for a
  // TreeLdlt without a model.
  std::mt19937 rng(15);
  for (const Model& model : test::models_of_every_size(rng)) {
    const TreeLdlt ldlt(model);
    EXPECT_GT(ldlt.memory_bytes(), 0u);
    EXPECT_GE(ldlt.memory_bytes(), static_cast<size_t>(model.chain_entries()) * sizeof(Matrix6));
  }
  EXPECT_EQ(TreeLdlt().memory_bytes(), 0u);
}

}  // namespace
}  // namespace kanedyn
