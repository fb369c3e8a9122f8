// MPEC friction estimation with noisy logs: the reported standard errors (reduced Hessian,
// Laplace approximation) are honest. Slow: 40 seeded estimations per complementarity
// treatment.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

// Coverage of the Laplace standard error over 40 noise seeds: the error is within 3 reported
// standard errors in ≥ 90% of them (nominal 99.7%; the s.e. is first order). Short logs keep
// the Monte Carlo to minutes (the earlier 20 × 1 mm × 0.6 s version took ~3 min per trial on
// the loaded machine and never completed): σ = 0.1 mm, positions only, every 5th step of 0.4 s
// (41 samples of a block still sliding at the end; 200 steps).
void CheckHonest(ComplementarityMethod method, bool state_noise) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const double sigma = 1e-4;
  int within = 0, converged = 0, finite = 0;
  const int trials = 40;
  double sum_z2 = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.4, 5, sigma, 100 + trial,
                                          "mpec_noisy_" + std::to_string(trial) + ".csv", false);
    const Log log = ReadLog({path}, sim.scene());
    MpecOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = state_noise ? sigma : 0.0;
    o.solver.method = method;
    const MpecEstimateResult r = EstimateMpec(sim, log, o);
    converged += r.converged;
    if (!std::isfinite(r.std_errors[0])) continue;
    ++finite;
    const double z = (r.estimates[0] - kTrueMu) / r.std_errors[0];
    sum_z2 += z * z;
    within += std::abs(z) <= 3.0;
    std::printf("trial %d: mu %.6f s.e. %.3g z %.2f iterations %d converged %d\n", trial,
                r.estimates[0], r.std_errors[0], z, r.iterations, r.converged ? 1 : 0);
    std::fflush(stdout);
    if (!state_noise) {
      EXPECT_NEAR(r.sigma, sigma, 0.3 * sigma);
    }
  }
  EXPECT_GE(converged, 36);
  EXPECT_GE(finite, 36);
  EXPECT_GE(within, 36) << "mean z² = " << sum_z2 / std::max(finite, 1);
  std::printf("%s: %d/%d within 3 s.e., mean z^2 %.3g, %d converged\n", ToString(method), within,
              trials, sum_z2 / std::max(finite, 1), converged);
}

TEST(MpecNoise, ScholtesStandardErrorsAreHonest) {
  CheckHonest(ComplementarityMethod::kScholtes, true);
}
TEST(MpecNoise, PenaltyStandardErrorsAreHonest) {
  CheckHonest(ComplementarityMethod::kPenalty, true);
}
TEST(MpecNoise, EstimatedSigmaStandardErrorsAreHonest) {
  CheckHonest(ComplementarityMethod::kScholtes, false);
}

// Two 0.1 mm logs stated as 0.025 mm: the decomposed estimator reports the contradiction (not
// converged, σ̂ ≈ 0.1 mm) as the joint one does (MpecEstimator.
// ResidualsThatContradictTheStatedNoiseAreReported), and a bootstrap keeps the resamples whose
// only fault is that contradiction (model error is what its spread is for).
TEST(MpecNoise, ContradictedNoiseDecomposedAndBootstrap) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log = ReadLog({SyntheticLog(sim, "block", kTrueMu, 0.3, 5, 1e-4, 41, "chi2_a.csv"),
                           SyntheticLog(sim, "block", kTrueMu, 0.3, 5, 1e-4, 42, "chi2_b.csv")},
                          sim.scene());
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 2.5e-5;
  o.episodes = MpecEpisodes::kDecomposed;
  const MpecEstimateResult dec = EstimateMpec(sim, log, o);
  EXPECT_FALSE(dec.converged);
  EXPECT_TRUE(dec.noise_contradicted) << dec.reason;
  EXPECT_NE(dec.reason.find("the residuals contradict the stated noise"), std::string::npos);
  EXPECT_GT(dec.sigma, 0.6e-4);
  EXPECT_LT(dec.sigma, 1.4e-4);

  o.episodes = MpecEpisodes::kJoint;
  o.bootstrap = 3;
  const MpecEstimateResult boot = EstimateMpec(sim, log, o);
  EXPECT_TRUE(boot.noise_contradicted) << boot.reason;
  EXPECT_EQ(boot.std_error_method, "bootstrap");
  EXPECT_EQ(boot.bootstrap_converged, 3);
  EXPECT_TRUE(std::isfinite(boot.std_errors[0]));
}

// Bootstrap over episodes: identical episodes make every resample the same data, so (the
// solver being deterministic) the bootstrap standard error is exactly 0; episodes with
// independent noise give a positive one of the order of the Laplace approximation.
TEST(MpecNoise, BootstrapOverEpisodes) {
  const sim::Simulator sim(sim::LoadSceneFile(testing::kPlateBoxFile));
  std::vector<std::string> same, noisy;
  for (int k = 0; k < 3; ++k) {
    same.push_back(SyntheticLog(sim, "box", 0.2, 0.03, 1, 1e-5, 11,
                                "mpec_boot_same_" + std::to_string(k) + ".csv"));
    noisy.push_back(SyntheticLog(sim, "box", 0.2, 0.03, 1, 1e-5, 20 + k,
                                 "mpec_boot_noisy_" + std::to_string(k) + ".csv"));
  }
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-5;
  o.bootstrap = 4;
  const MpecEstimateResult a = EstimateMpec(sim, ReadLog(same, sim.scene()), o);
  EXPECT_EQ(a.std_error_method, "bootstrap");
  EXPECT_EQ(a.bootstrap_converged, 4);
  EXPECT_EQ(a.std_errors[0], 0.0);
  const MpecEstimateResult b = EstimateMpec(sim, ReadLog(noisy, sim.scene()), o);
  o.bootstrap = 0;
  const MpecEstimateResult laplace = EstimateMpec(sim, ReadLog(noisy, sim.scene()), o);
  EXPECT_EQ(laplace.std_error_method, "laplace");
  EXPECT_EQ(b.estimates[0], laplace.estimates[0]);
  EXPECT_GT(b.std_errors[0], 0.0);
  EXPECT_LT(b.std_errors[0], 10 * laplace.std_errors[0]);
  EXPECT_GT(b.std_errors[0], 0.1 * laplace.std_errors[0]);
  o.bootstrap = -1;
  EXPECT_THROW(EstimateMpec(sim, ReadLog(noisy, sim.scene()), o), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
