// The step derivative's linear algebra (sim/src/simulator/sensitivity_internal.h): the
// complete-pivoting LU against Eigen's FullPivLU (rank at the same threshold, solutions, null
// space), and StructuredSolver's minimum-norm solution of a singular core against the complete
// orthogonal decomposition's.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <Eigen/QR>
#include <random>

#include "../../sim/src/simulator/sensitivity_internal.h"

namespace vinci::sim::internal {
namespace {

MatrixXd Random(int rows, int cols, std::mt19937* rng) {
  std::normal_distribution<double> normal;
  MatrixXd m(rows, cols);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) m(i, j) = normal(*rng);
  return m;
}

// A random n × n matrix of rank r (a product of n × r and r × n factors), with some entries of
// a sparse pattern zeroed only where r = n (a product has none).
MatrixXd RandomOfRank(int n, int r, std::mt19937* rng) {
  if (r == n) {
    MatrixXd m = Random(n, n, rng) + 4.0 * MatrixXd::Identity(n, n);
    std::uniform_int_distribution<int> keep(0, 2);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if (i != j && keep(*rng) == 0) m(i, j) = 0.0;
    return m;
  }
  return Random(n, r, rng) * Random(r, n, rng);
}

TEST(CompletePivotLuTest, RankSolutionAndKernelAsFullPivLu) {
  std::mt19937 rng(7);
  for (int n = 1; n <= 30; n += 3) {
    for (int r : {n, n - 1, n / 2, 0}) {
      if (r < 0) continue;
      const MatrixXd A = r == 0 ? MatrixXd::Zero(n, n) : RandomOfRank(n, r, &rng);
      CompletePivotLu lu;
      lu.Compute(A, 1e-10);
      Eigen::FullPivLU<MatrixXd> ref;
      ref.setThreshold(1e-10);
      ref.compute(A);
      ASSERT_EQ(lu.rank(), ref.rank()) << "n " << n << " r " << r;
      EXPECT_EQ(lu.rank(), r) << "n " << n;
      EXPECT_EQ(lu.invertible(), r == n);
      // A consistent right side: solved to round-off.
      const VectorXd b = A * Random(n, 1, &rng);
      VectorXd x;
      lu.Solve(b, &x);
      const double scale = A.cwiseAbs().maxCoeff() * std::max(1.0, x.cwiseAbs().maxCoeff()) + 1.0;
      EXPECT_LE((A * x - b).cwiseAbs().maxCoeff(), 1e-11 * scale) << "n " << n << " r " << r;
      if (r == n) {
        const VectorXd y = ref.solve(b);
        EXPECT_LE((x - y).cwiseAbs().maxCoeff(), 1e-10 * (1.0 + y.cwiseAbs().maxCoeff()));
      }
      // The kernel: n − r independent columns that A maps to round-off.
      MatrixXd N;
      lu.Kernel(&N);
      ASSERT_EQ(N.cols(), n - r);
      if (N.cols() > 0) {
        EXPECT_LE((A * N).cwiseAbs().maxCoeff(),
                  1e-10 * (1.0 + A.cwiseAbs().maxCoeff()) * N.cwiseAbs().maxCoeff());
        Eigen::FullPivLU<MatrixXd> kernel_rank(N);
        EXPECT_EQ(kernel_rank.rank(), n - r);
      }
    }
  }
}

// A dense matrix (no singleton row or column) is all core: a singular one's solution is the
// minimum-norm one, as the complete orthogonal decomposition gives it.
TEST(StructuredSolverTest, SingularCoreTakesTheMinimumNormSolution) {
  std::mt19937 rng(11);
  for (int n : {4, 9, 22}) {
    for (int r : {n - 1, n - 3}) {
      const MatrixXd A = RandomOfRank(n, r, &rng);
      SparseRows K;
      K.FromDense(A);
      StructuredSolver solver;
      solver.Compute(K);
      ASSERT_TRUE(solver.singular()) << "n " << n << " r " << r;
      ASSERT_EQ(solver.core_size(), n);
      const VectorXd b = A * Random(n, 1, &rng);
      const VectorXd x = solver.Solve(b);
      Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(A);
      const VectorXd y = cod.solve(b);
      EXPECT_LE((A * x - b).cwiseAbs().maxCoeff(), 1e-10 * (1.0 + b.cwiseAbs().maxCoeff()));
      EXPECT_LE((x - y).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + y.cwiseAbs().maxCoeff()))
          << "n " << n << " r " << r;
      const MatrixXd N = solver.NullSpace();
      EXPECT_EQ(N.cols(), n - r);
    }
  }
}

}  // namespace
}  // namespace vinci::sim::internal
