// The recursive baseline (augmented-state unscented Kalman filter): convergence on a clean log,
// a posterior that shrinks where the data inform μ and does not where they cannot.
#include "vinci/estimation/filter.h"

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

TEST(Filter, PlanarBlockCleanLogConverges) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "ukf_exact.csv");
  const Log log = ReadLog({path}, sim.scene());
  FilterOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-4;
  const EstimateResult r = EstimateFilter(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_EQ(r.method, "filter");
  EXPECT_EQ(r.iterations, log.episodes[0].num_samples());
  EXPECT_NEAR(r.estimates[0], kTrueMu, 0.01) << r.reason;
  // The prior is N(0.5, 0.25²); the sliding phase determines μ much better.
  EXPECT_LT(r.std_errors[0], 0.05);
  EXPECT_GT(r.std_errors[0], 0.0);
  EXPECT_LT(r.final_cost, r.initial_cost);
}

// A block at rest says nothing about μ (static friction is not active): the posterior stays at
// the prior.
TEST(Filter, RestingBlockLeavesMuAtThePrior) {
  std::string yaml = testing::kPlanarBlock;
  yaml.replace(yaml.find("velocity: {linear: [1.5, 0]}"), 28, "velocity: {linear: [0.0, 0]}");
  const sim::Simulator sim(sim::ParseScene(yaml, "rest.yaml"));
  const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.3, 5, 0.0, 1, "ukf_rest.csv");
  const Log log = ReadLog({path}, sim.scene());
  FilterOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-4;
  const EstimateResult r = EstimateFilter(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], 0.5, 0.02);
  EXPECT_GT(r.std_errors[0], 0.8 * 0.25);
}

TEST(Filter, NoiseFromLog) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 2e-3, 3, "ukf_sigma.csv", false);
  const Log log = ReadLog({path}, sim.scene());
  EXPECT_NEAR(EstimateNoiseFromLog(log, sim.scene().dim), 2e-3, 0.4e-3);
}

TEST(Filter, RejectsBadOptions) {
  FilterOptions o;
  EXPECT_THROW(o.Validate(), std::invalid_argument);  // no parameter
  o.params = {"mu.default"};
  o.alpha = 0.0;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

// The thesis' recursive-filtering argument (§7.2) on the vibrating plate, the same log as least
// squares: the filter folds each sample into a Gaussian belief and keeps process noise, so it
// extracts less about μ from the same samples than the batch fit — its posterior standard
// deviation is several times least squares' standard error — and its estimate is consistent
// with that wider posterior.
TEST(Filter, VibratingPlateIsLessInformativeThanLeastSquares) {
  const sim::Simulator sim(sim::ParseScene(testing::kVibratingPlate, "plate.yaml"));
  const double sigma = 1e-5, mu = 0.2;
  const Log log = testing::SampledLog(sim, mu, 200, 2, 50, sigma, 50000);
  FilterOptions f;
  f.params = {"mu.default"};
  f.noise_sigma = sigma;
  const EstimateResult ukf = EstimateFilter(sim, log, f);
  LeastSquaresOptions l;
  l.params = {"mu.default"};
  l.noise_sigma = sigma;
  l.max_iterations = 50;
  const EstimateResult lsq = EstimateLeastSquares(sim, log, l);
  ASSERT_TRUE(ukf.converged) << ukf.reason;
  ASSERT_TRUE(std::isfinite(lsq.std_errors[0])) << lsq.reason;
  EXPECT_LE(std::abs(ukf.estimates[0] - mu), 3 * ukf.std_errors[0]);
  EXPECT_GT(ukf.std_errors[0], 3 * lsq.std_errors[0]);
  // The posterior did learn from the data: it is narrower than the prior (0.15 around 0.3).
  EXPECT_LT(ukf.std_errors[0], 0.15);
}

}  // namespace
}  // namespace vinci::estimation
