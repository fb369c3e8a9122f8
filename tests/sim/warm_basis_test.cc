// The sparse warm-basis solve (solvers/warm_basis.h) against LemkeSolver's own warm start, and
// the Stewart–Trinkle step's structured fast path against the dense LCP (issue 16).
#include "vinci/sim/solvers/warm_basis.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "box_scenes.h"
#include "test_util.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

using testing::RandomBandedPLcp;

// Sizes below and above kDenseWarmBasisMax: the solution that Lemke found cold is accepted
// from the sparse operator with the same z as LemkeSolver's own warm start (0 pivots).
TEST(WarmBasisTest, AcceptsLemkeSolutionAsLemkeWarmStartDoes) {
  std::mt19937 rng(7);
  const LemkeSolver lemke;
  int checked = 0, above_dense = 0;
  for (int n : {6, 20, 60, 120}) {
    for (int trial = 0; trial < 5; ++trial) {
      const LcpProblem p = RandomBandedPLcp(n, &rng);
      VectorXd z_cold;
      ASSERT_TRUE(lemke.Solve(p, nullptr, &z_cold).ok());
      VectorXd z_lemke;
      const SolverReport warm = lemke.Solve(p, &z_cold, &z_lemke);
      ASSERT_TRUE(warm.ok());
      ASSERT_EQ(warm.iterations, 0);
      const Eigen::SparseMatrix<double> Ms = p.M.sparseView();
      const SparseLcpMatrix op(Ms);
      WarmBasisScratch scratch;
      VectorXd z;
      SolverReport report;
      ASSERT_TRUE(SolveOnWarmBasis(op, p.q, z_cold, lemke.options(), &scratch, &z, &report))
          << "n = " << n << " trial " << trial;
      EXPECT_EQ(report.status, SolverStatus::kSolved);
      EXPECT_EQ(report.iterations, 0);
      EXPECT_LE(report.residual, report.tolerance);
      EXPECT_LE(LcpResidual(p, z), warm.tolerance);
      // Same basis, same z up to the solve's roundoff.
      EXPECT_LE((z - z_lemke).lpNorm<Eigen::Infinity>(), 1e-10 * (1.0 + z_lemke.norm()));
      if ((z_cold.array() > 0.0).count() > kDenseWarmBasisMax) ++above_dense;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 20);
  EXPECT_GT(above_dense, 0);  // the sparse QR branch ran
}

// The scratch keeps the QR of its last two distinct dense basis blocks: problems solved in turn
// through one scratch (repeats, alternations, a third block replacing one) give the bits of a
// fresh scratch's solve.
TEST(WarmBasisTest, KeptFactorizationsGiveTheBitsOfAFreshSolve) {
  std::mt19937 rng(11);
  const LemkeSolver lemke;
  std::vector<LcpProblem> problems;
  std::vector<VectorXd> guesses;
  for (int i = 0; i < 3; ++i) {
    problems.push_back(RandomBandedPLcp(8, &rng));
    VectorXd z_cold;
    ASSERT_TRUE(lemke.Solve(problems.back(), nullptr, &z_cold).ok());
    guesses.push_back(z_cold);
  }
  WarmBasisScratch shared;
  for (int i : {0, 0, 1, 0, 1, 2, 1, 0, 2, 2}) {
    const Eigen::SparseMatrix<double> Ms = problems[i].M.sparseView();
    const SparseLcpMatrix op(Ms);
    WarmBasisScratch fresh;
    VectorXd z_shared, z_fresh;
    SolverReport report;
    ASSERT_TRUE(SolveOnWarmBasis(op, problems[i].q, guesses[i], lemke.options(), &shared, &z_shared,
                                 &report));
    ASSERT_TRUE(SolveOnWarmBasis(op, problems[i].q, guesses[i], lemke.options(), &fresh, &z_fresh,
                                 &report));
    ASSERT_EQ(z_shared.size(), z_fresh.size());
    EXPECT_EQ(std::memcmp(z_shared.data(), z_fresh.data(), sizeof(double) * z_fresh.size()), 0)
        << "problem " << i;
  }
}

// A guess whose basis is not feasible for the problem is refused (the caller then pivots), and
// q ≥ 0 gives z = 0 as Lemke's trivial stage does.
TEST(WarmBasisTest, RefusesInfeasibleBasisAndSolvesTrivialProblem) {
  // M = I, q = (−1, 1): the solution is z = (1, 0). Guess basis {1} gives z_1 = −1 < 0.
  MatrixXd M = MatrixXd::Identity(2, 2);
  const Eigen::SparseMatrix<double> Ms = M.sparseView();
  const SparseLcpMatrix op(Ms);
  WarmBasisScratch scratch;
  VectorXd z;
  SolverReport report;
  const LemkeOptions options;
  EXPECT_FALSE(SolveOnWarmBasis(op, Eigen::Vector2d(-1.0, 1.0), Eigen::Vector2d(0.0, 1.0), options,
                                &scratch, &z, &report));
  // Basis {0} (w_1 = 1 ≥ 0): accepted, z = (1, 0).
  ASSERT_TRUE(SolveOnWarmBasis(op, Eigen::Vector2d(-1.0, 1.0), Eigen::Vector2d(0.5, 0.0), options,
                               &scratch, &z, &report));
  EXPECT_DOUBLE_EQ(z[0], 1.0);
  EXPECT_EQ(z[1], 0.0);
  // An empty guess and q ≥ 0: z = 0.
  ASSERT_TRUE(SolveOnWarmBasis(op, Eigen::Vector2d(2.0, 1.0), Eigen::Vector2d(0.0, 0.0), options,
                               &scratch, &z, &report));
  EXPECT_EQ(z, Eigen::Vector2d::Zero());
  // Wrong sizes or a non-finite guess: refused.
  EXPECT_FALSE(SolveOnWarmBasis(op, Eigen::Vector3d(-1.0, 1.0, 0.0), Eigen::Vector3d(1, 0, 0),
                                options, &scratch, &z, &report));
  EXPECT_FALSE(SolveOnWarmBasis(op, Eigen::Vector2d(-1.0, 1.0), Eigen::Vector2d(std::nan(""), 0.0),
                                options, &scratch, &z, &report));
}

// An LCP solver that forwards to Lemke under another type: the Stewart–Trinkle step then
// always builds the dense LCP (its structured path is for LemkeSolver only).
class DenseLemke final : public LcpSolver {
 public:
  std::string_view name() const override { return "lemke"; }
  SolverReport Solve(const LcpProblem& problem, const VectorXd* warm_start,
                     VectorXd* z) const override {
    return lemke_.Solve(problem, warm_start, z);
  }

 private:
  LemkeSolver lemke_;
};

// The example scene with its default parameters applied (what Simulator::Step hands a
// formulation).
Scene Resolved(const std::string& file) {
  const Scene scene = LoadExample(file);
  return scene.ApplyParams(scene.DefaultParams());
}

// Runs `steps` steps of `model` with the structured path (LemkeSolver) and with the dense LCP
// (DenseLemke) side by side from the same state each step; returns the largest velocity
// difference and counts the steps the structured path took with zero pivots. With tau_ratio:
// the range of τ_structured / τ_dense over the steps both solved on the warm basis.
double CompareStructuredWithDense(const Scene& model, StepperOptions options, int steps,
                                  int* zero_pivot_steps, double (*tau_ratio)[2] = nullptr) {
  const StewartTrinkle fast(options, std::make_shared<LemkeSolver>());
  const StewartTrinkle dense(options, std::make_shared<DenseLemke>());
  State x = Simulator(model).InitialState();
  Workspace ws_fast, ws_dense;
  double worst = 0.0;
  *zero_pivot_steps = 0;
  if (tau_ratio) (*tau_ratio)[0] = (*tau_ratio)[1] = 1.0;
  for (int k = 0; k < steps; ++k) {
    State a, b;
    StepInfo ia, ib;
    fast.Step(model, x, StepInput{}, &ws_fast, &a, &ia);
    dense.Step(model, x, StepInput{}, &ws_dense, &b, &ib);
    EXPECT_TRUE(ia.ok) << ia.failure;
    EXPECT_TRUE(ib.ok) << ib.failure;
    if (!ia.ok || !ib.ok) return 1e300;
    worst = std::max(worst, (a.v - b.v).lpNorm<Eigen::Infinity>());
    EXPECT_EQ(a.warm_start.size(), b.warm_start.size());
    if (ia.solver.iterations == 0) ++*zero_pivot_steps;
    if (tau_ratio && ia.solver.message == "warm basis" && ib.solver.message == "warm basis") {
      const double r = ia.solver.tolerance / ib.solver.tolerance;
      (*tau_ratio)[0] = std::min((*tau_ratio)[0], r);
      (*tau_ratio)[1] = std::max((*tau_ratio)[1], r);
    }
    x = std::move(b);  // continue from the dense trajectory
  }
  return worst;
}

// The 10-box stack (40 contacts, 4 directions) settling and resting: the structured path gives
// the dense LCP's velocities to solver tolerance, and the resting steps take no pivots. Its τ is
// scaled by a bound on ‖M‖∞ (ContactLcpOperator::NormInfBound), the dense Lemke's by ‖M‖∞: at
// least as wide and, the bound being close, less than twice (the loaded stack's τ grows with it).
TEST(StructuredStepTest, BoxStackMatchesDenseLcp) {
  const Scene model = Resolved("box_stack.yaml");
  int zero = 0;
  double tau_ratio[2];
  const double worst = CompareStructuredWithDense(model, model.options, 300, &zero, &tau_ratio);
  EXPECT_LT(worst, 1e-9);
  EXPECT_GT(zero, 250);
  EXPECT_GE(tau_ratio[0], 1.0 - 1e-9);  // z of either path within round-off
  EXPECT_LT(tau_ratio[1], 2.0);
  EXPECT_GT(tau_ratio[1], 1.0);  // τ depended on the scale
}

// Sliding (σ and friction columns basic, the E and U entries), Anitescu–Potra, first order and
// a compliant pair (the compliance diagonal).
TEST(StructuredStepTest, SlidingVariantsAndComplianceMatchDenseLcp) {
  struct Case {
    std::string file;
    FormulationType formulation;
    int steps;
  };
  for (const Case& c :
       {Case{"block_sliding.yaml", FormulationType::kStewartTrinkle, 400},
        Case{"block_sliding.yaml", FormulationType::kAnitescuPotra, 400},
        Case{"first_order_push.yaml", FormulationType::kFirstOrder, 200},
        Case{"disc_on_compliant_plane.yaml", FormulationType::kStewartTrinkle, 2000}}) {
    const Scene model = Resolved(c.file);
    StepperOptions options = model.options;
    options.formulation = c.formulation;
    int zero = 0;
    const double worst = CompareStructuredWithDense(model, options, c.steps, &zero);
    EXPECT_LT(worst, 1e-9) << c.file;
    EXPECT_GT(zero, c.steps / 2) << c.file;
  }
}

// Spatial boxes whose contact pattern changes from step to step, so the operator's kept run
// classification of G (one run of six rows per column, all at one body's rows) must follow it:
// one tilted, spinning box landing on the floor (every column at the box's rows), and a box at
// rest with two boxes dropped, one beside it (columns at two bodies' rows) and one onto it
// (columns of two bodies).
TEST(StructuredStepTest, OneSidedContactPatternsMatchDenseLcp) {
  const std::string header =
      "dimension: 3\nstepper: {dt: 0.001, duration: 1.0, friction_directions: 8, envelope: "
      "0.002}\nfriction: {default: 0.5}\nbodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n";
  const std::string landing =
      "name: landing\n" + header +
      "  - {name: box, mass: 1.0, pose: {position: [0, 0, 0.09], rpy: [0.2, 0.15, 0]}, "
      "velocity: {linear: [0.2, 0, 0], angular: [0, 0, 3]}, "
      "shapes: [{type: box, half_extents: [0.1, 0.1, 0.05]}]}\n";
  const std::string drops = "name: drops\n" + header +
                            "  - {name: a, mass: 1.0, pose: {position: [0, 0, 0.05]}, "
                            "shapes: [{type: box, half_extents: [0.1, 0.1, 0.05]}]}\n"
                            "  - {name: b, mass: 2.0, pose: {position: [0.5, 0, 0.09]}, "
                            "shapes: [{type: box, half_extents: [0.1, 0.1, 0.05]}]}\n"
                            "  - {name: c, mass: 0.5, pose: {position: [0, 0, 0.2]}, "
                            "shapes: [{type: box, half_extents: [0.05, 0.05, 0.05]}]}\n";
  for (const std::string& text : {landing, drops}) {
    const Scene file = ParseScene(text, "one_sided");
    const Scene model = file.ApplyParams(file.DefaultParams());
    int zero = 0;
    EXPECT_LT(CompareStructuredWithDense(model, model.options, 400, &zero), 1e-9) << text;
    EXPECT_GT(zero, 200) << text;
  }
}

// Bases above kDenseWarmBasisMax: the resting 20-box stack (80 normals, M_BB symmetric and
// singular: the semidefinite LDLᵀ) and twelve cubes sliding apart on the floor (normal,
// friction and σ columns basic, M_BB not symmetric: the sparse QR on the structured block) give
// the dense LCP's velocities to solver tolerance with no pivots once settled.
TEST(StructuredStepTest, LargeBasesMatchDenseLcp) {
  const Scene stack_file = ParseScene(bench::StackYaml(20), "stack20");
  const Scene stack = stack_file.ApplyParams(stack_file.DefaultParams());
  int zero = 0;
  EXPECT_LT(CompareStructuredWithDense(stack, stack.options, 60, &zero), 1e-9);
  EXPECT_GT(zero, 50);
  std::string sliding =
      "name: sliding12\ndimension: 3\n"
      "stepper: {dt: 0.001, duration: 1.0, friction_directions: 4, envelope: 0.002}\n"
      "friction: {default: 0.3}\nbodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n";
  for (int i = 0; i < 12; ++i)
    sliding += "  - {name: box" + std::to_string(i) + ", mass: " + std::to_string(1.0 + 0.1 * i) +
               ", pose: {position: [" + std::to_string(0.3 * i) +
               ", 0, 0.1]}, velocity: {linear: [" + std::to_string(0.5 + 0.1 * i) +
               ", 0.3, 0]}, shapes: [{type: box, half_extents: [0.1, 0.1, 0.1]}]}\n";
  const Scene slide_file = ParseScene(sliding, "sliding12");
  const Scene slide = slide_file.ApplyParams(slide_file.DefaultParams());
  EXPECT_LT(CompareStructuredWithDense(slide, slide.options, 60, &zero), 1e-9);
  EXPECT_GT(zero, 50);
}

}  // namespace
}  // namespace vinci::sim
