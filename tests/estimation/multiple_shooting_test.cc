// Least squares with multiple shooting: exact recovery without noise, continuity at the
// solution, and the segments' own start states.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

LeastSquaresOptions MultipleShooting(int segment_samples) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.shooting = Shooting::kMultiple;
  o.segment_samples = segment_samples;
  return o;
}

TEST(MultipleShooting, PlanarBlockNoiseFreeRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "ms_exact.csv");
  const Log log = ReadLog({path}, sim.scene());
  const int n = log.episodes[0].num_samples();
  const EstimateResult r = EstimateLeastSquares(sim, log, MultipleShooting(20));
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  // Segments of 20 samples, a short tail merged into the last.
  EXPECT_EQ(r.num_segments, (n - 1) / 20 + ((n - 1) % 20 >= 10 ? 1 : 0));
  EXPECT_GE(r.num_segments, 2);
  EXPECT_EQ(r.num_continuity_residuals, (r.num_segments - 1) * 6);
  EXPECT_LT(r.continuity_defect, 1e-6);
  EXPECT_LT(r.episodes[0].rms_residual, 1e-6);
  EXPECT_TRUE(std::isfinite(r.std_errors[0]));
}

// From a poor guess (μ = 4: the model block stops after 4 cm instead of 38 cm), 10-sample
// segments, each starting on the data, recover μ. (Single shooting from there wandered off
// while Ceres' bounded line search interpolated cubically; with the quadratic interpolation it
// recovers μ too, so it is no longer the contrast: docs/estimation.md.)
TEST(MultipleShooting, RecoversMuFromAFarGuess) {
  const sim::Simulator truth(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path = SyntheticLog(truth, "block", kTrueMu, 0.6, 5, 0.0, 1, "ms_far.csv");
  std::string yaml = testing::kPlanarBlock;
  yaml.replace(yaml.find("default: 0.5"), 12, "default: 4.0");
  const sim::Simulator sim(sim::ParseScene(yaml, "far.yaml"));
  const Log log = ReadLog({path}, sim.scene());
  const EstimateResult b = EstimateLeastSquares(sim, log, MultipleShooting(10));
  EXPECT_EQ(b.initial_values[0], 4.0);
  EXPECT_TRUE(b.converged) << b.reason;
  EXPECT_NEAR(b.estimates[0], kTrueMu, 1e-4) << b.reason;
}

TEST(MultipleShooting, RejectsAFixedInitialState) {
  LeastSquaresOptions o = MultipleShooting(20);
  o.estimate_initial_state = false;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o = MultipleShooting(1);
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
