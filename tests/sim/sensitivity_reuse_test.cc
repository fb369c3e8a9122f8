// Step derivatives do not depend on what the calling thread evaluated before: the per-thread
// storage the derivative reuses (frozen model, residuals, the Jacobian writers' row patterns,
// sparse_rows.h) gives the same bits as a thread that starts cold.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "test_util.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

// Same size and bit pattern (NaN entries included).
bool SameMatrixBits(const MatrixXd& a, const MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(),
                                       sizeof(double) * static_cast<std::size_t>(a.size())) == 0);
}

class SensitivityReuseTest : public ::testing::TestWithParam<std::string> {};

// Along a rollout, each step's derivatives (every differentiable and motion parameter, and the
// state block) on this thread, whose storage holds the previous step's evaluation (same
// contact structure: the row patterns are reused; a changed one: sorted again), against the same
// call on a new thread (nothing held).
TEST_P(SensitivityReuseTest, WarmThreadMatchesColdThreadBitwise) {
  const Simulator sim(LoadExample(GetParam()));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(),
                           SensitivityParameterNames(sim.scene().param_table()));
  constexpr int kSteps = 60;
  State x0 = sim.InitialState();
  if (GetParam() == "ball_drop.yaml") {  // lands within the rollout: 5 mm above, 1 m/s down
    x0.q[2] = 0.105;
    x0.v[2] = -1.0;
  }
  const Trajectory traj = sim.Rollout(p, x0, kSteps);
  ASSERT_EQ(static_cast<int>(traj.states.size()), kSteps + 1);
  int contact_counts_changed = 0;
  int last_contacts = -1;
  for (int l = 0; l < kSteps; ++l) {
    const State& x = traj.states[l];
    const State& next = traj.states[l + 1];
    const StepSensitivity warm = StepDerivatives(sim, p, sel, x, {}, next, true);
    StepSensitivity cold;
    std::thread([&] { cold = StepDerivatives(sim, p, sel, x, {}, next, true); }).join();
    EXPECT_EQ(warm.status, cold.status) << "step " << l;
    EXPECT_EQ(warm.degenerate_pairs, cold.degenerate_pairs) << "step " << l;
    EXPECT_TRUE(SameMatrixBits(warm.d_theta, cold.d_theta)) << "step " << l;
    EXPECT_TRUE(SameMatrixBits(warm.d_x, cold.d_x)) << "step " << l;
    Workspace ws;
    State n;
    ASSERT_TRUE(sim.Step(p, x, {}, &ws, &n).ok);
    const int contacts = static_cast<int>(ws.contacts.size());
    if (last_contacts >= 0 && contacts != last_contacts) ++contact_counts_changed;
    last_contacts = contacts;
  }
  // The scenes whose contact set changes along the rollout exercise a changed pattern.
  if (GetParam() == "ball_drop.yaml") {
    EXPECT_GT(contact_counts_changed, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, SensitivityReuseTest,
                         ::testing::Values("block_sliding.yaml", "box_on_plane.yaml",
                                           "sphere_on_incline.yaml", "plate_disc_planar.yaml",
                                           "ball_drop.yaml", "pendulum_on_block_friction.yaml"));

}  // namespace
}  // namespace vinci::sim
