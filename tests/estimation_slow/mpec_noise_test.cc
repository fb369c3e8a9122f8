// MPEC friction estimation with noisy logs: the reported standard errors (reduced Hessian,
// Laplace approximation) are honest. Slow: 20 seeded estimations of both complementarity
// treatments.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

// With σ = 1 mm position noise (stated), the error is within 3 reported standard errors in
// ≥ 90% of 20 seeded trials. Positions only, as in the least-squares test.
void CheckHonest(ComplementarityMethod method, bool state_noise) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const double sigma = 1e-3;
  int within = 0, converged = 0;
  const int trials = 20;
  double sum_z2 = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.6, 5, sigma, 100 + trial,
                                          "mpec_noisy_" + std::to_string(trial) + ".csv", false);
    const Log log = ReadLog({path}, sim.scene());
    MpecOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = state_noise ? sigma : 0.0;
    o.solver.method = method;
    const MpecEstimateResult r = EstimateMpec(sim, log, o);
    converged += r.converged;
    if (!std::isfinite(r.std_errors[0])) continue;
    const double z = (r.estimates[0] - kTrueMu) / r.std_errors[0];
    sum_z2 += z * z;
    within += std::abs(z) <= 3.0;
    if (!state_noise) {
      EXPECT_NEAR(r.sigma, sigma, 0.3 * sigma);
    }
  }
  EXPECT_GE(converged, 18);
  EXPECT_GE(within, 18) << "mean z² = " << sum_z2 / trials;
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

}  // namespace
}  // namespace vinci::estimation
