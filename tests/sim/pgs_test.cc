// Tests of the block projected Gauss–Seidel / SOR LCP solver: closed-form LCPs, random SPD
// problems, the Stewart–Trinkle contact LCP with its friction-cone blocks (against Lemke),
// scalar PGS failing cleanly on zero-diagonal rows, warm start, invalid input and
// determinism. Every solution is checked independently of the solver.
#include "vinci/sim/solvers/pgs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "test_util.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

// The solver's default relative tolerance; used as the independent check as well.
constexpr double kTol = 1e-9;

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

// Symmetric positive definite M (eigenvalues ≥ 0.5) and q uniform in [−1, 1]: unique
// solution, and (block) Gauss–Seidel converges for every ω ∈ (0, 2).
LcpProblem RandomSpdLcp(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatrixXd A(n, n);
  VectorXd q(n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) A(i, j) = u(*rng);
  }
  for (int i = 0; i < n; ++i) q(i) = u(*rng);
  return Make(A * A.transpose() / n + 0.5 * MatrixXd::Identity(n, n), q);
}

// The Stewart–Trinkle LCP of a bundled scene after `steps` Lemke steps from rest (so the
// contacts and their forces are established), with what is needed to map z to ν_ℓ+1.
struct StepLcp {
  StepLcp(const std::string& scene, int steps) : sim(testing::LoadExample(scene)) {
    x = sim.InitialState();
    Workspace ws;
    for (int k = 0; k < steps; ++k) {
      State next;
      const StepInfo info = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next);
      if (!info.ok) throw std::runtime_error("setup step failed: " + info.failure);
      x = next;
    }
    a = st().Assemble(sim.scene(), x, StepInput{});
    lcp = st().BuildLcp(sim.scene(), a, x.v, &v_star, &joints);
  }
  const StewartTrinkle& st() const {
    return dynamic_cast<const StewartTrinkle&>(sim.formulation());
  }
  VectorXd VelocityAfter(const VectorXd& z) const {
    return st().VelocityAfter(a, v_star, z, joints);
  }

  Simulator sim;
  State x;
  StewartTrinkle::Assembly a;
  VectorXd v_star;
  StewartTrinkle::JointElimination joints;
  LcpProblem lcp;
};

TEST(PgsTest, ScalarProblem) {
  const LcpProblem p = Make(MatrixXd::Ones(1, 1), VectorXd::Constant(1, -9.8));
  VectorXd z;
  const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(z(0), 9.8, 1e-12);
  EXPECT_EQ(r.iterations, 1);  // the closed form is exact
  EXPECT_GE(r.time_s, 0.0);
  ExpectLcpSolution(p, z, kTol);
}

TEST(PgsTest, NonnegativeQGivesZeroWithoutSweeps) {
  MatrixXd M(3, 3);
  M << 1, -2, 3, 0, -1, 4, 5, 6, -7;
  const LcpProblem p = Make(M, Eigen::Vector3d(0.0, 1.0, 2.0));
  VectorXd z = VectorXd::Constant(3, 7.0);
  const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(z, VectorXd::Zero(3));
  EXPECT_EQ(r.residual, 0.0);
}

TEST(PgsTest, EmptyProblemIsSolved) {
  VectorXd z = VectorXd::Ones(2);
  const SolverReport r = PgsSolver().Solve(LcpProblem{}, nullptr, &z);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(z.size(), 0);
}

