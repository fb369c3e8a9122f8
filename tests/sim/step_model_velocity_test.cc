// The ν_ℓ columns of the frozen step model's x_ℓ block in closed form
// (StepModelOptions::closed_form_velocity, step_model.h): −M, plus h([ω]× I − [Iω]×) in a spatial
// body's angular rows, for the Stewart–Trinkle family; central differences elsewhere.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "test_util.h"
#include "vinci/sim/formulations/step_model.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

struct Case {
  std::string name;
  std::string scene;
  FormulationType formulation;
  int steps;
  bool spin;         // set a body-frame angular velocity with all three components (spatial)
  bool closed_form;  // the formulation has the closed form (else: central differences)
};

std::ostream& operator<<(std::ostream& os, const Case& c) { return os << c.name; }

const Case kCases[] = {
    {"SlidingBlockST", "block_sliding.yaml", FormulationType::kStewartTrinkle, 40, false, true},
    {"SlidingBlockAP", "block_sliding.yaml", FormulationType::kAnitescuPotra, 40, false, true},
    {"FirstOrderPush", "first_order_push.yaml", FormulationType::kFirstOrder, 100, false, true},
    {"PlanarPlateST", "plate_tilt_planar.yaml", FormulationType::kStewartTrinkle, 30, false, true},
    {"PlateBoxST", "plate_box.yaml", FormulationType::kStewartTrinkle, 30, false, true},
    {"SpinningBoxST", "box_on_plane.yaml", FormulationType::kStewartTrinkle, 20, true, true},
    {"SpinningBoxFirstOrder", "box_on_plane.yaml", FormulationType::kFirstOrder, 20, true, true},
    {"PendulumOnBlockST", "pendulum_on_block.yaml", FormulationType::kStewartTrinkle, 30, false,
     true},
    {"SpinningBoxNcp", "box_on_plane.yaml", FormulationType::kNcp, 20, true, false},
};

class StepModelVelocityTest : public ::testing::TestWithParam<Case> {};

// Max over the entries of |A − B| / max(1, |B|) in columns [c0, c1).
double MaxRelDiff(const SparseMatrixXd& A, const SparseMatrixXd& B, int c0, int c1) {
  const MatrixXd a = MatrixXd(A).middleCols(c0, c1 - c0), b = MatrixXd(B).middleCols(c0, c1 - c0);
  double err = 0.0;
  for (Eigen::Index j = 0; j < a.cols(); ++j)
    for (Eigen::Index i = 0; i < a.rows(); ++i)
      err = std::max(err, std::abs(a(i, j) - b(i, j)) / std::max(1.0, std::abs(b(i, j))));
  return err;
}

bool SameMatrix(const SparseMatrixXd& A, const SparseMatrixXd& B) {
  return A.rows() == B.rows() && A.cols() == B.cols() && MatrixXd(A) == MatrixXd(B);
}

