// Tests of the semismooth Newton MCP solver: the classic nonlinear test problems (Josephy,
// Kojima–Shindo), the published box-constrained 4×4 example, a convex QP's KKT system,
// agreement with Lemke on P-matrix LCPs (dense and sparse), Jacobians against finite
// differences, warm start, restarts and fallbacks, failures and misuse. Every solution is
// checked independently of the solver: McpResidual and the complementarity conditions row by
// row, and against the known solution where there is one.
#include "vinci/sim/solvers/mcp.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/types.h"

namespace vinci::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// The solver's default stopping tolerance on the natural residual.
constexpr double kTol = 1e-10;
// Row-wise complementarity checks: 10× the stopping tolerance for round-off in re-evaluating F.
constexpr double kComplementarityTol = 1e-9;
// Distance to a known solution: every known solution below is locally unique with a
// well-conditioned active-set Jacobian, so a natural residual of 1e-10 puts z within ~1e-9.
constexpr double kSolutionTol = 1e-8;
// Central differences of O(1) polynomials: truncation ~h² ≈ 1e-12, round-off ~ε/h ≈ 1e-10.
constexpr double kFdStep = 1e-6;
constexpr double kFdTol = 1e-7;

const double kSqrt6Half = std::sqrt(6.0) / 2.0;

// ---- Checks independent of the solver -------------------------------------------------------

// z ∈ [l, u] exactly, and row by row: z_i > l_i ⇒ F_i ≤ tol, z_i < u_i ⇒ F_i ≥ −tol (hence
// F_i = 0 in the interior), with the slack measured from the bounds; plus McpResidual ≤ tol.
void ExpectMcpSolution(const McpProblem& p, const VectorXd& z, double tol = kComplementarityTol) {
  ASSERT_EQ(z.size(), p.size());
  ASSERT_TRUE(z.allFinite());
  VectorXd F(p.size());
  p.evaluate(z, &F, nullptr);
  for (int i = 0; i < p.size(); ++i) {
    EXPECT_GE(z(i), p.lower(i)) << "i = " << i;
    EXPECT_LE(z(i), p.upper(i)) << "i = " << i;
    if (z(i) > p.lower(i) + tol) {
      EXPECT_LE(F(i), tol) << "i = " << i << ", z_i off its lower bound";
    }
    if (z(i) < p.upper(i) - tol) {
      EXPECT_GE(F(i), -tol) << "i = " << i << ", z_i off its upper bound";
    }
  }
  EXPECT_LE(McpResidual(p, z), tol);
}

// A solve that must succeed: status, reported residual = McpResidual at the returned z, and the
// independent checks.
void ExpectSolved(const McpProblem& p, const SolverReport& r, const VectorXd& z) {
  EXPECT_EQ(r.status, SolverStatus::kSolved) << r.message;
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.residual, McpResidual(p, z));
  EXPECT_LE(r.residual, kTol);
  EXPECT_GE(r.time_s, 0.0);
  ExpectMcpSolution(p, z);
}

// Largest |analytic − central-difference| entry of the Jacobian of F at z, relative to
// max(1, |entry|).
double JacobianFdError(const McpProblem& p, const VectorXd& z, double h = kFdStep) {
  const int n = p.size();
  VectorXd F(n), Fp(n), Fm(n);
  MatrixXd J(n, n);
  p.evaluate(z, &F, &J);
  double err = 0.0;
  for (int j = 0; j < n; ++j) {
    VectorXd zp = z, zm = z;
    zp(j) += h;
    zm(j) -= h;
    p.evaluate(zp, &Fp, nullptr);
    p.evaluate(zm, &Fm, nullptr);
    const VectorXd col = (Fp - Fm) / (2.0 * h);
    for (int i = 0; i < n; ++i) {
      err = std::max(err, std::abs(col(i) - J(i, j)) / std::max(1.0, std::abs(J(i, j))));
    }
  }
  return err;
}

// Same for the generalized Jacobian of Φ returned by McpFischerBurmeister (valid where Φ is
// differentiable).
double FischerBurmeisterFdError(const McpProblem& p, const VectorXd& z, double lambda,
                                double h = kFdStep) {
  const int n = p.size();
  MatrixXd H;
  McpFischerBurmeister(p, z, lambda, &H);
  double err = 0.0;
  for (int j = 0; j < n; ++j) {
    VectorXd zp = z, zm = z;
    zp(j) += h;
    zm(j) -= h;
    const VectorXd col = (McpFischerBurmeister(p, zp, lambda, nullptr) -
                          McpFischerBurmeister(p, zm, lambda, nullptr)) /
                         (2.0 * h);
    for (int i = 0; i < n; ++i) {
      err = std::max(err, std::abs(col(i) - H(i, j)) / std::max(1.0, std::abs(H(i, j))));
    }
  }
  return err;
}