// The classic 3×3 cycling example (P-matrix, unique solution (1/3, 1/3, 1/3)). Scalar
// Gauss–Seidel cannot solve it: near the solution its iteration matrix −(D + L)⁻¹U has
// eigenvalues ±2√2 i, and M's own eigenvalues 3, ±√3 i make SOR diverge for every ω. It must
// report that cleanly; one block holding all three variables is solved exactly by Lemke.
TEST(PgsTest, CyclingExampleFailsScalarButOneBlockSolves) {
  MatrixXd M(3, 3);
  M << 1, 2, 0, 0, 1, 2, 2, 0, 1;
  LcpProblem p = Make(M, -Eigen::Vector3d::Ones());
  for (double omega : {1.0, 0.5}) {
    PgsOptions o;
    o.relaxation = omega;
    VectorXd z;
    const SolverReport r = PgsSolver(o).Solve(p, nullptr, &z);
    EXPECT_EQ(r.status, SolverStatus::kMaxIterations) << "omega = " << omega;
    EXPECT_EQ(r.iterations, o.max_sweeps);
    EXPECT_NE(r.message.find("sweep limit"), std::string::npos) << r.message;
    ASSERT_EQ(z.size(), 3);
    EXPECT_TRUE(z.allFinite());
    EXPECT_GE(z.minCoeff(), 0.0);
    EXPECT_EQ(r.residual, LcpResidual(p, z));
    EXPECT_LE(r.residual, 1.0);  // the best iterate is no worse than the start z = 0
  }
  p.blocks = {{0, 1, 2}};
  VectorXd z;
  const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, 1);
  ExpectLcpSolution(p, z, kTol);
  EXPECT_LE((z - Eigen::Vector3d::Constant(1.0 / 3.0)).lpNorm<Eigen::Infinity>(), 1e-12);
}

TEST(PgsTest, RandomSpdProblemsMatchLemke) {
  std::mt19937 rng(20240612);
  for (int n : {10, 50}) {
    for (int trial = 0; trial < 3; ++trial) {
      const LcpProblem p = RandomSpdLcp(n, &rng);
      VectorXd z, z_lemke;
      const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
      ASSERT_TRUE(r.ok()) << "n = " << n << ", trial " << trial << ": " << r.message;
      EXPECT_GT(r.iterations, 1);
      EXPECT_EQ(r.residual, LcpResidual(p, z));
      ExpectLcpSolution(p, z, kTol);
      ASSERT_TRUE(LemkeSolver().Solve(p, nullptr, &z_lemke).ok());
      // Unique solution; PD with smallest eigenvalue ≥ 0.5 turns a residual of 1e-9 into an
      // error of a few 1e-9.
      EXPECT_LE((z - z_lemke).lpNorm<Eigen::Infinity>(), 1e-8) << "n = " << n;
    }
  }
}

TEST(PgsTest, RelaxationAndBlocksReachTheSameSolution) {
  std::mt19937 rng(99);
  LcpProblem p = RandomSpdLcp(30, &rng);
  VectorXd z_ref;
  ASSERT_TRUE(LemkeSolver().Solve(p, nullptr, &z_ref).ok());
  for (double omega : {0.6, 1.0, 1.4}) {
    for (bool blocked : {false, true}) {
      LcpProblem pb = p;
      if (blocked) {  // blocks of 4 (the last of 2), out of index order
        for (int b = 0; b < 30; b += 4) {
          pb.blocks.emplace_back();
          for (int i = std::min(29, b + 3); i >= b; --i) pb.blocks.back().push_back(i);
        }
      }
      PgsOptions o;
      o.relaxation = omega;
      VectorXd z;
      const SolverReport r = PgsSolver(o).Solve(pb, nullptr, &z);
      ASSERT_TRUE(r.ok()) << "omega = " << omega << ", blocked " << blocked << ": " << r.message;
      ExpectLcpSolution(pb, z, kTol);
      EXPECT_LE((z - z_ref).lpNorm<Eigen::Infinity>(), 1e-8);
    }
  }
}

TEST(PgsTest, ExactWarmStartNeedsNoSweeps) {
  std::mt19937 rng(3);
  const LcpProblem p = RandomSpdLcp(20, &rng);
  VectorXd z_cold;
  const SolverReport cold = PgsSolver().Solve(p, nullptr, &z_cold);
  ASSERT_TRUE(cold.ok()) << cold.message;
  ASSERT_GT(cold.iterations, 0);
  VectorXd z_warm;
  const SolverReport warm = PgsSolver().Solve(p, &z_cold, &z_warm);
  ASSERT_TRUE(warm.ok()) << warm.message;
  EXPECT_EQ(warm.iterations, 0);
  EXPECT_EQ(z_warm, z_cold);
  // The warm start may alias the output.
  VectorXd z = z_cold;
  const SolverReport aliased = PgsSolver().Solve(p, &z, &z);
  ASSERT_TRUE(aliased.ok()) << aliased.message;
  EXPECT_EQ(aliased.iterations, 0);
  EXPECT_EQ(z, z_cold);
  // A wrong-size warm start is ignored.
  const VectorXd wrong = VectorXd::Ones(3);
  const SolverReport r = PgsSolver().Solve(p, &wrong, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, cold.iterations);
}

