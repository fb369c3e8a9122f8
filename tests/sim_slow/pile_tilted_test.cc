// The tilted box pile (examples/scenes/box_pile_tilted.yaml) over its full duration, with the
// default solver (Lemke) warm-started by the stepper and cold-started every step (label "slow":
// the cold run takes ~10 s). A dropped box lands on an edge of the pyramid's top box, tips flat
// and slides; its step LCPs (n ≈ 234, six contacts of one face, rank 3) defeated every Lemke
// attempt and needed FB Newton's proximal-point fallback (lemke.h, fischer_burmeister.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "../sim/test_util.h"

namespace vinci::sim {
namespace {

// Resting height of the dropped box's centre: top box centre 0.3 + half extents 0.1 + 0.08 (m).
constexpr double kRestingHeight = 0.48;
// Rigid contact: the rest penetration is the solver's roundoff (min_gap ~ −5e-13 in the run).
constexpr double kHeightTol = 1e-6;
// Lying flat on the top face: the quaternion's x and y parts vanish (orientation about z only).
constexpr double kFlatTol = 1e-6;
// At rest at t = 1 s (measured speeds ~1e-10 m/s).
constexpr double kRestSpeed = 1e-6;
// Largest penetration during the run: below the contact envelope (stepper.envelope = 0.002 m).
constexpr double kMaxPenetration = 2e-3;

void RunPile(bool cold) {
  Simulator sim(testing::LoadExample("box_pile_tilted.yaml"));
  const Scene& s = sim.scene();
  ASSERT_EQ(s.options.solver, "lemke");
  const int steps = static_cast<int>(std::lround(s.options.duration / s.options.dt));
  ASSERT_EQ(steps, 1000);
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState();
  State next;
  int reported = 0;  // steps whose report carries a fallback/polish message
  double worst_gap = 0.0;
  for (int k = 0; k < steps; ++k) {
    if (cold) x.warm_start.resize(0);
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    ASSERT_LE(info.solver.residual, info.solver.tolerance) << "step " << k;
    if (!info.solver.message.empty() && info.solver.message != "warm basis") {
      ++reported;
    }
    worst_gap = std::min(worst_gap, info.min_gap);
    x = next;
  }
  ::testing::Test::RecordProperty(cold ? "cold_reported_steps" : "warm_reported_steps", reported);
  EXPECT_GT(worst_gap, -kMaxPenetration);
  int dropped = -1;
  for (int bi = 0; bi < static_cast<int>(s.bodies.size()); ++bi) {
    if (s.bodies[bi].name == "dropped_box") dropped = bi;
  }
  ASSERT_GE(dropped, 0);
  const int o = s.index(dropped).q;
  EXPECT_NEAR(x.q[o + 2], kRestingHeight, kHeightTol);
  EXPECT_NEAR(x.q[o + 4], 0.0, kFlatTol);  // q = (w, x, y, z) at q[o + 3 .. o + 6]
  EXPECT_NEAR(x.q[o + 5], 0.0, kFlatTol);
  for (int bi : s.dynamic_bodies()) {
    EXPECT_LT(x.v.segment<6>(s.index(bi).v).norm(), kRestSpeed) << s.bodies[bi].name;
  }
}

TEST(PileTiltedSlowTest, WarmStartedFullDurationHasNoFailedStep) { RunPile(false); }

TEST(PileTiltedSlowTest, ColdStartedFullDurationHasNoFailedStep) { RunPile(true); }

}  // namespace
}  // namespace vinci::sim
