// Finite-difference step and rollout derivatives (finite_difference.h) against closed forms.
#include "vinci/sim/simulator/finite_difference.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_util.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

constexpr double kG = 9.81;

// While the block slides (v0 = 2 m/s, μ = 0.4: it stops at 0.51 s) each Stewart–Trinkle step
// removes exactly μ g h of speed, so after N steps x_N = x_0 + h Σ_{k=1..N} (v0 − k μ g h) and
// ∂x_N/∂μ = −g h² N (N + 1)/2 — the continuous −g t²/2 (t = N h) up to a relative 1/N. The map
// is linear in μ, so central differences recover it to roundoff (1e-6 relative).
TEST(FiniteDifferenceTest, SlidingBlockPositionDerivativeIsMinusGTSquaredOverTwo) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const double h = sim.scene().options.dt;
  const int n = 300;  // t = 0.3 s < 0.51 s
  const int qx = sim.scene().index(sim.scene().FindBody("block")).q;
  const RolloutOutput x_final = [qx](const Trajectory& tr) {
    return VectorXd::Constant(1, tr.states.back().q[qx]);
  };
  const FiniteDifference fd =
      RolloutDerivativeFd(sim, p, sel, sim.InitialState(), std::vector<StepInput>(n), x_final);
  ASSERT_TRUE(fd.nominal_ok) << fd.failure;
  EXPECT_TRUE(fd.clean());
  ASSERT_EQ(fd.jacobian.rows(), 1);
  ASSERT_EQ(fd.jacobian.cols(), 1);
  const double discrete = -kG * h * h * n * (n + 1) / 2.0;
  const double t = n * h;
  EXPECT_NEAR(fd.jacobian(0, 0), discrete, 1e-6 * std::abs(discrete));
  EXPECT_NEAR(fd.jacobian(0, 0), -kG * t * t / 2.0, std::abs(discrete) / n * 1.01);

  // The full final state (null output): ∂v_N/∂μ = −g t, nothing else moves.
  const FiniteDifference full =
      RolloutDerivativeFd(sim, p, sel, sim.InitialState(), std::vector<StepInput>(n));
  ASSERT_TRUE(full.clean());
  const int nq = sim.scene().num_positions();
  const int vx = nq + sim.scene().index(sim.scene().FindBody("block")).v;
  EXPECT_NEAR(full.jacobian(qx, 0), discrete, 1e-6 * std::abs(discrete));
  EXPECT_NEAR(full.jacobian(vx, 0), -kG * t, 1e-6 * kG * t);
  for (int i = 0; i < full.jacobian.rows(); ++i)
    if (i != qx && i != vx) {
      EXPECT_NEAR(full.jacobian(i, 0), 0.0, 1e-7) << "row " << i;
    }
}

// One step of the sliding block: ∂v/∂μ = −g h, ∂x/∂μ = −g h² (q_ℓ+1 = q_ℓ + h ν_ℓ+1), and with
// the initial state: ∂x_ℓ+1/∂v_ℓ = h, ∂v_ℓ+1/∂v_ℓ = 1, ∂x_ℓ+1/∂x_ℓ = 1.
TEST(FiniteDifferenceTest, SlidingBlockStepDerivatives) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const double h = sim.scene().options.dt;
  FiniteDifferenceOptions opt;
  opt.initial_state = true;
  const FiniteDifference fd = StepDerivativeFd(sim, p, sel, sim.InitialState(), {}, opt);
  ASSERT_TRUE(fd.clean());
  const int nq = sim.scene().num_positions(), nv = sim.scene().num_velocities();
  ASSERT_EQ(fd.jacobian.rows(), nq + nv);
  ASSERT_EQ(fd.jacobian.cols(), 1 + nq + nv);
  const int qx = sim.scene().index(sim.scene().FindBody("block")).q;
  const int vx = sim.scene().index(sim.scene().FindBody("block")).v;
  EXPECT_NEAR(fd.jacobian(nq + vx, 0), -kG * h, 1e-9);
  EXPECT_NEAR(fd.jacobian(qx, 0), -kG * h * h, 1e-9);
  EXPECT_NEAR(fd.jacobian(qx, 1 + nq + vx), h, 1e-7);
  EXPECT_NEAR(fd.jacobian(nq + vx, 1 + nq + vx), 1.0, 1e-7);
  EXPECT_NEAR(fd.jacobian(qx, 1 + qx), 1.0, 1e-7);
}

// A resting stack does not depend on μ (no tangential load): ∂x_N/∂μ = 0.
TEST(FiniteDifferenceTest, RestingStackHasZeroFrictionDerivative) {
  const Simulator sim(LoadExample("box_stack.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const FiniteDifference fd =
      RolloutDerivativeFd(sim, p, sel, sim.InitialState(), std::vector<StepInput>(50));
  ASSERT_TRUE(fd.nominal_ok) << fd.failure;
  EXPECT_TRUE(fd.clean());
  EXPECT_LE(fd.jacobian.cwiseAbs().maxCoeff(), 1e-6);
}

// A perturbation that moves a contact across the envelope is flagged; one at a parameter
// bound is one-sided.
TEST(FiniteDifferenceTest, FlagsContactSetChangesAndBounds) {
  const Simulator sim(LoadExample("ball_drop.yaml"));
  const Params p = sim.DefaultParams();
  State x = sim.InitialState();
  const int qz = sim.scene().index(sim.scene().FindBody("ball")).q + 2;
  x.q[qz] = 0.1 + sim.scene().options.envelope + 1e-9;  // just outside the envelope
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  FiniteDifferenceOptions opt;
  opt.initial_state = true;
  opt.min_step = 1e-6;
  const FiniteDifference fd = StepDerivativeFd(sim, p, sel, x, {}, opt);
  ASSERT_TRUE(fd.nominal_ok);
  EXPECT_FALSE(fd.contact_set_changed[0]);  // μ: no contact either way
  EXPECT_TRUE(fd.contact_set_changed[1 + qz]);
  EXPECT_FALSE(fd.clean());

  const Params p0 = testing::WithParams(sim, {{"mu.default", 0.0}});
  const FiniteDifference at_bound = StepDerivativeFd(sim, p0, sel, sim.InitialState(), {});
  ASSERT_TRUE(at_bound.nominal_ok);
  EXPECT_EQ(at_bound.one_sided[0], sim.scene().param_table().info(0).lower >= 0.0);
  EXPECT_NEAR(at_bound.jacobian.cwiseAbs().maxCoeff(), 0.0, 1e-12);  // free fall: no μ effect
}

TEST(FiniteDifferenceTest, RejectsBadOptions) {
  const Simulator sim(LoadExample("ball_drop.yaml"));
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  FiniteDifferenceOptions opt;
  opt.relative_step = 0.0;
  EXPECT_THROW(StepDerivativeFd(sim, sim.DefaultParams(), sel, sim.InitialState(), {}, opt),
               std::invalid_argument);
}

}  // namespace
}  // namespace vinci::sim
