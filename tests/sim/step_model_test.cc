// The frozen, sparse step model (step_model.h): a simulated trajectory satisfies its
// formulation's step equations at the unknowns mapped from each step, the maps invert each
// other, the contact set stays fixed as x_ℓ moves, and the sparse Jacobians match central
// differences of the frozen equations.
#include "vinci/sim/formulations/step_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "test_util.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

StepModelOptions ValuesOnly() {
  StepModelOptions o;
  o.jacobians = false;
  return o;
}

struct Case {
  std::string name;
  std::string scene;
  FormulationType formulation;
  int steps;
};

std::ostream& operator<<(std::ostream& os, const Case& c) { return os << c.name; }

// Every formulation with Evaluate on the scenes the issue names: sliding box, resting box,
// stack, a planar scene with supports, a GI disc; plus joints (p_b recovered from the dynamics)
// and concave corners (the c unknowns).
const Case kCases[] = {
    {"SlidingBoxST", "block_sliding.yaml", FormulationType::kStewartTrinkle, 40},
    {"SlidingBoxAP", "block_sliding.yaml", FormulationType::kAnitescuPotra, 40},
    {"SlidingBoxNcp", "block_sliding.yaml", FormulationType::kNcp, 40},
    {"FirstOrderPush", "first_order_push.yaml", FormulationType::kFirstOrder, 100},
    {"RestingBoxST", "box_on_plane.yaml", FormulationType::kStewartTrinkle, 20},
    {"RestingBoxNcp", "box_on_plane.yaml", FormulationType::kNcp, 20},
    {"StackST", "box_stack.yaml", FormulationType::kStewartTrinkle, 10},
    {"StackAP", "box_stack.yaml", FormulationType::kAnitescuPotra, 10},
    {"PushingDqc", "planar_pushing.yaml", FormulationType::kQuasistaticDqc, 20},
    {"PushingDlc", "planar_pushing.yaml", FormulationType::kQuasistaticDlc, 20},
    {"PushingDynamicDqc", "planar_pushing.yaml", FormulationType::kDynamicDqc, 20},
    {"PushingST", "planar_pushing.yaml", FormulationType::kStewartTrinkle, 20},
    {"PendulumOnBlockST", "pendulum_on_block.yaml", FormulationType::kStewartTrinkle, 30},
    {"TrenchST", "concave_trench.yaml", FormulationType::kStewartTrinkle, 30},
    {"GiDisc", "disc_on_plane.yaml", FormulationType::kGeometricallyImplicit, 30},
    {"GiSpheres", "sphere_on_two_spheres.yaml", FormulationType::kGeometricallyImplicit, 200},
    {"GiBox", "box_on_plane.yaml", FormulationType::kGeometricallyImplicit, 10},
};

class StepModelTest : public ::testing::TestWithParam<Case> {
 protected:
  static Simulator Make(const Case& c) {
    Scene s = LoadExample(c.scene);
    s.options.formulation = c.formulation;
    return Simulator(std::move(s));
  }
};

// Central difference of the frozen equations' values along one input direction.
struct Rows {
  VectorXd e, a, b;
};
Rows Diff(const StepModelValues& p, const StepModelValues& m, double step) {
  return {(p.equality - m.equality) / (2 * step), (p.comp_a - m.comp_a) / (2 * step),
          (p.comp_b - m.comp_b) / (2 * step)};
}
double MaxError(const SparseMatrixXd& J, int col, const VectorXd& fd) {
  const VectorXd a = MatrixXd(J).col(col);
  double err = 0.0;
  for (int i = 0; i < fd.size(); ++i)
    err = std::max(err, std::abs(a[i] - fd[i]) / std::max(1.0, std::abs(fd[i])));
  return err;
}

