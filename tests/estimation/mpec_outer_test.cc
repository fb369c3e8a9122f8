// The decomposed MPEC's outer problem (estimation/src/mpec_outer.h): the secant correction of
// its Newton model and the episodes' jackknife covariance, on quadratic episodes whose answers
// are known in closed form.
#include "../../estimation/src/mpec_outer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace vinci::estimation::mpec_internal {
namespace {

using sim::MatrixXd;
using sim::VectorXd;

TEST(MpecOuter, SecantOfOneParameterIsTheDifferenceQuotient) {
  const MatrixXd h = MatrixXd::Constant(1, 1, 3.0);
  const VectorXd s = VectorXd::Constant(1, 0.5), y = VectorXd::Constant(1, 2.0);
  double ratio = 0.0;
  const MatrixXd b = SecantCorrected(h, s, y, &ratio);
  EXPECT_NEAR(b(0, 0), 4.0, 1e-14);  // y / s
  EXPECT_NEAR(ratio, 4.0 / 3.0, 1e-14);
}

TEST(MpecOuter, SecantMeetsTheStepAndKeepsTheModelOnConjugateDirections) {
  MatrixXd h(2, 2);
  h << 4.0, 1.0, 1.0, 2.0;
  VectorXd s(2), y(2);
  s << 0.3, -0.1;
  y << 1.5, 0.2;  // sᵀy = 0.43 > 0, sᵀhs = 0.32
  const MatrixXd b = SecantCorrected(h, s, y);
  EXPECT_LT((b * s - y).norm(), 1e-14);
  EXPECT_LT((b - b.transpose()).norm(), 1e-14);
  EXPECT_EQ(b.llt().info(), Eigen::Success);  // positive definite
  // v with vᵀ h s = 0 (and then vᵀ y need not vanish: B v = h v + y (yᵀv) / sᵀy).
  const VectorXd hs = h * s;
  VectorXd v(2);
  v << -hs[1], hs[0];
  EXPECT_LT((b * v - h * v - y * y.dot(v) / s.dot(y)).norm(), 1e-13);
}

TEST(MpecOuter, SecantRejectsNegativeOrImplausibleCurvature) {
  const MatrixXd h = MatrixXd::Identity(2, 2);
  const VectorXd s = VectorXd::Constant(2, 1.0);
  double ratio = 0.0;
  EXPECT_EQ(SecantCorrected(h, s, -s, &ratio), h);
  EXPECT_EQ(ratio, -1.0);
  EXPECT_EQ(SecantCorrected(h, s, 20 * s, &ratio), h);  // 20× the model's curvature
  EXPECT_EQ(ratio, 20.0);
  EXPECT_EQ(SecantCorrected(h, s, 0.05 * s, &ratio), h);
  EXPECT_NE(SecantCorrected(h, s, 5 * s, &ratio), h);
}

// n episodes f_e(θ) = (θ − θ_e)ᵀ A (θ − θ_e) (χ² units: C_e = A⁻¹) with θ_e drawn around the
// truth with covariance A⁻¹ + T (T: the model error, the episodes' scatter beyond their noise).
// θ̂ is their mean, g_e = 2 A (θ̂ − θ_e), H_e = 2 A. Returns the mean of C_robust over draws.
MatrixXd MeanRobustCovariance(const MatrixXd& a, const MatrixXd& t, int n, int draws) {
  const int p = static_cast<int>(a.rows());
  const MatrixXd scatter = a.inverse() + t;
  const MatrixXd l = scatter.llt().matrixL();
  std::mt19937 rng(5);
  std::normal_distribution<double> n01;
  MatrixXd sum = MatrixXd::Zero(p, p);
  for (int d = 0; d < draws; ++d) {
    std::vector<VectorXd> theta(n);
    VectorXd mean = VectorXd::Zero(p);
    for (VectorXd& th : theta) {
      VectorXd z(p);
      for (int i = 0; i < p; ++i) z[i] = n01(rng);
      th = l * z;
      mean += th / n;
    }
    std::vector<VectorXd> g;
    for (const VectorXd& th : theta) g.push_back(2 * a * (mean - th));
    sum += EpisodeJackknifeCovariance(std::vector<MatrixXd>(n, 2 * a), g);
  }
  return sum / draws;
}

TEST(MpecOuter, RobustCovarianceIsUnbiasedWhenTheModelIsRight) {
  MatrixXd a(2, 2);
  a << 4e4, 1e4, 1e4, 2e4;
  const int n = 10;
  const MatrixXd c = (2 * n * a).inverse() * 2;  // C = 2 H⁻¹ = A⁻¹ / n
  const MatrixXd mean = MeanRobustCovariance(a, MatrixXd::Zero(2, 2), n, 20000);
  // Relative s.d. of the mean over draws ~ √(2 / (n − 1)) / √20000 = 0.3 %.
  EXPECT_NEAR(mean(0, 0) / c(0, 0), 1.0, 0.02);
  EXPECT_NEAR(mean(1, 1) / c(1, 1), 1.0, 0.02);
  EXPECT_NEAR(mean(0, 1) / c(0, 1), 1.0, 0.05);
}

TEST(MpecOuter, RobustCovarianceCarriesTheEpisodesScatter) {
  const MatrixXd a = MatrixXd::Constant(1, 1, 1e6);   // each episode's s.e. 1e-3
  const MatrixXd t = MatrixXd::Constant(1, 1, 1e-4);  // model error: s.d. 1e-2 between episodes
  const int n = 10;
  const MatrixXd mean = MeanRobustCovariance(a, t, n, 20000);
  // E[C_robust] = (A⁻¹ + T) / n; the model's C = A⁻¹ / n is 101× smaller.
  EXPECT_NEAR(mean(0, 0) / ((1e-6 + 1e-4) / n), 1.0, 0.02);
}

// One episode with 10× the others' information and a between-episode variance 10× their noise:
// the weighted θ̂ leans on that episode, whose own deviation the sandwich H⁻¹ Σ g gᵀ H⁻¹ shrinks
// (measured 0.37 of the true variance); the jackknife's d_e = (H − H_e)⁻¹ g_e does not.
TEST(MpecOuter, RobustCovarianceCarriesTheScatterOfUnequalEpisodes) {
  constexpr int kN = 10, kDraws = 20000;
  constexpr double kT = 1e-4;
  std::vector<double> v(kN, 1e-5);
  v[0] = 1e-6;
  std::vector<MatrixXd> h;
  double sum_h = 0.0;
  for (double ve : v) {
    h.push_back(MatrixXd::Constant(1, 1, 2 / ve));
    sum_h += 2 / ve;
  }
  double truth = 0.0;  // Var θ̂ = Σ w_e² (v_e + T)
  for (double ve : v) truth += std::pow(2 / ve / sum_h, 2) * (ve + kT);
  std::mt19937 rng(3);
  std::normal_distribution<double> n01;
  double mean = 0.0;
  for (int d = 0; d < kDraws; ++d) {
    std::vector<double> theta(kN);
    double t = 0.0;
    for (int e = 0; e < kN; ++e) {
      theta[e] = std::sqrt(v[e] + kT) * n01(rng);
      t += 2 / v[e] / sum_h * theta[e];
    }
    std::vector<VectorXd> g;
    for (int e = 0; e < kN; ++e) g.push_back(VectorXd::Constant(1, 2 / v[e] * (t - theta[e])));
    mean += EpisodeJackknifeCovariance(h, g)(0, 0) / kDraws;
  }
  EXPECT_NEAR(mean / truth, 1.0, 0.05);
}

TEST(MpecOuter, RobustCovarianceNeedsTwoEpisodesAndCurvature) {
  const MatrixXd h = MatrixXd::Identity(1, 1);
  const VectorXd one = VectorXd::Ones(1);
  EXPECT_EQ(EpisodeJackknifeCovariance({h}, {one}).size(), 0);
  EXPECT_EQ(EpisodeJackknifeCovariance({h, -h}, {one, -one}).size(), 0);  // H − H_0 = −1
  EXPECT_EQ(EpisodeJackknifeCovariance({h}, {one, -one}).size(), 0);      // sizes disagree
  // Two episodes pulling ±1, H_e = 1: d_e = ±1, (2 − 1)/2 · (1 + 1) = 1.
  EXPECT_NEAR(EpisodeJackknifeCovariance({h, h}, {one, -one})(0, 0), 1.0, 1e-15);
}

// Session 24's 50-toss run: toss 30's restart from its guess stopped at the continuation's
// cap (1.1e-5 against 1e-6) with χ² 85 224, its warm start converged at 115 362; the converged
// one was kept. A gap that large is a different local solution: the lower one is kept.
TEST(MpecOuter, RestartKeepsAFarLowerObjectiveEvenUnconverged) {
  EXPECT_TRUE(PreferRestart({true, false, 85224.0}, {true, true, 115362.0}));
  EXPECT_FALSE(PreferRestart({true, true, 115362.0}, {true, false, 85224.0}));
}

TEST(MpecOuter, RestartPrefersConvergedWithinTheObjectiveGap) {
  // 0.5 % lower but not converged: within the gap (1 % of 1000), the converged warm start.
  EXPECT_FALSE(PreferRestart({true, false, 995.0}, {true, true, 1000.0}));
  EXPECT_TRUE(PreferRestart({true, true, 1005.0}, {true, false, 1000.0}));
  // Both converged (or neither): the lower objective; the warm start on a tie.
  EXPECT_TRUE(PreferRestart({true, true, 999.0}, {true, true, 1000.0}));
  EXPECT_FALSE(PreferRestart({true, false, 1000.0}, {true, false, 1000.0}));
  // Small objectives: the gap is absolute (kRestartObjectiveGap · 1), 0.5 − 0.495 is within it.
  EXPECT_FALSE(PreferRestart({true, false, 0.495}, {true, true, 0.5}));
  EXPECT_TRUE(PreferRestart({true, false, 0.4}, {true, true, 0.5 + kRestartObjectiveGap}));
}

TEST(MpecOuter, RestartNeedsAUsableSolution) {
  EXPECT_FALSE(PreferRestart({false, false, 1.0}, {true, false, 100.0}));
  EXPECT_TRUE(PreferRestart({true, false, 100.0}, {false, false, 1.0}));
  EXPECT_FALSE(PreferRestart({false, false, 1.0}, {false, false, 100.0}));
}

}  // namespace
}  // namespace vinci::estimation::mpec_internal