// The Stewart–Trinkle LCP (zero diagonal in the σ rows, non-symmetric U / −Eᵀ / E coupling)
// of a box resting on a plane: the contact-patch block from BuildLcp is solved by Lemke each
// sweep, and the step velocity matches Lemke's.
TEST(PgsTest, StewartTrinkleBoxOnPlaneWithBlocksMatchesLemke) {
  const StepLcp s("box_on_plane.yaml", 5);
  // 4 corner contacts, n_d = 8, all between the box and the plane: one patch block.
  ASSERT_EQ(s.lcp.size(), 4 * (8 + 2));
  ASSERT_EQ(s.lcp.blocks.size(), 1u);
  ASSERT_EQ(s.lcp.blocks[0].size(), 40u);
  PgsOptions o;
  o.tolerance = 1e-8;
  VectorXd z, z_lemke;
  const SolverReport r = PgsSolver(o).Solve(s.lcp, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.iterations, 0);
  ExpectLcpSolution(s.lcp, z, 1e-8);
  ASSERT_TRUE(LemkeSolver().Solve(s.lcp, nullptr, &z_lemke).ok());
  // Contact velocities are within the residual (1e-8) of each other; the body velocities of a
  // 1 kg, 0.2 m box differ by at most a small multiple of that.
  EXPECT_LE((s.VelocityAfter(z) - s.VelocityAfter(z_lemke)).lpNorm<Eigen::Infinity>(), 1e-6);
  // Physics: resting, so ν_ℓ+1 ≈ 0 and Σ p_n = m g h.
  EXPECT_LE(s.VelocityAfter(z).lpNorm<Eigen::Infinity>(), 1e-6);
  EXPECT_NEAR(z.head(4).sum(), 1.0 * 9.81 * s.sim.scene().options.dt, 1e-8);
}

// Same on the 10-box stack (n = 240), started from an iterate near the solution: cold, block
// PGS needs ~3·10⁴ sweeps here (the stack's swaying modes make the contact matrix
// ill-conditioned, eigenvalues from 1e-3 to 94), too slow for a unit test.
TEST(PgsTest, StewartTrinkleBoxStackFromNearbyStartMatchesLemke) {
  const StepLcp s("box_stack.yaml", 5);
  ASSERT_EQ(s.lcp.size(), 240);
  VectorXd z_lemke;
  ASSERT_TRUE(LemkeSolver().Solve(s.lcp, nullptr, &z_lemke).ok());
  // Perturb the normal impulses by 0.1 % and the friction impulses by 1e-7 N·s.
  VectorXd start = z_lemke;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 40; ++i) start(i) *= 1.0 + 0.001 * u(rng);
  for (int i = 40; i < 200; ++i) start(i) += 1e-7 * u(rng);
  ASSERT_GT(LcpResidual(s.lcp, start), 1e-7);
  PgsOptions o;
  o.tolerance = 1e-8;
  o.max_sweeps = 20000;
  VectorXd z;
  const SolverReport r = PgsSolver(o).Solve(s.lcp, &start, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.iterations, 0);
  ExpectLcpSolution(s.lcp, z, 1e-8);
  EXPECT_LE((s.VelocityAfter(z) - s.VelocityAfter(z_lemke)).lpNorm<Eigen::Infinity>(), 1e-6);
}

