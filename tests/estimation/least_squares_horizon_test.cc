// Single-shooting least squares with a growing horizon (LeastSquaresOptions::horizon_samples):
// the schedule, the warm starts, a noise-free tossed cube, and the options it rejects. Noisy
// tossed cubes are in tests/estimation_slow/least_squares_horizon_cube_test.cc.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

// Two noise-free block logs of different lengths (70 and 31 samples with the helper's
// irregular gaps), horizon 2 from μ = 0.5: the 2-sample horizon is skipped (7 unknowns per
// episode, 3 residuals per sample: x, y, θ), the fits grow from 3 samples by ⌈1.5 h⌉ to the
// longer log, and μ is recovered as by the whole-log fit.
TEST(LeastSquaresHorizon, GrowsToTheWholeLogAndRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string a = SyntheticLog(sim, "block", kTrueMu, 0.6, 4, 0.0, 1, "hz_a.csv");
  const std::string b = SyntheticLog(sim, "block", kTrueMu, 0.2, 3, 0.0, 1, "hz_b.csv");
  const Log log = ReadLog({a, b}, sim.scene());
  const int longest = log.episodes[0].num_samples();
  ASSERT_GT(longest, log.episodes[1].num_samples());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.horizon_samples = 2;
  o.horizon_growth = 1.5;
  std::vector<int> reported;
  o.horizon_progress = [&](int h, const EstimateResult&, const std::vector<int>&) {
    reported.push_back(h);
  };
  int last_iteration = -1;
  bool progress_monotone = true;
  o.progress = [&](int it, double, const sim::VectorXd&) {
    progress_monotone = progress_monotone && it >= last_iteration;
    last_iteration = it;
  };
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_EQ(r.initial_values[0], 0.5);
  // 3, ⌈4.5⌉ = 5, 8, 12, … longest.
  ASSERT_GE(r.horizons.size(), 3u);
  EXPECT_EQ(r.horizons.front(), 3);
  EXPECT_EQ(r.horizons.back(), longest);
  for (size_t i = 1; i + 1 < r.horizons.size(); ++i)
    EXPECT_EQ(r.horizons[i], static_cast<int>(std::ceil(1.5 * r.horizons[i - 1])));
  // Every fit but the last is reported, in order; the iterations count on across fits.
  EXPECT_EQ(reported, std::vector<int>(r.horizons.begin(), r.horizons.end() - 1));
  EXPECT_TRUE(progress_monotone);
  EXPECT_GT(last_iteration, 0);
  EXPECT_LE(last_iteration, r.iterations);
  // The shorter episode is fitted whole once the horizon passes its length: the result's
  // episodes are the whole logs.
  ASSERT_EQ(r.episodes.size(), 2u);
  EXPECT_LT(r.episodes[0].rms_residual, 1e-6);
  EXPECT_LT(r.episodes[1].rms_residual, 1e-6);
  // The whole-log fit without the continuation lands on the same μ.
  LeastSquaresOptions whole = o;
  whole.horizon_samples = 0;
  whole.horizon_progress = nullptr;
  whole.progress = nullptr;
  const EstimateResult w = EstimateLeastSquares(sim, log, whole);
  EXPECT_NEAR(r.estimates[0], w.estimates[0], 1e-6);
  EXPECT_TRUE(w.horizons.empty());
}

// A cube tossed onto a table (noise-free log at ~150 Hz: every 7th step of 1 ms, every third
// gap 8; 0.7 s, 96 samples), fitted from μ = 0.6 with horizon 10: μ̂ within 1e-4 of 0.4. Over
// the whole toss at once the fit stops in local minima (the noisy tosses of
// tests/estimation_slow/least_squares_horizon_cube_test.cc).
TEST(LeastSquaresHorizon, TossedCubeNoiseFreeRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  const std::string path = SyntheticLog(sim, "cube", 0.4, 0.7, 7, 0.0, 1, "hz_cube.csv");
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.horizon_samples = 10;
  o.threads = 2;
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], 0.4, 1e-4) << r.reason;
  EXPECT_LT(r.episodes[0].rms_residual, 1e-6);
}

// The vibrating plate's box over 150 samples at 10 µm: its first 10 samples hardly depend on μ
// (σ̂ at the noise for any μ), and that fit's Levenberg–Marquardt step carried μ from 0.5 to
// 3.2, from where the longer horizons stuck at 6.5 and 9.1. A parameter a horizon does not
// determine keeps its value, and the continuation reaches the truth.
TEST(LeastSquaresHorizon, UndeterminedParameterKeepsItsValue) {
  const sim::Simulator sim(sim::LoadSceneFile(testing::kPlateBoxFile));
  const std::string path =
      testing::SyntheticLog(sim, "box", 0.2, 0.15, 1, 1e-5, 3, "horizon_plate.csv");
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-5;
  o.horizon_samples = 10;
  o.horizon_growth = 4;
  o.max_iterations = 10;
  std::vector<double> fitted;
  o.horizon_progress = [&](int, const EstimateResult& fit, const std::vector<int>&) {
    fitted.push_back(fit.estimates[0]);
  };
  const EstimateResult r = EstimateLeastSquares(sim, ReadLog({path}, sim.scene()), o);
  ASSERT_EQ(fitted.size(), 2u);
  EXPECT_GT(fitted[0], 1.0);  // the first horizon's own fit wandered
  EXPECT_NEAR(fitted[1], 0.2, 0.01);
  EXPECT_NEAR(r.estimates[0], 0.2, 3 * r.std_errors[0]) << r.reason;
  EXPECT_LT(r.std_errors[0], 1e-3);
}

TEST(LeastSquaresHorizon, RejectsWhatItCannotDo) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.horizon_samples = 1;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o.horizon_samples = 10;
  o.horizon_growth = 1.0;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o.horizon_growth = 1.2;
  o.Validate();
  o.shooting = Shooting::kMultiple;
  try {
    o.Validate();
    FAIL() << "multiple shooting with a growing horizon was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("single shooting"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vinci::estimation
