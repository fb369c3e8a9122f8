// Noisy tossed cubes (spatial, 8 corners, bounces and tumbles) fitted by single-shooting least
// squares from μ = 0.6 with a growing horizon. Over the whole 0.7 s toss the rollout is a
// nearly chaotic function of μ and the initial state: the whole-log fit stopped in local minima
// on every one of the study's 20 tosses and on these three logs (docs/estimation.md). The
// noise-free toss is in tests/estimation/least_squares_horizon_test.cc. ~1 min of CPU.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

// 30 µm and 0.3 mrad of noise, three draws: each fit agrees with the noise (the χ² test of
// `converged`) and μ̂ is within 3 of its standard errors of the true 0.4.
TEST(LeastSquaresHorizonCube, NoisyTossesAreCovered) {
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  for (unsigned seed : {11u, 12u, 13u}) {
    const std::string path = testing::SyntheticLog(sim, "cube", 0.4, 0.7, 7, 3e-5, seed,
                                                   "cube_" + std::to_string(seed) + ".csv");
    const Log log = ReadLog({path}, sim.scene());
    LeastSquaresOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = 3e-5;
    o.horizon_samples = 10;
    o.threads = 2;
    const EstimateResult r = EstimateLeastSquares(sim, log, o);
    EXPECT_TRUE(r.converged) << "seed " << seed << ": " << r.reason;
    EXPECT_LT(std::abs(r.estimates[0] - 0.4), 3.0 * r.std_errors[0])
        << "seed " << seed << ": μ̂ " << r.estimates[0] << " ± " << r.std_errors[0];
  }
}

}  // namespace
}  // namespace vinci::estimation