// The iteration limit is reported with the best iterate, never worse than the start.
TEST(PgsTest, SweepLimitReturnsBestIterate) {
  const StepLcp s("box_stack.yaml", 5);
  PgsOptions o;
  o.max_sweeps = 50;
  VectorXd z;
  const SolverReport r = PgsSolver(o).Solve(s.lcp, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(r.iterations, 50);
  EXPECT_NE(r.message.find("sweep limit 50"), std::string::npos) << r.message;
  ASSERT_EQ(z.size(), s.lcp.size());
  EXPECT_GE(z.minCoeff(), 0.0);
  EXPECT_EQ(r.residual, LcpResidual(s.lcp, z));
  EXPECT_LT(r.residual, LcpResidual(s.lcp, VectorXd::Zero(s.lcp.size())));
}

// A larger sweep limit never returns a worse iterate, since the best one seen is kept: on the
// cycling example with ω = 0.5 the residual after each sweep goes 0.5, 0.25, 0.625, ...
TEST(PgsTest, MoreSweepsNeverReturnAWorseIterate) {
  MatrixXd M(3, 3);
  M << 1, 2, 0, 0, 1, 2, 2, 0, 1;
  const LcpProblem p = Make(M, -Eigen::Vector3d::Ones());
  double previous = LcpResidual(p, VectorXd::Zero(3));
  for (int sweeps = 1; sweeps <= 20; ++sweeps) {
    PgsOptions o;
    o.max_sweeps = sweeps;
    o.relaxation = 0.5;
    VectorXd z;
    const SolverReport r = PgsSolver(o).Solve(p, nullptr, &z);
    ASSERT_EQ(r.status, SolverStatus::kMaxIterations);
    EXPECT_LE(r.residual, previous) << "sweeps = " << sweeps;
    previous = std::min(previous, r.residual);
  }
}

// SOR over-relaxation is projected back onto z ≥ 0: from z = 1, ω = 1.5 overshoots the
// solution z = 0 of the 1×1 LCP to −0.5, which must be clamped to 0 in the same sweep.
TEST(PgsTest, OverRelaxationIsProjectedOntoTheOrthant) {
  const LcpProblem p = Make(MatrixXd::Ones(1, 1), VectorXd::Ones(1));
  PgsOptions o;
  o.relaxation = 1.5;
  const VectorXd start = VectorXd::Ones(1);
  VectorXd z;
  const SolverReport r = PgsSolver(o).Solve(p, &start, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.iterations, 1);
  EXPECT_EQ(z(0), 0.0);
}

// Without blocks the σ rows (M_ii = 0) have no 1×1 solution once friction builds up; the solve
// must stop with a clear report, not crash or report success.
TEST(PgsTest, ScalarPgsOnStewartTrinkleReportsZeroDiagonalFailure) {
  StepLcp s("box_on_plane.yaml", 5);
  s.lcp.blocks.clear();
  s.lcp.block_parts.clear();
  VectorXd z;
  const SolverReport r = PgsSolver().Solve(s.lcp, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kNumericalFailure);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message.find("M_ii = 0"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("LcpProblem::blocks"), std::string::npos) << r.message;
  ASSERT_EQ(z.size(), s.lcp.size());
  EXPECT_TRUE(z.allFinite());
  EXPECT_EQ(r.residual, LcpResidual(s.lcp, z));
  EXPECT_GT(r.residual, 1e-8);
}

TEST(PgsTest, ZeroDiagonalRowWithNonnegativeRIsZero) {
  // w_1 = z_0 − 0.5 with M_11 = 0: after z_0 = 1, r_1 = 0.5 ≥ 0 and z_1 = 0.
  MatrixXd M(2, 2);
  M << 1, 0, 1, 0;
  const LcpProblem p = Make(M, Vector2d(-1.0, -0.5));
  VectorXd z;
  const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(z, Vector2d(1.0, 0.0));
}

TEST(PgsTest, InfeasibleProblemsFail) {
  for (const LcpProblem& p : {Make(MatrixXd::Zero(1, 1), VectorXd::Constant(1, -1.0)),
                              Make(-MatrixXd::Identity(2, 2), -Vector2d::Ones())}) {
    VectorXd z;
    const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
    EXPECT_EQ(r.status, SolverStatus::kNumericalFailure) << r.message;
    EXPECT_GE(r.residual, 1.0 - 1e-12);
  }
}

TEST(PgsTest, InvalidInputIsReportedNotThrown) {
  const PgsSolver solver;
  VectorXd z;
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
  EXPECT_TRUE(std::isnan(r.residual));

  // Blocks that do not partition the variables.
  struct Case {
    std::vector<std::vector<int>> blocks;
    const char* expected;
  };
  for (const Case& c :
       {Case{{{0, 1}, {1, 2}}, "index 1 is in blocks 0 and 1"},
        Case{{{0, 1}}, "index 2 is in no block"}, Case{{{0, 1, 3}, {2}}, "outside [0, 3)"},
        Case{{{0, 1, 2}, {}}, "block 1 is empty"}}) {
    LcpProblem p = Make(MatrixXd::Identity(3, 3), -Eigen::Vector3d::Ones());
    p.blocks = c.blocks;
    const SolverReport rb = solver.Solve(p, nullptr, &z);
    EXPECT_EQ(rb.status, SolverStatus::kInvalidInput) << c.expected;
    EXPECT_NE(rb.message.find(c.expected), std::string::npos) << rb.message;
    EXPECT_EQ(z, VectorXd::Zero(3));
  }
}

TEST(PgsTest, MisuseThrows) {
  const LcpProblem p = Make(MatrixXd::Identity(1, 1), VectorXd::Constant(1, -1.0));
  EXPECT_THROW(PgsSolver().Solve(p, nullptr, nullptr), std::invalid_argument);
  VectorXd z;
  for (double omega : {0.0, 2.0, std::nan("")}) {
    PgsOptions o;
    o.relaxation = omega;
    try {
      PgsSolver(o).Solve(p, nullptr, &z);
      FAIL() << "expected std::invalid_argument for omega = " << omega;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("relaxation"), std::string::npos) << e.what();
    }
  }
  PgsOptions o;
  o.max_sweeps = 0;
  EXPECT_THROW(PgsSolver(o).Solve(p, nullptr, &z), std::invalid_argument);
  o = PgsOptions{};
  o.tolerance = -1.0;
  EXPECT_THROW(PgsSolver(o).Solve(p, nullptr, &z), std::invalid_argument);
}

