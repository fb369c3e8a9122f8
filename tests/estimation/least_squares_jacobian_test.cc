// Least squares: the residual Jacobians from forward step sensitivities agree with central
// finite differences of rollouts where the rollout is smooth in the unknowns.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

struct Jacobians {
  sim::VectorXd r_sens, r_fd;
  sim::MatrixXd sens, fd;
  std::string note_sens, note_fd;
};

Jacobians Both(const sim::Simulator& sim, const Log& log, int first, int last, double mu,
               Shooting shooting) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.shooting = shooting;
  const sim::VectorXd theta = sim::VectorXd::Constant(1, mu);
  Jacobians j;
  sim::VectorXd s;
  o.jacobian = LeastSquaresJacobian::kSensitivity;
  EXPECT_TRUE(
      SegmentJacobian(sim, log, 0, first, last, theta, o, &s, &j.r_sens, &j.sens, &j.note_sens))
      << j.note_sens;
  o.jacobian = LeastSquaresJacobian::kFiniteDifference;
  EXPECT_TRUE(SegmentJacobian(sim, log, 0, first, last, theta, o, &s, &j.r_fd, &j.fd, &j.note_fd))
      << j.note_fd;
  return j;
}

// Every column (or the listed ones) agrees to `tol` relative to the column's largest entry
// (columns the residuals do not depend on, e.g. a velocity into the floor, are zero in both).
void ExpectColumnsAgree(const Jacobians& j, double tol, std::vector<int> columns = {}) {
  ASSERT_EQ(j.sens.rows(), j.fd.rows());
  ASSERT_EQ(j.sens.cols(), j.fd.cols());
  EXPECT_EQ(j.r_sens, j.r_fd);  // the same rollout
  const double overall = j.fd.lpNorm<Eigen::Infinity>();
  if (columns.empty())
    for (int c = 0; c < j.fd.cols(); ++c) columns.push_back(c);
  for (const int c : columns) {
    const double scale = std::max(j.fd.col(c).lpNorm<Eigen::Infinity>(), 1e-4 * overall);
    Eigen::Index row = 0;
    const double diff = (j.sens.col(c) - j.fd.col(c)).cwiseAbs().maxCoeff(&row);
    EXPECT_LE(diff, tol * scale) << "column " << c << ", row " << row << " of " << j.fd.rows()
                                 << ": sensitivity " << j.sens(row, c) << ", fd " << j.fd(row, c);
  }
}

// The planar block sliding (at μ = 0.4 it stops at t ≈ 0.38 s): single shooting over its first
// 26 samples (t ≤ 0.3 s, before the stop) and a multiple-shooting segment (samples 5..25) with
// its continuity rows.
TEST(LeastSquaresJacobian, SensitivityAgreesWithFiniteDifferencesWhileTheBlockSlides) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log =
      ReadLog({SyntheticLog(sim, "block", 0.3, 0.6, 5, 0.0, 1, "jac_block.csv")}, sim.scene());
  ASSERT_LT(log.episodes[0].t[25], 0.35);
  const Jacobians single = Both(sim, log, 0, 25, 0.4, Shooting::kSingle);
  EXPECT_EQ(single.note_sens, "sensitivity");
  EXPECT_EQ(single.note_fd, "fd");
  ExpectColumnsAgree(single, 1e-5);
  const Jacobians segment = Both(sim, log, 5, 25, 0.4, Shooting::kMultiple);
  ExpectColumnsAgree(segment, 1e-5);
}

