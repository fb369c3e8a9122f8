// Least-squares standard errors on the noisy vibrating plate (thesis chapter 7, true μ = 0.2):
// the error is within 3 reported standard errors in ≥ 90% of 20 seeded trials. Slow (20 fits
// of 1–5 s each).
#include <gtest/gtest.h>

#include <cmath>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

void ExpectCoverage(Shooting shooting, double sigma) {
  const sim::Simulator sim(sim::ParseScene(testing::kVibratingPlate, "plate.yaml"));
  const double true_mu = 0.2;
  const int trials = 20;
  int within = 0;
  double sum_z2 = 0.0;
  for (int trial = 0; trial < trials; ++trial) {
    // 50 samples at 500 Hz (two plate cycles) after 0.2 s, the study's seeds.
    const Log log = testing::SampledLog(sim, true_mu, 200, 2, 50, sigma, 50000 + trial);
    LeastSquaresOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = sigma;
    o.shooting = shooting;
    o.segment_samples = 25;
    o.max_iterations = 50;
    const EstimateResult r = EstimateLeastSquares(sim, log, o);
    const double z = (r.estimates[0] - true_mu) / r.std_errors[0];
    within += std::abs(z) <= 3.0;
    sum_z2 += std::isfinite(z) ? z * z : 0.0;
  }
  EXPECT_GE(within, 18) << "mean z² = " << sum_z2 / trials;
}

TEST(PlateCoverage, MultipleShootingTenMicrons) { ExpectCoverage(Shooting::kMultiple, 1e-5); }
TEST(PlateCoverage, SingleShootingTenMicrons) { ExpectCoverage(Shooting::kSingle, 1e-5); }
TEST(PlateCoverage, MultipleShootingHundredMicrons) { ExpectCoverage(Shooting::kMultiple, 1e-4); }

}  // namespace
}  // namespace vinci::estimation
