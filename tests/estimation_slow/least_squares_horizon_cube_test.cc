// Noisy tossed cubes (spatial, 8 corners, bounces and tumbles) fitted by single-shooting least
// squares from μ = 0.6 with a growing horizon. Over the whole 0.7 s toss the rollout is a
// nearly chaotic function of μ and the initial state: the whole-log fit stopped in local minima
// on every one of the study's 20 tosses and on these three logs (docs/estimation.md). The
// noise-free toss is in tests/estimation/least_squares_horizon_test.cc. ~2 min of CPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

constexpr double kNoise = 3e-5;  // the logs' position noise (m)

// μ (from the scene's 0.6) fitted with a growing horizon of 10 samples at the stated noise.
EstimateResult FitWithGrowingHorizon(const sim::Simulator& sim, const Log& log) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = kNoise;
  o.horizon_samples = 10;
  o.threads = 2;
  return EstimateLeastSquares(sim, log, o);
}

// 30 µm and 0.3 mrad of noise, three draws: each fit agrees with the noise (the χ² test of
// `converged`) and μ̂ is within 3 of its standard errors of the true 0.4.
TEST(LeastSquaresHorizonCube, NoisyTossesAreCovered) {
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  for (unsigned seed : {11u, 12u, 13u}) {
    const std::string path = testing::SyntheticLog(sim, "cube", 0.4, 0.7, 7, kNoise, seed,
                                                   "cube_" + std::to_string(seed) + ".csv");
    const EstimateResult r = FitWithGrowingHorizon(sim, ReadLog({path}, sim.scene()));
    EXPECT_TRUE(r.converged) << "seed " << seed << ": " << r.reason;
    EXPECT_LT(std::abs(r.estimates[0] - 0.4), 3.0 * r.std_errors[0])
        << "seed " << seed << ": μ̂ " << r.estimates[0] << " ± " << r.std_errors[0];
  }
}

// Fits one of the study's tosses (tests/data/logs/NAME: a log `estimation_study cube
// --write-logs` wrote, the scene's launch plus its seeded velocity, 30 µm and 0.3 mrad of noise)
// from μ = 0.6 with the growing horizon: the fit agrees with the noise and μ̂ is within 3 of its
// standard errors of the true 0.4.
void ExpectStudyTossFitted(const std::string& name) {
  SCOPED_TRACE(name);
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  const EstimateResult r = FitWithGrowingHorizon(
      sim, ReadLog({std::string(VINCI_SOURCE_DIR) + "/tests/data/logs/" + name}, sim.scene()));
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LT(r.sigma_residual, 1.2 * kNoise);
  EXPECT_LT(std::abs(r.estimates[0] - 0.4), 3.0 * r.std_errors[0])
      << "μ̂ " << r.estimates[0] << " ± " << r.std_errors[0];
}

// Toss 42 of the 50-toss benchmark: its first impact is near the stick–slip threshold, so from
// the flight's fitted state the cost over the impact is sharp in μ (measured: σ̂ 0.9 mm at
// μ = 0.424, 35 µm at 0.4). The parameter scan before each horizon's fit ended at 2^{±1/2}
// steps, took 0.424, and Levenberg–Marquardt stalled at μ̂ = 0.3966 with σ̂ = 165 µm; the scan's
// refinement to 2^{±1/64} reaches the data's basin.
TEST(LeastSquaresHorizonCube, ANearCriticalImpactIsFitted) {
  ExpectStudyTossFitted("cube_toss42.csv");
}

// Toss 21 of the 50-toss benchmark's trial 11: its first impact sticks, where every μ above the
// threshold fits alike, and the next one slips. The scan's noise-level gains took μ from 0.6 to
// 1.7 over the first impact, no step of the next scan (2^{±1/2}, 2^{±1}) was cheaper from there
// (0.85 sticks as well), and Levenberg–Marquardt ended at μ̂ = 6.4e7 with σ̂ 6 mm. A parameter
// the fit leaves undetermined now returns to its value from before the scan.
TEST(LeastSquaresHorizonCube, AStickingImpactDoesNotCarryMuAway) {
  ExpectStudyTossFitted("cube_trial11_toss21.csv");
}

