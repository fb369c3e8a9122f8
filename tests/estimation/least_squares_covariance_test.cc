// Least-squares standard errors on the vibrating plate (thesis chapter 7): the covariance is the
// same for single and multiple shooting at the same solution, and σ is not taken smaller than
// the residuals show. The seeded-coverage version (20 trials) is in
// tests/estimation_slow/plate_coverage_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SampledLog;

constexpr double kTrueMu = 0.2;

LeastSquaresOptions PlateOptions(Shooting shooting, double sigma) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = sigma;
  o.shooting = shooting;
  o.segment_samples = 25;
  o.max_iterations = 50;
  return o;
}

// Multiple shooting's continuity residuals are constraints: chaining the segments' Jacobians
// through them gives single shooting's Jacobian, so at the same solution the two report the
// same standard error (the Gauss–Newton covariance of the stacked system, with the continuity
// rows weighted 10³ and a pseudo-inverse, reported one 4× smaller).
TEST(LeastSquaresCovariance, SingleAndMultipleShootingAgreeOnThePlate) {
  const sim::Simulator sim(sim::ParseScene(testing::kVibratingPlate, "plate.yaml"));
  const double sigma = 1e-5;
  // 50 samples at 500 Hz (two plate cycles) after 0.2 s.
  const Log log = SampledLog(sim, kTrueMu, 200, 2, 50, sigma, 50000);
  const EstimateResult a = EstimateLeastSquares(sim, log, PlateOptions(Shooting::kSingle, sigma));
  const EstimateResult b = EstimateLeastSquares(sim, log, PlateOptions(Shooting::kMultiple, sigma));
  ASSERT_TRUE(a.converged) << a.reason;
  ASSERT_TRUE(b.converged) << b.reason;
  ASSERT_NEAR(a.estimates[0], b.estimates[0], 1e-5) << "not the same solution";
  ASSERT_TRUE(std::isfinite(a.std_errors[0])) << a.reason;
  EXPECT_NEAR(b.std_errors[0], a.std_errors[0], 0.05 * a.std_errors[0]);
  // Both fits reach the noise level: σ̂ ≈ σ, and σ is the stated one.
  EXPECT_NEAR(a.sigma_residual, sigma, 0.3 * sigma);
  EXPECT_EQ(a.sigma, std::max(sigma, a.sigma_residual));
  EXPECT_LE(std::abs(a.estimates[0] - kTrueMu), 3 * a.std_errors[0]);
}

// Noise-free, multiple shooting recovers μ of the plate to 1e-4.
TEST(LeastSquaresCovariance, MultipleShootingRecoversThePlateNoiseFree) {
  const sim::Simulator sim(sim::ParseScene(testing::kVibratingPlate, "plate.yaml"));
  const Log log = SampledLog(sim, kTrueMu, 200, 2, 50, 0.0, 1);
  const EstimateResult r = EstimateLeastSquares(sim, log, PlateOptions(Shooting::kMultiple, 0));
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
}

// A stated noise smaller than the residuals show does not shrink the standard errors: σ is the
// residual estimate then, the standard error scales with it, and the fit is flagged.
TEST(LeastSquaresCovariance, UnderstatedNoiseUsesTheResidualEstimate) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const double sigma = 1e-3;
  const std::string path =
      testing::SyntheticLog(sim, "block", 0.3, 0.6, 5, sigma, 3, "understated.csv", false);
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = sigma;
  const EstimateResult honest = EstimateLeastSquares(sim, log, o);
  o.noise_sigma = sigma / 10;
  const EstimateResult understated = EstimateLeastSquares(sim, log, o);
  ASSERT_TRUE(std::isfinite(honest.std_errors[0])) << honest.reason;
  EXPECT_NEAR(understated.sigma, understated.sigma_residual, 1e-15);
  // ... and the fit is not reported as converged: its residuals contradict the stated σ.
  EXPECT_TRUE(honest.converged) << honest.reason;
  EXPECT_FALSE(understated.converged);
  EXPECT_NE(understated.reason.find("contradict the stated noise"), std::string::npos)
      << understated.reason;
  EXPECT_NEAR(understated.sigma_residual, sigma, 0.3 * sigma);
  EXPECT_NEAR(understated.std_errors[0] / honest.std_errors[0], understated.sigma / honest.sigma,
              1e-6);
}

}  // namespace
}  // namespace vinci::estimation
