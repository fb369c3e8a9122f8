// SolveOnWarmBasis with an operator that only bounds ‖M‖∞ (LcpMatrixOperator::NormInfBounds):
// the same acceptance, z and τ as with the exact norm whatever the bounds' width, and the exact
// norm formed only where the bounds cannot decide.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <utility>
#include <vector>

#include "test_util.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/warm_basis.h"

namespace vinci::sim {
namespace {

using testing::RandomBandedPLcp;

// M through SparseLcpMatrix, with bounds lo = f_lo ‖M‖∞ and hi = f_hi ‖M‖∞ (powers of two: exact
// scalings) and a count of the exact norms formed.
class BoundedNormMatrix final : public LcpMatrixOperator {
 public:
  BoundedNormMatrix(const Eigen::SparseMatrix<double>& M, double f_lo, double f_hi)
      : inner_(M), f_lo_(f_lo), f_hi_(f_hi) {}
  int size() const override { return inner_.size(); }
  double NormInf() const override {
    ++norm_calls;
    return inner_.NormInf();
  }
  void NormInfBounds(double* lo, double* hi) const override {
    const double m = inner_.NormInf();
    *lo = f_lo_ * m;
    *hi = f_hi_ * m;
  }
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
  double f_lo_, f_hi_;
};

bool SameBits(const VectorXd& a, const VectorXd& b) {
  if (a.size() != b.size()) return false;
  for (Eigen::Index i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(double)) != 0) return false;
  return true;
}

// Lemke's solutions (accepted) and perturbed guesses (some refused), at every bound width: the
// bounded solve answers as the exact one, bit for bit.
TEST(WarmBasisBoundsTest, SameOutcomeAsExactNormForAnyBounds) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const LemkeSolver lemke;
  int accepted = 0, refused = 0;
  for (int n : {6, 20, 60}) {
    for (int trial = 0; trial < 4; ++trial) {
      LcpProblem p = RandomBandedPLcp(n, &rng);
      if (trial % 2 == 1) p.q *= 1e-4;  // small z: the bounds decide alone
      VectorXd z_cold;
      ASSERT_TRUE(lemke.Solve(p, nullptr, &z_cold).ok());
      VectorXd perturbed = z_cold;
      for (Eigen::Index i = 0; i < n; ++i)
        if (u(rng) < 0.2) perturbed[i] = perturbed[i] > 0.0 ? 0.0 : 1e-3;
      const Eigen::SparseMatrix<double> Ms = p.M.sparseView();
      for (const VectorXd* guess : {&z_cold, &perturbed}) {
        const SparseLcpMatrix exact(Ms);
        WarmBasisScratch s_exact;
        VectorXd z_exact;
        SolverReport r_exact;
        const bool ok_exact =
            SolveOnWarmBasis(exact, p.q, *guess, lemke.options(), &s_exact, &z_exact, &r_exact);
        ok_exact ? ++accepted : ++refused;
        for (const auto& [f_lo, f_hi] :
             {std::pair{1.0, 1.0}, std::pair{0.5, 2.0}, std::pair{1.0 / 1024, 1024.0}}) {
          const BoundedNormMatrix bounded(Ms, f_lo, f_hi);
          WarmBasisScratch s;
          VectorXd z;
          SolverReport r;
          const bool ok = SolveOnWarmBasis(bounded, p.q, *guess, lemke.options(), &s, &z, &r);
          ASSERT_EQ(ok, ok_exact) << "n = " << n << " trial " << trial << " bounds ×" << f_hi;
          if (!ok) continue;
          EXPECT_TRUE(SameBits(z, z_exact));
          EXPECT_EQ(r.tolerance, r_exact.tolerance);
          EXPECT_EQ(r.residual, r_exact.residual);
        }
      }
    }
  }
  EXPECT_GT(accepted, 0);
  EXPECT_GT(refused, 0);
}

// M = 2I, q = −c: z = c/2. With small c the bounds [‖M‖/2, 2‖M‖] decide (τ = rtol·max(1, ‖q‖∞)
// either way) and the exact norm is never formed; with large c, τ depends on ‖M‖∞ and it is.
TEST(WarmBasisBoundsTest, FormsExactNormOnlyWhenTheBoundsCannotDecide) {
  const int n = 4;
  const Eigen::SparseMatrix<double> M = (2.0 * MatrixXd::Identity(n, n)).sparseView();
  const LemkeOptions options;
  for (double c : {1e-3, 1e3}) {
    const VectorXd q = VectorXd::Constant(n, -c);
    const VectorXd guess = VectorXd::Constant(n, c);  // the basis {all}, near z
    const BoundedNormMatrix bounded(M, 0.5, 2.0);
    WarmBasisScratch s;
    VectorXd z;
    SolverReport r;
    ASSERT_TRUE(SolveOnWarmBasis(bounded, q, guess, options, &s, &z, &r));
    EXPECT_NEAR(z[0], c / 2, 1e-12 * c);
    if (c < 1.0)
      EXPECT_EQ(bounded.norm_calls, 0);
    else
      EXPECT_GT(bounded.norm_calls, 0);
  }
}

}  // namespace
}  // namespace vinci::sim
