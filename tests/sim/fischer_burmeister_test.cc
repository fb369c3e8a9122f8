// Tests of the semismooth Newton solver on the penalized Fischer–Burmeister function:
// closed-form LCPs, Murty's and the cycling example, random SPD and P-matrix problems,
// degenerate and infeasible problems, warm start, invalid input and determinism. Every
// solution is checked independently of the solver.
#include "vinci/sim/solvers/fischer_burmeister.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>

#include "contact_lcp_test_util.h"
#include "test_util.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_file.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

// The solver's default relative tolerance; used as the independent check as well.
constexpr double kTol = 1e-10;

LcpProblem Make(const MatrixXd& M, const VectorXd& q) { return LcpProblem{M, q}; }

// Independent check of a solution: z ≥ 0, w = Mz + q ≥ −tol, |z_i w_i| ≤ tol·(1 + |z_i|),
// and the residual recomputed by LcpResidual.
void ExpectLcpSolution(const LcpProblem& p, const VectorXd& z, double tol) {
  ASSERT_EQ(z.size(), p.size());
  ASSERT_TRUE(z.allFinite());
  const VectorXd w = p.M * z + p.q;
  const double scale = std::max(1.0, p.q.lpNorm<Eigen::Infinity>());
  for (int i = 0; i < p.size(); ++i) {
    EXPECT_GE(z(i), 0.0) << "i = " << i;
    EXPECT_GE(w(i), -tol * scale) << "i = " << i;
    EXPECT_LE(std::abs(z(i) * w(i)), tol * scale * (1.0 + std::abs(z(i)))) << "i = " << i;
  }
  EXPECT_LE(LcpResidual(p, z), tol * scale);
}

MatrixXd Uniform(int rows, int cols, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatrixXd A(rows, cols);
  for (int j = 0; j < cols; ++j) {
    for (int i = 0; i < rows; ++i) A(i, j) = u(*rng);
  }
  return A;
}

// Symmetric positive definite M (eigenvalues ≥ 0.5): unique solution.
LcpProblem RandomSpdLcp(int n, std::mt19937* rng) {
  const MatrixXd A = Uniform(n, n, rng);
  return Make(A * A.transpose() / n + 0.5 * MatrixXd::Identity(n, n), Uniform(n, 1, rng));
}

// Positive definite non-symmetric M (a P-matrix): unique solution.
LcpProblem RandomPMatrixLcp(int n, std::mt19937* rng) {
  const MatrixXd A = Uniform(n, n, rng);
  const MatrixXd S = Uniform(n, n, rng);
  return Make(A * A.transpose() / n + 0.1 * MatrixXd::Identity(n, n) + S - S.transpose(),
              Uniform(n, 1, rng));
}

// Murty's matrix: 1 on the diagonal, 2 above it; with q = −e the unique solution is e_n.
LcpProblem Murty(int n) {
  MatrixXd M = MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    M(i, i) = 1.0;
    for (int j = i + 1; j < n; ++j) M(i, j) = 2.0;
  }
  return Make(M, -VectorXd::Ones(n));
}

TEST(FischerBurmeisterTest, ScalarProblem) {
  const LcpProblem p = Make(MatrixXd::Ones(1, 1), VectorXd::Constant(1, -9.8));
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(z(0), 9.8, 1e-9);
  EXPECT_GT(r.iterations, 0);
  EXPECT_GE(r.time_s, 0.0);
  EXPECT_EQ(r.residual, LcpResidual(p, z));
  ExpectLcpSolution(p, z, kTol);
}

TEST(FischerBurmeisterTest, NonnegativeQGivesZeroWithoutIterations) {
  MatrixXd M(3, 3);
  M << 1, -2, 3, 0, -1, 4, 5, 6, -7;
  const LcpProblem p = Make(M, Eigen::Vector3d(0.0, 1.0, 2.0));
  VectorXd z = VectorXd::Constant(3, 7.0);
  const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(z, VectorXd::Zero(3));
  EXPECT_EQ(r.residual, 0.0);
}

TEST(FischerBurmeisterTest, EmptyProblemIsSolved) {
  VectorXd z = VectorXd::Ones(2);
  const SolverReport r = FischerBurmeisterSolver().Solve(LcpProblem{}, nullptr, &z);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(z.size(), 0);
}

