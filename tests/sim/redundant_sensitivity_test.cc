// Step derivatives where the contact impulses are not unique (sensitivity.h, docs/sensitivity.md
// "Redundant contacts"): what the derivative means there and where it is known to be wrong.
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
// other corner taking the extra load — so one-step differences agree from both sides; the
// derivative, solved on the solver's split (its sensitivity LCP cannot move load along K's null
// space), takes the sliding branch of the corner at its edge. Such steps must be flagged
// kDegenerate, never kExact; at every other step the box's velocity derivative along its own
// start velocity matches the differences. When the derivative learns to redistribute load, the
// mismatch disappears: update this test and docs/sensitivity.md.
TEST(RedundantContactSensitivityTest, EdgeOfConeSplitIsFlaggedAndTheDifferenceIsRight) {
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
  const int vx = nq + sim.scene().index(box).v;  // the box's x velocity in [q; ν]
  const auto step_vx = [&](const State& x) {
    Workspace w;
    State n;
    EXPECT_TRUE(sim.Step(p, x, {}, &w, &n).ok);
    return n.v[vx - nq];
  };
  int mismatched = 0;
  for (int k = first; k < last; ++k) {
    const State& x = tr.states[k];
    const State& next = tr.states[k + 1];
    const StepSensitivity s = StepDerivatives(sim, p, sel, x, {}, next, true);
    ASSERT_NE(s.status, SensitivityStatus::kFailed) << "step " << k << ": " << s.message;
    ASSERT_EQ(s.d_x.rows(), nx);
    // One-step differences of the box's end velocity along its start velocity (1e-8 m/s: the
    // steps' round-off is ~1e-17 m/s).
    const double h = 1e-8;
    State xp = x, xm = x;
    xp.v[vx - nq] += h;
    xm.v[vx - nq] -= h;
    const double fp = step_vx(xp), fm = step_vx(xm), f0 = next.v[vx - nq];
    const double forward = (fp - f0) / h, backward = (f0 - fm) / h, central = (fp - fm) / (2 * h);
    const double exact = s.d_x(vx, vx);
    if (std::abs(exact - central) <= 1e-6 * std::max(1.0, std::abs(central))) continue;
    ++mismatched;
    SCOPED_TRACE("step " + std::to_string(k) + ": exact " + std::to_string(exact) +
                 ", differences " + std::to_string(central));
    // Flagged, never exact.
    EXPECT_EQ(s.status, SensitivityStatus::kDegenerate) << s.message;
    EXPECT_GT(s.degenerate_pairs, 0);
    // The difference is a derivative here: no kink of the step map along the column.
    EXPECT_NEAR(forward, backward, 1e-6);
    // It is the sticking one (the box takes the plate's velocity: ∂v_x,ℓ+1/∂v_x,ℓ = 0), the
    // derivative the sliding one (the corner at its edge slides: friction fixed at μ p_n).
    EXPECT_NEAR(central, 0.0, 1e-6);
    EXPECT_NEAR(exact, 1.0, 1e-6);
    // The split: a loaded box corner sticking at its cone edge and one strictly inside it.
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
    EXPECT_TRUE(at_edge);
    EXPECT_TRUE(inside);
  }
  // The known gap is present over this cycle (one step when this was written).
  EXPECT_GE(mismatched, 1);
  EXPECT_LE(mismatched, 3);
}

}  // namespace
}  // namespace vinci::sim