// The same block over the whole 0.6 s log, across its stop and the sticking steps after it
// (their unloaded friction directions are degenerate pairs), at the log's μ = 0.3 and above it
// (stops at ≈ 0.51, 0.38, 0.30 s). Until the step derivatives of issue 17's sessions 25–27
// the samples after the stop differed by one step's dt ∂v/∂v_0 (the stop step differentiated as
// sliding); measured now: within 1e-8 of each column's largest entry.
TEST(LeastSquaresJacobian, SensitivityAgreesWithFiniteDifferencesAcrossTheStop) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log =
      ReadLog({SyntheticLog(sim, "block", 0.3, 0.6, 5, 0.0, 1, "jac_stop.csv")}, sim.scene());
  const int last = log.episodes[0].num_samples() - 1;
  ASSERT_GT(log.episodes[0].t[last], 0.55);
  for (const double mu : {0.3, 0.4, 0.5}) {
    SCOPED_TRACE("mu " + std::to_string(mu));
    ExpectColumnsAgree(Both(sim, log, 0, last, mu, Shooting::kSingle), 1e-5);
  }
}

// A spatial box started at rest on its face, sliding (four corners, 8 friction directions), over
// its first 0.3 s (before it stops). Its first step has an unloaded corner touching the floor;
// until session 33 the step derivative gave that corner friction (∂ω_z/∂v_x = −6 where the
// differences are 0), which put ∂x/∂z_0 near 36 over the rollout. The columns compared: μ and
// the initial state's x, y, z, q_z, v and ω_z; a tilt of the initial pose (q_w, q_x, q_y, ω_x,
// ω_y) lifts or presses that corner, a kink where the sensitivities' one-sided derivative and the
// central differences' average of the two sides differ (by up to 6e-3 of the column).
TEST(LeastSquaresJacobian, SensitivityAgreesWithFiniteDifferencesOnTheSlidingBox) {
  const sim::Simulator sim(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  const Log log =
      ReadLog({SyntheticLog(sim, "box", 0.3, 0.5, 5, 0.0, 1, "jac_box.csv")}, sim.scene());
  int last = 0;
  while (log.episodes[0].t[last + 1] <= 0.3) ++last;
  for (const double mu : {0.25, 0.3}) {  // stops at 0.49 s and 0.41 s
    SCOPED_TRACE("mu " + std::to_string(mu));
    // [μ | x y z r_x r_y r_z | v_x v_y v_z ω_x ω_y ω_z], r the rotation vector
    // Central differences of this 150-step spatial rollout carry the step LCP's ~1e-8 noise in ν:
    // up to 3e-3 of the ω_z column at the last sample (the errors fixed were 0.2 … 36).
    ExpectColumnsAgree(Both(sim, log, 0, last, mu, Shooting::kSingle), 1e-2,
                       {0, 1, 2, 3, 6, 7, 8, 9, 12});
  }
}

// A contact removes a velocity perturbation into it to round-off every step (×1e-17), so such a
// column of the forward sensitivities passes through the denormals within ~20 steps. The
// observation map's central difference along it divided by its size (∞ for a denormal) and
// ∞ · 0 put NaN into the Jacobian: two of 80 noisy block fits of the studies failed at their
// first evaluation. Positions of the sliding block every 5th step for 0.3 s with 1 mm noise,
// evaluated at μ = 0.5: seed 45 was one of 60 that failed so.
TEST(LeastSquaresJacobian, ColumnsDecayingThroughDenormalsStayFinite) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  for (const unsigned seed : {45u, 1u, 2u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Log log = ReadLog(
        {SyntheticLog(sim, "block", 0.3, 0.3, 5, 1e-3, seed, "denormal.csv", false)}, sim.scene());
    const Jacobians j =
        Both(sim, log, 0, log.episodes[0].num_samples() - 1, 0.5, Shooting::kSingle);
    EXPECT_TRUE(j.sens.allFinite());
    EXPECT_TRUE(j.r_sens.allFinite());
  }
}

TEST(LeastSquaresJacobian, ParsesTheOption) {
  EXPECT_EQ(ParseLeastSquaresJacobian("sensitivity"), LeastSquaresJacobian::kSensitivity);
  EXPECT_EQ(ParseLeastSquaresJacobian("fd"), LeastSquaresJacobian::kFiniteDifference);
  EXPECT_THROW(ParseLeastSquaresJacobian("exact"), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
