// The frozen step model's x_ℓ block on box–box contacts (step_model.h): the per-coordinate
// Jacobian times random directions is the central difference of the step equations along those
// directions, on flush stacks (every box–box contact a vertex on a vertex: a feature switch the
// frozen model holds on one side and flags) and on a box resting on a box at an offset (vertices
// inside faces and crossing edges: smooth). Before the frozen contacts kept their vertex, the
// re-collided flush contacts switched between "a's vertex on b's face" and "b's vertex on a's
// face" with the direction of the move and the two differed by 1e-5 relative (2.5e-2 absolute).
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "test_util.h"
#include "vinci/sim/formulations/step_model.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim {
namespace {

// A 0.2 m cube on the floor and n − 1 cubes of half size `half` on it, each shifted by
// (dx, dy) from the one below.
std::string Stack(int n, double half, double dx, double dy) {
  std::string s =
      "name: boxes\ndimension: 3\nstepper: {dt: 0.001, friction_directions: 4, envelope: 0.002}\n"
      "friction: {default: 0.6}\nbodies:\n  - name: floor\n    kind: static\n"
      "    shapes: [{type: halfspace}]\n  - name: box0\n    mass: 1.0\n"
      "    pose: {position: [0, 0, 0.1]}\n"
      "    shapes: [{type: box, half_extents: [0.1, 0.1, 0.1]}]\n";
  double z = 0.2;
  const std::string h = std::to_string(half);
  for (int i = 1; i < n; ++i) {
    s += "  - name: box" + std::to_string(i) + "\n    mass: 1.0\n    pose: {position: [" +
         std::to_string(i * dx) + ", " + std::to_string(i * dy) + ", " + std::to_string(z + half) +
         "]}\n    shapes: [{type: box, half_extents: [" + h + ", " + h + ", " + h + "]}]\n";
    z += 2 * half;
  }
  return s;
}

struct Case {
  std::string name;
  std::string yaml;
  bool flush;  // box–box contacts at a feature switch
};
std::ostream& operator<<(std::ostream& os, const Case& c) { return os << c.name; }

const Case kCases[] = {
    {"FlushTwo", Stack(2, 0.1, 0.0, 0.0), true},
    {"FlushThree", Stack(3, 0.1, 0.0, 0.0), true},
    {"OffsetEqual", Stack(2, 0.1, 0.03, 0.02), false},  // crossing edges: edge–edge contacts
    {"OffsetSmaller", Stack(2, 0.05, 0.02, 0.01), false},
};

VectorXd Rows(const StepModelValues& v) {
  VectorXd r(v.equality.size() + v.comp_a.size() + v.comp_b.size());
  r << v.equality, v.comp_a, v.comp_b;
  return r;
}
VectorXd Rows(const StepResiduals& v) {
  VectorXd r(v.equality.size() + v.comp_a.size() + v.comp_b.size());
  r << v.equality, v.comp_a, v.comp_b;
  return r;
}
double Rel(const VectorXd& got, const VectorXd& want) {
  return (got - want).cwiseAbs().maxCoeff() / std::max(1.0, want.cwiseAbs().maxCoeff());
}

class BoxBoxStateJacobianTest : public ::testing::TestWithParam<Case> {};

// After 10 steps at rest: J_x s (Evaluate's per-coordinate block, steps 1e-7) against central
// differences of Evaluate's values along s with steps 1e-5 and 1e-6 (two steps: a kink would
// show as an h-independent gap; truncation is O(h²) ≈ 1e-10 relative) and against
// StateDirectionalDerivative (closed-form vertex–face rates). Tolerance 1e-6 relative to the
// largest entry (~1e3: the gap rows ψ/h): differences with h = 1e-7 carry ~1e-9 of round-off.
TEST_P(BoxBoxStateJacobianTest, PerCoordinateBlockIsTheDirectionalDerivative) {
  const Case& c = GetParam();
  const Simulator sim(ParseScene(c.yaml, c.name));
  const Params p = sim.DefaultParams();
  const int steps = 10;
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const State& x = tr.states[steps - 1];
  const auto frozen = Freeze(sim.formulation(), sim.scene().ApplyParams(p), p, x);
  const VectorXd z = frozen->UnknownsFromStep(tr.states[steps]);
  const int nq = static_cast<int>(x.q.size()), nx = nq + static_cast<int>(x.v.size());
  const StepModelValues full = frozen->Evaluate(z, p, x);
  StepModelOptions values_only;
  values_only.jacobians = false;
  std::mt19937 gen(5);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 4; ++trial) {
    VectorXd s(nx);
    for (int i = 0; i < nx; ++i) s[i] = normal(gen);
    VectorXd Js(full.equality.size() + full.comp_a.size() + full.comp_b.size());
    Js << full.d_equality.d_x * s, full.d_comp_a.d_x * s, full.d_comp_b.d_x * s;
    for (const double h : {1e-5, 1e-6}) {
      State xp = x, xm = x;
      xp.q += h * s.head(nq);
      xm.q -= h * s.head(nq);
      xp.v += h * s.tail(nx - nq);
      xm.v -= h * s.tail(nx - nq);
      const VectorXd cd = (Rows(frozen->Evaluate(z, p, xp, values_only)) -
                           Rows(frozen->Evaluate(z, p, xm, values_only))) /
                          (2 * h);
      EXPECT_LE(Rel(Js, cd), 1e-6) << "trial " << trial << " h " << h;
    }
    const VectorXd dir = Rows(frozen->StateDirectionalDerivative(z, StepInput{}, s, 1e-7));
    EXPECT_LE(Rel(Js, dir), 1e-6) << "trial " << trial;
  }
  // Flush stacks are flagged (one-sided in x_ℓ), offset ones are not.
  const int box_box = frozen->num_contacts() - 4;  // the bottom box's 4 corners on the floor
  ASSERT_GT(box_box, 0);
  EXPECT_EQ(frozen->feature_kinks(), c.flush ? box_box : 0);
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const StepSensitivity st =
      StepDerivatives(sim, p, sel, x, StepInput{}, tr.states[steps], /*with_state=*/false);
  EXPECT_EQ(st.feature_kink_contacts, frozen->feature_kinks());
  if (c.flush) {
    EXPECT_EQ(st.status, SensitivityStatus::kDegenerate) << st.message;
    EXPECT_NE(st.message.find("feature switch"), std::string::npos) << st.message;
  } else {
    EXPECT_EQ(st.message.find("feature switch"), std::string::npos) << st.message;
  }
}

INSTANTIATE_TEST_SUITE_P(Stacks, BoxBoxStateJacobianTest, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

}  // namespace
}  // namespace vinci::sim
