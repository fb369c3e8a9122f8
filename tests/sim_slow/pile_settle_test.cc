// A 27-box pile (bench/box_scenes.h's PileYaml: three layers of 3 × 3 cubes, the middle layer
// shifted so that each of its cubes rests on one to four cubes below) started in exact contact,
// stepped with the default solver (Lemke, warm-started by the stepper; its LCP has 1416
// unknowns, so the refused warm bases go to the sparse Lemke), and the 100-box pile of
// vinci_vs_mujoco. Label "slow" (~1 min together).
//
// Without the terminal-basis polish of the sparse run (stewart_trinkle.cc) the 27-box pile's
// step 1574 fails the sparse Lemke (cold run at residual 1.8e-8 against τ = 1.5e-8); without the
// bounded fallback a failed sparse run on the 100-box pile went on to minutes of dense Lemke.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "box_scenes.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

// At rest: the pile starts in exact contact and nothing should move. Rigid contact keeps the
// speeds at the solver's round-off level (≤ 1e-7 m/s measured; MuJoCo's soft contact sinks at
// ~1e-3 m/s during its settling).
constexpr double kRestSpeed = 1e-6;
// Penetration: solver round-off (≤ 1e-11 m measured), far below the 2 mm contact envelope.
constexpr double kMaxPenetration = 1e-9;

// The first 1700 steps: the pile rests on the warm basis until a rocking mode (load carried by
// diagonally opposite supports, bench/README.md) refuses it at t ≈ 1.49 s; the sparse Lemke then
// re-solves, and twice (steps 1574 and 1606) only the re-solve of its terminal basis passes τ.
TEST(PileSettleSlowTest, TwentySevenBoxPileHasNoFailedStepAndStaysNearRest) {
  const Simulator sim(ParseScene(bench::PileYaml(17, 3, 3), "pile27"));
  const Scene& s = sim.scene();
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  double worst_gap = 0.0, worst_speed = 0.0;
  for (int k = 0; k < 1700; ++k) {
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    worst_gap = std::min(worst_gap, info.min_gap);
    std::swap(x, next);
    for (int b : s.dynamic_bodies())
      worst_speed = std::max(worst_speed, x.v.segment<6>(s.index(b).v).norm());
  }
  EXPECT_GT(worst_gap, -kMaxPenetration);
  EXPECT_LT(worst_speed, kRestSpeed);
}

// The 100-box pile (6432 unknowns) up to past t = 0.33 s, where its warm basis is refused and
// the sparse Lemke fails: the step must end within seconds, failed with kSolverFailed and the
// sparse solver's report, not after minutes of dense fallback.
TEST(PileSettleSlowTest, HundredBoxPileStepIsBoundedAndFailsWithAStatus) {
  const Simulator sim(ParseScene(bench::PileYaml(), "pile100"));
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  for (int k = 0; k < 400; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // A cold sparse run takes ~1.5 s on an idle machine; the dense fallback took minutes.
    EXPECT_LT(wall, 60.0) << "step " << k;
    if (!info.ok) {
      EXPECT_EQ(info.status, StepStatus::kSolverFailed) << info.failure;
      EXPECT_NE(info.failure.find("sparse"), std::string::npos) << info.failure;
      EXPECT_FALSE(info.solver.ok());
      return;
    }
    EXPECT_GT(info.min_gap, -kMaxPenetration) << "step " << k;
    std::swap(x, next);
  }
}

}  // namespace
}  // namespace vinci::sim
