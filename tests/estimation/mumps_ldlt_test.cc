// Sequential MUMPS as the estimator's symmetric indefinite LDLᵀ (estimation/src/mumps_ldlt.h):
// a singular KKT matrix (a constraint stated twice) is factored with its null pivot set aside,
// and a right-hand side in the matrix' range is solved to rounding, with the component that is
// determined equal to the minimum-norm solution's.
#include "../../estimation/src/mumps_ldlt.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <vector>

namespace vinci::estimation::mpec_internal {
namespace {

// K = [H Aᵀ; A 0], H = diag(2, 1, 1), A = two copies of the row (−1, 1, 1): one null direction
// (0, 0, 0, 1, −1), whose θ component (entry 0) is 0, so y_0 of K y = e_0 is unique.
sim::SparseMatrixXd SingularKkt() {
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(5, 5);
  k.diagonal().head(3) << 2, 1, 1;
  for (int r = 3; r < 5; ++r) {
    k(r, 0) = k(0, r) = -1;
    k(r, 1) = k(1, r) = 1;
    k(r, 2) = k(2, r) = 1;
  }
  return k.sparseView();
}

TEST(MumpsLdlt, SolvesASingularKktInItsRange) {
  const sim::SparseMatrixXd K = SingularKkt();
  MumpsLdlt f;
  ASSERT_TRUE(f.Compute(K));
  EXPECT_EQ(f.null_pivots(), 1);
  const sim::VectorXd b = sim::VectorXd::Unit(5, 0);
  const sim::VectorXd y = f.solve(b);
  ASSERT_TRUE(y.allFinite());
  EXPECT_LE((K * y - b).norm(), 1e-14);
  const Eigen::MatrixXd dense(K);
  const sim::VectorXd min_norm = dense.completeOrthogonalDecomposition().solve(b);
  EXPECT_NEAR(y[0], min_norm[0], 1e-14);
  // By hand (λ the two rows' summed multiplier): 2θ − λ = 1, u_i + λ = 0, θ = u1 + u2, so
  // λ = −1/5 and y_0 = θ = 2/5.
  EXPECT_NEAR(y[0], 0.4, 1e-14);
}

TEST(MumpsLdlt, RefactorsAnotherMatrixAndSolvesAgain) {
  MumpsLdlt f;
  ASSERT_TRUE(f.Compute(SingularKkt()));
  Eigen::MatrixXd spd(3, 3);
  spd << 4, 1, 0, 1, 3, 1, 0, 1, 2;
  ASSERT_TRUE(f.Compute(sim::SparseMatrixXd(spd.sparseView())));
  EXPECT_EQ(f.null_pivots(), 0);
  const sim::VectorXd b = (sim::VectorXd(3) << 1, 2, 3).finished();
  EXPECT_LE((spd * f.solve(b) - b).norm(), 1e-14);
}

}  // namespace
}  // namespace vinci::estimation::mpec_internal
