// The design search on problems with known optima.
#include "vinci/design/optimize.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "vinci/design/spec.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

// A block launched at v = 1 m/s stops after d = v²/(2 μ g) (Stewart–Trinkle, implicit step:
// d = v²/(2 μ g) − h v/2). The friction that stops it at 0.5 m is found to 1e-3.
TEST(DesignOptimize, BlockStoppingFrictionMatchesClosedForm) {
  const DesignSpec spec = LoadDesignSpec(kData + "block_distance.yaml");
  for (const std::string optimizer : {"direct-l+bobyqa", "crs2+sbplx", "ipopt"}) {
    JobOptions o;
    o.optimizer = optimizer;
    // Ipopt's finite-difference gradients (2 rollouts each) on the V-shaped |x − target| need
    // more evaluations than the derivative-free searches.
    if (optimizer == "ipopt") o.budget = 300;
    const DesignResult r = RunDesign(spec, o);
    ASSERT_TRUE(r.errors.empty()) << r.errors.front();
    const double g = 9.81, v = 1.0, d = 0.5, h = 1e-3;
    const double mu_continuous = v * v / (2 * g * d);
    const double mu_discrete = v * v / (2 * g * (d + h * v / 2));
    EXPECT_NEAR(r.best[0], mu_discrete, 1e-3) << optimizer;
    EXPECT_NEAR(r.best[0], mu_continuous, 1e-3) << optimizer;
    EXPECT_LT(r.best_search.objective, 2e-3) << optimizer;
    EXPECT_LE(r.evaluations, (o.budget > 0 ? o.budget : spec.budget) / spec.samples + 2)
        << optimizer;
  }
}

// The farther the target, the less friction: beyond the longest slide the optimum is the lower
// bound.
TEST(DesignOptimize, OptimumAtTheLowerBound) {
  const DesignSpec spec = ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: mu.default, lower: 0.2, upper: 1.0, start: 0.6}]\n"
      "samples: 1\nduration: 1.0\nbudget: 30\n"
      "objective: {type: distance, body: block, target: [2.0, 0.05]}\n",
      "bound.yaml", kData);
  const DesignResult r = RunDesign(spec, JobOptions{});
  ASSERT_TRUE(r.errors.empty());
  EXPECT_EQ(r.best[0], 0.2);
  // d = 2 − v²/(2 μ g) + h v/2 at μ = 0.2.
  EXPECT_NEAR(r.best_search.objective, 2.0 - 1.0 / (2 * 0.2 * 9.81) + 0.0005, 1e-6);
}

// An interrupted search resumed from its history replays the recorded evaluations and ends
// exactly where the uninterrupted search ends; 2 threads give the same search.
TEST(DesignOptimize, ResumeAfterInterruptionAndThreadsGiveTheSameSearch) {
  const DesignSpec spec = ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: mu.default, lower: 0.05, upper: 0.6}]\n"
      "uncertain: [{name: initial.block.vx, uniform: [0.8, 1.2]}]\n"
      "samples: 8\nduration: 1.0\nbudget: 160\n"
      "objective: {type: success, body: block, region: {min: [0.3, 0], max: [0.5, 0.1]}}\n",
      "resume.yaml", kData);
  JobOptions full;
  full.optimizer = "crs2+neldermead";
  const DesignResult a = RunDesign(spec, full);
  ASSERT_TRUE(a.errors.empty());
  EXPECT_GT(a.best_search.objective, a.start_search.objective);

  JobOptions first = full;
  std::vector<Evaluation> history;
  first.on_evaluation = [&](const HistoryEntry& h, const Progress&) {
    history.push_back(h.eval);
    return history.size() < 9;  // "Ctrl-C" after 9 evaluations
  };
  const DesignResult interrupted = RunDesign(spec, first);
  EXPECT_TRUE(interrupted.cancelled);
  EXPECT_EQ(interrupted.evaluations, 9);

  JobOptions resumed = full;
  resumed.replay = history;
  resumed.threads = 2;
  const DesignResult b = RunDesign(spec, resumed);
  // Nothing done before the interruption is recomputed (repeated points are cached too).
  EXPECT_GE(b.replayed, 9);
  EXPECT_EQ(b.evaluations, a.evaluations);
  EXPECT_EQ(b.simulations + interrupted.simulations, a.simulations);
  EXPECT_EQ(b.best[0], a.best[0]);
  EXPECT_EQ(b.best_fresh.objective, a.best_fresh.objective);
}

}  // namespace
}  // namespace vinci::design
