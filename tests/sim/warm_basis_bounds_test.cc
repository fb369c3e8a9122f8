// SolveOnWarmBasis with an operator that bounds ‖M‖∞ (LcpMatrixOperator::NormInfBound): the
// tolerances are scaled by the bound instead of the norm (never formed then), so they widen by at
// most the bound's factor; z itself does not depend on the scale.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "test_util.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/warm_basis.h"

namespace vinci::sim {
namespace {

using testing::RandomBandedPLcp;

// M through SparseLcpMatrix, with the bound f ‖M‖∞ (f a power of two: an exact scaling; f = +inf:
// no bound) and a count of the exact norms formed.
class BoundedNormMatrix final : public LcpMatrixOperator {
 public:
  BoundedNormMatrix(const Eigen::SparseMatrix<double>& M, double f) : inner_(M), f_(f) {}
  int size() const override { return inner_.size(); }
  double NormInf() const override {
    ++norm_calls;
    return inner_.NormInf();
  }
  double NormInfBound() const override { return f_ * inner_.NormInf(); }
  void MultiplyAdd(const VectorXd& z, const VectorXd& q, VectorXd* w) const override {
    inner_.MultiplyAdd(z, q, w);
  }
  void PrincipalBlock(const std::vector<int>& index, MatrixXd* out) const override {
    inner_.PrincipalBlock(index, out);
  }
  void PrincipalBlockSparse(const std::vector<int>& index, CompressedColumns* out) const override {
    inner_.PrincipalBlockSparse(index, out);
  }
  mutable int norm_calls = 0;

 private:
  SparseLcpMatrix inner_;
  double f_;
};

bool SameBits(const VectorXd& a, const VectorXd& b) {
  if (a.size() != b.size()) return false;
  for (Eigen::Index i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(double)) != 0) return false;
  return true;
}

// Lemke's solutions, accepted with the exact norm, are accepted with a bound f ‖M‖∞ too, with the
// same z and residual and τ_exact ≤ τ ≤ f τ_exact; the exact norm is formed only without a bound,
// and then the answer is the exact operator's.
TEST(WarmBasisBoundsTest, BoundWidensToleranceByAtMostItsFactor) {
  std::mt19937 rng(11);
  const LemkeSolver lemke;
  int widened = 0;
  for (int n : {6, 20, 60}) {
    for (int trial = 0; trial < 4; ++trial) {
      LcpProblem p = RandomBandedPLcp(n, &rng);
      if (trial % 2 == 1) p.q *= 1e-4;  // small z: τ = rtol·max(1, ‖q‖∞) whatever the scale
      VectorXd z_cold;
      ASSERT_TRUE(lemke.Solve(p, nullptr, &z_cold).ok());
      const Eigen::SparseMatrix<double> Ms = p.M.sparseView();
      const SparseLcpMatrix exact(Ms);
      WarmBasisScratch s_exact;
      VectorXd z_exact;
      SolverReport r_exact;
      ASSERT_TRUE(
          SolveOnWarmBasis(exact, p.q, z_cold, lemke.options(), &s_exact, &z_exact, &r_exact));
      for (double f : {1.0, 2.0, 1024.0, std::numeric_limits<double>::infinity()}) {
        const BoundedNormMatrix bounded(Ms, f);
        WarmBasisScratch s;
        VectorXd z;
        SolverReport r;
        ASSERT_TRUE(SolveOnWarmBasis(bounded, p.q, z_cold, lemke.options(), &s, &z, &r))
            << "n = " << n << " trial " << trial << " bound ×" << f;
        EXPECT_TRUE(SameBits(z, z_exact));
        EXPECT_EQ(r.residual, r_exact.residual);
        if (std::isfinite(f)) {
          EXPECT_EQ(bounded.norm_calls, 0);
          EXPECT_GE(r.tolerance, r_exact.tolerance);
          EXPECT_LE(r.tolerance, f * r_exact.tolerance);
          if (r.tolerance > r_exact.tolerance) ++widened;
        } else {
          EXPECT_GT(bounded.norm_calls, 0);
          EXPECT_EQ(r.tolerance, r_exact.tolerance);
        }
      }
    }
  }
  EXPECT_GT(widened, 0);  // some τ depended on the scale
}

// M = I, q = (−c, ε), guess basis {0, 1}: z_B = (c, −ε). With c = 100, τ(z_B) = rtol · 100 ‖M‖∞:
// z_B,1 = −1.5 rtol · 100 is refused with the exact norm and accepted (z = (c, 0)) with the bound
// 2 ‖M‖∞.
TEST(WarmBasisBoundsTest, ToleranceScalesWithTheBound) {
  const Eigen::SparseMatrix<double> M = MatrixXd::Identity(2, 2).sparseView();
  const LemkeOptions options;
  const double c = 100.0, eps = 1.5 * options.residual_tolerance * c;
  const Eigen::Vector2d q(-c, eps), guess(c, 1.0);
  for (double f : {1.0, 2.0}) {
    const BoundedNormMatrix bounded(M, f);
    WarmBasisScratch s;
    VectorXd z;
    SolverReport r;
    const bool ok = SolveOnWarmBasis(bounded, q, guess, options, &s, &z, &r);
    EXPECT_EQ(ok, f > 1.0) << "bound ×" << f;
    if (!ok) continue;
    EXPECT_EQ(z, Eigen::Vector2d(c, 0.0));
    EXPECT_DOUBLE_EQ(r.tolerance, options.residual_tolerance * f * c);
  }
}

}  // namespace
}  // namespace vinci::sim
