// Step derivatives where the contact impulses are not unique (sensitivity.h, docs/sensitivity.md
// "Redundant contacts").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "test_util.h"
#include "vinci/sim/formulations/step_model.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim {
namespace {

// The box of plate_disc_planar.yaml rides the vibrating plate on two corners (their tangential
// impulses are interchangeable: K is singular) and alternates between sliding and sticking.
// Over a cycle there are steps at which the box starts to stick and the solver's impulse split
// puts one corner exactly at its friction cone edge (σ = 0, μ p_n = Σ p_f) while the other is
// strictly inside. The true step map is smooth there — perturbed steps on both sides stick, the
// other corner taking the extra load — and one-step differences agree from both sides.
// Linearized at the solver's split, the sensitivity LCP (which cannot move load along K's null
// space) let the corner at its edge slide: ∂v_x,ℓ+1/∂v_x,ℓ = 1 instead of 0, and ∂v_x,N/∂A_x of
// the box 0 instead of −75 over the cycle. The derivative now linearizes at a split inside the
// solution set (Linearization::InteriorShift): it must match the differences at every step of
// the cycle, the edge-of-cone steps included (which must occur, or the test checks nothing), and
// forward mode over the cycle must match central differences of the rollout.
TEST(RedundantContactSensitivityTest, EdgeOfConeSplitIsMovedInsideAndMatchesDifferences) {
  const Simulator sim(testing::LoadExample("plate_disc_planar.yaml"));
  const Params p = sim.DefaultParams();
  const double mu = p.values[sim.scene().param_table().Find("mu.default")];
  const ParamSelection sel(sim.scene().param_table(), {"motion.plate.x.amplitude0"});
  const int first = 500, last = 750;  // a cycle (250 steps of 0.2 ms at 20 Hz) after settling
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), last);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const int nq = static_cast<int>(tr.states[0].q.size());
  const int nx = nq + static_cast<int>(tr.states[0].v.size());
  const int box = sim.scene().FindBody("box");
  const int qx = sim.scene().index(box).q, vx = nq + sim.scene().index(box).v;
  const auto step_vx = [&](const State& x) {
    Workspace w;
    State n;
    EXPECT_TRUE(sim.Step(p, x, {}, &w, &n).ok);
    return n.v[vx - nq];
  };
  int edge_steps = 0;
  for (int k = first; k < last; ++k) {
    const State& x = tr.states[k];
    const State& next = tr.states[k + 1];
    const StepSensitivity s = StepDerivatives(sim, p, sel, x, {}, next, true);
    ASSERT_NE(s.status, SensitivityStatus::kFailed) << "step " << k << ": " << s.message;
    ASSERT_EQ(s.d_x.rows(), nx);
    // One-step central differences of the box's end velocity along its start velocity (1e-8
    // m/s: the steps' round-off is ~1e-17 m/s).
    const double h = 1e-8;
    State xp = x, xm = x;
    xp.v[vx - nq] += h;
    xm.v[vx - nq] -= h;
    const double central = (step_vx(xp) - step_vx(xm)) / (2 * h);
    EXPECT_NEAR(s.d_x(vx, vx), central, 1e-6 * std::max(1.0, std::abs(central)))
        << "step " << k << " (" << SensitivityStatusName(s.status) << ": " << s.message << ")";
    // The solver's split: a loaded corner sticking at its cone edge, another strictly inside.
    Workspace w;
    const Scene& model = sim.ResolveWithInputs(p, {}, &w);
    const std::unique_ptr<StepModel> frozen = Freeze(sim.formulation(), model, p, x);
    const VectorXd z = frozen->UnknownsFromStep(next);
    const StepLayout& l = frozen->layout();
    bool at_edge = false, inside = false;
    double pn_max = 0.0;
    for (int c = 0; c < l.nc; ++c) pn_max = std::max(pn_max, z[l.pn() + c]);
    for (int c = 0; c < l.nc; ++c) {
      const double pn = z[l.pn() + c];
      if (pn <= 1e-9 * pn_max || z[l.sigma() + c] > 0.0) continue;  // unloaded or sliding
      double pf = 0.0;
      for (int j = 0; j < l.nd; ++j) pf += z[l.pf() + c * l.nd + j];
      const double slack = mu * pn - pf;
      at_edge = at_edge || slack <= 1e-9 * mu * pn;
      inside = inside || slack > 1e-3 * mu * pn;
    }
    if (at_edge && inside) {
      ++edge_steps;
      EXPECT_NE(s.status, SensitivityStatus::kExact) << "step " << k;
    }
  }
  EXPECT_GE(edge_steps, 1);
  // Forward mode over the cycle: the box's ∂x_N/∂A_x and ∂v_N/∂A_x against central differences
  // of the rollout (relative step 1e-6).
  const State& x0 = tr.states[first];
  const int steps = last - first;
  const RolloutSensitivity r =
      RolloutForward(sim, p, sel, x0, std::vector<StepInput>(steps), false);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_EQ(r.failed_steps, 0);
  VectorXd up = sel.Get(p), down = up;
  const double dA = 1e-6 * std::abs(up[0]);
  up[0] += dA;
  down[0] -= dA;
  const State sp = sim.Rollout(sel.Set(p, up), x0, steps).states.back();
  const State sm = sim.Rollout(sel.Set(p, down), x0, steps).states.back();
  const double fd_x = (sp.q[qx] - sm.q[qx]) / (2 * dA),
               fd_v = (sp.v[vx - nq] - sm.v[vx - nq]) / (2 * dA);
  // The velocity to 1e-6 (observed 1e-8); the position to 1e-5: observed 5e-6 with differences
  // converged to 1e-9 for relative steps 1e-4 … 1e-7, an error not explained yet (every step of
  // this cycle also has near-kink columns, the disc's rolling contact).
  EXPECT_NEAR(r.d_state.back()(qx, 0), fd_x, 1e-5 * std::max(1.0, std::abs(fd_x)));
  EXPECT_NEAR(r.d_state.back()(vx, 0), fd_v, 1e-6 * std::abs(fd_v));
  EXPECT_GT(std::abs(fd_v), 1.0);  // the box does follow the plate at the end of the cycle
}

}  // namespace
}  // namespace vinci::sim