// Matches the message of an std::invalid_argument thrown by `f`.
void ExpectInvalidArgument(const std::function<void()>& f, const std::string& fragment) {
  try {
    f();
    ADD_FAILURE() << "expected std::invalid_argument containing '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

// Default options with one field changed.
template <typename T>
McpOptions With(T McpOptions::*field, T value) {
  McpOptions o;
  o.*field = value;
  return o;
}

VectorXd Vec(std::initializer_list<double> v) {
  VectorXd out(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double x : v) out(i++) = x;
  return out;
}

// ---- Test problems ---------------------------------------------------------------------------

// Josephy (Kojima's NCP) and Kojima–Shindo share their structure; they differ in the
// coefficients (a, b, c) of x3 in F2, x4 in F3 and the constant of F3.
McpProblem KojimaFamily(double a, double b, double c) {
  McpProblem p;
  p.lower = VectorXd::Zero(4);
  p.upper = VectorXd::Constant(4, kInf);
  p.evaluate = [a, b, c](const VectorXd& x, VectorXd* F, MatrixXd* J) {
    F->resize(4);
    (*F)(0) = 3 * x(0) * x(0) + 2 * x(0) * x(1) + 2 * x(1) * x(1) + x(2) + 3 * x(3) - 6;
    (*F)(1) = 2 * x(0) * x(0) + x(0) + x(1) * x(1) + a * x(2) + 2 * x(3) - 2;
    (*F)(2) = 3 * x(0) * x(0) + x(0) * x(1) + 2 * x(1) * x(1) + 2 * x(2) + b * x(3) - c;
    (*F)(3) = x(0) * x(0) + 3 * x(1) * x(1) + 2 * x(2) + 3 * x(3) - 3;
    if (J != nullptr) {
      J->resize(4, 4);
      *J << 6 * x(0) + 2 * x(1), 2 * x(0) + 4 * x(1), 1, 3,  //
          4 * x(0) + 1, 2 * x(1), a, 2,                      //
          6 * x(0) + x(1), x(0) + 4 * x(1), 2, b,            //
          2 * x(0), 6 * x(1), 2, 3;
    }
  };
  return p;
}
McpProblem Josephy() { return KojimaFamily(3.0, 3.0, 1.0); }
McpProblem KojimaShindo() { return KojimaFamily(10.0, 9.0, 9.0); }

// F(z) = M z + q on [l, u], with the sparse Jacobian too.
McpProblem Affine(const MatrixXd& M, const VectorXd& q, const VectorXd& l, const VectorXd& u) {
  McpProblem p;
  p.lower = l;
  p.upper = u;
  p.evaluate = [M, q](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    *F = M * z + q;
    if (J != nullptr) *J = M;
  };
  const Eigen::SparseMatrix<double> Ms = M.sparseView();
  p.sparse_jacobian = [Ms](const VectorXd&, Eigen::SparseMatrix<double>* J) { *J = Ms; };
  return p;
}

// The 4×4 example of PATH's Julia interface documentation (Complementarity.jl, MCP.md):
// F(z) = Mz + q, z ≥ 0, solution (2.8, 0, 0.8, 1.2). Published with u = ∞; u = 10 here makes
// it box-constrained without changing the solution (every component < 10).
MatrixXd Box4M() {
  MatrixXd M(4, 4);
  M << 0, 0, -1, -1,  //
      0, 0, 1, -2,    //
      1, -1, 2, -2,   //
      1, 2, -2, 4;
  return M;
}
McpProblem Box4() {
  return Affine(Box4M(), Vec({2, 2, -2, -6}), VectorXd::Zero(4), VectorXd::Constant(4, 10.0));
}
// A variant constructed here so that one component sits at an upper bound: same M, u4 = 1.2
// and q4 = −7, so at z* = (2.8, 0, 0.8, 1.2) F = (0, 0.4, 0, −1): z1, z3 interior with F = 0,
// z2 at its lower bound with F > 0, z4 at its upper bound with F < 0 (all strictly).
McpProblem Box4Upper() {
  return Affine(Box4M(), Vec({2, 2, -2, -7}), VectorXd::Zero(4), Vec({10, 10, 10, 1.2}));
}

// KKT system of the convex QP  min ‖x − p‖²  s.t.  x1 + x2 + x3 = 3,  x3 ≤ 1,  −x1 ≤ 0,
// p = (1, 2, 3). z = (x, ν, μ1, μ2): x and ν free (equations), μ ≥ 0 (NCP rows):
//   2(x − p) + ν(1, 1, 1) + μ1 e3 − μ2 e1 = 0,   x1 + x2 + x3 − 3 = 0,
//   0 ≤ μ1 ⊥ 1 − x3 ≥ 0,   0 ≤ μ2 ⊥ x1 ≥ 0.
// Solution by hand: x3 = 1 active, (x1, x2) the projection of (1, 2) onto x1 + x2 = 2, i.e.
// (0.5, 1.5) with x1 > 0 inactive; ν = 1, μ1 = 3, μ2 = 0.
McpProblem QpKkt() {
  MatrixXd M = MatrixXd::Zero(6, 6);
  M.topLeftCorner(3, 3) = 2.0 * Matrix3d::Identity();
  M.block(0, 3, 3, 1).setOnes();  // ν
  M(2, 4) = 1.0;                  // μ1
  M(0, 5) = -1.0;                 // μ2
  M.block(3, 0, 1, 3).setOnes();  // x1 + x2 + x3 − 3
  M(4, 2) = -1.0;                 // 1 − x3
  M(5, 0) = 1.0;                  // x1
  const VectorXd q = Vec({-2, -4, -6, -3, 1, 0});
  return Affine(M, q, Vec({-kInf, -kInf, -kInf, -kInf, 0, 0}),
                Vec({kInf, kInf, kInf, kInf, kInf, kInf}));
}
const VectorXd kQpSolution = Vec({0.5, 1.5, 1.0, 1.0, 3.0, 0.0});

// Random positive definite (hence P-) matrix M = AAᵀ + (S − Sᵀ) + 0.1 I and q ∈ [−5, 5]ⁿ: the
// LCP has exactly one solution.
LcpProblem RandomPLcp(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatrixXd A(n, n), S(n, n);
  for (int k = 0; k < n * n; ++k) {
    A.data()[k] = u(rng);
    S.data()[k] = u(rng);
  }
  LcpProblem lcp;
  lcp.M = A * A.transpose() + (S - S.transpose()) + 0.1 * MatrixXd::Identity(n, n);
  lcp.q.resize(n);
  for (int i = 0; i < n; ++i) lcp.q(i) = 5.0 * u(rng);
  return lcp;
}
McpProblem McpFromLcp(const LcpProblem& lcp) {
  return Affine(lcp.M, lcp.q, VectorXd::Zero(lcp.size()), VectorXd::Constant(lcp.size(), kInf));
}

// ---- McpResidual -----------------------------------------------------------------------------

TEST(McpResidualTest, NaturalResidualWithInfiniteBounds) {
  // Rows: NCP (l = 0), equation, upper bound only, box. F is a constant vector.
  McpProblem p;
  p.lower = Vec({0, -kInf, -kInf, 1});
  p.upper = Vec({kInf, kInf, 2, 3});
  VectorXd Fc = Vec({2, -0.25, -1, 0.5});
  p.evaluate = [&Fc](const VectorXd&, VectorXd* F, MatrixXd*) { *F = Fc; };
  const VectorXd z = Vec({0.5, 1.0, 2.0, 1.0});
  // |0.5 − mid(0, ∞, −1.5)| = 0.5, |F2| = 0.25, |2 − mid(−∞, 2, 3)| = 0, |1 − mid(1, 3, 0.5)| = 0.
  EXPECT_DOUBLE_EQ(McpResidual(p, z), 0.5);
  Fc(0) = 0.4;  // |0.5 − 0.1| = 0.4
  EXPECT_DOUBLE_EQ(McpResidual(p, z), 0.4);
  Fc(0) = 0.0;
  Fc(2) = 1.0;  // z3 = u3 but F3 > 0: |2 − mid(−∞, 2, 1)| = 1
  EXPECT_DOUBLE_EQ(McpResidual(p, z), 1.0);
  Fc(2) = -1.0;
  Fc(1) = 0.0;
  EXPECT_EQ(McpResidual(p, z), 0.0);
  Fc(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isnan(McpResidual(p, z)));
  ExpectInvalidArgument([&] { McpResidual(p, VectorXd::Zero(3)); }, "size");
}

// ---- Jacobians -------------------------------------------------------------------------------

TEST(McpJacobianTest, TestProblemJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 3.0);
  for (const McpProblem& p : {Josephy(), KojimaShindo()}) {
    for (int trial = 0; trial < 5; ++trial) {
      const VectorXd z = Vec({u(rng), u(rng), u(rng), u(rng)});
      EXPECT_LE(JacobianFdError(p, z), kFdTol);
    }
  }
  // The helper is not vacuous: a wrong entry is detected.
  McpProblem wrong = Josephy();
  const auto right = wrong.evaluate;
  wrong.evaluate = [right](const VectorXd& x, VectorXd* F, MatrixXd* J) {
    right(x, F, J);
    if (J != nullptr) (*J)(1, 2) += 1e-3;
  };
  EXPECT_GT(JacobianFdError(wrong, Vec({1, 1, 1, 1})), 1e-4);
}

// A nonlinear problem with every kind of row: equation, lower only, upper only, box (two
// rows) and a fixed variable.
McpProblem AllRowKinds() {
  McpProblem p;
  p.lower = Vec({-kInf, 0.0, -kInf, -1.0, 0.0, 0.5});
  p.upper = Vec({kInf, kInf, 2.0, 1.0, 3.0, 0.5});
  p.evaluate = [](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    const int n = 6;
    MatrixXd A(n, n);
    A << 3, 1, 0, 0, -1, 0,  //
        1, 4, 1, 0, 0, 1,    //
        0, -1, 3, 1, 0, 0,   //
        0, 0, 1, 2, 1, 0,    //
        1, 0, 0, -1, 4, 1,   //
        0, 1, 0, 0, 1, 2;
    const VectorXd b = Vec({-1.0, 0.5, -2.0, 0.3, -4.0, 0.2});
    *F = A * z + b;
    for (int i = 0; i < n; ++i) (*F)(i) += 0.3 * z(i) * z(i) * z(i);
    if (J != nullptr) {
      *J = A;
      for (int i = 0; i < n; ++i) (*J)(i, i) += 0.9 * z(i) * z(i);
    }
  };
  return p;
}

// φ_λ(a, b) straight from the definition, for an independent check of Φ.
double PenalizedFbReference(double a, double b, double lambda) {
  return lambda * (std::sqrt(a * a + b * b) - a - b) -
         (1.0 - lambda) * std::max(a, 0.0) * std::max(b, 0.0);
}

TEST(McpJacobianTest, FischerBurmeisterValuesFollowTheDefinition) {
  const McpProblem p = AllRowKinds();
  const VectorXd z = Vec({0.3, 0.7, 1.1, 0.2, 2.5, 0.5});
  const double lambda = 0.95;
  VectorXd F(6);
  p.evaluate(z, &F, nullptr);
  const VectorXd& l = p.lower;
  const VectorXd& u = p.upper;
  const VectorXd phi = McpFischerBurmeister(p, z, lambda, nullptr);
  constexpr double kValueTol = 1e-14;  // a few ulps of O(1) values
  EXPECT_NEAR(phi(0), -F(0), kValueTol);
  EXPECT_NEAR(phi(1), PenalizedFbReference(z(1) - l(1), F(1), lambda), kValueTol);
  EXPECT_NEAR(phi(2), -PenalizedFbReference(u(2) - z(2), -F(2), lambda), kValueTol);
  for (int i : {3, 4}) {
    EXPECT_NEAR(
        phi(i),
        PenalizedFbReference(z(i) - l(i), PenalizedFbReference(u(i) - z(i), -F(i), lambda), lambda),
        kValueTol);
  }
  EXPECT_EQ(phi(5), 0.0);  // fixed variable at its value
  // Φ vanishes exactly on solutions: the solved problem gives Φ ≈ 0.
  VectorXd zs = VectorXd::Zero(6);
  const SolverReport r = McpSolver().Solve(p, &zs);
  ExpectSolved(p, r, zs);
  EXPECT_LE(McpFischerBurmeister(p, zs, lambda, nullptr).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(McpJacobianTest, FischerBurmeisterJacobianMatchesFiniteDifferences) {
  const McpProblem p = AllRowKinds();
  std::mt19937 rng(11);
  int checked = 0;
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd z(6);
    for (int i = 0; i < 6; ++i) {
      const double lo = std::isfinite(p.lower(i)) ? p.lower(i) : -2.0;
      const double hi = std::isfinite(p.upper(i)) ? p.upper(i) : 2.0;
      z(i) = std::uniform_real_distribution<double>(lo, hi)(rng);
    }
    z(5) = 0.5;
    // Differentiable at z: every argument of every φ (z − l, u − z, ±F and the inner φ of the
    // box rows) is away from 0 by much more than the difference step.
    VectorXd F(6);
    p.evaluate(z, &F, nullptr);
    bool smooth = true;
    for (int i = 0; i < 5; ++i) {
      smooth &= std::abs(F(i)) > 1e-3;
      if (std::isfinite(p.lower(i))) smooth &= z(i) - p.lower(i) > 1e-3;
      if (std::isfinite(p.upper(i))) smooth &= p.upper(i) - z(i) > 1e-3;
    }
    for (int i : {3, 4}) {
      smooth &= std::abs(PenalizedFbReference(p.upper(i) - z(i), -F(i), 0.95)) > 1e-3;
    }
    if (!smooth) continue;
    ++checked;
    for (double lambda : {0.95, 1.0, 0.5}) {
      EXPECT_LE(FischerBurmeisterFdError(p, z, lambda), kFdTol) << "lambda " << lambda;
    }
  }
  EXPECT_GE(checked, 10);
}

TEST(McpJacobianTest, DirectionalElementAtDegeneratePoints) {
  // F = Mz + q built so that at z0: row 0 (l = 0) has z = 0 and F = 0, row 1 (box [0, 1]) has
  // z = u and F = 0 — both Fischer–Burmeister pairs are (0, 0) — and row 2 (l = 0) has
  // z = 0.5, F = 0.3, differentiable. The element's rows applied to d = e0 + e1 must be the
  // one-sided directional derivatives (Φ(z0 + h d) − Φ(z0)) / h.
  MatrixXd M(3, 3);
  M << 2, 1, -1,  //
      -1, 3, 1,   //
      1, 1, 2;
  const VectorXd z0 = Vec({0.0, 1.0, 0.5});
  const VectorXd q = Vec({0.0, 0.0, 0.3}) - M * z0;
  const McpProblem p = Affine(M, q, Vec({0, 0, 0}), Vec({kInf, 1, kInf}));
  const VectorXd d = Vec({1, 1, 0});
  // With F affine each FB pair is positively homogeneous along d; the penalty a₊b₊ = O(h²)
  // and the curvature of the nested φ leave an O(h) error (~10 h), round-off ~ε/h.
  constexpr double kH = 1e-8;
  constexpr double kDirTol = 1e-6;
  for (double lambda : {0.95, 1.0}) {
    MatrixXd H;
    const VectorXd phi0 = McpFischerBurmeister(p, z0, lambda, &H);
    EXPECT_NEAR(phi0(0), 0.0, 1e-15);
    EXPECT_NEAR(phi0(1), 0.0, 1e-15);
    const VectorXd fd = (McpFischerBurmeister(p, z0 + kH * d, lambda, nullptr) - phi0) / kH;
    const VectorXd Hd = H * d;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(Hd(i), fd(i), kDirTol) << "row " << i;
    // Not the trivial element: the degenerate rows have non-zero directional derivatives.
    EXPECT_GT(std::abs(Hd(0)), 0.1);
    EXPECT_GT(std::abs(Hd(1)), 0.1);
  }
}

// ---- Classic nonlinear problems ----------------------------------------------------------------

TEST(McpSolverTest, JosephyFromStandardStartingPoints) {
  const McpProblem p = Josephy();
  const VectorXd solution = Vec({kSqrt6Half, 0.0, 0.0, 0.5});
  for (const VectorXd& start : {Vec({1, 1, 1, 1}), Vec({0, 0, 0, 0})}) {
    VectorXd z = start;
    McpSolveStats stats;
    const SolverReport r = McpSolver().Solve(p, &z, &stats);
    ExpectSolved(p, r, z);
    EXPECT_LE((z - solution).lpNorm<Eigen::Infinity>(), kSolutionTol) << z.transpose();
    // Observed 6 and 7 Newton steps without restarts: a guard on the local superlinear rate.
    EXPECT_LE(r.iterations, 12);
    EXPECT_EQ(stats.restarts, 0);
  }
}

TEST(McpSolverTest, KojimaShindoFindsBothSolutions) {
  const McpProblem p = KojimaShindo();
  const VectorXd s1 = Vec({1.0, 0.0, 3.0, 0.0});
  const VectorXd s2 = Vec({kSqrt6Half, 0.0, 0.0, 0.5});
  // Both are solutions (checked without the solver).
  ExpectMcpSolution(p, s1, 1e-14);
  ExpectMcpSolution(p, s2, 1e-14);
  int found1 = 0, found2 = 0;
  for (const VectorXd& start :
       {Vec({1, 1, 1, 1}), Vec({0, 0, 0, 0}), Vec({1, 0, 1, 0}), Vec({10, 10, 10, 10}),
        Vec({0.5, 0.5, 3, 0.5}), Vec({0, 0, 5, 0}), Vec({3, 3, 3, 3}), Vec({1, 0, 0, 0})}) {
    VectorXd z = start;
    const SolverReport r = McpSolver().Solve(p, &z);
    ExpectSolved(p, r, z);
    const bool is1 = (z - s1).lpNorm<Eigen::Infinity>() <= kSolutionTol;
    const bool is2 = (z - s2).lpNorm<Eigen::Infinity>() <= kSolutionTol;
    EXPECT_TRUE(is1 || is2) << "start " << start.transpose() << " -> " << z.transpose();
    found1 += is1;
    found2 += is2;
  }
  EXPECT_GE(found1, 1);
  EXPECT_GE(found2, 1);
}

TEST(McpSolverTest, OptionVariantsSolveTheNonlinearProblems) {
  // Pure Fischer–Burmeister (λ = 1), a monotone line search and a strongly penalized φ.
  for (const McpOptions& o :
       {With(&McpOptions::lambda, 1.0), With(&McpOptions::nonmonotone_memory, 1),
        With(&McpOptions::lambda, 0.5)}) {
    for (const McpProblem& p : {Josephy(), KojimaShindo()}) {
      for (const VectorXd& start : {Vec({1, 1, 1, 1}), Vec({0, 0, 0, 0})}) {
        VectorXd z = start;
        ExpectSolved(p, McpSolver(o).Solve(p, &z), z);
      }
    }
  }
}

// ---- Box-constrained and mixed problems ------------------------------------------------------

// Uniqueness certificate for an affine MCP with M + Mᵀ ⪰ 0 (monotone, so the solution set is
// convex): z* is strictly complementary and M restricted to its interior rows is nonsingular,
// so z* is locally unique, hence the only solution.
void ExpectUniqueAffineSolution(const MatrixXd& M, const McpProblem& p, const VectorXd& zs) {
  const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(M + M.transpose());
  EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-12);
  VectorXd F(p.size());
  p.evaluate(zs, &F, nullptr);
  std::vector<int> interior;
  for (int i = 0; i < p.size(); ++i) {
    if (zs(i) == p.lower(i)) {
      EXPECT_GT(F(i), 0.1) << i;
    } else if (zs(i) == p.upper(i)) {
      EXPECT_LT(F(i), -0.1) << i;
    } else {
      EXPECT_NEAR(F(i), 0.0, 1e-14) << i;
      interior.push_back(i);
    }
  }
  MatrixXd Mff(interior.size(), interior.size());
  for (size_t a = 0; a < interior.size(); ++a) {
    for (size_t b = 0; b < interior.size(); ++b) Mff(a, b) = M(interior[a], interior[b]);
  }
  EXPECT_GT(std::abs(Mff.determinant()), 0.1);
}

TEST(McpSolverTest, BoxConstrainedFourByFour) {
  const VectorXd solution = Vec({2.8, 0.0, 0.8, 1.2});
  for (const McpProblem& p : {Box4(), Box4Upper()}) {
    ExpectUniqueAffineSolution(Box4M(), p, solution);
    for (const VectorXd& start : {Vec({0, 0, 0, 0}), Vec({1, 1, 1, 1}), Vec({10, 10, 10, 10}),
                                  Vec({0, 1, 0, 1}), Vec({5, 0, 5, 0})}) {
      VectorXd z = start;
      const SolverReport r = McpSolver().Solve(p, &z);
      ExpectSolved(p, r, z);
      EXPECT_LE((z - solution).lpNorm<Eigen::Infinity>(), kSolutionTol)
          << "start " << start.transpose() << " -> " << z.transpose();
    }
  }
}

TEST(McpSolverTest, QpKktWithEquationsAndInequalities) {
  const McpProblem p = QpKkt();
  for (const VectorXd& start :
       {VectorXd::Zero(6).eval(), Vec({5, -5, 5, -5, 5, 5}), Vec({0.5, 1.5, 1, 1, 3, 0})}) {
    VectorXd z = start;
    const SolverReport r = McpSolver().Solve(p, &z);
    ExpectSolved(p, r, z);
    EXPECT_LE((z - kQpSolution).lpNorm<Eigen::Infinity>(), kSolutionTol) << z.transpose();
    // The QP's own KKT conditions.
    const Vector3d x = z.head<3>();
    EXPECT_NEAR(x.sum(), 3.0, kComplementarityTol);
    EXPECT_LE(x(2), 1.0 + kComplementarityTol);
    EXPECT_GE(x(0), -kComplementarityTol);
    EXPECT_GE(z(4), 0.0);
    EXPECT_GE(z(5), 0.0);
    EXPECT_NEAR(z(4) * (1.0 - x(2)), 0.0, kComplementarityTol);
    EXPECT_NEAR(z(5) * x(0), 0.0, kComplementarityTol);
    const Vector3d stationarity = 2.0 * (x - Vector3d(1, 2, 3)) + z(3) * Vector3d::Ones() +
                                  z(4) * Vector3d::UnitZ() - z(5) * Vector3d::UnitX();
    EXPECT_LE(stationarity.lpNorm<Eigen::Infinity>(), kComplementarityTol);
  }
}

TEST(McpSolverTest, EveryRowKindSeparable) {
  // F_i = (z_i − c_i) + (z_i − c_i)³ is increasing, so the solution is mid(l_i, u_i, c_i):
  // equations, lower-active, upper-active (upper bound only and box), interior box rows and a
  // fixed variable.
  const VectorXd l = Vec({-kInf, 0.0, -kInf, -kInf, -1.0, -1.0, -1.0, 2.0});
  const VectorXd u = Vec({kInf, kInf, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0});
  const VectorXd c = Vec({-3.0, -2.0, 4.0, 0.5, -5.0, 5.0, 0.25, 7.0});
  McpProblem p;
  p.lower = l;
  p.upper = u;
  p.evaluate = [c](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    const VectorXd e = z - c;
    *F = e + e.cwiseProduct(e).cwiseProduct(e);
    if (J != nullptr) *J = (VectorXd::Ones(c.size()) + 3.0 * e.cwiseProduct(e)).asDiagonal();
  };
  const VectorXd expected = c.cwiseMax(l).cwiseMin(u);
  for (double s : {0.0, 0.9, -0.9}) {
    VectorXd z = VectorXd::Constant(8, s);
    const SolverReport r = McpSolver().Solve(p, &z);
    ExpectSolved(p, r, z);
    EXPECT_LE((z - expected).lpNorm<Eigen::Infinity>(), kSolutionTol) << z.transpose();
  }
}

// ---- LCPs: agreement with Lemke, sparse path -------------------------------------------------

TEST(McpSolverTest, LcpAgreesWithLemkeOnRandomPMatrices) {
  // Unique solutions; both solvers stop at residual ≤ 1e-9, ‖M⁻¹‖-type constants are O(10)
  // for these matrices.
  constexpr double kAgreeTol = 1e-7;
  for (int n : {10, 30}) {
    for (unsigned seed : {1u, 2u, 3u}) {
      const LcpProblem lcp = RandomPLcp(n, seed);
      const McpProblem p = McpFromLcp(lcp);
      VectorXd z = VectorXd::Zero(n);
      const SolverReport r = McpSolver().Solve(p, &z);
      ExpectSolved(p, r, z);
      EXPECT_LE(LcpResidual(lcp, z), kComplementarityTol);
      VectorXd zl;
      const SolverReport rl = LemkeSolver().Solve(lcp, nullptr, &zl);
      ASSERT_TRUE(rl.ok()) << rl.message;
      EXPECT_LE((z - zl).lpNorm<Eigen::Infinity>(), kAgreeTol) << "n " << n << " seed " << seed;
      // Non-trivial instances: some components active on each side.
      EXPECT_GT((zl.array() > 1e-6).count(), 0);
      EXPECT_GT((zl.array() < 1e-12).count(), 0);
    }
  }
}

TEST(McpSolverTest, SparsePathMatchesDense) {
  for (int n : {10, 30}) {
    const LcpProblem lcp = RandomPLcp(n, 5);
    McpProblem p = McpFromLcp(lcp);
    VectorXd zd = VectorXd::Zero(n);
    const SolverReport rd = McpSolver().Solve(p, &zd);
    ExpectSolved(p, rd, zd);
    // The sparse solve must not ask for the dense Jacobian.
    McpProblem ps = p;
    const auto dense = p.evaluate;
    ps.evaluate = [dense](const VectorXd& z, VectorXd* F, MatrixXd* J) {
      if (J != nullptr) throw std::logic_error("dense Jacobian requested on the sparse path");
      dense(z, F, nullptr);
    };
    VectorXd zs = VectorXd::Zero(n);
    const SolverReport rs = McpSolver(With(&McpOptions::sparse, true)).Solve(ps, &zs);
    ExpectSolved(ps, rs, zs);
    EXPECT_LE((zs - zd).lpNorm<Eigen::Infinity>(), kSolutionTol);
  }
  // A genuinely sparse problem: tridiagonal, diagonally dominant (a P-matrix), n = 200, with
  // box rows.
  const int n = 200;
  MatrixXd M = MatrixXd::Zero(n, n);
  VectorXd q(n);
  for (int i = 0; i < n; ++i) {
    M(i, i) = 4.0;
    if (i > 0) M(i, i - 1) = -1.0;
    if (i + 1 < n) M(i, i + 1) = -1.5;
    q(i) = std::sin(0.37 * i) * 3.0;
  }
  const McpProblem p = Affine(M, q, VectorXd::Zero(n), VectorXd::Constant(n, 0.4));
  VectorXd zd = VectorXd::Zero(n), zs = VectorXd::Zero(n);
  const SolverReport rd = McpSolver().Solve(p, &zd);
  const SolverReport rs = McpSolver(With(&McpOptions::sparse, true)).Solve(p, &zs);
  ExpectSolved(p, rd, zd);
  ExpectSolved(p, rs, zs);
  EXPECT_LE((zs - zd).lpNorm<Eigen::Infinity>(), kSolutionTol);
  EXPECT_GT((zs.array() == 0.4).count(), 0);  // some rows at the upper bound
}

// ---- Warm start, limits, determinism ---------------------------------------------------------

TEST(McpSolverTest, ExactWarmStartTakesZeroIterations) {
  {
    const McpProblem p = Josephy();
    const VectorXd solution = Vec({kSqrt6Half, 0.0, 0.0, 0.5});
    VectorXd z = solution;
    const SolverReport r = McpSolver().Solve(p, &z);
    ExpectSolved(p, r, z);
    EXPECT_EQ(r.iterations, 0);
    EXPECT_EQ(z, solution);
  }
  {
    const McpProblem p = McpFromLcp(RandomPLcp(30, 9));
    VectorXd z = VectorXd::Zero(30);
    ASSERT_TRUE(McpSolver().Solve(p, &z).ok());
    const VectorXd solved = z;
    McpSolveStats stats;
    const SolverReport r = McpSolver().Solve(p, &z, &stats);
    ExpectSolved(p, r, z);
    EXPECT_EQ(r.iterations, 0);
    EXPECT_EQ(stats.function_evaluations, 1);
    EXPECT_EQ(z, solved);
  }
}

TEST(McpSolverTest, IterationLimit) {
  const McpProblem p = Josephy();
  VectorXd z = Vec({10, 10, 10, 10});
  const SolverReport r = McpSolver(With(&McpOptions::max_iterations, 2)).Solve(p, &z);
  EXPECT_EQ(r.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(r.iterations, 2);
  EXPECT_EQ(r.residual, McpResidual(p, z));
  EXPECT_GT(r.residual, kTol);
  EXPECT_FALSE(r.message.empty());
}

TEST(McpSolverTest, Deterministic) {
  for (const McpProblem& p : {KojimaShindo(), McpFromLcp(RandomPLcp(30, 4))}) {
    VectorXd z1 = VectorXd::Zero(p.size()), z2 = VectorXd::Zero(p.size());
    const SolverReport r1 = McpSolver().Solve(p, &z1);
    const SolverReport r2 = McpSolver().Solve(p, &z2);
    EXPECT_EQ(z1, z2);
    EXPECT_EQ(r1.iterations, r2.iterations);
    EXPECT_EQ(r1.residual, r2.residual);
  }
}

TEST(McpSolverTest, NeverEvaluatesOutsideTheBox) {
  // F(z) = √(z + 1) − 2 on z ≥ 0 (solution z = 3): the evaluation throws outside the box.
  McpProblem p;
  p.lower = VectorXd::Zero(1);
  p.upper = VectorXd::Constant(1, kInf);
  p.evaluate = [](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    if (z(0) < 0.0) throw std::domain_error("evaluated outside the box");
    F->resize(1);
    (*F)(0) = std::sqrt(z(0) + 1.0) - 2.0;
    if (J != nullptr) {
      J->resize(1, 1);
      (*J)(0, 0) = 0.5 / std::sqrt(z(0) + 1.0);
    }
  };
  for (double s : {0.0, 1.0, 10.0, 100.0}) {
    VectorXd z = VectorXd::Constant(1, s);
    const SolverReport r = McpSolver().Solve(p, &z);
    ExpectSolved(p, r, z);
    EXPECT_NEAR(z(0), 3.0, kSolutionTol);
  }
  // And on the test problems, from every start used above.
  for (McpProblem q : {Josephy(), KojimaShindo(), Box4(), Box4Upper()}) {
    int outside = 0;
    const auto inner = q.evaluate;
    const VectorXd l = q.lower, u = q.upper;
    q.evaluate = [&outside, inner, l, u](const VectorXd& z, VectorXd* F, MatrixXd* J) {
      outside += ((z.array() < l.array()) || (z.array() > u.array())).count();
      inner(z, F, J);
    };
    for (const VectorXd& start : {Vec({0, 0, 0, 0}), Vec({1, 1, 1, 1}), Vec({-5, 20, 3, -1})}) {
      VectorXd z = start;
      EXPECT_TRUE(McpSolver().Solve(q, &z).ok());
    }
    EXPECT_EQ(outside, 0);
  }
}

TEST(McpSolverTest, EmptyProblemIsSolved) {
  McpProblem p;
  p.lower.resize(0);
  p.upper.resize(0);
  p.evaluate = [](const VectorXd&, VectorXd* F, MatrixXd* J) {
    F->resize(0);
    if (J != nullptr) J->resize(0, 0);
  };
  for (bool sparse : {false, true}) {
    McpProblem q = p;
    q.sparse_jacobian = [](const VectorXd&, Eigen::SparseMatrix<double>* J) { J->resize(0, 0); };
    VectorXd z(0);
    const SolverReport r = McpSolver(With(&McpOptions::sparse, sparse)).Solve(q, &z);
    EXPECT_EQ(r.status, SolverStatus::kSolved);
    EXPECT_EQ(r.iterations, 0);
    EXPECT_EQ(r.residual, 0.0);
  }
}

// ---- Fallbacks and restarts ------------------------------------------------------------------

TEST(McpSolverTest, ProjectedGradientWhenNewtonMatrixIsSingular) {
  // Equations F1 = z1 + z2 − 2, F2 = z1 + z2 − 2 + (z1 − z2)³ (unique root (1, 1)): at z = 0
  // the Jacobian [[1, 1], [1, 1]] is singular, but ∇Ψ ≠ 0.
  McpProblem p;
  p.lower = VectorXd::Constant(2, -kInf);
  p.upper = VectorXd::Constant(2, kInf);
  p.evaluate = [](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    const double s = z(0) + z(1) - 2.0, d = z(0) - z(1);
    *F = Vec({s, s + d * d * d});
    if (J != nullptr) {
      J->resize(2, 2);
      *J << 1, 1, 1 + 3 * d * d, 1 - 3 * d * d;
    }
  };
  for (bool lm : {false, true}) {
    SCOPED_TRACE(lm);
    VectorXd z = VectorXd::Zero(2);
    McpSolveStats stats;
    McpOptions o;
    o.levenberg_marquardt = lm;
    const SolverReport r = McpSolver(o).Solve(p, &z, &stats);
    ExpectSolved(p, r, z);
    // Without LM the singular Newton matrix falls back to the gradient; with LM, LM steps.
    EXPECT_GE(lm ? stats.lm_steps : stats.gradient_steps, 1);
    EXPECT_LE((z - Vec({1, 1})).lpNorm<Eigen::Infinity>(), 1e-3);  // cube-root conditioning
  }
}

TEST(McpSolverTest, LevenbergMarquardtCrossesANearlyFlatSolutionValley) {
  // s + s³ = 0 with s = z1 + z2 + z3 − 3 (a plane of roots) and two tie-breaking rows
  // ε1 (z1 − z2) = 0, ε2 (z2 − z3) = 0, ε1 = 1e-6, ε2 = 1e-7: the root (1, 1, 1) is unique but
  // nearly non-isolated, like the redundant normal and sticking friction impulses of a box on
  // four corners (ncp.h). From (1.2, 0.9, 0.9) the Newton step has ∇Ψᵀd = −‖Φ‖² ≈ −(0.3 ε1)², far
  // below the descent test's −ρ‖d‖^2.1, and the gradient follows the ε1 direction and crawls
  // along the ε2 one (rate 1 − (ε2/ε1)²): without LM the attempt stalls; the LM step
  // (HᵀH + min(1, ‖Φ‖²) max diag(HᵀH) I) d = −∇Ψ is Newton's here and crosses the valley.
  static constexpr double kE1 = 1e-6, kE2 = 1e-7;
  McpProblem p;
  p.lower = VectorXd::Constant(3, -kInf);
  p.upper = VectorXd::Constant(3, kInf);
  p.evaluate = [](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    const double s = z.sum() - 3.0;
    *F = Vec({s + s * s * s, kE1 * (z(0) - z(1)), kE2 * (z(1) - z(2))});
    if (J != nullptr) {
      J->resize(3, 3);
      const double ds = 1.0 + 3.0 * s * s;
      *J << ds, ds, ds, kE1, -kE1, 0.0, 0.0, kE2, -kE2;
    }
  };
  McpOptions o;
  o.tolerance = 1e-14;  // the start's residual is 0.3 ε1: the valley must be crossed
  o.max_restarts = 0;   // one attempt (a random restart off the plane would hide the stall)
  for (bool lm : {false, true}) {
    SCOPED_TRACE(lm);
    o.levenberg_marquardt = lm;
    VectorXd z = Vec({1.2, 0.9, 0.9});
    McpSolveStats stats;
    const SolverReport r = McpSolver(o).Solve(p, &z, &stats);
    if (lm) {
      EXPECT_TRUE(r.ok()) << r.message;
      EXPECT_LE(McpResidual(p, z), o.tolerance);
      EXPECT_GE(stats.lm_steps, 1);
      // Residual ≤ 1e-14 leaves |z2 − z3| ≤ 1e-14/ε2 = 1e-7 along the valley.
      EXPECT_LE((z - Vec({1, 1, 1})).lpNorm<Eigen::Infinity>(), 1e-6);
    } else {
      EXPECT_FALSE(r.ok()) << "the solver without LM crossed the valley: the test lost its point";
      EXPECT_GT((z - Vec({1, 1, 1})).lpNorm<Eigen::Infinity>(), 1e-4);  // crawled, not crossed
    }
  }
}

TEST(McpSolverTest, RestartEscapesAStationaryPointOfTheMerit) {
  // The equation z³ − 3z + 5 = 0 (one real root ≈ −2.279) started at z = 1, where F' = 0:
  // ∇Ψ = F F' = 0 but F = 3, a stationary point that is not a solution. The crash point
  // z₀ − F(z₀) = −2 leads to the root.
  McpProblem p;
  p.lower = VectorXd::Constant(1, -kInf);
  p.upper = VectorXd::Constant(1, kInf);
  p.evaluate = [](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    F->resize(1);
    (*F)(0) = z(0) * z(0) * z(0) - 3.0 * z(0) + 5.0;
    if (J != nullptr) {
      J->resize(1, 1);
      (*J)(0, 0) = 3.0 * z(0) * z(0) - 3.0;
    }
  };
  {
    VectorXd z = VectorXd::Ones(1);
    McpSolveStats stats;
    const SolverReport r = McpSolver(With(&McpOptions::max_restarts, 0)).Solve(p, &z, &stats);
    EXPECT_EQ(r.status, SolverStatus::kStalled);
    EXPECT_NE(r.message.find("stalled"), std::string::npos) << r.message;
    EXPECT_EQ(stats.restarts, 0);
    EXPECT_EQ(r.restarts, 0);
    EXPECT_EQ(z(0), 1.0);
  }
  // Record where F is evaluated: the restart must begin at the crash point.
  std::vector<double> evaluated;
  McpProblem recorded = p;
  recorded.evaluate = [&evaluated, inner = p.evaluate](const VectorXd& x, VectorXd* F,
                                                       MatrixXd* J) {
    evaluated.push_back(x(0));
    inner(x, F, J);
  };
  VectorXd z = VectorXd::Ones(1);
  McpSolveStats stats;
  const SolverReport r = McpSolver().Solve(recorded, &z, &stats);
  ExpectSolved(p, r, z);
  EXPECT_EQ(stats.restarts, 1);
  EXPECT_EQ(r.restarts, 1);  // visible in the report too
  EXPECT_NE(std::find(evaluated.begin(), evaluated.end(), -2.0), evaluated.end());
  EXPECT_NE(r.message.find("1 restart"), std::string::npos) << r.message;
  EXPECT_NEAR(z(0), -2.2790187861665, 1e-9);
}

// ---- Failures ----------------------------------------------------------------------------------

TEST(McpSolverTest, InfeasibleNcpTerminatesUnsolved) {
  // F(z) = −1 − z < 0 for every z ≥ 0: no solution.
  McpProblem p;
  p.lower = VectorXd::Zero(1);
  p.upper = VectorXd::Constant(1, kInf);
  p.evaluate = [](const VectorXd& z, VectorXd* F, MatrixXd* J) {
    F->resize(1);
    (*F)(0) = -1.0 - z(0);
    if (J != nullptr) J->setConstant(1, 1, -1.0);
  };
  for (double s : {0.0, 3.0}) {
    VectorXd z = VectorXd::Constant(1, s);
    McpSolveStats stats;
    const McpOptions options;
    const SolverReport r = McpSolver(options).Solve(p, &z, &stats);
    EXPECT_NE(r.status, SolverStatus::kSolved);
    EXPECT_FALSE(r.message.empty());
    EXPECT_LE(r.iterations, options.max_iterations);
    EXPECT_EQ(stats.restarts, options.max_restarts);
    EXPECT_EQ(r.restarts, options.max_restarts);
    EXPECT_EQ(r.residual, McpResidual(p, z));
    EXPECT_GE(r.residual, 1.0 - 1e-12);  // |z − max(0, 1 + 2z)| ≥ 1 everywhere on z ≥ 0
    EXPECT_GE(z(0), 0.0);
  }
}

TEST(McpSolverTest, ThrowingEvaluateIsANumericalFailure) {
  // Throws on the first call.
  McpProblem p = Josephy();
  p.evaluate = [](const VectorXd&, VectorXd*, MatrixXd*) {
    throw std::runtime_error("contact query failed");
  };
  VectorXd z = Vec({1, 1, 1, 1});
  SolverReport r;
  EXPECT_NO_THROW(r = McpSolver().Solve(p, &z));
  EXPECT_EQ(r.status, SolverStatus::kNumericalFailure);
  EXPECT_NE(r.message.find("contact query failed"), std::string::npos) << r.message;
  // Throws on the fourth call: z is the best iterate so far, inside the box.
  McpProblem q = Josephy();
  int calls = 0;
  const auto inner = q.evaluate;
  q.evaluate = [&calls, inner](const VectorXd& x, VectorXd* F, MatrixXd* J) {
    if (++calls == 4) throw std::runtime_error("late failure");
    inner(x, F, J);
  };
  z = Vec({10, 10, 10, 10});
  r = McpSolver().Solve(q, &z);
  EXPECT_EQ(r.status, SolverStatus::kNumericalFailure);
  EXPECT_NE(r.message.find("late failure"), std::string::npos) << r.message;
  EXPECT_GE(r.iterations, 1);
  EXPECT_TRUE(z.allFinite());
  EXPECT_GE(z.minCoeff(), 0.0);
  EXPECT_EQ(r.residual, McpResidual(Josephy(), z));
}

TEST(McpSolverTest, NonFiniteFunctionIsANumericalFailure) {
  McpProblem p = Josephy();
  p.evaluate = [](const VectorXd&, VectorXd* F, MatrixXd* J) {
    *F = VectorXd::Constant(4, std::numeric_limits<double>::quiet_NaN());
    if (J != nullptr) J->setZero(4, 4);
  };
  VectorXd z = Vec({1, 1, 1, 1});
  const SolverReport r = McpSolver().Solve(p, &z);
  EXPECT_EQ(r.status, SolverStatus::kNumericalFailure);
  EXPECT_NE(r.message.find("non-finite"), std::string::npos) << r.message;
  // A NaN Jacobian alone as well.
  McpProblem q = Josephy();
  const auto inner = q.evaluate;
  q.evaluate = [inner](const VectorXd& x, VectorXd* F, MatrixXd* J) {
    inner(x, F, J);
    if (J != nullptr) (*J)(2, 2) = std::numeric_limits<double>::quiet_NaN();
  };
  z = Vec({1, 1, 1, 1});
  EXPECT_EQ(McpSolver().Solve(q, &z).status, SolverStatus::kNumericalFailure);
}

// ---- Misuse ------------------------------------------------------------------------------------

TEST(McpSolverTest, InvalidInputThrows) {
  const McpProblem p = Josephy();
  const McpSolver solver;
  VectorXd z = VectorXd::Zero(4);
  ExpectInvalidArgument([&] { solver.Solve(p, nullptr); }, "z is null");
  VectorXd z3 = VectorXd::Zero(3);
  ExpectInvalidArgument([&] { solver.Solve(p, &z3); }, "z has size 3");
  McpProblem q = p;
  q.upper = VectorXd::Constant(3, kInf);
  ExpectInvalidArgument([&] { solver.Solve(q, &z); }, "upper has size 3");
  q = p;
  q.upper(2) = -1.0;
  ExpectInvalidArgument([&] { solver.Solve(q, &z); }, "bounds of row 2");
  q = p;
  q.lower(1) = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalidArgument([&] { solver.Solve(q, &z); }, "bounds of row 1");
  q = p;
  q.evaluate = nullptr;
  ExpectInvalidArgument([&] { solver.Solve(q, &z); }, "evaluate is empty");
  q = p;
  q.evaluate = [](const VectorXd&, VectorXd* F, MatrixXd*) { F->setZero(3); };
  ExpectInvalidArgument([&] { solver.Solve(q, &z); }, "F of size 3");
  VectorXd zbad = VectorXd::Zero(4);
  zbad(0) = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalidArgument([&] { solver.Solve(p, &zbad); }, "starting point");
  ExpectInvalidArgument([&] { McpSolver(With(&McpOptions::lambda, 0.0)).Solve(p, &z); }, "lambda");
  ExpectInvalidArgument([&] { McpSolver(With(&McpOptions::tolerance, -1.0)).Solve(p, &z); },
                        "tolerance");
  ExpectInvalidArgument([&] { McpSolver(With(&McpOptions::nonmonotone_memory, 0)).Solve(p, &z); },
                        "nonmonotone_memory");
  ExpectInvalidArgument([&] { McpSolver(With(&McpOptions::max_restarts, -1)).Solve(p, &z); },
                        "max_restarts");
  ExpectInvalidArgument([&] { McpFischerBurmeister(p, z, 1.5, nullptr); }, "lambda");
}

}  // namespace
}  // namespace vinci::sim
