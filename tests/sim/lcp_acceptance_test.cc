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

// Lemke's answers on recorded simulator LCPs (those it solves) pass the acceptance check.
TEST(LcpAcceptanceTest, RecordedSimulatorProblemsStillPass) {
  for (const char* file : {"box_pile_step0", "box_pile_tilted_step216", "box_pile_tilted_step233",
                           "box_pile_tilted_cold_step232", "box_stack_cold_step425",
                           "box_stack_cold_step7724", "incline_sliding_step9744"}) {
    const LcpProblem p =
        ReadLcpFile(std::string(VINCI_SOURCE_DIR "/tests/data/lcp/") + file + ".lcp");
    SCOPED_TRACE(file);
    VectorXd z;
    const SolverReport r = MakeLcpSolver("lemke")->Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_LE(LcpScaledResidual(p, z), kLcpAcceptanceTolerance);
  }
}

// A row written 1e-10 below the other (fuzz/crashes/lcp/lemke_fb_row_scaled.lcp): the solution
// is z = (0, 1e-7). Lemke and FB Newton reported z = (4e-10, 1e-12) as solved, w_2 = −1e-19
// (violated by its whole size), which the largest row's scale (4e-10) passed. Each row is now
// judged at its own scale (floored at 1e-8 of the problem's), and scaling row 2 changes nothing.
TEST(LcpAcceptanceTest, RowsAreJudgedAtTheirOwnScale) {
  MatrixXd M(2, 2);
  M << 1e-12, 1, 0, 1e-12;
  const VectorXd q = (VectorXd(2) << -1e-12, -1e-19).finished();
  const VectorXd wrong = (VectorXd(2) << 4e-10, 1e-12).finished();
  const VectorXd solution = (VectorXd(2) << 0.0, 1e-7).finished();
  const LcpProblem p = Make(M, q);
  // |w_2| = 1e-19 against the floor 1e-8 · 4e-10 (row 2's own terms, 1e-19, are below it).
  EXPECT_NEAR(LcpScaledResidual(p, wrong), 0.025, 1e-6);
  EXPECT_LE(LcpScaledResidual(p, solution), 1e-12);
  for (double s : {1e3, 1e6}) {  // row 2 in units above the floor: judged by its own terms
    MatrixXd Ms = M;
    VectorXd qs = q;
    Ms.row(1) *= s;
    qs(1) *= s;
    EXPECT_NEAR(LcpScaledResidual(Make(Ms, qs), wrong), 1.0, 1e-4);
    EXPECT_LE(LcpScaledResidual(Make(Ms, qs), solution), 1e-12);
  }
  for (const std::string& name : LcpSolverNames()) {
    SCOPED_TRACE(name);
    VectorXd z;
    const SolverReport r = MakeLcpSolver(name)->Solve(p, nullptr, &z);
    if (r.ok()) {
      EXPECT_NEAR(z(0), 0.0, 1e-13);
      EXPECT_NEAR(z(1), 1e-7, 1e-13);
    }
  }
}

// A row that is zero in exact arithmetic (entries ~1e-16 of the others, as a degenerate friction
// direction of the sensitivity LCP, sensitivity.cc): its residual is the cancellation
// 1.04e-17 − 1.07e-17, 1.4 % of its own terms but 5e-18 of the problem's scale. Judged at its
// own scale alone, every answer would fail (SensitivityTest.RollingSphereStepMatchesFinite-
// Differences then lost the degenerate branch); the floor at 1e-8 of the problem's scale passes it.
TEST(LcpAcceptanceTest, RowsOfPureRoundoffPass) {
  MatrixXd M(2, 2);
  M << 1, 1e-16, 3.78e-16, 1.09e-16;
  const VectorXd q = (VectorXd(2) << -0.0275, -1.07e-17).finished();
  const VectorXd z = (VectorXd(2) << 0.0275, 0.0).finished();
  const LcpProblem p = Make(M, q);
  ASSERT_LT((M * z + q)(1), 0.0);  // w_2 is a negative roundoff
  EXPECT_LE(LcpScaledResidual(p, z), kLcpAcceptanceTolerance);
  // The same violation in a row of real size fails.
  MatrixXd M2 = M;
  M2.row(1) *= 1e14;
  EXPECT_GT(LcpScaledResidual(Make(M2, (VectorXd(2) << -0.0275, -1.07e-3).finished()), z), 1e-3);
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