TEST(PgsTest, DeterministicAcrossCallsAndThreads) {
  const StepLcp s("box_on_plane.yaml", 5);
  const PgsSolver solver;
  VectorXd z1, z2, z3;
  const SolverReport r1 = solver.Solve(s.lcp, nullptr, &z1);
  const SolverReport r2 = solver.Solve(s.lcp, nullptr, &z2);
  SolverReport r3;
  std::thread t([&] { r3 = solver.Solve(s.lcp, nullptr, &z3); });
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

// Cold block PGS on the 10-box stack (n = 240) with one friction-cone block per contact
// (StewartTrinkle::LcpBlocking::kContact, ordered bottom to top; BuildLcp's blocks before the
// contact-patch grouping): approximate. 1000 sweeps reach a residual of
// 1.1e-5 (ω = 1; 5.9e-6 with ω = 0.7, 1e-5…4e-5 with ω = 1.3…1.9, the same in reverse order),
// far from the 1e-9 tolerance. Grouping the 4 contacts of each box pair into one block
// (solved exactly by Lemke) removes the stall: 585 sweeps at ω = 1, 319 at ω = 1.3.
TEST(PgsTest, BoxStackColdPerContactBlocksAreApproximate) {
  StepLcp s("box_stack.yaml", 5);
  ASSERT_EQ(s.lcp.size(), 240);
  s.lcp.blocks = StewartTrinkle::LcpBlocks(s.a, StewartTrinkle::LcpBlocking::kContact);
  s.lcp.block_parts.clear();
  ASSERT_EQ(s.lcp.blocks.size(), 40u);
  VectorXd z;
  const SolverReport r = PgsSolver().Solve(s.lcp, nullptr, &z);
  EXPECT_EQ(r.status, SolverStatus::kMaxIterations) << r.message;
  EXPECT_EQ(r.iterations, 1000);
  // What 1000 sweeps reach (measured 1.09e-5; bound with 2× margin for roundoff order).
  EXPECT_LE(r.residual, 2e-5);
  EXPECT_GT(r.residual, PgsOptions().tolerance);
}

// The same LCP with one block per contact patch (all contacts between the same two bodies):
// BuildLcp's blocks, checked against patches built here from the per-contact blocks.
TEST(PgsTest, BoxStackColdPatchBlocksConverge) {
  StepLcp s("box_stack.yaml", 5);
  const std::vector<std::vector<int>> per_contact =
      StewartTrinkle::LcpBlocks(s.a, StewartTrinkle::LcpBlocking::kContact);
  std::vector<std::vector<int>> patches;
  std::vector<std::pair<int, int>> patch_bodies;
  for (size_t c = 0; c < s.a.contacts.size(); ++c) {
    const std::pair<int, int> bodies(s.a.contacts[c].body_a, s.a.contacts[c].body_b);
    const auto it = std::find(patch_bodies.begin(), patch_bodies.end(), bodies);
    if (it == patch_bodies.end()) {
      patch_bodies.push_back(bodies);
      patches.push_back(per_contact[c]);
    } else {
      std::vector<int>& b = patches[it - patch_bodies.begin()];
      b.insert(b.end(), per_contact[c].begin(), per_contact[c].end());
    }
  }
  ASSERT_EQ(patches.size(), 10u);  // floor–box0, box0–box1, ..., box8–box9
  EXPECT_EQ(s.lcp.blocks, patches);
  // Parts: one per contact (6 rows each: p_n, 4 p_f, σ).
  EXPECT_EQ(s.lcp.block_parts, std::vector<std::vector<int>>(10, std::vector<int>{0, 6, 12, 18}));
  VectorXd z_lemke;
  ASSERT_TRUE(LemkeSolver().Solve(s.lcp, nullptr, &z_lemke).ok());
  for (const double omega : {1.0, 1.3}) {
    PgsOptions o;
    o.relaxation = omega;
    VectorXd z;
    const SolverReport r = PgsSolver(o).Solve(s.lcp, nullptr, &z);
    ASSERT_TRUE(r.ok()) << "omega = " << omega << ": " << r.message;
    // Measured 585 (ω = 1) and 319 (ω = 1.3) sweeps; SOR must help.
    EXPECT_LE(r.iterations, omega == 1.0 ? 700 : 400) << "omega = " << omega;
    ExpectLcpSolution(s.lcp, z, kTol);
    EXPECT_LE((s.VelocityAfter(z) - s.VelocityAfter(z_lemke)).lpNorm<Eigen::Infinity>(), 1e-6);
  }
}

// Polish (PgsOptions::polish_interval): subspace minimization on the active set every 25
// sweeps solves the same cold stack LCP in 25 sweeps (measured) instead of 585.
TEST(PgsTest, BoxStackColdPolishConvergesInFewSweeps) {
  const StepLcp s("box_stack.yaml", 5);
  PgsOptions o;
  o.polish_interval = 25;
  VectorXd z, z_lemke;
  const SolverReport r = PgsSolver(o).Solve(s.lcp, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_LE(r.iterations, 50);  // measured 25: the first polish finds the active set
  ExpectLcpSolution(s.lcp, z, kTol);
  ASSERT_TRUE(LemkeSolver().Solve(s.lcp, nullptr, &z_lemke).ok());
  EXPECT_LE((s.VelocityAfter(z) - s.VelocityAfter(z_lemke)).lpNorm<Eigen::Infinity>(), 1e-6);
  o.polish_interval = -1;
  EXPECT_THROW(PgsSolver(o).Solve(s.lcp, nullptr, &z), std::invalid_argument);
}

// LcpBlocks partitions the unknowns, with a corner unknown c_k in the block of its contact
// (concave_trench.yaml: a box at the corners of a trench, contacts with the trench only).
TEST(PgsTest, PatchBlocksPartitionAndHoldCornerUnknowns) {
  const StepLcp s("concave_trench.yaml", 1000);  // the block over the first corner
  const int nk = static_cast<int>(s.a.corner_contact.size());
  ASSERT_GT(nk, 0);
  const int n = s.lcp.size();
  std::vector<int> owner(n, -1);
  for (int b = 0; b < static_cast<int>(s.lcp.blocks.size()); ++b) {
    for (int i : s.lcp.blocks[b]) {
      ASSERT_TRUE(i >= 0 && i < n);
      EXPECT_EQ(owner[i], -1) << "index " << i << " twice";
      owner[i] = b;
    }
  }
  for (int i = 0; i < n; ++i) EXPECT_GE(owner[i], 0) << "index " << i << " in no block";
  for (int k = 0; k < nk; ++k) {
    EXPECT_EQ(owner[n - nk + k], owner[s.a.corner_contact[k]]) << "corner " << k;
  }
  // One block per body pair here (fewer than kMaxPatchContacts contacts each).
  std::vector<std::pair<int, int>> pairs;
  for (const Contact& c : s.a.contacts) {
    const std::pair<int, int> p(std::min(c.body_a, c.body_b), std::max(c.body_a, c.body_b));
    if (std::find(pairs.begin(), pairs.end(), p) == pairs.end()) pairs.push_back(p);
  }
  EXPECT_EQ(s.lcp.blocks.size(), pairs.size());
  VectorXd z;
  const SolverReport r = PgsSolver().Solve(s.lcp, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  ExpectLcpSolution(s.lcp, z, kTol);
}

// A block on which Lemke fails falls back to its parts (LcpProblem::block_parts): the LCP of
// bench/vinci_vs_siconos.cc's "pyramid2@50" (3 slightly rotated boxes, two resting on the floor
// and one on both; n = 162) has a 6-contact patch (36 rows) whose block LCP Lemke cannot solve
// (residual 1.3 after its retries). Its 6 contacts, solved one by one, converge (577 sweeps).
TEST(PgsTest, FailedPatchBlockFallsBackToItsContacts) {
  Scene scene = testing::LoadExample("box_stack.yaml");
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const Body like = scene.bodies[1];
  scene.bodies.resize(1);
  for (int row = 0; row < 2; ++row) {
    for (int i = 0; i < 2 - row; ++i) {
      Vector3d axis(unit(rng), unit(rng), unit(rng));
      axis.normalize();
      Body b = like;
      b.name = "p" + std::to_string(row) + "_" + std::to_string(i);
      b.X_WB0 = Isometry3d::Identity();
      b.X_WB0.linear() = Eigen::AngleAxisd(0.01 * unit(rng), axis).toRotationMatrix();
      b.X_WB0.translation() = Vector3d(0.205 * (i + 0.5 * row) + 0.002 * unit(rng),
                                       0.002 * unit(rng), 0.1 + 0.2005 * row + 0.001);
      scene.bodies.push_back(b);
    }
  }
  const Simulator sim(std::move(scene));
  State x = sim.InitialState(), next;
  Workspace ws;
  for (int k = 0; k < 50; ++k) {
    ASSERT_TRUE(sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next).ok) << "step " << k;
    std::swap(x, next);
  }
  const auto& st = dynamic_cast<const StewartTrinkle&>(sim.formulation());
  const StewartTrinkle::Assembly a = st.Assemble(sim.scene(), x, StepInput{});
  VectorXd v_star;
  StewartTrinkle::JointElimination joints;
  LcpProblem lcp = st.BuildLcp(sim.scene(), a, x.v, &v_star, &joints);
  ASSERT_EQ(lcp.size(), 162);
  VectorXd z, z_lemke;
  const SolverReport r = PgsSolver().Solve(lcp, nullptr, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GE(r.restarts, 1);  // at least one block fell back to its parts
  ExpectLcpSolution(lcp, z, kTol);
  ASSERT_TRUE(LemkeSolver().Solve(lcp, nullptr, &z_lemke).ok());
  EXPECT_LE((st.VelocityAfter(a, v_star, z, joints) - st.VelocityAfter(a, v_star, z_lemke, joints))
                .lpNorm<Eigen::Infinity>(),
            1e-6);
  // Without parts the same failure stops the solve, naming the block.
  lcp.block_parts.clear();
  const SolverReport without = PgsSolver().Solve(lcp, nullptr, &z);
  EXPECT_EQ(without.status, SolverStatus::kNumericalFailure);
  EXPECT_NE(without.message.find("Lemke failed on the block LCP"), std::string::npos)
      << without.message;
}

TEST(PgsTest, InvalidBlockPartsAreReported) {
  LcpProblem p = Make(MatrixXd::Identity(3, 3), -Eigen::Vector3d::Ones());
  p.blocks = {{0, 1}, {2}};
  for (const std::vector<std::vector<int>>& parts :
       {std::vector<std::vector<int>>{{0}}, {{1}, {}}, {{0, 2}, {}}, {{0, 0}, {}}}) {
    p.block_parts = parts;
    VectorXd z;
    const SolverReport r = PgsSolver().Solve(p, nullptr, &z);
    EXPECT_EQ(r.status, SolverStatus::kInvalidInput);
    EXPECT_NE(r.message.find("block_parts"), std::string::npos) << r.message;
  }
  p.block_parts = {{0, 1}, {}};
  VectorXd z;
  ASSERT_TRUE(PgsSolver().Solve(p, nullptr, &z).ok());
}

}  // namespace
}  // namespace vinci::sim