// A simulated trajectory satisfies the frozen step equations at the mapped unknowns to 1e-9,
// the frozen model at x_ℓ IS Formulation::Evaluate (same values, bit for bit), and
// StateFromUnknowns inverts UnknownsFromStep.
TEST_P(StepModelTest, TrajectorySatisfiesFrozenStepEquations) {
  const Case& c = GetParam();
  const Simulator sim = Make(c);
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), c.steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const Scene model = sim.scene().ApplyParams(p);
  int with_contacts = 0;
  for (int k = 0; k < c.steps; ++k) {
    const State& x = tr.states[k];
    const State& next = tr.states[k + 1];
    const auto frozen = Freeze(sim.formulation(), model, p, x);
    const VectorXd z = frozen->UnknownsFromStep(next);
    const StepModelValues v = frozen->Evaluate(z, p, x, ValuesOnly());
    // Lemke / Newton solve to ~1e-12 relative; the residuals are in N·s, m/s and m.
    EXPECT_LE(v.Violation(), 1e-9) << "step " << k;
    const StepResiduals r = sim.formulation().Evaluate(model, p, x, StepInput{}, z);
    EXPECT_EQ(r.equality, v.equality) << "step " << k;
    EXPECT_EQ(r.comp_a, v.comp_a) << "step " << k;
    EXPECT_EQ(r.comp_b, v.comp_b) << "step " << k;
    const State back = frozen->StateFromUnknowns(z);
    EXPECT_DOUBLE_EQ(back.t, next.t);
    EXPECT_LE((back.q - next.q).cwiseAbs().maxCoeff(), 1e-12) << "step " << k;
    EXPECT_LE((back.v - next.v).cwiseAbs().maxCoeff(), 1e-12) << "step " << k;
    ASSERT_EQ(back.warm_start.size(), next.warm_start.size());
    if (next.warm_start.size() > 0) {
      EXPECT_LE((back.warm_start - next.warm_start).cwiseAbs().maxCoeff(), 1e-12) << "step " << k;
    }
    with_contacts += frozen->num_contacts() > 0;
  }
  EXPECT_GT(with_contacts, 0) << "the case must exercise contact rows";
}

