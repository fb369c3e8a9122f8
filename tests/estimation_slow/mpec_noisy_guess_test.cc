// The MPEC estimator on a noisy densely sampled log (the failure of issue 15: a block logged
// every 2 ms step with 1 mm position and 10 mrad angle noise). From the raw poses the guessed
// velocities carry √2 σ / Δt ≈ 0.7 m/s of noise and the homotopy did not converge (500
// samples: 113 s, NaN standard error); from the smoothed log (MpecOptions::smooth_initial_guess)
// it converges with an honest standard error. Slow: ~10 s of CPU per seed.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

TEST(MpecNoisyGuess, DenseOneMillimetreBlockConvergesWithAnHonestStandardError) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const double sigma = 1e-3, mu = 0.3;
  for (const unsigned seed : {11u, 12u}) {
    // 0.3 s every step: 151 samples of the block sliding (it stops at 0.51 s).
    const std::string path = testing::SyntheticLog(
        sim, "block", mu, 0.3, 1, sigma, seed, "mpec_noisy_guess_" + std::to_string(seed) + ".csv");
    const Log log = ReadLog({path}, sim.scene());
    MpecOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = sigma;
    const MpecEstimateResult r = EstimateMpec(sim, log, o);
    EXPECT_TRUE(r.converged) << r.reason;
    ASSERT_TRUE(std::isfinite(r.std_errors[0])) << r.reason;
    EXPECT_GT(r.std_errors[0], 0.0);
    // 3 reported standard errors (nominal 99.7%).
    EXPECT_LE(std::abs(r.estimates[0] - mu), 3 * r.std_errors[0])
        << "seed " << seed << ": " << r.estimates[0] << " ± " << r.std_errors[0];
    std::printf("seed %u: mu %.6f s.e. %.3g iterations %d time %.2f s\n", seed, r.estimates[0],
                r.std_errors[0], r.iterations, r.time_s);
  }
}

}  // namespace
}  // namespace vinci::estimation
