// SemidefiniteLdlt (solvers/semidefinite_ldlt.h): the warm-basis solve of a singular contact
// block. The test matrices are A = Gᵀ W G of a stack of boxes, each resting on the one below at
// its four bottom corners (rank 3 per face: exactly singular, as the contact step's M_BB).
#include "vinci/sim/solvers/semidefinite_ldlt.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/warm_basis.h"

namespace vinci::sim {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// Round-off bound of the solves below, relative to ‖b‖ (the matrices are well scaled).
constexpr double kSolveTol = 1e-10;

// Gᵀ W G for k stacked 0.2 m cubes (body i on body i − 1, body −1 the ground), four corner
// contacts per face with normal +z, W a random symmetric positive definite 6 × 6 block per body;
// contact order permuted by `order` (order[c] = the position of contact c). `pattern` gets the
// structural pattern: entries where two contacts share a body.
MatrixXd StackMatrix(int k, const std::vector<int>& order, std::mt19937* rng,
                     Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic>* pattern) {
  const int n = 4 * k;
  MatrixXd G = MatrixXd::Zero(6 * k, n);
  const double corners[4][2] = {{-0.1, -0.1}, {0.1, -0.1}, {0.1, 0.1}, {-0.1, 0.1}};
  const Eigen::Vector3d normal(0, 0, 1);
  for (int i = 0; i < k; ++i)
    for (int c = 0; c < 4; ++c) {
      const int col = order[4 * i + c];
      const Eigen::Vector3d above(corners[c][0], corners[c][1], -0.1);  // from body i's centre
      G.block<3, 1>(6 * i, col) = normal;
      G.block<3, 1>(6 * i + 3, col) = above.cross(normal);
      if (i > 0) {
        const Eigen::Vector3d below(corners[c][0], corners[c][1], 0.1);  // from body i − 1's
        G.block<3, 1>(6 * (i - 1), col) = -normal;
        G.block<3, 1>(6 * (i - 1) + 3, col) = -below.cross(normal);
      }
    }
  std::normal_distribution<double> g;
  MatrixXd W = MatrixXd::Zero(6 * k, 6 * k);
  for (int i = 0; i < k; ++i) {
    MatrixXd R(6, 6);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) R(r, c) = 0.3 * g(*rng);
    W.block(6 * i, 6 * i, 6, 6) = R.transpose() * R + MatrixXd::Identity(6, 6);
  }
  pattern->setConstant(n, n, false);
  for (int i = 0; i < k; ++i)
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        if (G.block(6 * i, a, 6, 1).any() && G.block(6 * i, b, 6, 1).any()) (*pattern)(a, b) = true;
  MatrixXd A = G.transpose() * W * G;
  // Exactly symmetric, as the contact operator's blocks are.
  return 0.5 * (A + A.transpose());
}

std::vector<int> Identity(int n) {
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  return order;
}

CompressedColumns Compress(const MatrixXd& A,
                           const Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic>& pattern) {
  CompressedColumns out;
  const int n = static_cast<int>(A.rows());
  out.Reset(n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i)
      if (pattern(i, j)) {
        out.row.push_back(i);
        out.value.push_back(A(i, j));
      }
    out.col_start[j + 1] = static_cast<int>(out.row.size());
  }
  return out;
}

// A stack of k boxes is singular with rank 3k: one of each face's four corners is dropped, it
// gets x = 0, and A x = b holds for b in A's range.
TEST(SemidefiniteLdltTest, StackBlockRankAndBasicSolution) {
  std::mt19937 rng(3);
  for (int k : {1, 5, 20}) {
    Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic> pattern;
    const MatrixXd A = StackMatrix(k, Identity(4 * k), &rng, &pattern);
    SemidefiniteLdlt ldlt;
    ASSERT_TRUE(ldlt.Factorize(Compress(A, pattern), 1e-10));
    EXPECT_EQ(ldlt.rank(), 3 * k);
    const VectorXd y = VectorXd::Random(4 * k);
    const VectorXd b = A * y;
    VectorXd x;
    ldlt.Solve(b, &x);
    EXPECT_LE((A * x - b).norm(), kSolveTol * b.norm()) << "k = " << k;
    int dropped = 0;
    for (int i = 0; i < 4 * k; ++i)
      if (ldlt.dropped(i)) {
        ++dropped;
        EXPECT_EQ(x[i], 0.0);
      }
    EXPECT_EQ(dropped, k);
    // One corner per face: the other three are independent.
    for (int i = 0; i < k; ++i) {
      int face = 0;
      for (int c = 0; c < 4; ++c) face += ldlt.dropped(4 * i + c) ? 1 : 0;
      EXPECT_EQ(face, 1) << "face " << i;
    }
  }
}

