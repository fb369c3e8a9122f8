// The 100-box pile (bench/box_scenes.h's PileYaml) with each layer started 1 mm above the one
// below: the layers fall, land one on another over ~15 ms and come to rest. The landing steps
// give sparse Lemke degenerate warm bases (dependent loaded normals, repaired by
// StartBasisRepair) and paths whose degenerate rows carry roundoff of −1e-12..−1e-7 next to
// noise-level pivots (step 24: the plain run ends with a residual of 14, the shifted retry of
// sparse_lemke.cc solves). Label "slow" (~15 s).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "box_scenes.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

TEST(PileGapDropSlowTest, HundredBoxPileDroppedLayerByLayerHasNoFailedStepAndSettles) {
  const Simulator sim(ParseScene(bench::PileYaml(17, 4, 5, 1e-3), "pile100_gap"));
  const Scene& s = sim.scene();
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  double worst_gap = 0.0, final_speed = 0.0;
  for (int k = 0; k < 60; ++k) {
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    worst_gap = std::min(worst_gap, info.min_gap);
    std::swap(x, next);
    final_speed = 0.0;
    for (int b : s.dynamic_bodies())
      final_speed = std::max(final_speed, x.v.segment<6>(s.index(b).v).norm());
  }
  // Rigid contact: no penetration beyond round-off (measured 9e-14 m), and the landed pile is at
  // rest (the falling layers reach 0.27 m/s; measured 2e-10 m/s at step 50).
  EXPECT_GT(worst_gap, -1e-10);
  EXPECT_LT(final_speed, 1e-6);
}

// Layers started 0.5 mm apart: step 29 (the pile landed, 6432 unknowns) ends every Lemke run on
// a degenerate terminal basis whose basic values reach −2e-8 (residual 1.2e-7 and, shifted,
// 5.5e-8 against τ = 2.5e-8); principal pivots from that basis (PolishTerminalBasis in
// sparse_lemke.cc) bring it within τ. Before them the rollout failed at step 29.
TEST(PileGapDropSlowTest, HalfMillimetreGapsPassTheDegenerateLandingSteps) {
  const Simulator sim(ParseScene(bench::PileYaml(17, 4, 5, 5e-4), "pile100_gap_half_mm"));
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  double worst_gap = 0.0;
  for (int k = 0; k < 32; ++k) {
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    worst_gap = std::min(worst_gap, info.min_gap);
    std::swap(x, next);
  }
  EXPECT_GT(worst_gap, -1e-10);  // rigid contact: no penetration beyond round-off
}

}  // namespace
}  // namespace vinci::sim
