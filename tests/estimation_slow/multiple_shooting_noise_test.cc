// Multiple shooting with seeded noise (slow: ~20 s): it agrees with single shooting.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

// Single and multiple shooting agree with noise (same model, the continuity is a constraint up
// to O(1/w²)), and their standard errors are close.
TEST(MultipleShooting, AgreesWithSingleShootingWithNoise) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 1e-3, 7, "ms_noise.csv", false);
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions single;
  single.params = {"mu.default"};
  const EstimateResult a = EstimateLeastSquares(sim, log, single);
  const EstimateResult b = EstimateLeastSquares(sim, log, [] {
    LeastSquaresOptions o;
    o.params = {"mu.default"};
    o.shooting = Shooting::kMultiple;
    o.segment_samples = 20;
    return o;
  }());
  ASSERT_TRUE(a.converged) << a.reason;
  ASSERT_TRUE(b.converged) << b.reason;
  EXPECT_NEAR(b.estimates[0], a.estimates[0], 0.1 * a.std_errors[0]);
  EXPECT_NEAR(b.std_errors[0], a.std_errors[0], 0.1 * a.std_errors[0]);
  EXPECT_NEAR(b.sigma, a.sigma, 0.1 * a.sigma);
}

}  // namespace
}  // namespace vinci::estimation