// The sparse Jacobian blocks (z, θ, x_ℓ, input) match central differences of the frozen
// equations. Steps: 1e-6 relative (the x_ℓ block is itself differenced inside Evaluate with
// 1e-7, so the check uses another step). Tolerance 1e-5 relative to max(1, |J|): central
// differences with h ~ 1e-6 carry truncation O(h² f''') and roundoff O(1e-16 |f| / h) ≈ 1e-10;
// the largest term is the differenced quaternion kinematics inside the ST z block (~1e-8).
TEST_P(StepModelTest, SparseJacobiansMatchFiniteDifferences) {
  const Case& c = GetParam();
  const Simulator sim = Make(c);
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), c.steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const Scene model = sim.scene().ApplyParams(p);
  // The last step with contacts.
  int k = c.steps - 1;
  while (k > 0 && Freeze(sim.formulation(), model, p, tr.states[k])->num_contacts() == 0) --k;
  const State& x = tr.states[k];
  const auto frozen = Freeze(sim.formulation(), model, p, x);
  ASSERT_GT(frozen->num_contacts(), 0);
  const VectorXd z = frozen->UnknownsFromStep(tr.states[k + 1]);
  const StepModelValues J = frozen->Evaluate(z, p, x);
  const StepModelOptions values_only = ValuesOnly();
  const double kTol = 1e-5, kRel = 1e-6;
  const auto check = [&](const Rows& fd, int col, const SparseMatrixXd& Je,
                         const SparseMatrixXd& Ja, const SparseMatrixXd& Jb,
                         const std::string& what) {
    EXPECT_LE(MaxError(Je, col, fd.e), kTol) << what << " column " << col << " (equality)";
    EXPECT_LE(MaxError(Ja, col, fd.a), kTol) << what << " column " << col << " (comp_a)";
    EXPECT_LE(MaxError(Jb, col, fd.b), kTol) << what << " column " << col << " (comp_b)";
  };
  for (int j = 0; j < z.size(); ++j) {
    const double h = kRel * std::max(1.0, std::abs(z[j]));
    VectorXd zp = z, zm = z;
    zp[j] += h;
    zm[j] -= h;
    check(Diff(frozen->Evaluate(zp, p, x, values_only), frozen->Evaluate(zm, p, x, values_only), h),
          j, J.d_equality.d_z, J.d_comp_a.d_z, J.d_comp_b.d_z, "z");
  }
  const std::vector<int>& cols = frozen->param_columns();
  ASSERT_FALSE(cols.empty());
  for (std::size_t j = 0; j < cols.size(); ++j) {
    const double h = kRel * std::max(1.0, std::abs(p.values[cols[j]]));
    Params pp = p, pm = p;
    pp.values[cols[j]] += h;
    pm.values[cols[j]] -= h;
    if (pm.values[cols[j]] < sim.scene().param_table().info(cols[j]).lower) continue;
    check(Diff(frozen->Evaluate(z, pp, x, values_only), frozen->Evaluate(z, pm, x, values_only), h),
          static_cast<int>(j), J.d_equality.d_theta, J.d_comp_a.d_theta, J.d_comp_b.d_theta,
          "theta " + sim.scene().param_table().info(cols[j]).name);
  }
  const int nq = static_cast<int>(x.q.size()), nv = static_cast<int>(x.v.size());
  for (int j = 0; j < nq + nv; ++j) {
    State xp = x, xm = x;
    double& cp = j < nq ? xp.q[j] : xp.v[j - nq];
    double& cm = j < nq ? xm.q[j] : xm.v[j - nq];
    const double h = kRel * std::max(1.0, std::abs(cp));
    cp += h;
    cm -= h;
    check(Diff(frozen->Evaluate(z, p, xp, values_only), frozen->Evaluate(z, p, xm, values_only), h),
          j, J.d_equality.d_x, J.d_comp_a.d_x, J.d_comp_b.d_x, "x");
  }
  for (int j = 0; j < nv; ++j) {
    StepInput up, um;
    up.generalized_force = VectorXd::Zero(nv);
    um.generalized_force = VectorXd::Zero(nv);
    up.generalized_force[j] = 1e-3;
    um.generalized_force[j] = -1e-3;
    check(Diff(frozen->Evaluate(z, p, x, up, values_only),
               frozen->Evaluate(z, p, x, um, values_only), 1e-3),
          j, J.d_equality.d_u, J.d_comp_a.d_u, J.d_comp_b.d_u, "u");
  }
}

// EvaluateResiduals (the step sensitivities' dense path) is Evaluate without the sparse
// conversion: the same values, z and θ Jacobians at the freeze point, and the same values (the
// values-only evaluation) at a moved start state; it accepts only the freeze parameters.
TEST_P(StepModelTest, DenseResidualsAreTheSparseEvaluation) {
  const Case& c = GetParam();
  const Simulator sim = Make(c);
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), c.steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const Scene model = sim.scene().ApplyParams(p);
  int k = c.steps - 1;
  while (k > 0 && Freeze(sim.formulation(), model, p, tr.states[k])->num_contacts() == 0) --k;
  const State& x = tr.states[k];
  const auto frozen = Freeze(sim.formulation(), model, p, x);
  const VectorXd z = frozen->UnknownsFromStep(tr.states[k + 1]);
  const int nz = frozen->layout().size(), np = static_cast<int>(frozen->param_columns().size());
  StepModelOptions no_state;
  no_state.state_jacobian = false;
  const StepModelValues sparse = frozen->Evaluate(z, p, x, no_state);
  const StepResiduals dense = frozen->EvaluateResiduals(z, p, x, StepInput{}, true);
  EXPECT_EQ(dense.equality, sparse.equality);
  EXPECT_EQ(dense.comp_a, sparse.comp_a);
  EXPECT_EQ(dense.comp_b, sparse.comp_b);
  const auto same = [&](const MatrixXd& d, const StepModelJacobian& s) {
    ASSERT_EQ(d.cols(), nz + np);
    EXPECT_EQ(MatrixXd(d.leftCols(nz)), MatrixXd(s.d_z));
    EXPECT_EQ(MatrixXd(d.rightCols(np)), MatrixXd(s.d_theta));
  };
  same(dense.d_equality, sparse.d_equality);
  same(dense.d_comp_a, sparse.d_comp_a);
  same(dense.d_comp_b, sparse.d_comp_b);

  State moved = x;
  moved.q[0] += 1e-4;
  moved.v[0] += 1e-3;
  const StepModelValues vs = frozen->Evaluate(z, p, moved, ValuesOnly());
  const StepResiduals vd = frozen->EvaluateResiduals(z, p, moved, StepInput{}, false);
  EXPECT_EQ(vd.equality, vs.equality);
  EXPECT_EQ(vd.comp_a, vs.comp_a);
  EXPECT_EQ(vd.comp_b, vs.comp_b);

  Params other = p;
  other.values[0] += 0.1;
  EXPECT_THROW(frozen->EvaluateResiduals(z, other, x, StepInput{}, false), std::invalid_argument);
}

