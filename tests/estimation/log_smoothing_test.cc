// The log smoother behind the MPEC estimator's initial guess (estimation/src/log_smoothing.h):
// the noise estimate from second differences and the SURE-chosen local quadratic fit.
#include "../../estimation/src/log_smoothing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "estimation_test_util.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

// The sliding block logged every 2 ms step with σ = 1 mm (angles σ / 0.1 m), 0.6 s.
Log BlockLog(double sigma, unsigned seed, const sim::Simulator& sim) {
  const std::string path = testing::SyntheticLog(sim, "block", 0.3, 0.6, 1, sigma, seed,
                                                 "smoothing_" + std::to_string(seed) + ".csv");
  return ReadLog({path}, sim.scene());
}

TEST(LogSmoothing, EstimatesTheNoiseFromTheDataAlone) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  for (const double sigma : {1e-4, 1e-3}) {
    const Log log = BlockLog(sigma, 3, sim);
    // ~500 samples × 2 columns: the median's relative spread is ~5%.
    EXPECT_NEAR(internal::EstimatePositionNoise(log.episodes[0]), sigma, 0.15 * sigma);
  }
  // Exact log: only the dynamics' second differences, μ g dt² / √6 ≈ 5e-6 m while sliding.
  EXPECT_LT(internal::EstimatePositionNoise(BlockLog(0.0, 3, sim).episodes[0]), 2e-5);
}

TEST(LogSmoothing, SmoothedPosesAreCloserToTheTruth) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log noisy = BlockLog(1e-3, 5, sim), exact = BlockLog(0.0, 5, sim);
  int k = 0;
  const Episode smooth = internal::SmoothedEpisode(noisy.episodes[0], true, &k);
  EXPECT_GE(k, 2);
  double raw = 0.0, fitted = 0.0;
  const sim::MatrixXd& truth = exact.episodes[0].bodies[0].pose;
  for (int i = 0; i < truth.rows(); ++i) {
    for (int c = 0; c < 2; ++c) {
      raw += std::pow(noisy.episodes[0].bodies[0].pose(i, c) - truth(i, c), 2);
      fitted += std::pow(smooth.bodies[0].pose(i, c) - truth(i, c), 2);
    }
  }
  // A window of 2k + 1 ≥ 5 samples averages the noise down by ≥ √5 where the motion is
  // quadratic (sliding, resting); the stop's kink costs a little.
  EXPECT_LT(fitted, raw / 3) << "k = " << k;
  // Times, sample count and the logged columns' layout are kept.
  EXPECT_EQ(smooth.t, noisy.episodes[0].t);
  EXPECT_EQ(smooth.bodies[0].pose.rows(), truth.rows());
}

}  // namespace
}  // namespace vinci::estimation
