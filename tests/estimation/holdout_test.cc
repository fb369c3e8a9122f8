// Hold-out validation: the split, the body size, and rollout errors against their baselines.
#include "vinci/estimation/holdout.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "estimation_test_util.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

TEST(Holdout, SplitKeepsEveryKthEpisode) {
  Log log;
  for (int e = 1; e <= 5; ++e) {
    log.episodes.emplace_back();
    log.episodes.back().file = "ep" + std::to_string(e);
  }
  Log fit, held;
  SplitHoldout(log, 2, &fit, &held);
  ASSERT_EQ(held.episodes.size(), 2u);
  EXPECT_EQ(held.episodes[0].file, "ep2");
  EXPECT_EQ(held.episodes[1].file, "ep4");
  ASSERT_EQ(fit.episodes.size(), 3u);
  EXPECT_EQ(fit.episodes[2].file, "ep5");
  EXPECT_THROW(SplitHoldout(log, 1, &fit, &held), std::invalid_argument);
  EXPECT_THROW(SplitHoldout(log, 6, &fit, &held), std::invalid_argument);
}

TEST(Holdout, BodySizeIsTheBoundingBoxDiagonal) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  EXPECT_NEAR(BodySize(sim.scene(), sim.scene().FindBody("block")), std::hypot(0.4, 0.2), 1e-12);
  const sim::Simulator box(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  EXPECT_NEAR(BodySize(box.scene(), box.scene().FindBody("box")), std::sqrt(0.04 + 0.04 + 0.01),
              1e-12);
}

// A noise-free log of the block (μ = 0.3): the true parameters reproduce it, the scene's μ = 0.5
// stops the block early, the stationary baseline misses the whole slide.
TEST(Holdout, RolloutErrorsOrderTrueGuessStationary) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path = SyntheticLog(sim, "block", 0.3, 0.6, 5, 0.0, 1, "holdout.csv");
  const Log log = ReadLog({path}, sim.scene());
  sim::Params truth = sim.DefaultParams();
  truth.values[sim.scene().param_table().Index("mu.default")] = 0.3;
  const HoldoutResult h = EvaluateHoldout(sim, truth, log);
  const Episode& ep = log.episodes[0];
  EXPECT_EQ(h.fitted.samples, ep.num_samples());
  // The rollout starts from the log's initial velocity, the slope of a quadratic through the
  // first samples, which is μ g dt / 2 = 2.9 mm/s below the discrete trajectory's v0: the
  // position error grows as 2.9 mm/s × t until the block stops (0.51 s), a mean under 1.5 mm.
  EXPECT_LT(h.fitted.position_m, 1.5e-3);
  EXPECT_GT(h.fitted.position_m, 0.0);
  EXPECT_LT(h.fitted.orientation_deg, 1e-6);
  // Stationary: the mean distance from the first logged position.
  double mean = 0.0;
  for (int i = 0; i < ep.num_samples(); ++i)
    mean += (ep.bodies[0].pose.row(i).head(2) - ep.bodies[0].pose.row(0).head(2)).norm();
  mean /= ep.num_samples();
  EXPECT_NEAR(h.stationary.position_m, mean, 1e-12);
  EXPECT_NEAR(h.stationary.position_percent, 100 * mean / std::hypot(0.4, 0.2), 1e-9);
  // The slide ends at v0² / (2 μ g): 0.382 m for μ = 0.3, 0.229 m for μ = 0.5.
  EXPECT_GT(h.initial_guess.position_m, 0.05);
  EXPECT_GT(h.initial_guess.position_m, 20 * h.fitted.position_m);
  EXPECT_LT(h.initial_guess.position_m, h.stationary.position_m);
}

// Spatial logs: the orientation error is in degrees and the position error in % of the body's
// size. A noise-free log of the sliding box (which does not turn) with the orientations of the
// samples from the 9th on turned by 5° about the vertical (the first 8 give the rollout's
// initial velocity, so it stays that of the slide): the mean angle is 5° (n − 8) / n both for
// the stationary baseline and for the true parameters' rollout.
TEST(Holdout, SpatialOrientationErrorInDegrees) {
  const sim::Simulator sim(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  const std::string path = SyntheticLog(sim, "box", 0.3, 0.4, 5, 0.0, 1, "holdout_box.csv");
  Log log = ReadLog({path}, sim.scene());
  BodyTrack& b = log.episodes[0].bodies[0];
  const int n = log.episodes[0].num_samples();
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()));
  for (int i = 8; i < n; ++i) {
    const Eigen::Quaterniond q =
        turn * Eigen::Quaterniond(b.pose(i, 3), b.pose(i, 4), b.pose(i, 5), b.pose(i, 6));
    b.pose.row(i).tail(4) << q.w(), q.x(), q.y(), q.z();
  }
  sim::Params truth = sim.DefaultParams();
  truth.values[sim.scene().param_table().Index("mu.default")] = 0.3;
  const HoldoutResult h = EvaluateHoldout(sim, truth, log);
  EXPECT_NEAR(h.stationary.orientation_deg, 5.0 * (n - 8) / n, 1e-6);
  EXPECT_NEAR(h.fitted.orientation_deg, 5.0 * (n - 8) / n, 1e-3);
  const double size = std::sqrt(0.2 * 0.2 + 0.2 * 0.2 + 0.1 * 0.1);
  EXPECT_NEAR(h.fitted.position_percent, 100 * h.fitted.position_m / size, 1e-9);
  EXPECT_NEAR(h.stationary.position_percent, 100 * h.stationary.position_m / size, 1e-9);
  // The true μ reproduces the slide far better than staying put or the scene's μ = 0.5.
  EXPECT_LT(h.fitted.position_m, 0.1 * h.stationary.position_m);
  EXPECT_LT(h.fitted.position_m, h.initial_guess.position_m);
  EXPECT_EQ(h.fitted.failed_rollouts, 0);
}

}  // namespace
}  // namespace vinci::estimation