// The derivative along a state direction (StepModel::StateDirectionalDerivative: closed-form
// contact rates where the shape pair has one, re-collision elsewhere) is the central difference
// of Evaluate (every contact re-collided) at x_ℓ ± h s. Both are differences with h = 1e-7:
// they agree to ~1e-11 here. (Evaluate's x_ℓ block times s is checked against both on box–box
// stacks in box_box_state_jacobian_test.cc.)
TEST_P(StepModelTest, DirectionalDerivativeMatchesRecollidedDifferences) {
  const Case& c = GetParam();
  const Simulator sim = Make(c);
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), c.steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const Scene model = sim.scene().ApplyParams(p);
  int k = c.steps - 1;
  while (k > 0 && Freeze(sim.formulation(), model, p, tr.states[k])->num_contacts() == 0) --k;
  const State& x = tr.states[k];
  const auto frozen = Freeze(sim.formulation(), model, p, x);
  const VectorXd z = frozen->UnknownsFromStep(tr.states[k + 1]);
  const int nx = static_cast<int>(x.q.size() + x.v.size()), nq = static_cast<int>(x.q.size());
  VectorXd s(nx);
  for (int i = 0; i < nx; ++i) s[i] = std::sin(1.0 + 3.7 * i);  // a fixed generic direction
  const double h = 1e-7;
  const StepResiduals d = frozen->StateDirectionalDerivative(z, StepInput{}, s, h);
  State xp = x, xm = x;
  xp.q += h * s.head(nq);
  xm.q -= h * s.head(nq);
  xp.v += h * s.tail(nx - nq);
  xm.v -= h * s.tail(nx - nq);
  const Rows want =
      Diff(frozen->Evaluate(z, p, xp, ValuesOnly()), frozen->Evaluate(z, p, xm, ValuesOnly()), h);
  const auto expect_near = [&](const VectorXd& got, const VectorXd& ref, const char* what) {
    ASSERT_EQ(got.size(), ref.size()) << what;
    for (int i = 0; i < ref.size(); ++i)
      EXPECT_NEAR(got[i], ref[i], 1e-6 * std::max(1.0, std::abs(ref[i]))) << what << " " << i;
  };
  expect_near(d.equality, want.e, "equality");
  expect_near(d.comp_a, want.a, "comp_a");
  expect_near(d.comp_b, want.b, "comp_b");
  EXPECT_THROW(frozen->StateDirectionalDerivative(z, StepInput{}, s.head(nx - 1), 1e-7),
               std::invalid_argument);
  EXPECT_THROW(frozen->StateDirectionalDerivative(z, StepInput{}, s, 0.0), std::invalid_argument);
}

