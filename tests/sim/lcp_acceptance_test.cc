// The shared acceptance test of every LCP solver (lcp_acceptance.h) and the solvers' reports on
// problems where an absolute tolerance floor or overflow used to make them lie (issue 18,
// findings 4 and 7).
#include "vinci/sim/solvers/lcp_acceptance.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_file.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::sim {
namespace {

LcpProblem Make(const MatrixXd& M, const VectorXd& q) {
  LcpProblem p;
  p.M = M;
  p.q = q;
  return p;
}

TEST(LcpAcceptanceTest, ScaledResidualIsScaleInvariant) {
  MatrixXd M(2, 2);
  M << 2, 1, 1, 2;
  const VectorXd q = VectorXd::Constant(2, -3.0);
  const VectorXd z = VectorXd::Ones(2);  // w = 0: the solution
  for (double s : {1e-12, 1.0, 1e12}) {
    EXPECT_EQ(LcpScaledResidual(Make(s * M, s * q), z), 0.0);
    // z = 0 leaves w = q < 0: violated by the whole scale of w.
    EXPECT_DOUBLE_EQ(LcpScaledResidual(Make(s * M, s * q), VectorXd::Zero(2)), 1.0);
    // Units of z: M scaled against q, the solution scales inversely.
    EXPECT_EQ(LcpScaledResidual(Make(s * M, q), z / s), 0.0);
  }
}

TEST(LcpAcceptanceTest, NegativePartsOfZAndWAreBounded) {
  const LcpProblem p = Make(MatrixXd::Identity(2, 2), VectorXd::Constant(2, 1.0));
  EXPECT_EQ(CheckLcpSolution(p, VectorXd::Zero(2)), "");
  VectorXd z = VectorXd::Zero(2);
  z(0) = -0.5;                                       // w = (0.5, 1) ≥ 0 but z < 0
  EXPECT_NEAR(LcpScaledResidual(p, z), 0.5, 1e-15);  // z_0 / s_z with s_z = ‖q‖/‖M‖ = 1
  EXPECT_THAT(CheckLcpSolution(p, z), ::testing::HasSubstr("scale-aware residual"));
  EXPECT_TRUE(std::isinf(LcpScaledResidual(p, VectorXd::Constant(2, INFINITY))));
}

// M = 1e-12·I, q = −1e-12·(1, 1): the solution is z = (1, 1). The absolute floor
// max(1, ‖q‖∞) of PGS and FB Newton accepted z = 0 (w = q < 0) as solved.
TEST(LcpAcceptanceTest, EverySolverSolvesASmallScaleProblem) {
  const LcpProblem p = Make(1e-12 * MatrixXd::Identity(2, 2), VectorXd::Constant(2, -1e-12));
  for (const std::string& name : LcpSolverNames()) {
    SCOPED_TRACE(name);
    VectorXd z;
    const SolverReport r = MakeLcpSolver(name)->Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_TRUE(z.isApprox(VectorXd::Ones(2), 1e-6)) << z.transpose();
  }
}

// Finding 4: n = 2, M = [[5, 6], [-22, 61]], q = (−1.7e308, 1): the products overflow. Lemke threw
// std::logic_error ("failed solve reported as kSolved": inf ≤ an overflowed tolerance). Every
// solver must return a status; if it says solved, the answer must pass the independent check.
TEST(LcpAcceptanceTest, OverflowingProblemGivesAStatusNotAnException) {
  MatrixXd M(2, 2);
  M << 5, 6, -22, 61;
  for (const VectorXd& q : {VectorXd((VectorXd(2) << -1.7e308, 1.0).finished()),
                            VectorXd((VectorXd(2) << 1.0, -1.7e308).finished()),
                            VectorXd((VectorXd(2) << -1.7e308, -1.7e308).finished())}) {
    const LcpProblem p = Make(M, q);
    for (const std::string& name : LcpSolverNames()) {
      SCOPED_TRACE(name + " q = " + FormatNumber(q(0)) + ", " + FormatNumber(q(1)));
      VectorXd z;
      SolverReport r;
      ASSERT_NO_THROW(r = MakeLcpSolver(name)->Solve(p, nullptr, &z));
      ASSERT_EQ(z.size(), 2);
      if (r.ok()) {
        EXPECT_EQ(CheckLcpSolution(p, z), "");
      } else {
        EXPECT_FALSE(r.message.empty());
      }
    }
  }
}

// Scaling a row of (M, q) by a positive factor gives the same LCP: the verdict must not change.
// With one global scale for w, the row written in small units could be violated by 100 % of
// its own size and still pass (fuzz/crashes/lcp/lemke_fb_row_scaled.lcp).
TEST(LcpAcceptanceTest, ScaledResidualIsInvariantToRowScaling) {
  MatrixXd M(3, 3);
  M << 2, 1, 0, 1, 3, -1, 0, 1, 4;
  const VectorXd q = (VectorXd(3) << -1, 0.5, -2).finished();
  for (const VectorXd& z : {VectorXd((VectorXd(3) << 0.3, 0.0, 0.6).finished()),
                            VectorXd((VectorXd(3) << 0.5, 0.2, 0.5).finished()),
                            VectorXd((VectorXd(3) << -0.1, 0.4, 0.0).finished())}) {
    const double r = LcpScaledResidual(Make(M, q), z);
    for (double d : {1e-15, 1e-6, 1e9}) {
      for (int row = 0; row < 3; ++row) {
        MatrixXd Ms = M;
        VectorXd qs = q;
        Ms.row(row) *= d;
        qs(row) *= d;
        EXPECT_NEAR(LcpScaledResidual(Make(Ms, qs), z), r, 1e-12 * (1.0 + r))
            << "row " << row << " scaled by " << d;
      }
    }
  }
}

// fuzz/crashes/lcp/lemke_fb_row_scaled.lcp: M = [[1e-12, 1], [0, 1e-12]], q = (−1e-12, −1e-19),
// unique solution z = (0, 1e-7) (row 2: z_2 = 1e-19 / 1e-12; row 1: w_1 = z_2 − 1e-12 > 0).
// Lemke (after its polish) and FB Newton reported z = (4e-10, 1e-12) as solved: w_2 = −1e-19, the
// whole size of row 2, which a global scale (4e-10) passed.
TEST(LcpAcceptanceTest, RowScaledProblemIsSolvedOrFailedNeverFaked) {
  const LcpProblem p = ReadLcpFile(VINCI_SOURCE_DIR "/fuzz/crashes/lcp/lemke_fb_row_scaled.lcp");
  EXPECT_GT(LcpScaledResidual(p, (VectorXd(2) << 4.0e-10, 1.0e-12).finished()), 0.5);
  EXPECT_LT(LcpScaledResidual(p, (VectorXd(2) << 0.0, 1e-7).finished()), 1e-12);
  for (const std::string& name : LcpSolverNames()) {
    SCOPED_TRACE(name);
    VectorXd z;
    const SolverReport r = MakeLcpSolver(name)->Solve(p, nullptr, &z);
    if (!r.ok()) continue;  // a failure status is an honest answer
    EXPECT_NEAR(z(0), 0.0, 1e-6 * 1e-7);
    EXPECT_NEAR(z(1), 1e-7, 1e-6 * 1e-7);
  }
}

// The answers every solver accepts on recorded simulator LCPs still pass the row-wise check:
// rows whose terms are all roundoff (q_i = 0) are judged against the floor s_z Σ_j |M_ij|.
TEST(LcpAcceptanceTest, RecordedSimulatorProblemsStillPass) {
  for (const char* file :
       {"box_pile_step0", "box_pile_tilted_step216", "box_pile_tilted_step233",
        "box_pile_tilted_cold_step232", "box_stack_cold_step425", "box_stack_cold_step7724",
        "incline_sliding_step9744", "feeder_tumbling_step107"}) {
    const LcpProblem p =
        ReadLcpFile(std::string(VINCI_SOURCE_DIR "/tests/data/lcp/") + file + ".lcp");
    SCOPED_TRACE(file);
    VectorXd z;
    const SolverReport r = MakeLcpSolver("lemke")->Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_LE(LcpScaledResidual(p, z), kLcpAcceptanceTolerance);
  }
}

TEST(LcpAcceptanceTest, ConfirmSolvedDowngradesAFalseSuccess) {
  const LcpProblem p = Make(1e-12 * MatrixXd::Identity(2, 2), VectorXd::Constant(2, -1e-12));
  SolverReport r;
  r.status = SolverStatus::kSolved;
  ConfirmSolved(p, VectorXd::Zero(2), &r);
  EXPECT_EQ(r.status, SolverStatus::kNumericalFailure);
  EXPECT_THAT(r.message, ::testing::HasSubstr("acceptance check"));
  r.status = SolverStatus::kSolved;
  r.message.clear();
  ConfirmSolved(p, VectorXd::Ones(2), &r);
  EXPECT_TRUE(r.ok());
}

}  // namespace
}  // namespace vinci::sim
