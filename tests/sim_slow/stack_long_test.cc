// Long-horizon checks (label "slow"): the 10-box stack over 10⁴ steps.
#include <gtest/gtest.h>

#include "../sim/test_util.h"

namespace vinci::sim {
namespace {

TEST(StewartTrinkleSlowTest, TenBoxStackStandsLong) {
  Simulator sim(testing::LoadExample("box_stack.yaml"));
  const Scene& s = sim.scene();
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 10000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  for (int bi : s.dynamic_bodies()) {
    const int o = s.index(bi).q;
    const double drift = (tr.states.back().q.segment<3>(o) - x0.q.segment<3>(o)).norm();
    EXPECT_LT(drift, 1e-6) << s.bodies[bi].name;
    // Orientation unchanged: the quaternion stays the identity.
    EXPECT_NEAR(std::abs(tr.states.back().q[o + 3]), 1.0, 1e-9) << s.bodies[bi].name;
  }
  double worst = 0.0;
  for (const StepInfo& info : tr.steps) worst = std::min(worst, info.min_gap);
  EXPECT_GT(worst, -1e-6);
}

}  // namespace
}  // namespace vinci::sim
