// The MPEC estimator with one step per logged sample (MpecOptions::substeps = 1) on noise-free
// block logs (slow: ~15 s of CPU each, the first relaxation stage of these exact logs takes
// ~2000 Ipopt iterations). The grid itself: tests/estimation/mpec_substeps_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

constexpr double kTrueMu = 0.3;

// kPlanarBlock with another dt.
std::string BlockWithDt(const std::string& dt) {
  std::string s = testing::kPlanarBlock;
  const std::string from = "dt: 0.002";
  s.replace(s.find(from), from.size(), "dt: " + dt);
  return s;
}

// A log of the block simulated at dt = 10 ms, one sample per step, estimated with the 2 ms
// scene and one step per sample: the grid's step is the formulation's at h = 10 ms, so the
// rollout satisfies every step equation and complementarity pair to 1e-9 and the noise-free μ̂
// is the truth within 1e-4 (no model error).
TEST(MpecSubstepsEstimate, PerSampleGridRecoversMuWithoutModelError) {
  const sim::Simulator coarse(sim::ParseScene(BlockWithDt("0.01"), "block10.yaml"));
  const sim::Simulator fine(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log = testing::SampledLog(coarse, kTrueMu, 0, 1, 60, 0.0, 1);
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-3;
  o.contact_margin = 0.0;  // the coarse simulation's contact sets
  o.substeps = 1;
  {
    const MpecEstimationProblem problem(fine, log, o, 1e-3);
    EXPECT_EQ(problem.num_steps(), 59);
    sim::Params p = coarse.DefaultParams();
    p.values[coarse.scene().param_table().Index("mu.default")] = kTrueMu;
    const sim::Trajectory tr = coarse.Rollout(p, coarse.InitialState(), 59);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const sim::VectorXd x = problem.VariablesFromRollouts({tr}, p);
    double equality = 0, complementarity = 0;
    problem.StepViolation(x, &equality, &complementarity);
    EXPECT_LE(equality, 1e-9);
    EXPECT_LE(complementarity, 1e-9);
  }
  const MpecEstimateResult r = EstimateMpec(fine, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_EQ(r.num_steps, 59);
  EXPECT_TRUE(std::isfinite(r.std_errors[0]));
}

// The block simulated at its own dt = 2 ms and logged every 5th step, fitted with one step of
// 10 ms per sample: while it slides, the coarse step's positions differ from the fine ones by a
// constant velocity offset (semi-implicit Euler under a constant deceleration μ g), which the
// estimated initial state absorbs, so μ̂ stays within 1e-4; the stop is where the model error is.
TEST(MpecSubstepsEstimate, PerSampleGridOnAFinerLogKeepsTheBlocksTolerance) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log = testing::SampledLog(sim, kTrueMu, 0, 5, 60, 0.0, 1);
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-3;
  o.substeps = 1;
  const MpecEstimateResult r = EstimateMpec(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_EQ(r.num_steps, 59);
}

}  // namespace
}  // namespace vinci::estimation