INSTANTIATE_TEST_SUITE_P(AllFormulations, StepModelTest, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

// The contact set stays fixed while x_ℓ moves: lifting a resting box 1 cm above the envelope
// keeps its four contacts, whose Stewart–Trinkle normal rows G_nᵀν + ψ/h grow by exactly
// 0.01/h, while Formulation::Evaluate at the lifted state finds no contact at all.
TEST(StepModelFrozenTest, LiftedBoxKeepsItsContactsAndGapsMoveWithIt) {
  Scene s = LoadExample("box_on_plane.yaml");
  const Simulator sim(std::move(s));
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), 5);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const State& x = tr.states[4];
  const auto frozen = Freeze(sim.formulation(), sim.scene(), p, x);
  ASSERT_EQ(frozen->num_contacts(), 4);
  const VectorXd z = frozen->UnknownsFromStep(tr.states[5]);
  State lifted = x;
  lifted.q[2] += 0.01;  // z of the box
  EXPECT_EQ(sim.formulation().Layout(sim.scene(), lifted).nc, 0);
  const StepModelValues v0 = frozen->Evaluate(z, p, x, ValuesOnly());
  const StepModelValues v1 = frozen->Evaluate(z, p, lifted, ValuesOnly());
  ASSERT_EQ(v1.comp_b.size(), v0.comp_b.size());
  const double h = sim.scene().options.dt;
  for (int c = 0; c < 4; ++c) EXPECT_NEAR(v1.comp_b[c] - v0.comp_b[c], 0.01 / h, 1e-9);
}

// For vertex–face contacts on a static floor the moved contacts are exactly the re-detected
// ones, so the frozen x_ℓ block equals Formulation::EvaluateStateJacobians (central differences
// with collision detection re-run) — here on a tilted, spinning box on two of its corners.
// Tolerance 1e-6: both are central differences (steps 1e-7), roundoff ~1e-16 |f| / 1e-7.
TEST(StepModelFrozenTest, StateBlockMatchesRedetectionForVertexFaceContacts) {
  const Simulator sim(LoadExample("box_on_plane.yaml"));
  const Params p = sim.DefaultParams();
  State x = sim.InitialState();
  // Rotate the box about x by 0.2 rad and lower it so one edge (two corners) is in the envelope.
  const Eigen::Quaterniond Q(Eigen::AngleAxisd(0.2, Vector3d::UnitX()));
  x.q.segment<4>(3) << Q.w(), Q.x(), Q.y(), Q.z();
  x.q[2] = 0.1 * std::sin(0.2) + 0.05 * std::cos(0.2) + 0.001;
  x.v << 0.3, -0.2, -0.1, 0.5, 1.0, -2.0;
  const auto frozen = Freeze(sim.formulation(), sim.scene(), p, x);
  ASSERT_EQ(frozen->num_contacts(), 2);
  VectorXd z = VectorXd::Zero(frozen->layout().size());
  for (int i = 0; i < z.size(); ++i) z[i] = 0.1 * std::sin(1.0 + i);  // a generic point
  const StepModelValues v = frozen->Evaluate(z, p, x);
  const StateJacobians redetect =
      sim.formulation().EvaluateStateJacobians(sim.scene(), p, x, StepInput{}, z);
  ASSERT_TRUE(redetect.contact_set_stable);
  EXPECT_LE((MatrixXd(v.d_equality.d_x) - redetect.d_equality).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LE((MatrixXd(v.d_comp_a.d_x) - redetect.d_comp_a).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LE((MatrixXd(v.d_comp_b.d_x) - redetect.d_comp_b).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT(MatrixXd(v.d_comp_b.d_x).cwiseAbs().maxCoeff(), 1.0);  // not trivially zero
}

TEST(StepModelFrozenTest, RejectsMismatchedSizes) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const State x = sim.InitialState();
  const auto frozen = Freeze(sim.formulation(), sim.scene(), p, x);
  EXPECT_THROW(frozen->Evaluate(VectorXd::Zero(frozen->layout().size() + 1), p, x),
               std::invalid_argument);
  State later = x;
  later.t += 0.5;
  EXPECT_THROW(frozen->Evaluate(VectorXd::Zero(frozen->layout().size()), p, later),
               std::invalid_argument);
  State bad = x;
  bad.warm_start = VectorXd::Zero(3);
  EXPECT_THROW(frozen->UnknownsFromStep(bad), std::invalid_argument);
  Params short_p;
  short_p.values = VectorXd::Zero(0);
  EXPECT_THROW(Freeze(sim.formulation(), sim.scene(), short_p, x), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::sim
