// Tests of the Lemke LCP solver: closed-form LCPs, known hard cases (exponential, cycling,
// degenerate, infeasible), Stewart–Trinkle contact LCPs, warm start, regularized retry,
// invalid input and determinism. Every solution is checked independently of the solver.
#include "vinci/sim/solvers/lemke.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "contact_lcp_test_util.h"
#include "test_util.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_acceptance.h"
#include "vinci/sim/solvers/lcp_file.h"

namespace vinci::sim {
namespace {

using testing::AddContactColumns;
using testing::BoxOnPlane;
using testing::ContactLcp;
using testing::RandomContactLcp;
using testing::Uniform;

// Default residual_tolerance of the solver; used as the independent check as well.
constexpr double kTol = 1e-9;
constexpr double kGravity = 9.81;  // m/s²

// The acceptance scale documented in lemke.h, max(b, min(‖M‖∞‖z‖∞, 1000·b)) with
// b = max(1, ‖q‖∞) and ‖M‖∞ the max absolute row sum, computed here independently.
double AcceptanceScale(const LcpProblem& p, const VectorXd& z) {
  double m_norm = 0.0;
  for (int i = 0; i < p.size(); ++i) {
    double row = 0.0;
    for (int j = 0; j < p.size(); ++j) row += std::abs(p.M(i, j));
    m_norm = std::max(m_norm, row);
  }
  double z_norm = 0.0, q_norm = 0.0;
  for (int i = 0; i < p.size(); ++i) {
    z_norm = std::max(z_norm, std::abs(z(i)));
    q_norm = std::max(q_norm, std::abs(p.q(i)));
  }
  const double base = std::max(1.0, q_norm);
  return std::max(base, std::min(m_norm * z_norm, 1e3 * base));
}

// Independent check of a solution with the documented scaled criterion (s = AcceptanceScale):
// z ≥ 0, w = Mz + q ≥ −tol·s, |z_i w_i| ≤ tol·s·(1 + |z_i|), and LcpResidual ≤ tol·s.
void ExpectLcpSolution(const LcpProblem& p, const VectorXd& z, double tol) {
  ASSERT_EQ(z.size(), p.size());
  ASSERT_TRUE(z.allFinite());
  const VectorXd w = p.M * z + p.q;
  const double scale = AcceptanceScale(p, z);
  for (int i = 0; i < p.size(); ++i) {
    EXPECT_GE(z(i), 0.0) << "i = " << i;
    EXPECT_GE(w(i), -tol * scale) << "i = " << i;
    EXPECT_LE(std::abs(z(i) * w(i)), tol * scale * (1.0 + std::abs(z(i)))) << "i = " << i;
  }
  EXPECT_LE(LcpResidual(p, z), tol * scale);
}

LcpProblem Make(const MatrixXd& M, const VectorXd& q) { return LcpProblem{M, q}; }

// Murty's matrix: 1 on the diagonal, 2 above it.
LcpProblem Murty(int n) {
  MatrixXd M = MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) {
    M(i, i) = 1.0;
    for (int j = i + 1; j < n; ++j) M(i, j) = 2.0;
  }
  return Make(M, -VectorXd::Ones(n));
}

// Monotone (PSD, non-symmetric, rank n/2 symmetric part) LCP with a planted complementary
// solution, so it is solvable; many entries are degenerate (z_i = w_i = 0).
LcpProblem RandomPsdLcp(int n, std::mt19937* rng) {
  const MatrixXd A = Uniform(n, n / 2 + 1, rng);
  const MatrixXd S = Uniform(n, n, rng);
  const MatrixXd M = A * A.transpose() + S - S.transpose();
  std::uniform_real_distribution<double> u(0.0, 1.0);
  VectorXd z(n), w(n);
  for (int i = 0; i < n; ++i) {
    const double r = u(*rng);
    z(i) = r < 0.4 ? u(*rng) + 0.1 : 0.0;
    w(i) = r >= 0.5 ? u(*rng) + 0.1 : 0.0;  // 0.4 ≤ r < 0.5: degenerate pair
  }
  return Make(M, w - M * z);
}

// Positive definite non-symmetric matrix (a P-matrix): unique solution for every q.
LcpProblem RandomPMatrixLcp(int n, std::mt19937* rng) {
  const MatrixXd A = Uniform(n, n, rng);
  const MatrixXd S = Uniform(n, n, rng);
  const MatrixXd M = A * A.transpose() / n + 0.1 * MatrixXd::Identity(n, n) + S - S.transpose();
  return Make(M, Uniform(n, 1, rng));
}

TEST(LcpTest, ToStringNamesEveryStatus) {
  EXPECT_EQ(ToString(SolverStatus::kSolved), "solved");
  EXPECT_EQ(ToString(SolverStatus::kSecondaryRay), "secondary ray");
  EXPECT_EQ(ToString(SolverStatus::kMaxIterations), "max iterations");
  EXPECT_EQ(ToString(SolverStatus::kNumericalFailure), "numerical failure");
  EXPECT_EQ(ToString(SolverStatus::kInvalidInput), "invalid input");
  EXPECT_EQ(ToString(SolverStatus::kStalled), "stalled");
}

TEST(LcpTest, ResidualIsZeroAtSolutionAndMeasuresViolation) {
  const LcpProblem p = Make(MatrixXd::Identity(2, 2), Vector2d(-1.0, 2.0));
  EXPECT_EQ(LcpResidual(p, Vector2d(1.0, 0.0)), 0.0);
  EXPECT_DOUBLE_EQ(LcpResidual(p, Vector2d(0.0, 0.0)), 1.0);   // w_0 = −1
  EXPECT_DOUBLE_EQ(LcpResidual(p, Vector2d(1.0, -0.5)), 0.5);  // z_1 < 0
  EXPECT_DOUBLE_EQ(LcpResidual(p, Vector2d(3.0, 0.0)), 2.0);   // z_0 w_0 ≠ 0
  EXPECT_TRUE(std::isnan(LcpResidual(p, Vector2d(std::nan(""), 0.0))));
}

TEST(LcpTest, ResidualThrowsOnSizeMismatch) {
  const LcpProblem p = Make(MatrixXd::Identity(2, 2), Vector2d(-1.0, 2.0));
  EXPECT_THROW(LcpResidual(p, VectorXd::Zero(3)), std::invalid_argument);
  EXPECT_THROW(LcpResidual(Make(MatrixXd::Identity(3, 2), Vector2d(1, 1)), Vector2d(0, 0)),
               std::invalid_argument);
}

TEST(LemkeTest, ScalarProblem) {
  const LcpProblem p = Make(MatrixXd::Ones(1, 1), VectorXd::Constant(1, -9.8));
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(z(0), 9.8, 1e-12);
  EXPECT_FALSE(r.regularized);
  EXPECT_GE(r.time_s, 0.0);
  ExpectLcpSolution(p, z, kTol);
}

TEST(LemkeTest, NonnegativeQGivesZeroWithoutPivots) {
  MatrixXd M(3, 3);
  M << 1, -2, 3, 0, -1, 4, 5, 6, -7;
  const LcpProblem p = Make(M, Eigen::Vector3d(0.0, 1.0, 2.0));
  VectorXd z = VectorXd::Constant(3, 7.0);
  const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(z, VectorXd::Zero(3));
  EXPECT_EQ(r.residual, 0.0);
}

TEST(LemkeTest, EmptyProblemIsSolved) {
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(LcpProblem{}, nullptr, &z);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(z.size(), 0);
}

class LemkeOptionsTest : public ::testing::TestWithParam<std::tuple<bool, bool>> {
 protected:
  LemkeOptions Options() const {
    LemkeOptions o;
    o.lexicographic = std::get<0>(GetParam());
    o.scale = std::get<1>(GetParam());
    return o;
  }
};

// Murty's matrix with q = −e (a P-matrix, unique solution e_n).
TEST_P(LemkeOptionsTest, MurtyExponentialExample) {
  for (int n : {8, 16}) {
    const LcpProblem p = Murty(n);
    VectorXd z;
    const SolverReport r = LemkeSolver(Options()).Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << "n = " << n << ": " << r.message;
    ExpectLcpSolution(p, z, kTol);
    VectorXd expected = VectorXd::Zero(n);
    expected(n - 1) = 1.0;
    EXPECT_LE((z - expected).lpNorm<Eigen::Infinity>(), 1e-12) << "n = " << n;
  }
}

// The transpose (1 on the diagonal, 2 below, q = −e; solution e_1) is the exponential case
// for Lemke with covering vector e: exactly 2^n pivots (Murty 1978).
TEST_P(LemkeOptionsTest, MurtyLowerTriangularExponentialPath) {
  for (int n : {8, 16}) {
    LcpProblem p = Murty(n);
    p.M.transposeInPlace();
    LemkeOptions o = Options();
    o.max_pivots = 1 << 17;
    VectorXd z;
    const SolverReport r = LemkeSolver(o).Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << "n = " << n << ": " << r.message;
    // The count is that of the lexicographic (perturbed, nondegenerate) path; the plain rule
    // breaks the degenerate ties of q = −e differently and happens to finish in 4 pivots.
    if (o.lexicographic) {
      EXPECT_EQ(r.iterations, 1 << n);
    }
    ExpectLcpSolution(p, z, kTol);
    VectorXd expected = VectorXd::Zero(n);
    expected(0) = 1.0;
    EXPECT_LE((z - expected).lpNorm<Eigen::Infinity>(), 1e-12) << "n = " << n;
  }
}

TEST(LemkeTest, ExponentialPathHitsTheDefaultPivotLimitCleanly) {
  const int n = 16;  // 2^16 pivots needed, default limit 50n + 100 = 900
  LcpProblem p = Murty(n);
  p.M.transposeInPlace();
  LemkeOptions o;
  o.regularization = 0.0;
  VectorXd z;
  const SolverReport r = LemkeSolver(o).Solve(p, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(r.iterations, 50 * n + 100);
  EXPECT_NE(r.message.find("pivot limit"), std::string::npos) << r.message;
  ASSERT_EQ(z.size(), n);
  EXPECT_TRUE(z.allFinite());
  EXPECT_EQ(r.residual, LcpResidual(p, z));
}

// The classic 3×3 cycling example (P-matrix, unique solution (1/3, 1/3, 1/3)).
TEST_P(LemkeOptionsTest, CyclingExample) {
  if (!std::get<0>(GetParam())) GTEST_SKIP() << "anti-cycling needs the lexicographic rule";
  MatrixXd M(3, 3);
  M << 1, 2, 0, 0, 1, 2, 2, 0, 1;
  const LcpProblem p = Make(M, -Eigen::Vector3d::Ones());
  VectorXd z;
  const SolverReport r = LemkeSolver(Options()).Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(p, z, kTol);
  EXPECT_LE((z - Eigen::Vector3d::Constant(1.0 / 3.0)).lpNorm<Eigen::Infinity>(), 1e-12);
}

// PSD singular with tied q: a continuum of solutions z_0 + z_1 = 1.
TEST_P(LemkeOptionsTest, DegenerateTiedPsd) {
  const LcpProblem p = Make(MatrixXd::Ones(2, 2), -Vector2d::Ones());
  VectorXd z;
  const SolverReport r = LemkeSolver(Options()).Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(p, z, kTol);
  EXPECT_NEAR(z.sum(), 1.0, 1e-12);
}

TEST_P(LemkeOptionsTest, DegenerateWithZerosInQ) {
  // q has exact zeros and ties: every ratio test in the first pivots is degenerate.
  MatrixXd M(4, 4);
  M << 1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 2, -1, 0, 0, 1, 0;
  const LcpProblem p = Make(M, Eigen::Vector4d(-1.0, -1.0, 0.0, 0.0));
  VectorXd z;
  const SolverReport r = LemkeSolver(Options()).Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(p, z, kTol);
}

TEST_P(LemkeOptionsTest, RandomPsdAndPMatrixProblems) {
  std::mt19937 rng(20240611);
  for (int n : {10, 50, 200}) {
    for (int trial = 0; trial < 3; ++trial) {
      for (const LcpProblem& p : {RandomPsdLcp(n, &rng), RandomPMatrixLcp(n, &rng)}) {
        VectorXd z;
        const SolverReport r = LemkeSolver(Options()).Solve(p, nullptr, &z);
        ASSERT_TRUE(r.ok()) << "n = " << n << ", trial " << trial << ": " << r.message;
        EXPECT_FALSE(r.regularized);
        EXPECT_GT(r.iterations, 0);
        ExpectLcpSolution(p, z, kTol);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(LexAndScale, LemkeOptionsTest,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool()));

// Stewart–Trinkle LCPs recorded from simulations that the default options used to fail:
// a box sliding down an incline (n = 40; the lexicographic rule pivoted on a noise entry of
// 1.5e-12 in a degenerate step, residual 0.54) and a 10-box stack at rest (n = 240, highly
// degenerate; ~200 rows, z0 among them, tied at one ratio up to roundoff, z0 was not seen as
// blocking and the run ended on a spurious secondary ray).
const char* const kRecordedLcps[] = {
    VINCI_SOURCE_DIR "/tests/data/lcp/incline_sliding_step9744.lcp",
    VINCI_SOURCE_DIR "/tests/data/lcp/box_stack_cold_step425.lcp",
};

TEST(LemkeTest, RecordedContactLcpsSolveWithDefaultOptions) {
  for (const char* path : kRecordedLcps) {
    SCOPED_TRACE(path);
    const LcpProblem p = ReadLcpFile(path);
    VectorXd z;
    const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    // Solved by the plain run itself: no regularized retry and no retry without scaling.
    EXPECT_FALSE(r.regularized) << r.message;
    EXPECT_TRUE(r.message.empty()) << r.message;
    EXPECT_EQ(r.residual, LcpResidual(p, z));
    ExpectLcpSolution(p, z, kTol);
  }
}

// Cold solves of the 10-box stack that the absolute acceptance test max(1, ‖q‖∞)·1e-9
// rejected: step 1410 (residual 1.4e-9, ‖M‖∞‖z‖∞ = 6.1) and step 7724 (residual 3.8e-8
// after termination, a basic w_i left negative by the degenerate basis; FB polish needed).
TEST(LemkeTest, ColdStackLcpsPassTheScaledTest) {
  const struct {
    const char* path;
    bool polished;
  } cases[] = {
      {VINCI_SOURCE_DIR "/tests/data/lcp/box_stack_cold_step1410.lcp", false},
      {VINCI_SOURCE_DIR "/tests/data/lcp/box_stack_cold_step7724.lcp", true},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.path);
    const LcpProblem p = ReadLcpFile(c.path);
    VectorXd z;
    const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_FALSE(r.regularized) << r.message;
    EXPECT_EQ(r.residual, LcpResidual(p, z));
    // The reported tolerance is the documented one, recomputed independently.
    EXPECT_NEAR(r.tolerance, kTol * AcceptanceScale(p, z), 1e-12 * r.tolerance);
    EXPECT_GT(AcceptanceScale(p, z), std::max(1.0, p.q.lpNorm<Eigen::Infinity>()));
    EXPECT_EQ(r.message.find("polished") != std::string::npos, c.polished) << r.message;
    ExpectLcpSolution(p, z, kTol);
  }
}

// A sensitivity LCP of box_on_plane.yaml (sensitivity_linearization.h) whose q is round-off,
// ‖q‖∞ = 5.3e-22. At that scale Lemke's absolute pivot and tie tolerances leave an iterate
// accurate only to q's own size, which the scale-aware check rejects and the Fischer–Burmeister
// polish repairs; with `polish` off the failure goes to the retries instead and the report does
// not claim a polish. The LCP is positively homogeneous in q, and at unit scale (q · 2^71,
// exact) plain Lemke solves it with no polish, to the same M λ after scaling back.
TEST(LemkeTest, RoundoffSizedQIsSolvedAtUnitScaleWithoutPolish) {
  const LcpProblem p =
      ReadLcpFile(VINCI_SOURCE_DIR "/tests/data/lcp/box_sensitivity_roundoff_q.lcp");
  ASSERT_EQ(p.size(), 32);
  const double q_norm = p.q.lpNorm<Eigen::Infinity>();
  ASSERT_LT(q_norm, 1e-20);
  VectorXd z_own;
  const SolverReport own = LemkeSolver().Solve(p, nullptr, &z_own);
  ASSERT_TRUE(own.ok()) << own.message;
  EXPECT_NE(own.message.find("polished"), std::string::npos) << own.message;

  LemkeOptions no_polish;
  no_polish.polish = false;
  no_polish.regularization = 0.0;
  no_polish.newton_fallback = false;
  VectorXd z_plain;
  const SolverReport plain = LemkeSolver(no_polish).Solve(p, nullptr, &z_plain);
  EXPECT_EQ(plain.message.find("polished"), std::string::npos) << plain.message;
  EXPECT_FALSE(plain.ok()) << plain.message;

  const int exponent = std::ilogb(q_norm);
  LcpProblem unit = p;
  unit.q *= std::ldexp(1.0, -exponent);
  VectorXd z_unit;
  const SolverReport r = LemkeSolver(no_polish).Solve(unit, nullptr, &z_unit);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_TRUE(r.message.empty()) << r.message;
  ExpectLcpSolution(unit, z_unit, kTol);
  const VectorXd z_back = std::ldexp(1.0, exponent) * z_unit;
  EXPECT_TRUE(CheckLcpSolution(p, z_back).empty()) << CheckLcpSolution(p, z_back);
  // M is symmetric positive semidefinite and singular: λ is not unique, but M λ is.
  EXPECT_LE((p.M * (z_back - z_own)).lpNorm<Eigen::Infinity>(), 1e-6 * q_norm);
}

// A pile with a tilted box landing on an edge (box_pile.yaml with rpy (0.3, 0.2, 0.5) on the
// dropped box), step 216, n = 246: every Lemke attempt ends on a spurious secondary ray; the
// Fischer–Burmeister Newton fallback solves it and says so.
TEST(LemkeTest, PileLcpSolvedByTheReportedNewtonFallback) {
  const LcpProblem p = ReadLcpFile(VINCI_SOURCE_DIR "/tests/data/lcp/box_pile_tilted_step216.lcp");
  ASSERT_EQ(p.size(), 246);
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.restarts, 1);
  EXPECT_NE(r.message.find("Newton fallback"), std::string::npos) << r.message;
  EXPECT_FALSE(r.regularized);
  ExpectLcpSolution(p, z, kTol);
  // Without the fallback the failure is reported, not hidden.
  LemkeOptions o;
  o.newton_fallback = false;
  VectorXd z_plain;
  const SolverReport plain = LemkeSolver(o).Solve(p, nullptr, &z_plain);
  EXPECT_FALSE(plain.ok());
  EXPECT_EQ(plain.restarts, 0);
  EXPECT_EQ(plain.residual, LcpResidual(p, z_plain));
}

// The tilted pile again (box_pile_tilted.yaml): step 233 as recorded at commit 57cc679 and
// step 232 of a cold-started run with the current stepper, n = 234. A dropped box lands
// flat on the top box with six contact points (rank 3) while sliding at ~0.26 m/s; M_nn has
// rank 19 of 39 and every Lemke attempt ends on a spurious secondary ray or terminates in a
// basis whose residual is 0.08–0.3 (pivots on roundoff-sized entries); FB Newton from the
// terminated iterate stalls (residual 8e-7 after 100 steps). FB Newton's proximal-point fallback
// (fischer_burmeister.h) solves both, and the report says how.
TEST(LemkeTest, TiltedPileLcpsSolvedThroughTheReportedProximalFallback) {
  for (const char* path : {VINCI_SOURCE_DIR "/tests/data/lcp/box_pile_tilted_step233.lcp",
                           VINCI_SOURCE_DIR "/tests/data/lcp/box_pile_tilted_cold_step232.lcp"}) {
    SCOPED_TRACE(path);
    const LcpProblem p = ReadLcpFile(path);
    ASSERT_EQ(p.size(), 234);
    VectorXd z;
    const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_NE(r.message.find("proximal-point fallback"), std::string::npos) << r.message;
    EXPECT_FALSE(r.regularized) << r.message;
    EXPECT_EQ(r.residual, LcpResidual(p, z));
    ExpectLcpSolution(p, z, kTol);
  }
}

// Stepping the 10-box stack with no warm start: every step a cold Lemke solve of a
// degenerate n = 240 LCP (the absolute residual test failed at step 1410).
TEST(LemkeTest, ColdStartedStackSimulates2000Steps) {
  constexpr int kSteps = 2000;
  Simulator sim(testing::LoadExample("box_stack.yaml"));
  ASSERT_EQ(sim.scene().options.solver, "lemke");
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState();
  State next;
  int regularized = 0;
  for (int k = 0; k < kSteps; ++k) {
    x.warm_start.resize(0);  // cold start
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    ASSERT_LE(info.solver.residual, info.solver.tolerance) << "step " << k;
    ASSERT_GT(info.solver.iterations, 0) << "step " << k;  // really solved cold
    if (info.solver.regularized) ++regularized;
    x = next;
  }
  EXPECT_EQ(regularized, 0);
  // The stack still stands: the top box (q offset of the last body) near its initial height.
  const Scene& s = sim.scene();
  const int top = s.dynamic_bodies().back();
  EXPECT_NEAR(x.q[s.index(top).q + 2], sim.InitialState().q[s.index(top).q + 2], 1e-3);
}

TEST_P(LemkeOptionsTest, RecordedContactLcps) {
  LemkeOptions o = Options();
  o.regularization = 0.0;  // the plain run must do it
  for (const char* path : kRecordedLcps) {
    SCOPED_TRACE(path);
    const LcpProblem p = ReadLcpFile(path);
    VectorXd z;
    const SolverReport r = LemkeSolver(o).Solve(p, nullptr, &z);
    // Clean termination in every case: a real status, a finite z ≥ 0, a truthful residual.
    EXPECT_NE(r.status, SolverStatus::kInvalidInput);
    ASSERT_EQ(z.size(), p.size());
    ASSERT_TRUE(z.allFinite());
    EXPECT_GE(z.minCoeff(), 0.0);
    EXPECT_EQ(r.residual, LcpResidual(p, z));
    // Every combination solves both problems (non-lexicographic included, which has no
    // anti-cycling guarantee but does solve these two).
    ASSERT_TRUE(r.ok()) << r.message;
    if (o.scale) {
      EXPECT_EQ(r.message.find("without scaling"), std::string::npos) << r.message;
    }
    ExpectLcpSolution(p, z, kTol);
  }
}

TEST(LemkeTest, InfeasibleProblemsEndOnSecondaryRay) {
  // w = 0·z − 1 < 0 for all z, and w = −z − 1 < 0 for all z ≥ 0: no solution exists.
  const std::vector<LcpProblem> problems = {
      Make(MatrixXd::Zero(1, 1), VectorXd::Constant(1, -1.0)),
      Make(-MatrixXd::Identity(2, 2), -Vector2d::Ones()),
      // Row 0 alone is solvable (z_0 = 1), but row 1 is w_1 = −z_0 − 1 < 0.
      Make((MatrixXd(2, 2) << 1, 0, -1, 0).finished(), Vector2d(-1.0, -1.0))};
  for (const LcpProblem& p : problems) {
    VectorXd z;
    const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
    EXPECT_EQ(r.status, SolverStatus::kSecondaryRay) << r.message;
    EXPECT_FALSE(r.ok());
    EXPECT_FALSE(r.regularized);
    EXPECT_NE(r.message.find("secondary ray"), std::string::npos) << r.message;
    ASSERT_EQ(z.size(), p.size());
    EXPECT_TRUE(z.allFinite());
    EXPECT_GE(r.residual, 1.0 - 1e-12);  // no z can do better than |w_i| = 1
  }
}

TEST(LemkeTest, MaxPivotsIsReported) {
  MatrixXd M(3, 3);
  M << 1, 2, 0, 0, 1, 2, 2, 0, 1;
  const LcpProblem p = Make(M, -Eigen::Vector3d::Ones());
  LemkeOptions o;
  o.max_pivots = 1;
  o.regularization = 0.0;
  VectorXd z;
  const SolverReport r = LemkeSolver(o).Solve(p, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_GT(r.residual, kTol);
}

TEST(LemkeTest, BoxAtRestOnPlaneStaysAtRest) {
  const double mass = 2.0, h = 0.01, mu = 0.5;
  const ContactLcp c = BoxOnPlane(mass, Vector3d(0.3, 0.2, 0.1), 0.4, VectorXd::Zero(6), mu, h, 4);
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(c.lcp, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(c.lcp, z, kTol);
  EXPECT_LE(c.VelocityAfter(z).lpNorm<Eigen::Infinity>(), 1e-9);
  EXPECT_NEAR(z.head(4).sum(), mass * kGravity * h, 1e-9);  // Σ p_n = m g h
}

TEST(LemkeTest, SlidingBoxDeceleratesByMuGH) {
  // Low box sliding along +x: μ c < a so it cannot tip; all four corners slide.
  const double mass = 1.5, h = 0.01, mu = 0.5, vx = 1.0;
  VectorXd v = VectorXd::Zero(6);
  v(0) = vx;
  const ContactLcp c = BoxOnPlane(mass, Vector3d(0.2, 0.2, 0.05), 0.0, v, mu, h, 4);
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(c.lcp, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(c.lcp, z, kTol);
  VectorXd expected = VectorXd::Zero(6);
  expected(0) = vx - mu * kGravity * h;
  EXPECT_LE((c.VelocityAfter(z) - expected).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(LemkeTest, RandomBoxOnPlaneContactLcps) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 30; ++trial) {
    const Vector3d half(0.1 + 0.1 * (u(rng) + 1.0), 0.1 + 0.1 * (u(rng) + 1.0),
                        0.05 + 0.05 * (u(rng) + 1.0));
    VectorXd v = Uniform(6, 1, &rng);
    v(2) = -std::abs(v(2));  // approaching or resting
    const ContactLcp c = BoxOnPlane(1.0 + u(rng) * 0.5, half, M_PI * u(rng), v, 0.5, 0.01, 4);
    ASSERT_EQ(c.lcp.size(), 24);
    VectorXd z;
    const SolverReport r = LemkeSolver().Solve(c.lcp, nullptr, &z);
    ASSERT_TRUE(r.ok()) << "trial " << trial << ": " << r.message;
    EXPECT_LE(LcpResidual(c.lcp, z), 1e-9);
    ExpectLcpSolution(c.lcp, z, kTol);
    // Physics: no contact point moves into the plane after the step.
    EXPECT_GE((c.g_n.transpose() * c.VelocityAfter(z)).minCoeff(), -1e-9);
  }
}

TEST(LemkeTest, RandomMultiBodyContactLcps) {
  std::mt19937 rng(11);
  for (int nc : {2, 8, 33}) {
    for (int trial = 0; trial < 3; ++trial) {
      const ContactLcp c = RandomContactLcp(std::max(1, nc / 4), nc, 4, &rng);
      VectorXd z;
      const SolverReport r = LemkeSolver().Solve(c.lcp, nullptr, &z);
      ASSERT_TRUE(r.ok()) << "nc = " << nc << ", trial " << trial << ": " << r.message;
      ExpectLcpSolution(c.lcp, z, kTol);
    }
  }
}

TEST(LemkeTest, FrequentRefactorizationGivesTheSameSolution) {
  // Refactor B⁻¹ from an LU of the basis every 3 pivots instead of max(50, n).
  std::mt19937 rng(17);
  LemkeOptions refactor;
  refactor.refactor_interval = 3;
  for (int trial = 0; trial < 4; ++trial) {
    const LcpProblem p = RandomPMatrixLcp(40, &rng);  // unique solution
    VectorXd z_default, z_refactor;
    const SolverReport r0 = LemkeSolver().Solve(p, nullptr, &z_default);
    const SolverReport r1 = LemkeSolver(refactor).Solve(p, nullptr, &z_refactor);
    ASSERT_TRUE(r0.ok()) << r0.message;
    ASSERT_TRUE(r1.ok()) << r1.message;
    ASSERT_GT(r1.iterations, 3);
    ExpectLcpSolution(p, z_refactor, kTol);
    EXPECT_LE((z_refactor - z_default).lpNorm<Eigen::Infinity>(), 1e-9);
  }
}

TEST(LemkeTest, ExactWarmStartNeedsNoPivots) {
  std::mt19937 rng(3);
  for (const ContactLcp& c :
       {BoxOnPlane(1.0, Vector3d(0.2, 0.1, 0.05), 0.3,
                   (VectorXd(6) << 0.5, -0.2, 0, 0, 0, 1).finished(), 0.5, 0.01, 4),
        RandomContactLcp(4, 16, 4, &rng)}) {
    VectorXd z_cold;
    const SolverReport cold = LemkeSolver().Solve(c.lcp, nullptr, &z_cold);
    ASSERT_TRUE(cold.ok()) << cold.message;
    ASSERT_GT(cold.iterations, 0);
    VectorXd z_warm;
    const SolverReport warm = LemkeSolver().Solve(c.lcp, &z_cold, &z_warm);
    ASSERT_TRUE(warm.ok()) << warm.message;
    EXPECT_EQ(warm.iterations, 0);
    EXPECT_LE((z_warm - z_cold).lpNorm<Eigen::Infinity>(), 1e-9);
    ExpectLcpSolution(c.lcp, z_warm, kTol);
  }
}

TEST(LemkeTest, InexactWarmStartStillSolves) {
  std::mt19937 rng(5);
  const LcpProblem p = RandomPMatrixLcp(30, &rng);
  VectorXd z_cold;
  ASSERT_TRUE(LemkeSolver().Solve(p, nullptr, &z_cold).ok());
  // Wrong active set: drop the first positive entry, add a zero one.
  VectorXd guess = z_cold;
  int dropped = -1, added = -1;
  for (int i = 0; i < guess.size(); ++i) {
    if (guess(i) > 0.0 && dropped < 0) {
      guess(i) = 0.0;
      dropped = i;
    } else if (guess(i) == 0.0 && added < 0) {
      guess(i) = 1.0;
      added = i;
    }
  }
  ASSERT_GE(dropped, 0);
  ASSERT_GE(added, 0);
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(p, &guess, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.iterations, 0);  // the wrong basis was rejected, a cold run solved it
  ExpectLcpSolution(p, z, kTol);
  // A P-matrix LCP has a unique solution.
  EXPECT_LE((z - z_cold).lpNorm<Eigen::Infinity>(), 1e-9);

  // A warm start of the wrong size is ignored.
  const VectorXd wrong = VectorXd::Ones(3);
  const SolverReport r2 = LemkeSolver().Solve(p, &wrong, &z);
  ASSERT_TRUE(r2.ok()) << r2.message;
  ExpectLcpSolution(p, z, kTol);
}

TEST(LemkeTest, RegularizedRetryIsReported) {
  // A pivot of 1e-13 is below the pivot tolerance, so the plain (unscaled) run stops on a
  // spurious secondary ray; on M + 1e-10·I it terminates with z = 1e-13/(1e-13 + 1e-10) ≈ 1e-3,
  // for the solution z = 1. Its absolute residual (1e-13) used to pass; the scale-aware
  // acceptance check (lcp_acceptance.h, issue 18) rejects it (w ≈ q < 0 at the problem's
  // scale) and the report says the retry ran.
  const LcpProblem p = Make(MatrixXd::Constant(1, 1, 1e-13), VectorXd::Constant(1, -1e-13));
  LemkeOptions plain;
  plain.scale = false;
  plain.regularization = 0.0;
  plain.newton_fallback = false;  // Lemke alone
  VectorXd z;
  const SolverReport r0 = LemkeSolver(plain).Solve(p, nullptr, &z);
  EXPECT_EQ(r0.status, SolverStatus::kSecondaryRay);
  EXPECT_FALSE(r0.regularized);

  LemkeOptions retry = plain;
  retry.regularization = 1e-10;
  const SolverReport r = LemkeSolver(retry).Solve(p, nullptr, &z);
  EXPECT_FALSE(r.ok()) << r.message;
  EXPECT_NE(r.message.find("regularized retries (eps=1e-10: "), std::string::npos) << r.message;
  EXPECT_EQ(r.residual, LcpResidual(p, z));

  // With the default options (scaling) the pivot is 1 and Lemke solves it.
  const SolverReport r1 = LemkeSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r1.ok()) << r1.message;
  EXPECT_NEAR(z(0), 1.0, 1e-12);
}

TEST(LemkeTest, RegularizedRetryNeverAcceptsAWrongAnswer) {
  // Infeasible: the retry on M + εI terminates (z = 1/ε) but fails on the original problem.
  const LcpProblem p = Make(MatrixXd::Zero(1, 1), VectorXd::Constant(1, -1.0));
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kSecondaryRay);
  EXPECT_NE(r.message.find("regularized retries"), std::string::npos) << r.message;
  EXPECT_EQ(r.residual, LcpResidual(p, z));
  EXPECT_GE(r.residual, 1.0);
}

TEST(LemkeTest, ScalingHandlesBadlyScaledRows) {
  // Rows/columns spanning 12 orders of magnitude; scaling makes the pivots admissible.
  std::mt19937 rng(9);
  LcpProblem p = RandomPMatrixLcp(20, &rng);
  VectorXd d(20);
  for (int i = 0; i < 20; ++i) d(i) = std::pow(10.0, -6.0 + 12.0 * i / 19.0);
  p.M = d.asDiagonal() * p.M * d.asDiagonal();
  p.q = d.asDiagonal() * p.q;
  VectorXd z;
  const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(p, z, kTol);
}

TEST(LemkeTest, InvalidInputIsReportedNotThrown) {
  VectorXd z;
  const LemkeSolver solver;
  const LcpProblem nan_q = Make(MatrixXd::Identity(2, 2), Vector2d(std::nan(""), -1.0));
  EXPECT_EQ(solver.Solve(nan_q, nullptr, &z).status, SolverStatus::kInvalidInput);
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

TEST(LemkeTest, MisuseThrows) {
  const LcpProblem p = Make(MatrixXd::Identity(1, 1), VectorXd::Constant(1, -1.0));
  EXPECT_THROW(LemkeSolver().Solve(p, nullptr, nullptr), std::invalid_argument);
  LemkeOptions o;
  o.pivot_tolerance = -1.0;
  VectorXd z;
  try {
    LemkeSolver(o).Solve(p, nullptr, &z);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pivot_tolerance"), std::string::npos) << e.what();
  }
  o = LemkeOptions{};
  o.max_pivots = -3;
  EXPECT_THROW(LemkeSolver(o).Solve(p, nullptr, &z), std::invalid_argument);
}

TEST(LemkeTest, DeterministicAcrossCallsAndThreads) {
  std::mt19937 rng(13);
  const ContactLcp c = RandomContactLcp(8, 33, 4, &rng);
  const LemkeSolver solver;
  VectorXd z1, z2, z3;
  const SolverReport r1 = solver.Solve(c.lcp, nullptr, &z1);
  const SolverReport r2 = solver.Solve(c.lcp, nullptr, &z2);
  SolverReport r3;
  std::thread t([&] { r3 = solver.Solve(c.lcp, nullptr, &z3); });
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

// The solver keeps one scratch workspace per thread (lemke.cc): solves of LCPs of different
// sizes, interleaved on four threads at once, give bit for bit the reports and z of serial
// solves (each thread's workspace is resized between problems; no state leaks across solves
// or threads).
TEST(LemkeTest, ConcurrentSolvesOfMixedSizesMatchSerial) {
  constexpr int kThreads = 4;
  constexpr int kRounds = 3;
  std::mt19937 rng(29);
  std::vector<LcpProblem> problems;
  for (const auto& [bodies, contacts] : {std::pair{2, 6}, {6, 25}, {1, 3}, {10, 45}}) {
    problems.push_back(RandomContactLcp(bodies, contacts, 4, &rng).lcp);
  }
  problems.push_back(ReadLcpFile(VINCI_SOURCE_DIR "/tests/data/lcp/incline_sliding_step9744.lcp"));
  problems.push_back(ReadLcpFile(VINCI_SOURCE_DIR "/tests/data/lcp/box_stack_cold_step425.lcp"));
  const LemkeSolver solver;
  const int count = static_cast<int>(problems.size());
  std::vector<SolverReport> serial(count);
  std::vector<VectorXd> serial_z(count);
  for (int k = 0; k < count; ++k) {
    serial[k] = solver.Solve(problems[k], nullptr, &serial_z[k]);
    ASSERT_TRUE(serial[k].ok()) << "problem " << k << ": " << serial[k].message;
    ASSERT_GT(serial[k].iterations, 0) << "problem " << k;  // really pivoted (q has q_i < 0)
  }
  // Thread t solves problem (t + i) mod count at its i-th solve: different sizes run at once.
  std::vector<std::vector<SolverReport>> reports(kThreads);
  std::vector<std::vector<VectorXd>> zs(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kRounds * count; ++i) {
        const int k = (t + i) % count;
        VectorXd z;
        reports[t].push_back(solver.Solve(problems[k], nullptr, &z));
        zs[t].push_back(std::move(z));
      }
    });
  }
  for (std::thread& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_EQ(static_cast<int>(reports[t].size()), kRounds * count);
    for (int i = 0; i < kRounds * count; ++i) {
      const int k = (t + i) % count;
      const SolverReport& r = reports[t][i];
      const VectorXd& z = zs[t][i];
      ASSERT_EQ(z.size(), serial_z[k].size()) << "thread " << t << ", problem " << k;
      EXPECT_EQ(std::memcmp(z.data(), serial_z[k].data(), sizeof(double) * z.size()), 0)
          << "thread " << t << ", problem " << k;
      EXPECT_EQ(r.status, serial[k].status);
      EXPECT_EQ(r.iterations, serial[k].iterations);
      EXPECT_EQ(r.residual, serial[k].residual);
      EXPECT_EQ(r.tolerance, serial[k].tolerance);
      EXPECT_EQ(r.message, serial[k].message);
    }
  }
}

}  // namespace
}  // namespace vinci::sim
