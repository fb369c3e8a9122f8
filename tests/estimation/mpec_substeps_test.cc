// The MPEC estimator's time grid with MpecOptions::substeps (mpec_estimator.h): N steps per log
// interval of h = Δt / N instead of the scene's dt. With N = 1 the step equations are the
// formulation's at h = the sample interval: a log simulated at that step is reproduced exactly,
// and a log simulated at a finer dt is fitted with the coarser step's model error.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "estimation_test_util.h"
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

TEST(MpecSubsteps, RejectsNegative) {
  MpecOptions o;
  o.params = {"mu.default"};
  o.substeps = -1;
  try {
    o.Validate();
    FAIL() << "substeps = -1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("substeps = -1, expected ≥ 0"), std::string::npos)
        << e.what();
  }
  o.substeps = 0;
  EXPECT_NO_THROW(o.Validate());
}

// N steps per interval of an irregular log (every 5th step, every third gap one step longer),
// whatever the intervals' lengths; 0 keeps the scene's dt.
TEST(MpecSubsteps, GridHasNStepsPerInterval) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.2, 5, 0.0, 1, "mpec_substeps_grid.csv");
  const Log log = ReadLog({path}, sim.scene());
  const Episode& ep = log.episodes[0];
  const int intervals = ep.num_samples() - 1;
  for (int n : {0, 1, 3}) {
    MpecOptions o;
    o.params = {"mu.default"};
    o.substeps = n;
    const MpecEstimationProblem problem(sim, log, o, 1e-3);
    const int expected =
        n > 0 ? n * intervals : static_cast<int>(std::lround((ep.t.back() - ep.t[0]) / 0.002));
    EXPECT_EQ(problem.num_steps(), expected) << "substeps " << n;
  }
}

// A log of the block simulated at dt = 10 ms, one sample per step, on the grid of the 2 ms
// scene with one step per sample: the grid's step is the formulation's at h = 10 ms, so the
// rollout satisfies every step equation and complementarity pair to 1e-9 (the estimation on this
// log: tests/estimation_slow/mpec_substeps_estimate_test.cc).
TEST(MpecSubsteps, PerSampleGridIsTheStepAtTheSampleInterval) {
  const sim::Simulator coarse(sim::ParseScene(BlockWithDt("0.01"), "block10.yaml"));
  const sim::Simulator fine(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log = testing::SampledLog(coarse, kTrueMu, 0, 1, 60, 0.0, 1);
  MpecOptions o;
  o.params = {"mu.default"};
  o.contact_margin = 0.0;  // the coarse simulation's contact sets
  o.substeps = 1;
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
  // With the scene's dt the grid has 5 steps per sample and the 10 ms rollout has no state at
  // the inner nodes.
  o.substeps = 0;
  const MpecEstimationProblem fine_grid(fine, log, o, 1e-3);
  EXPECT_EQ(fine_grid.num_steps(), 59 * 5);
  EXPECT_THROW(fine_grid.VariablesFromRollouts({tr}, p), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