TEST(FischerBurmeisterTest, CyclingExample) {
  MatrixXd M(3, 3);
  M << 1, 2, 0, 0, 1, 2, 2, 0, 1;
  const LcpProblem p = Make(M, -Eigen::Vector3d::Ones());
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(p, z, kTol);
  // Unique solution; M⁻¹ has norm ≤ 1, so the error is of the order of the residual.
  EXPECT_LE((z - Eigen::Vector3d::Constant(1.0 / 3.0)).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(FischerBurmeisterTest, MurtyExample) {
  for (int n : {8, 16}) {
    const LcpProblem p = Murty(n);
    VectorXd z;
    const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << "n = " << n << ": " << r.message;
    ExpectLcpSolution(p, z, kTol);
    VectorXd expected = VectorXd::Zero(n);
    expected(n - 1) = 1.0;
    EXPECT_LE((z - expected).lpNorm<Eigen::Infinity>(), 1e-9) << "n = " << n;
  }
}

TEST(FischerBurmeisterTest, RandomSpdAndPMatrixProblemsMatchLemke) {
  std::mt19937 rng(20240613);
  for (int n : {10, 50}) {
    for (int trial = 0; trial < 3; ++trial) {
      for (const LcpProblem& p : {RandomSpdLcp(n, &rng), RandomPMatrixLcp(n, &rng)}) {
        VectorXd z, z_lemke;
        const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
        ASSERT_TRUE(r.ok()) << "n = " << n << ", trial " << trial << ": " << r.message;
        EXPECT_GT(r.iterations, 0);
        EXPECT_EQ(r.residual, LcpResidual(p, z));
        ExpectLcpSolution(p, z, kTol);
        ASSERT_TRUE(LemkeSolver().Solve(p, nullptr, &z_lemke).ok());
        // Unique solutions; the P-matrices have a symmetric part ≥ 0.1 I, so a residual of
        // 1e-10 moves z by at most ~1e-9.
        EXPECT_LE((z - z_lemke).lpNorm<Eigen::Infinity>(), 1e-8) << "n = " << n;
      }
    }
  }
}

// Local convergence is superlinear: a P-matrix problem of size 50 takes few Newton steps.
TEST(FischerBurmeisterTest, NewtonConvergesInFewIterations) {
  std::mt19937 rng(8);
  const LcpProblem p = RandomPMatrixLcp(50, &rng);
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LE(r.iterations, 30);
  EXPECT_TRUE(r.message.empty()) << r.message;
}

TEST(FischerBurmeisterTest, DegenerateProblems) {
  // PSD singular with tied q (a continuum z_0 + z_1 = 1), and exact zeros in q.
  MatrixXd D(4, 4);
  D << 1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 2, -1, 0, 0, 1, 0;
  for (const LcpProblem& p : {Make(MatrixXd::Ones(2, 2), -Vector2d::Ones()),
                              Make(D, Eigen::Vector4d(-1.0, -1.0, 0.0, 0.0))}) {
    VectorXd z;
    const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    ExpectLcpSolution(p, z, kTol);
  }
}

// The 10-box stack at rest (n = 240): 4 contacts per face make the normal impulses
// indeterminate, so the solutions are not isolated and H is singular at every iterate. The
// minimum-norm least-squares direction still converges fast (a basic QR solution took 138
// iterations), and the step velocity is Lemke's.
TEST(FischerBurmeisterTest, DegenerateBoxStackLcpWithSingularJacobian) {
  Simulator sim(testing::LoadExample("box_stack.yaml"));
  const State x = sim.InitialState();
  const auto& st = dynamic_cast<const StewartTrinkle&>(sim.formulation());
  const StewartTrinkle::Assembly a = st.Assemble(sim.scene(), x, StepInput{});
  VectorXd v_star;
  StewartTrinkle::JointElimination joints;
  const LcpProblem p = st.BuildLcp(sim.scene(), a, x.v, &v_star, &joints);
  ASSERT_EQ(p.size(), 240);
  VectorXd z, z_lemke;
  const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LE(r.iterations, 30);
  EXPECT_NE(r.message.find("least-squares"), std::string::npos) << r.message;
  ExpectLcpSolution(p, z, kTol);
  ASSERT_TRUE(LemkeSolver().Solve(p, nullptr, &z_lemke).ok());
  // Residuals ≤ 1e-10 on 1 kg boxes: velocities agree to ~1e-9.
  EXPECT_LE((st.VelocityAfter(a, v_star, z, joints) - st.VelocityAfter(a, v_star, z_lemke, joints))
                .lpNorm<Eigen::Infinity>(),
            1e-8);
}

TEST(FischerBurmeisterTest, PlainFischerBurmeisterAlsoSolves) {
  FischerBurmeisterOptions o;
  o.lambda = 1.0;
  std::mt19937 rng(21);
  const LcpProblem p = RandomPMatrixLcp(20, &rng);
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver(o).Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(p, z, kTol);
}

TEST(FischerBurmeisterTest, InfeasibleProblemsFail) {
  // No z ≥ 0 has w ≥ 0 in any of these (see LemkeTest.InfeasibleProblemsEndOnSecondaryRay).
  for (const LcpProblem& p :
       {Make(MatrixXd::Zero(1, 1), VectorXd::Constant(1, -1.0)),
        Make(-MatrixXd::Identity(2, 2), -Vector2d::Ones()),
        Make((MatrixXd(2, 2) << 1, 0, -1, 0).finished(), -Vector2d::Ones())}) {
    VectorXd z;
    const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
    EXPECT_FALSE(r.ok());
    EXPECT_TRUE(r.status == SolverStatus::kMaxIterations ||
                r.status == SolverStatus::kNumericalFailure)
        << ToString(r.status);
    EXPECT_FALSE(r.message.empty());
    ASSERT_EQ(z.size(), p.size());
    EXPECT_TRUE(z.allFinite());
    EXPECT_GE(z.minCoeff(), 0.0);
    EXPECT_EQ(r.residual, LcpResidual(p, z));
    EXPECT_GE(r.residual, 1.0 - 1e-12);  // no z can do better than |w_i| = 1
  }
}

// The penalty term must carry the sign of the FB term on the orthant: mixing the conventions,
// λ(√(a² + b²) − a − b) + (1 − λ) a₊ b₊, has a spurious root at a = b = λ(2 − √2)/(1 − λ).
// Started there (M = 1, q = 0, so a = b = z), the solver must still reach z = 0.
TEST(FischerBurmeisterTest, PenaltySignHasNoSpuriousRoot) {
  const FischerBurmeisterOptions o;
  const double t = o.lambda * (2.0 - std::sqrt(2.0)) / (1.0 - o.lambda);
  const LcpProblem p = Make(MatrixXd::Ones(1, 1), VectorXd::Zero(1));
  const VectorXd start = VectorXd::Constant(1, t);
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver(o).Solve(p, &start, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.iterations, 0);
  EXPECT_LE(z(0), kTol);
}

// A larger iteration limit never returns a worse point (the best iterate is kept).
TEST(FischerBurmeisterTest, MoreIterationsNeverReturnAWorsePoint) {
  std::mt19937 rng(31);
  const LcpProblem p = RandomPMatrixLcp(40, &rng);
  double previous = LcpResidual(p, VectorXd::Zero(p.size()));
  int limit_hit = 0;
  for (int iterations = 1; iterations <= 30; ++iterations) {
    FischerBurmeisterOptions o;
    o.max_iterations = iterations;
    o.lemke_fallback = false;  // Newton's own iterates
    o.proximal_fallback = false;
    VectorXd z;
    const SolverReport r = FischerBurmeisterSolver(o).Solve(p, nullptr, &z);
    if (r.status == SolverStatus::kMaxIterations) ++limit_hit;
    EXPECT_LE(r.residual, previous) << "iterations = " << iterations;
    previous = std::min(previous, r.residual);
  }
  EXPECT_GT(limit_hit, 3);  // the limit was reached in several runs (the check is not vacuous)
}

TEST(FischerBurmeisterTest, IterationLimitIsReported) {
  const LcpProblem p = Murty(16);
  FischerBurmeisterOptions o;
  o.max_iterations = 2;
  o.lemke_fallback = false;  // Newton's own limit
  o.proximal_fallback = false;
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver(o).Solve(p, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(r.iterations, 2);
  EXPECT_NE(r.message.find("iteration limit 2"), std::string::npos) << r.message;
  EXPECT_EQ(r.residual, LcpResidual(p, z));
  EXPECT_GT(r.residual, kTol);
  EXPECT_LT(r.residual, 1.0);  // the best iterate beats the start z = 0 (residual 1)
}

// A tilted box pile step (tests/data/lcp/box_pile_tilted_step233.lcp, n = 234, see
// LemkeTest.TiltedPileLcpsSolvedThroughTheReportedProximalFallback): Newton from z = 0 stalls
// at residual 1.5e-6; the proximal-point fallback reaches the tolerance, without Lemke.
TEST(FischerBurmeisterTest, ProximalFallbackSolvesTheTiltedPileStep) {
  const LcpProblem p = ReadLcpFile(VINCI_SOURCE_DIR "/tests/data/lcp/box_pile_tilted_step233.lcp");
  FischerBurmeisterOptions o;
  o.lemke_fallback = false;  // the proximal loop alone
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver(o).Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.restarts, 1);
  EXPECT_NE(r.message.find("proximal-point fallback"), std::string::npos) << r.message;
  EXPECT_EQ(r.residual, LcpResidual(p, z));
  EXPECT_LE(r.residual, kTol);  // ‖q‖∞ < 1, so the scaled tolerance is kTol itself
  EXPECT_GE(z.minCoeff(), 0.0);
  // Without the fallback Newton stalls: the failure is reported, the proximal loop is needed.
  o.proximal_fallback = false;
  VectorXd z_plain;
  const SolverReport plain = FischerBurmeisterSolver(o).Solve(p, nullptr, &z_plain);
  EXPECT_FALSE(plain.ok());
  EXPECT_EQ(plain.restarts, 0);
  EXPECT_GT(plain.residual, 100 * kTol);
}

// A cold-started step of the same pile (box_pile_tilted_cold_step232.lcp): Newton stalls at
// 5e-7, the proximal loop at 2e-8 (its subproblems stall too); the Lemke fallback then solves
// it. Both fallbacks are reported and counted.
TEST(FischerBurmeisterTest, LemkeFallbackAfterTheProximalFallbackIsReported) {
  const LcpProblem p =
      ReadLcpFile(VINCI_SOURCE_DIR "/tests/data/lcp/box_pile_tilted_cold_step232.lcp");
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.restarts, 2);
  EXPECT_NE(r.message.find("proximal-point fallback"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("Lemke fallback"), std::string::npos) << r.message;
  EXPECT_EQ(r.residual, LcpResidual(p, z));
  EXPECT_LE(r.residual, kTol);  // ‖q‖∞ < 1
  EXPECT_GE(z.minCoeff(), 0.0);
}

TEST(FischerBurmeisterTest, ExactWarmStartNeedsNoIterations) {
  std::mt19937 rng(3);
  const LcpProblem p = RandomPMatrixLcp(30, &rng);
  VectorXd z_lemke;
  ASSERT_TRUE(LemkeSolver().Solve(p, nullptr, &z_lemke).ok());
  VectorXd z;
  const SolverReport r = FischerBurmeisterSolver().Solve(p, &z_lemke, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(z, z_lemke);
  // Aliased warm start and output.
  z = z_lemke;
  const SolverReport aliased = FischerBurmeisterSolver().Solve(p, &z, &z);
  ASSERT_TRUE(aliased.ok());
  EXPECT_EQ(aliased.iterations, 0);
  EXPECT_EQ(z, z_lemke);
  // An inexact warm start still converges; a wrong-size one is ignored.
  const VectorXd guess = z_lemke + 0.1 * VectorXd::Ones(30);
  const SolverReport r2 = FischerBurmeisterSolver().Solve(p, &guess, &z);
  ASSERT_TRUE(r2.ok()) << r2.message;
  EXPECT_GT(r2.iterations, 0);
  ExpectLcpSolution(p, z, kTol);
  const VectorXd wrong = VectorXd::Ones(3);
  const SolverReport r3 = FischerBurmeisterSolver().Solve(p, &wrong, &z);
  ASSERT_TRUE(r3.ok()) << r3.message;
  ExpectLcpSolution(p, z, kTol);
}

TEST(FischerBurmeisterTest, InvalidInputIsReportedNotThrown) {
  const FischerBurmeisterSolver solver;
  VectorXd z;
  const LcpProblem nan_q = Make(MatrixXd::Identity(2, 2), Vector2d(std::nan(""), -1.0));
  const SolverReport r0 = solver.Solve(nan_q, nullptr, &z);
  EXPECT_EQ(r0.status, SolverStatus::kInvalidInput);
  EXPECT_TRUE(std::isnan(r0.residual));
  EXPECT_EQ(z, VectorXd::Zero(2));
  MatrixXd inf_m = MatrixXd::Identity(2, 2);
  inf_m(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(solver.Solve(Make(inf_m, -Vector2d::Ones()), nullptr, &z).status,
            SolverStatus::kInvalidInput);
  const SolverReport r =
      solver.Solve(Make(MatrixXd::Identity(3, 3), -Vector2d::Ones()), nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kInvalidInput);
  EXPECT_NE(r.message.find("3x3"), std::string::npos) << r.message;
  EXPECT_EQ(solver.Solve(Make(MatrixXd::Identity(2, 3), -Vector2d::Ones()), nullptr, &z).status,
            SolverStatus::kInvalidInput);
}

TEST(FischerBurmeisterTest, MisuseThrows) {
  const LcpProblem p = Make(MatrixXd::Identity(1, 1), VectorXd::Constant(1, -1.0));
  EXPECT_THROW(FischerBurmeisterSolver().Solve(p, nullptr, nullptr), std::invalid_argument);
  VectorXd z;
  for (double lambda : {0.0, 1.5, std::nan("")}) {
    FischerBurmeisterOptions o;
    o.lambda = lambda;
    try {
      FischerBurmeisterSolver(o).Solve(p, nullptr, &z);
      FAIL() << "expected std::invalid_argument for lambda = " << lambda;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("lambda"), std::string::npos) << e.what();
    }
  }
  FischerBurmeisterOptions o;
  o.max_iterations = -1;
  EXPECT_THROW(FischerBurmeisterSolver(o).Solve(p, nullptr, &z), std::invalid_argument);
  o = FischerBurmeisterOptions{};
  o.tolerance = -1.0;
  EXPECT_THROW(FischerBurmeisterSolver(o).Solve(p, nullptr, &z), std::invalid_argument);
}

TEST(FischerBurmeisterTest, DeterministicAcrossCallsAndThreads) {
  std::mt19937 rng(13);
  const LcpProblem p = RandomPMatrixLcp(40, &rng);
  const FischerBurmeisterSolver solver;
  VectorXd z1, z2, z3;
  const SolverReport r1 = solver.Solve(p, nullptr, &z1);
  const SolverReport r2 = solver.Solve(p, nullptr, &z2);
  SolverReport r3;
  std::thread t([&] { r3 = solver.Solve(p, nullptr, &z3); });
  t.join();
  ASSERT_TRUE(r1.ok()) << r1.message;
  ASSERT_EQ(z1.size(), z2.size());
  ASSERT_EQ(z1.size(), z3.size());
  EXPECT_EQ(std::memcmp(z1.data(), z2.data(), sizeof(double) * z1.size()), 0);
  EXPECT_EQ(std::memcmp(z1.data(), z3.data(), sizeof(double) * z1.size()), 0);
  EXPECT_EQ(r1.iterations, r2.iterations);
  EXPECT_EQ(r1.iterations, r3.iterations);
  EXPECT_EQ(r1.residual, r3.residual);
}

// 300 random contact LCPs (1–8 spatial bodies, 1–5 contacts per body, 4 friction directions;
// fixed seed), the Stewart–Trinkle structure with its zero σ diagonal and degenerate friction
// rows. Newton alone stalls on problem 64 (n = 240, residual 9e-4 at the iteration limit);
// the proximal-point fallback solves it (5 outer steps, 35 Newton steps; before it existed,
// the Lemke fallback did) and is reported.
TEST(FischerBurmeisterTest, RandomContactLcpsAllSolve) {
  constexpr int kProblems = 300;
  // Newton itself must do almost all of them: the fallback is a safety net.
  constexpr int kMaxFallbacks = 3;
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> bodies(1, 8);
  int solved = 0, fallbacks = 0, newton_failures = 0;
  FischerBurmeisterOptions newton_only;
  newton_only.lemke_fallback = false;
  newton_only.proximal_fallback = false;
  for (int k = 0; k < kProblems; ++k) {
    const int nb = bodies(rng);
    const int nc = std::uniform_int_distribution<int>(1, 5 * nb)(rng);
    const sim::testing::ContactLcp c = sim::testing::RandomContactLcp(nb, nc, 4, &rng);
    VectorXd z;
    const SolverReport r = FischerBurmeisterSolver().Solve(c.lcp, nullptr, &z);
    EXPECT_TRUE(r.ok()) << "problem " << k << " (n = " << c.lcp.size() << "): " << r.message;
    const bool proximal = r.message.find("proximal-point fallback") != std::string::npos;
    const bool lemke = r.message.find("Lemke fallback") != std::string::npos;
    const bool fell_back = proximal || lemke;
    EXPECT_EQ(r.restarts, (proximal ? 1 : 0) + (lemke ? 1 : 0)) << r.message;
    if (fell_back) {
      ++fallbacks;
      VectorXd z_newton;
      EXPECT_FALSE(FischerBurmeisterSolver(newton_only).Solve(c.lcp, nullptr, &z_newton).ok());
    }
    if (r.ok()) {
      ++solved;
      ExpectLcpSolution(c.lcp, z, kTol);
    } else {
      ++newton_failures;
    }
  }
  EXPECT_EQ(solved, kProblems);
  EXPECT_EQ(newton_failures, 0);
  EXPECT_GE(fallbacks, 1);  // problem 64: the fallback path is exercised
  EXPECT_LE(fallbacks, kMaxFallbacks);
}

}  // namespace
}  // namespace vinci::sim
