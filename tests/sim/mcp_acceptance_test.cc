// MCP solves pass the same scale-aware acceptance test as LCP solves (issue 18, deliverable 4):
// McpScaledResidual and McpSolver's use of it.
#include <gtest/gtest.h>

#include <Eigen/SparseCore>
#include <cmath>
#include <limits>
#include <random>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_acceptance.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// F(z) = M z + q on [l, u]; `sparse`: also the sparse Jacobian.
McpProblem Affine(const MatrixXd& M, const VectorXd& q, const VectorXd& l, const VectorXd& u,
                  bool sparse) {
  McpProblem p;
  p.lower = l;
  p.upper = u;
  p.evaluate = [M, q](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    *F = M * z + q;
    if (J != nullptr) *J = M;
  };
  if (sparse) {
    const Eigen::SparseMatrix<double> Ms = M.sparseView();
    p.sparse_jacobian = [Ms](const VectorXd&, Eigen::SparseMatrix<double>* J) { *J = Ms; };
  }
  return p;
}

// F(z) = s (z − 1) on z ≥ 0 with s = 1e-12: the solution is z = 1 (F = 0). At z = 0, F = −s < 0
// violates the problem by its whole size, but the natural residual |min(z, F)| = 1e-12 passes
// the solver's absolute tolerance 1e-10: before the acceptance test the solver reported z = 0
// as solved, in 0 iterations.
McpProblem SmallUnits(bool sparse) {
  return Affine(1e-12 * MatrixXd::Identity(1, 1), VectorXd::Constant(1, -1e-12), VectorXd::Zero(1),
                VectorXd::Constant(1, kInf), sparse);
}

TEST(McpAcceptanceTest, ScaledResidualSeesASmallUnitsViolation) {
  for (bool sparse : {false, true}) {
    const McpProblem p = SmallUnits(sparse);
    EXPECT_LE(McpResidual(p, VectorXd::Zero(1)), McpOptions().tolerance);
    EXPECT_DOUBLE_EQ(McpScaledResidual(p, VectorXd::Zero(1)), 1.0);
    EXPECT_EQ(McpScaledResidual(p, VectorXd::Ones(1)), 0.0);
  }
}

TEST(McpAcceptanceTest, SolverDoesNotReportTheBogusPointAsSolved) {
  for (bool sparse : {false, true}) {
    SCOPED_TRACE(sparse ? "sparse" : "dense");
    McpOptions options;
    options.sparse = sparse;
    // With a budget it iterates on to the solution.
    VectorXd z = VectorXd::Zero(1);
    SolverReport r = McpSolver(options).Solve(SmallUnits(sparse), &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_NEAR(z(0), 1.0, 1e-6);
    EXPECT_LE(McpScaledResidual(SmallUnits(sparse), z), kLcpAcceptanceTolerance);
    // Without one, z = 0 passes the absolute test only: not solved, and the message says why.
    options.max_iterations = 0;
    z = VectorXd::Zero(1);
    r = McpSolver(options).Solve(SmallUnits(sparse), &z);
    EXPECT_FALSE(r.ok());
    EXPECT_NE(r.message.find("scale-aware"), std::string::npos) << r.message;
  }
}

// An upper-bounded row in small units: z ∈ [0, 2], F = 1e-12 (z − 3) < 0 on the box, so the
// solution sits at the upper bound z = 2. At z = 1.99, |z − mid(0, 2, z − F)| = 1e-12 · 1.01
// passes the absolute tolerance; the scaled residual does not.
TEST(McpAcceptanceTest, UpperBoundRowsAreJudgedAtTheirScale) {
  const McpProblem p = Affine(1e-12 * MatrixXd::Identity(1, 1), VectorXd::Constant(1, -3e-12),
                              VectorXd::Zero(1), VectorXd::Constant(1, 2.0), false);
  EXPECT_LE(McpResidual(p, VectorXd::Constant(1, 1.99)), McpOptions().tolerance);
  EXPECT_GT(McpScaledResidual(p, VectorXd::Constant(1, 1.99)), 1e-3);  // 0.01 / s_z, s_z = 3
  EXPECT_EQ(McpScaledResidual(p, VectorXd::Constant(1, 2.0)), 0.0);
  VectorXd z = VectorXd::Constant(1, 1.99);
  const SolverReport r = McpSolver().Solve(p, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(z(0), 2.0, 1e-9);
}

// On an LCP written as an MCP (F = Mz + q, l = 0, u = ∞) the two measures agree.
TEST(McpAcceptanceTest, AgreesWithTheLcpMeasure) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 5;
  for (int trial = 0; trial < 20; ++trial) {
    LcpProblem lcp;
    lcp.M = MatrixXd::NullaryExpr(n, n, [&] { return u(rng); });
    lcp.q = VectorXd::NullaryExpr(n, [&] { return u(rng); });
    const VectorXd z = VectorXd::NullaryExpr(n, [&] { return u(rng); });
    const double r = LcpScaledResidual(lcp, z);
    const McpProblem p =
        Affine(lcp.M, lcp.q, VectorXd::Zero(n), VectorXd::Constant(n, kInf), trial % 2 == 0);
    EXPECT_NEAR(McpScaledResidual(p, z), r, 1e-12 * (1.0 + r));
  }
}

}  // namespace
}  // namespace vinci::sim