// At a start state and θ away from the freeze (an optimizer's iterate: moved poses, velocities,
// a changed friction coefficient), the closed-form ν_ℓ columns are the central differences' to
// 1e-7 relative (to max(1, |entry|)); the q_ℓ columns and the z, θ and u blocks and the values are
// the same bits. A formulation without the closed form (NCP) ignores the option: the same bits.
TEST_P(StepModelVelocityTest, ClosedFormVelocityColumnsMatchCentralDifferences) {
  const Case& c = GetParam();
  Scene scene = LoadExample(c.scene);
  scene.options.formulation = c.formulation;
  if (c.formulation == FormulationType::kFirstOrder && scene.dim == Dim::kSpatial) {
    for (Body& b : scene.bodies)  // the first-order model's h C (first_order.h)
      if (b.kind == BodyKind::kDynamic)
        b.damping = Eigen::Matrix<double, 6, 1>(2.0, 2.0, 2.0, 0.5, 0.5, 0.5).asDiagonal();
  }
  const Simulator sim(std::move(scene));
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), c.steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const Scene model = sim.scene().ApplyParams(p);
  int k = c.steps - 1;
  while (k > 0 && Freeze(sim.formulation(), model, p, tr.states[k])->num_contacts() == 0) --k;
  const auto frozen = Freeze(sim.formulation(), model, p, tr.states[k]);
  ASSERT_GT(frozen->num_contacts(), 0);
  const VectorXd z = frozen->UnknownsFromStep(tr.states[k + 1]);
  State x = tr.states[k];
  const int nq = static_cast<int>(x.q.size()), nv = static_cast<int>(x.v.size());
  for (int i = 0; i < nq; ++i) x.q[i] += 1e-5 * std::cos(1.0 + i);
  for (int i = 0; i < nv; ++i) x.v[i] += 0.05 * std::sin(2.0 + i);
  const bool spatial = sim.scene().dim == Dim::kSpatial;
  if (c.spin) {
    ASSERT_TRUE(spatial);
    x.v.segment<3>(3) = Vector3d(1.5, -2.0, 3.0);  // body frame, the first dynamic body
  }
  Params theta = p;
  theta.values[0] *= 1.1;  // mu.default: the applied-scene path
  StepInput u;
  u.generalized_force = VectorXd::Constant(nv, 0.3);
  StepModelOptions closed, differenced;
  closed.closed_form_velocity = true;
  differenced.closed_form_velocity = false;
  const StepModelValues a = frozen->Evaluate(z, theta, x, u, closed);
  const StepModelValues b = frozen->Evaluate(z, theta, x, u, differenced);
  EXPECT_TRUE(testing::SameBits(a.equality, b.equality));
  EXPECT_TRUE(testing::SameBits(a.comp_a, b.comp_a));
  EXPECT_TRUE(testing::SameBits(a.comp_b, b.comp_b));
  int velocity_entries = 0;
  for (const auto& [ja, jb, what] : {std::make_tuple(&a.d_equality, &b.d_equality, "equality"),
                                     std::make_tuple(&a.d_comp_a, &b.d_comp_a, "comp_a"),
                                     std::make_tuple(&a.d_comp_b, &b.d_comp_b, "comp_b")}) {
    EXPECT_TRUE(SameMatrix(ja->d_z, jb->d_z)) << what;
    EXPECT_TRUE(SameMatrix(ja->d_theta, jb->d_theta)) << what;
    EXPECT_TRUE(SameMatrix(ja->d_u, jb->d_u)) << what;
    ASSERT_EQ(ja->d_x.cols(), nq + nv);
    const MatrixXd xa = MatrixXd(ja->d_x), xb = MatrixXd(jb->d_x);
    EXPECT_TRUE(xa.leftCols(nq) == xb.leftCols(nq)) << what << ": the q_ℓ columns";
    if (!c.closed_form) {
      EXPECT_TRUE(xa == xb) << what << ": no closed form, the same differences";
      continue;
    }
    EXPECT_LE(MaxRelDiff(ja->d_x, jb->d_x, nq, nq + nv), 1e-7) << what << ": the ν_ℓ columns";
    velocity_entries += static_cast<int>((xa.rightCols(nv).array() != 0.0).count());
  }
  // The cases exercise the columns: −M on the dynamics rows (none in first order), and with
  // the spin a gyroscopic entry off the angular block's diagonal (the box's I_xx = I_yy ≠ I_zz:
  // ∂(ω × Iω)/∂ω has (I_zz − I_xx) ω_y at (x, z) and (I_xx − I_zz) ω_x at (y, z)).
  const bool first_order = c.formulation == FormulationType::kFirstOrder;
  if (c.closed_form && !first_order) {
    EXPECT_GE(velocity_entries, nv);
  }
  if (c.closed_form && first_order) {
    EXPECT_EQ(velocity_entries, 0);
  }
  if (c.spin && c.closed_form && !first_order) {
    const MatrixXd D = MatrixXd(a.d_equality.d_x).block(3, nq + 3, 3, 3);
    EXPECT_NE(D(0, 2), 0.0);
    EXPECT_NE(D(1, 2), 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, StepModelVelocityTest, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

}  // namespace
}  // namespace vinci::sim