// Toss 11 of the 50-toss benchmark (trial 0) and toss 21 of trial 17: a horizon step that takes
// a new impact in (48 → 58 samples; 27 → 33) ended in a local minimum of the initial state (σ̂
// 47 µm and 57 µm for 30 µm, the same from the true μ), and every longer horizon stayed there. A
// fit that loses the log's agreement with the noise is now discarded and the horizon approached
// in halved steps (58 → 53 → 50; 33 → 30), which fit at the noise.
TEST(LeastSquaresHorizonCube, AnImpactThatStallsTheFitIsApproachedInSmallerSteps) {
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  for (const char* name : {"cube_toss11.csv", "cube_trial17_toss21.csv"}) {
    SCOPED_TRACE(name);
    LeastSquaresOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = kNoise;
    o.horizon_samples = 10;
    o.threads = 2;
    std::vector<int> discarded;  // the discarded fits' horizons
    o.horizon_progress = [&](int h, const EstimateResult&, const std::vector<int>& episodes) {
      if (!episodes.empty()) discarded.push_back(h);
    };
    const EstimateResult r = EstimateLeastSquares(
        sim, ReadLog({std::string(VINCI_SOURCE_DIR) + "/tests/data/logs/" + name}, sim.scene()), o);
    EXPECT_FALSE(discarded.empty());
    EXPECT_TRUE(r.converged) << r.reason;
    ASSERT_EQ(r.episodes.size(), 1u);
    EXPECT_FALSE(EpisodeContradictsNoise(r.episodes[0], kNoise)) << r.episodes[0].rms_residual;
    EXPECT_LT(r.sigma_residual, 1.2 * kNoise);
    EXPECT_LT(std::abs(r.estimates[0] - 0.4), 3.0 * r.std_errors[0])
        << "μ̂ " << r.estimates[0] << " ± " << r.std_errors[0];
    // A discarded horizon is fitted again once the smaller steps reach it.
    for (int h : discarded)
      EXPECT_GE(std::count(r.horizons.begin(), r.horizons.end(), h), 2) << "horizon " << h;
    EXPECT_EQ(r.horizons.back(), 100);  // the log's 100 samples
  }
}

// Toss 27 of the 50-toss benchmark fitted jointly with tosses 0–4: μ is shared, and the joint
// fit holds toss 27's initial state in a local minimum (rms 42 µm among the 50 tosses, for 30
// µm of noise) that toss 27 alone leaves (30 µm at μ̂ 0.399965). With episode restarts it is
// fitted alone, moved to the joint μ̂ and the log fitted again from there: cheaper, with toss 27
// nearer the noise.
TEST(LeastSquaresHorizonCube, AnEpisodeHeldInALocalMinimumIsStartedAgainFromItsOwnFit) {
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  std::vector<std::string> files;
  for (int k : {27, 0, 1, 2, 3, 4})
    files.push_back(std::string(VINCI_SOURCE_DIR) + "/tests/data/logs/cube_toss" +
                    std::to_string(k) + ".csv");
  const Log log = ReadLog(files, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = kNoise;
  o.horizon_samples = 10;
  o.threads = 2;
  o.episode_restarts = false;
  const EstimateResult joint = EstimateLeastSquares(sim, log, o);
  ASSERT_EQ(joint.episodes.size(), 6u);
  ASSERT_TRUE(EpisodeContradictsNoise(joint.episodes[0], kNoise)) << joint.episodes[0].rms_residual;
  o.episode_restarts = true;
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_NE(r.reason.find("episodes 0 started again from their own fits (kept"), std::string::npos)
      << r.reason;
  EXPECT_LT(r.final_cost, joint.final_cost);
  EXPECT_LT(r.episodes[0].rms_residual, joint.episodes[0].rms_residual);
  EXPECT_GT(r.iterations, joint.iterations);
  EXPECT_EQ(r.horizons, joint.horizons);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LT(std::abs(r.estimates[0] - 0.4), 3.0 * r.std_errors[0])
      << "μ̂ " << r.estimates[0] << " ± " << r.std_errors[0];
}

}  // namespace
}  // namespace vinci::estimation