// Nonsingular: the same solution as a dense LDLᵀ, nothing dropped.
TEST(SemidefiniteLdltTest, NonsingularMatchesDenseLdlt) {
  std::mt19937 rng(5);
  Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic> pattern;
  const int k = 8;
  const MatrixXd A =
      StackMatrix(k, Identity(4 * k), &rng, &pattern) + 0.01 * MatrixXd::Identity(4 * k, 4 * k);
  SemidefiniteLdlt ldlt;
  ASSERT_TRUE(ldlt.Factorize(Compress(A, pattern), 1e-10));
  EXPECT_EQ(ldlt.rank(), 4 * k);
  const VectorXd b = VectorXd::Random(4 * k);
  VectorXd x;
  ldlt.Solve(b, &x);
  const VectorXd x_dense = A.ldlt().solve(b);
  EXPECT_LE((x - x_dense).norm(), kSolveTol * x_dense.norm());
}

// The contacts in a random order: the ordering recovers the stack's chain, so L's fill is
// linear in k (the natural order of a shuffled chain would fill most of the triangle).
TEST(SemidefiniteLdltTest, FillLinearInStackHeight) {
  std::mt19937 rng(11);
  for (int k : {10, 40}) {
    std::vector<int> order = Identity(4 * k);
    std::shuffle(order.begin(), order.end(), rng);
    Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic> pattern;
    const MatrixXd A = StackMatrix(k, order, &rng, &pattern);
    SemidefiniteLdlt ldlt;
    ASSERT_TRUE(ldlt.Factorize(Compress(A, pattern), 1e-10));
    EXPECT_EQ(ldlt.rank(), 3 * k);
    // A block-tridiagonal chain of 4 × 4 blocks: at most 7 entries below the diagonal per
    // column in the band order.
    EXPECT_LE(ldlt.nonzeros_l(), 7 * 4 * k) << "k = " << k;
    const VectorXd b = A * VectorXd::Random(4 * k);
    VectorXd x;
    ldlt.Solve(b, &x);
    EXPECT_LE((A * x - b).norm(), kSolveTol * b.norm());
  }
}

// The symbolic analysis kept for a new matrix of the same pattern gives the bits of a fresh
// factorization; a different pattern in between is analysed anew.
TEST(SemidefiniteLdltTest, KeptAnalysisGivesFreshBits) {
  std::mt19937 rng(13);
  std::vector<int> order = Identity(4 * 12);
  std::shuffle(order.begin(), order.end(), rng);
  Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic> pattern, other_pattern;
  const MatrixXd A1 = StackMatrix(12, order, &rng, &pattern);
  const MatrixXd A2 = StackMatrix(12, order, &rng, &pattern);  // same pattern, new W
  const MatrixXd A3 = StackMatrix(7, Identity(28), &rng, &other_pattern);
  const VectorXd b = A2 * VectorXd::Random(48);

  SemidefiniteLdlt fresh;
  ASSERT_TRUE(fresh.Factorize(Compress(A2, pattern), 1e-10));
  EXPECT_FALSE(fresh.reused_analysis());
  VectorXd x_fresh;
  fresh.Solve(b, &x_fresh);

  SemidefiniteLdlt kept;
  ASSERT_TRUE(kept.Factorize(Compress(A1, pattern), 1e-10));
  ASSERT_TRUE(kept.Factorize(Compress(A2, pattern), 1e-10));
  EXPECT_TRUE(kept.reused_analysis());
  VectorXd x_kept;
  kept.Solve(b, &x_kept);
  EXPECT_EQ(x_kept, x_fresh);  // bit for bit
  EXPECT_EQ(kept.rank(), fresh.rank());

  ASSERT_TRUE(kept.Factorize(Compress(A3, other_pattern), 1e-10));
  EXPECT_FALSE(kept.reused_analysis());
  EXPECT_EQ(kept.rank(), 21);
  ASSERT_TRUE(kept.Factorize(Compress(A2, pattern), 1e-10));
  EXPECT_FALSE(kept.reused_analysis());
  kept.Solve(b, &x_kept);
  EXPECT_EQ(x_kept, x_fresh);
  EXPECT_LE((A2 * x_kept - b).norm(), kSolveTol * b.norm());
}

// Indefinite or non-finite matrices are refused; a zero matrix has rank 0 and x = 0.
TEST(SemidefiniteLdltTest, RefusesIndefiniteAndNonFinite) {
  const Eigen::Matrix<bool, 2, 2> full = Eigen::Matrix<bool, 2, 2>::Constant(true);
  SemidefiniteLdlt ldlt;
  MatrixXd A(2, 2);
  A << 1.0, 2.0, 2.0, 1.0;  // eigenvalues 3, −1
  EXPECT_FALSE(ldlt.Factorize(Compress(A, full), 1e-10));
  A << -1.0, 0.0, 0.0, 1.0;
  EXPECT_FALSE(ldlt.Factorize(Compress(A, full), 1e-10));
  A << 1.0, std::nan(""), std::nan(""), 1.0;
  EXPECT_FALSE(ldlt.Factorize(Compress(A, full), 1e-10));
  A.setZero();
  ASSERT_TRUE(ldlt.Factorize(Compress(A, full), 1e-10));
  EXPECT_EQ(ldlt.rank(), 0);
  VectorXd x;
  ldlt.Solve(VectorXd::Ones(2), &x);
  EXPECT_EQ(x, VectorXd::Zero(2));
}

