// Least squares: the residual Jacobians from forward step sensitivities agree with central
// finite differences of rollouts where the rollout is smooth in the unknowns.
#include <gtest/gtest.h>

#include <string>

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

// Every column agrees to `tol` relative to the column's largest entry (columns the residuals do
// not depend on, e.g. a velocity into the floor, are zero in both).
void ExpectColumnsAgree(const Jacobians& j, double tol) {
  ASSERT_EQ(j.sens.rows(), j.fd.rows());
  ASSERT_EQ(j.sens.cols(), j.fd.cols());
  EXPECT_EQ(j.r_sens, j.r_fd);  // the same rollout
  const double overall = j.fd.lpNorm<Eigen::Infinity>();
  for (Eigen::Index c = 0; c < j.fd.cols(); ++c) {
    const double scale = std::max(j.fd.col(c).lpNorm<Eigen::Infinity>(), 1e-6 * overall);
    EXPECT_LE((j.sens.col(c) - j.fd.col(c)).lpNorm<Eigen::Infinity>(), tol * scale)
        << "column " << c << "\nsensitivity " << j.sens.col(c).transpose().head(12)
        << "\nfd          " << j.fd.col(c).transpose().head(12);
  }
}

// The planar block sliding to rest (it stops at t ≈ 0.38 s for μ = 0.4): single shooting over
// the whole log, and a multiple-shooting segment with its continuity rows.
TEST(LeastSquaresJacobian, SensitivityAgreesWithFiniteDifferencesOnTheBlock) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log =
      ReadLog({SyntheticLog(sim, "block", 0.3, 0.6, 5, 0.0, 1, "jac_block.csv")}, sim.scene());
  const Jacobians single =
      Both(sim, log, 0, log.episodes[0].num_samples() - 1, 0.4, Shooting::kSingle);
  EXPECT_EQ(single.note_sens, "sensitivity");
  EXPECT_EQ(single.note_fd, "fd");
  ExpectColumnsAgree(single, 1e-5);
  const Jacobians segment = Both(sim, log, 10, 30, 0.4, Shooting::kMultiple);
  ExpectColumnsAgree(segment, 1e-5);
}

// A spatial box sliding on a plane (four redundant corner contacts, eight friction directions):
// the orientation residuals and rotation-vector state columns too.
TEST(LeastSquaresJacobian, SensitivityAgreesWithFiniteDifferencesOnASpatialBox) {
  const sim::Simulator sim(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  const Log log =
      ReadLog({SyntheticLog(sim, "box", 0.3, 0.2, 5, 0.0, 2, "jac_box.csv")}, sim.scene());
  const Jacobians j = Both(sim, log, 0, 12, 0.4, Shooting::kMultiple);
  EXPECT_EQ(j.note_sens, "sensitivity");
  ExpectColumnsAgree(j, 1e-5);
}

TEST(LeastSquaresJacobian, ParsesTheOption) {
  EXPECT_EQ(ParseLeastSquaresJacobian("sensitivity"), LeastSquaresJacobian::kSensitivity);
  EXPECT_EQ(ParseLeastSquaresJacobian("fd"), LeastSquaresJacobian::kFiniteDifference);
  EXPECT_THROW(ParseLeastSquaresJacobian("exact"), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
