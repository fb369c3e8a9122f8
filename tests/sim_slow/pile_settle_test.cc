// A 27-box pile (bench/box_scenes.h's PileYaml: three layers of 3 × 3 cubes, the middle layer
// shifted so that each of its cubes rests on one to four cubes below) started in exact contact,
// stepped with the default solver (Lemke, warm-started by the stepper; its LCP has 1416
// unknowns, so the refused warm bases go to the sparse Lemke), and the 100-box pile of
// vinci_vs_mujoco. Label "slow" (~1 min together).
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
// speeds at the solver's round-off level (≤ 1e-11 m/s measured since the global spread of the
// normal impulses; 1e-8–8e-8 m/s and growing before it; MuJoCo's soft contact sinks at ~1e-3 m/s
// during its settling).
constexpr double kRestSpeed = 1e-9;
// Penetration: solver round-off (≤ 2e-15 m measured; 1e-11 m before the global spread), far
// below the 2 mm contact envelope.
constexpr double kMaxPenetration = 1e-12;

// The first 1700 steps: before the global spread of the normal impulses (spread_normals.h) the
// pile rested on the warm basis until a rocking mode (load carried by diagonally opposite
// supports, bench/README.md) refused it at t ≈ 1.49 s; the sparse Lemke then re-solved every
// 20–80 steps. Now every step after the first is solved on the warm basis.
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

// The 100-box pile (6432 unknowns) rests for 1 s (1000 steps) without a failed step, in exact
// contact. Before the global spread of its normal impulses (spread_normals.h) the warm basis
// held only Lemke's vertex of loaded contacts (rank 296 of the pile's 300 normal directions),
// cubes rocked about their loaded supports with a speed doubling every ~35 ms, and the sparse
// Lemke failed the step at t = 0.33 s. Every step must also end within the hang guard.
TEST(PileSettleSlowTest, HundredBoxPileRestsOneSecondWithNoFailedStep) {
  const Simulator sim(ParseScene(bench::PileYaml(), "pile100"));
  const Scene& s = sim.scene();
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  double worst_gap = 0.0, worst_speed = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The cold first step takes ~1 s on an idle machine, a resting step a few ms.
    EXPECT_LT(wall, 60.0) << "step " << k;
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    worst_gap = std::min(worst_gap, info.min_gap);
    std::swap(x, next);
    for (int b : s.dynamic_bodies())
      worst_speed = std::max(worst_speed, x.v.segment<6>(s.index(b).v).norm());
  }
  // Measured: speeds ≤ 1e-11 m/s, penetration ≤ 2e-15 m.
  EXPECT_GT(worst_gap, -kMaxPenetration);
  EXPECT_LT(worst_speed, kRestSpeed);
  // No creep: every cube is where it started, to round-off.
  const State x0 = sim.InitialState();
  EXPECT_LT((x.q - x0.q).lpNorm<Eigen::Infinity>(), 1e-9);
}

}  // namespace
}  // namespace vinci::sim