TEST(SemidefiniteLdltTest, SymmetryCheckSeesValuesAndPattern) {
  std::mt19937 rng(17);
  Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic> pattern;
  const MatrixXd A = StackMatrix(6, Identity(24), &rng, &pattern);
  std::vector<int> cursor;
  CompressedColumns c = Compress(A, pattern);
  EXPECT_TRUE(c.IsSymmetric(&cursor));
  MatrixXd B = A;
  B(0, 5) += 1e-15;
  EXPECT_FALSE(Compress(B, pattern).IsSymmetric(&cursor));
  auto lopsided = pattern;
  lopsided(0, 20) = true;  // (0, 20) stored, (20, 0) not
  EXPECT_FALSE(Compress(A, lopsided).IsSymmetric(&cursor));
  // Multiply is A x.
  const VectorXd x = VectorXd::Random(24);
  VectorXd y;
  c.Multiply(x, &y);
  EXPECT_LE((y - A * x).norm(), 1e-14 * (A * x).norm());
}

// The LCP of a 20-box stack's normal impulses (M = Gᵀ W G, singular), with 72 of its 80
// contacts loaded (z* > 0, w* = 0) and 8 separating (z* = 0, w* > 0; one corner of 8 faces),
// from a guess off z* by up to 5 % in
// every loaded component: SolveOnWarmBasis takes the sparse LDLᵀ branch (72 > kDenseWarmBasisMax),
// returns a solution (M z + q = w* up to round-off: z − z* in M's null space), and gives the
// same bits with a scratch that solved another problem of the same pattern before (its analysis
// kept) as with a fresh scratch.
TEST(SemidefiniteLdltTest, WarmBasisSolvesSingularStackLcpWithKeptAnalysis) {
  std::mt19937 rng(19);
  const int k = 20, n = 4 * k;
  std::uniform_real_distribution<double> u(0.5, 1.5);
  VectorXd z_star(n), w_star = VectorXd::Zero(n), guess(n);
  for (int i = 0; i < n; ++i) {
    const bool loaded = i % 10 != 3;
    z_star[i] = loaded ? u(rng) : 0.0;
    if (!loaded) w_star[i] = u(rng);
    guess[i] = loaded ? z_star[i] * (1.0 + 0.1 * (u(rng) - 1.0)) : 0.0;
  }
  ASSERT_GT((z_star.array() > 0.0).count(), kDenseWarmBasisMax);
  auto lcp = [&](const MatrixXd& A,
                 const Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic>& pattern,
                 Eigen::SparseMatrix<double>* M) {
    std::vector<Eigen::Triplet<double>> entries;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if (pattern(i, j)) entries.emplace_back(i, j, A(i, j));
    M->resize(n, n);
    M->setFromTriplets(entries.begin(), entries.end());
    return VectorXd(w_star - A * z_star);
  };
  Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic> pattern;
  const MatrixXd A1 = StackMatrix(k, Identity(n), &rng, &pattern);
  const MatrixXd A2 = StackMatrix(k, Identity(n), &rng, &pattern);
  Eigen::SparseMatrix<double> M1, M2;
  const VectorXd q1 = lcp(A1, pattern, &M1), q2 = lcp(A2, pattern, &M2);
  const LemkeOptions options;

  WarmBasisScratch fresh, kept;
  VectorXd z_fresh, z_kept, z_other;
  SolverReport report;
  ASSERT_TRUE(SolveOnWarmBasis(SparseLcpMatrix(M2), q2, guess, options, &fresh, &z_fresh, &report));
  EXPECT_FALSE(fresh.ldlt.reused_analysis());
  EXPECT_EQ(fresh.ldlt.rank(), 3 * k);  // three corners of a face are independent
  ASSERT_TRUE(SolveOnWarmBasis(SparseLcpMatrix(M1), q1, guess, options, &kept, &z_other, &report));
  ASSERT_TRUE(SolveOnWarmBasis(SparseLcpMatrix(M2), q2, guess, options, &kept, &z_kept, &report));
  EXPECT_TRUE(kept.ldlt.reused_analysis());
  EXPECT_EQ(z_kept, z_fresh);  // bit for bit

  const VectorXd w = A2 * z_fresh + q2;
  EXPECT_LE((w - w_star).lpNorm<Eigen::Infinity>(), kSolveTol * A2.norm() * z_star.norm());
  EXPECT_LE(report.residual, report.tolerance);
  EXPECT_GE(z_fresh.minCoeff(), 0.0);
  // z differs from z* only in M's null space (the unloaded corners' split), and the dropped
  // (dependent) unknowns kept their guess.
  int kept_guess = 0;
  for (int i = 0; i < n; ++i) kept_guess += z_fresh[i] == guess[i] && guess[i] > 0.0 ? 1 : 0;
  EXPECT_EQ(kept_guess, k - 8);  // one per face with four loaded corners
}

}  // namespace
}  // namespace vinci::sim
