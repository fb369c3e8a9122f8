// The MPEC layer (mpec.h) on MacMPEC toy problems with known optima: the relaxation homotopy,
// the penalty, the polish and their options.
#include "vinci/estimation/mpec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <tuple>
#include <vector>

namespace vinci::estimation {
namespace {

using sim::VectorXd;

// A small MPEC with a quadratic objective ½ xᵀ P x + cᵀ x + f0 and linear constraints
// A x (bounds g_l, g_u), written out densely.
class QuadraticMpec : public MpecProblem {
 public:
  sim::MatrixXd P, A;
  VectorXd c, x_l, x_u, g_l, g_u, x0;
  double f0 = 0.0;
  std::vector<std::pair<int, int>> pairs;

  int num_variables() const override { return static_cast<int>(c.size()); }
  int num_constraints() const override { return static_cast<int>(A.rows()); }
  void Bounds(VectorXd* xl, VectorXd* xu, VectorXd* gl, VectorXd* gu) const override {
    *xl = x_l;
    *xu = x_u;
    *gl = g_l;
    *gu = g_u;
  }
  VectorXd StartingPoint() const override { return x0; }
  std::vector<std::pair<int, int>> ComplementarityPairs() const override { return pairs; }
  bool Objective(const VectorXd& x, double* f) const override {
    *f = 0.5 * x.dot(P * x) + c.dot(x) + f0;
    return true;
  }
  bool Gradient(const VectorXd& x, VectorXd* g) const override {
    *g = P * x + c;
    return true;
  }
  bool Constraints(const VectorXd& x, VectorXd* g) const override {
    *g = A * x;
    return true;
  }
  std::vector<Entry> JacobianStructure() const override {
    std::vector<Entry> e;
    for (int i = 0; i < A.rows(); ++i)
      for (int j = 0; j < A.cols(); ++j) e.push_back({i, j});
    return e;
  }
  bool JacobianValues(const VectorXd&, VectorXd* v) const override {
    v->resize(A.size());
    int k = 0;
    for (int i = 0; i < A.rows(); ++i)
      for (int j = 0; j < A.cols(); ++j) (*v)[k++] = A(i, j);
    return true;
  }
  bool has_hessian() const override { return true; }
  std::vector<Entry> HessianStructure() const override {
    std::vector<Entry> e;
    for (int i = 0; i < P.rows(); ++i)
      for (int j = 0; j <= i; ++j) e.push_back({i, j});
    return e;
  }
  bool HessianValues(const VectorXd&, double s, const VectorXd&, VectorXd* v) const override {
    v->resize(P.rows() * (P.rows() + 1) / 2);
    int k = 0;
    for (int i = 0; i < P.rows(); ++i)
      for (int j = 0; j <= i; ++j) (*v)[k++] = s * P(i, j);
    return true;
  }
};

constexpr double kBig = 1e20;

// scholtes3: min ½((x1 − 1)² + (x2 − 1)²), 0 ≤ x1 ⊥ x2 ≥ 0, from (1e-4, 1e-4); optimum 0.5
// at (1, 0) or (0, 1).
QuadraticMpec Scholtes3() {
  QuadraticMpec p;
  p.P = sim::MatrixXd::Identity(2, 2);
  p.c = VectorXd::Constant(2, -1.0);
  p.f0 = 1.0;
  p.A.resize(0, 2);
  p.x_l = VectorXd::Zero(2);
  p.x_u = VectorXd::Constant(2, kBig);
  p.g_l.resize(0);
  p.g_u.resize(0);
  p.x0 = VectorXd::Constant(2, 1e-4);
  p.pairs = {{0, 1}};
  return p;
}

// jr1: min (z1 − 1)² + z2², 0 ≤ z2 ⊥ z2 − z1 ≥ 0 (slack s = z2 − z1); optimum 0.5 at
// z = (0.5, 0.5).
QuadraticMpec Jr1() {
  QuadraticMpec p;
  p.P = sim::MatrixXd::Zero(3, 3);
  p.P(0, 0) = 2;
  p.P(1, 1) = 2;
  p.c = VectorXd::Zero(3);
  p.c[0] = -2;
  p.f0 = 1.0;
  p.A.resize(1, 3);
  p.A << -1, 1, -1;  // z2 − z1 − s = 0
  p.g_l = VectorXd::Zero(1);
  p.g_u = VectorXd::Zero(1);
  p.x_l = VectorXd::Constant(3, -kBig);
  p.x_u = VectorXd::Constant(3, kBig);
  p.x0 = VectorXd::Zero(3);
  p.pairs = {{1, 2}};
  return p;
}

// scholtes5: min (z1 − 1)² + (z2 − 2)² + (z3 + 1)², 0 ≤ z1 ⊥ z3 ≥ 0, 0 ≤ z2 ⊥ z3 ≥ 0, from
// (1, 1, 1); optimum 1 at (1, 2, 0).
QuadraticMpec Scholtes5() {
  QuadraticMpec p;
  p.P = 2 * sim::MatrixXd::Identity(3, 3);
  p.c = VectorXd(3);
  p.c << -2, -4, 2;
  p.f0 = 1 + 4 + 1;
  p.A.resize(0, 3);
  p.g_l.resize(0);
  p.g_u.resize(0);
  p.x_l = VectorXd::Zero(3);
  p.x_u = VectorXd::Constant(3, kBig);
  p.x0 = VectorXd::Ones(3);
  p.pairs = {{0, 2}, {1, 2}};
  return p;
}

struct Toy {
  std::string name;
  std::function<QuadraticMpec()> make;
  double optimum;
};

class MacMpecTest : public ::testing::TestWithParam<std::tuple<int, ComplementarityMethod, bool>> {
};

const Toy kToys[] = {
    {"scholtes3", Scholtes3, 0.5}, {"jr1", Jr1, 0.5}, {"scholtes5", Scholtes5, 1.0}};

TEST_P(MacMpecTest, ReachesKnownOptimum) {
  const auto [index, method, polish] = GetParam();
  const Toy& toy = kToys[index];
  const QuadraticMpec p = toy.make();
  MpecSolverOptions o;
  o.method = method;
  o.polish = polish;
  const MpecSolution s = SolveMpec(p, o);
  EXPECT_TRUE(s.converged) << toy.name << ": " << s.reason;
  EXPECT_NEAR(s.objective, toy.optimum, 1e-6) << toy.name << ": " << s.reason;
  // Relaxed: x_a x_b ≤ ε_end = 1e-8 up to Ipopt's bound relaxation (1e-8), x_a ≈ 1.
  EXPECT_LE(s.complementarity_violation, polish ? 1e-8 : 3e-8) << toy.name;
  EXPECT_EQ(s.polished, polish) << toy.name;
  EXPECT_GT(s.iterations, 0);
  if (toy.name == "jr1") {
    EXPECT_NEAR(s.x[0], 0.5, 1e-6);
    EXPECT_NEAR(s.x[1], 0.5, 1e-6);
  }
  if (toy.name == "scholtes5") {
    EXPECT_NEAR(s.x[0], 1.0, 1e-6);
    EXPECT_NEAR(s.x[1], 2.0, 1e-6);
    EXPECT_NEAR(s.x[2], 0.0, 1e-6);
  }
}

INSTANTIATE_TEST_SUITE_P(Toys, MacMpecTest,
                         ::testing::Combine(::testing::Values(0, 1, 2),
                                            ::testing::Values(ComplementarityMethod::kScholtes,
                                                              ComplementarityMethod::kPenalty),
                                            ::testing::Bool()),
                         [](const auto& i) {
                           return kToys[std::get<0>(i.param)].name + "_" +
                                  ToString(std::get<1>(i.param)) +
                                  (std::get<2>(i.param) ? "_polish" : "_relaxed");
                         });

// The warm-started stages' push (the estimator's ε), a cold first stage pushed 0.1 inside its
// bounds and the ε predictor change the homotopy's path, not its end point.
TEST(MpecSolver, WarmStartPushAndPredictorReachTheKnownOptima) {
  for (const Toy& toy : kToys) {
    for (const bool predictor : {false, true}) {
      MpecSolverOptions o;
      o.cold_bound_push = 0.1;
      o.warm_start_push_per_epsilon = 1.0;
      o.epsilon_predictor = predictor;
      o.polish = false;
      const MpecSolution s = SolveMpec(toy.make(), o);
      EXPECT_TRUE(s.converged) << toy.name << ": " << s.reason;
      EXPECT_NEAR(s.objective, toy.optimum, 1e-6) << toy.name << " predictor " << predictor;
      EXPECT_LE(s.complementarity_violation, 3e-8) << toy.name;
    }
  }
}

// scholtes3's early polish after the first stage (ε = 0.1) reaches the optimum 0.5, 0.03 above
// the relaxed value 0.4675 (the relaxation's first-order rise ε Σ λ_k is 0.22): the plain
// tolerance (0) rejects it and the homotopy runs on; within 2 ε Σ λ_k
// (MpecSolverOptions::early_polish_rise_factor) it is accepted after that one stage.
TEST(MpecSolver, EarlyPolishWithinTheRelaxationsRise) {
  MpecSolverOptions o;
  o.early_polish_tolerance = 0.0;
  const MpecSolution plain = SolveMpec(Scholtes3(), o);
  EXPECT_TRUE(plain.converged) << plain.reason;
  EXPECT_GT(plain.stages, 3);
  EXPECT_NEAR(plain.objective, 0.5, 1e-6);
  o.early_polish_rise_factor = 2.0;
  const MpecSolution rise = SolveMpec(Scholtes3(), o);
  EXPECT_TRUE(rise.converged) << rise.reason;
  EXPECT_TRUE(rise.polished);
  EXPECT_EQ(rise.stages, 2) << rise.reason;
  EXPECT_NEAR(rise.objective, 0.5, 1e-6);
  EXPECT_EQ(rise.complementarity_violation, 0.0);
}

// Past a failed polish (here: polish off) the homotopy goes on below epsilon_end until the
// relaxed iterate is complementary within the tolerance (MpecSolverOptions::epsilon_floor);
// without a floor it stops at epsilon_end, ~1e-4 from complementary, not converged. (scholtes3:
// its relaxation row stays active along the homotopy; jr1's and scholtes5's relaxed solutions
// are exactly complementary.)
TEST(MpecSolver, EpsilonFloorContinuesTheRelaxedHomotopyToTheTolerance) {
  for (const Toy& toy : {kToys[0]}) {
    MpecSolverOptions o;
    o.polish = false;
    o.epsilon_end = 1e-4;
    const MpecSolution stop = SolveMpec(toy.make(), o);
    EXPECT_FALSE(stop.converged) << toy.name << ": " << stop.reason;
    EXPECT_GT(stop.complementarity_violation, 1e-5) << toy.name;
    EXPECT_DOUBLE_EQ(stop.final_epsilon, 1e-4) << toy.name;
    o.epsilon_floor = 1e-12;
    const MpecSolution s = SolveMpec(toy.make(), o);
    EXPECT_TRUE(s.converged) << toy.name << ": " << s.reason;
    EXPECT_TRUE(s.solved) << toy.name;
    EXPECT_FALSE(s.polished);
    EXPECT_LE(s.complementarity_violation, o.complementarity_tolerance) << toy.name;
    EXPECT_LT(s.final_epsilon, 1e-5) << toy.name;
    EXPECT_GT(s.stages, stop.stages) << toy.name;
    EXPECT_NEAR(s.objective, toy.optimum, 1e-5) << toy.name << ": " << s.reason;
    EXPECT_NE(s.reason.find("relaxed iterate at eps"), std::string::npos) << s.reason;
  }
}

// A continued stage that does not end within MpecSolverOptions::continued_max_iterations ends
// the continuation: the result is the last accepted iterate (here epsilon_end's, as without a
// floor), from a solved stage, and the progress says where it stopped.
TEST(MpecSolver, ContinuedStagesEndAtTheirIterationCap) {
  MpecSolverOptions o;
  o.polish = false;
  o.epsilon_end = 1e-4;
  const MpecSolution stop = SolveMpec(Scholtes3(), o);
  o.epsilon_floor = 1e-12;
  o.continued_max_iterations = 1;
  std::vector<std::string> lines;
  o.progress = [&lines](const std::string& l) { lines.push_back(l); };
  const MpecSolution s = SolveMpec(Scholtes3(), o);
  EXPECT_FALSE(s.converged) << s.reason;
  EXPECT_TRUE(s.iterate_solved);
  EXPECT_DOUBLE_EQ(s.final_epsilon, 1e-4);
  EXPECT_EQ(s.x, stop.x);
  EXPECT_EQ(s.stages, stop.stages + 1);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back(),
            "scholtes eps 1e-05 (continued: not polished): maximum iterations exceeded after 1 "
            "iterations, stopped");
}

// A relaxed solution's multipliers (MpecSolution::relaxed) warm-start the same stage: it ends
// at once where it started; multipliers of the wrong size are rejected.
TEST(MpecSolver, RelaxedMultipliersWarmStartTheStage) {
  for (const Toy& toy : kToys) {
    MpecSolverOptions o;
    o.polish = false;
    const QuadraticMpec p = toy.make();
    const MpecSolution cold = SolveMpec(p, o);
    ASSERT_TRUE(cold.converged) << toy.name << ": " << cold.reason;
    ASSERT_EQ(cold.relaxed.lambda.size(), p.num_constraints() + p.pairs.size()) << toy.name;
    QuadraticMpec from = p;
    from.x0 = cold.x;
    MpecSolverOptions w = o;
    w.epsilon_start = w.epsilon_end = cold.final_epsilon;
    const MpecSolution warm = SolveMpec(from, w, &cold.relaxed);
    EXPECT_TRUE(warm.converged) << toy.name << ": " << warm.reason;
    EXPECT_EQ(warm.stages, 1);
    EXPECT_LE(warm.iterations, 5) << toy.name << ": " << warm.reason;
    EXPECT_LT((warm.x - cold.x).cwiseAbs().maxCoeff(), 1e-6) << toy.name;
    MpecMultipliers bad = cold.relaxed;
    bad.z_l.conservativeResize(bad.z_l.size() - 1);
    EXPECT_THROW(SolveMpec(from, w, &bad), std::invalid_argument) << toy.name;
  }
}

TEST(MpecSolver, RejectsBadOptionsAndPairs) {
  const QuadraticMpec p = Scholtes3();
  MpecSolverOptions o;
  o.epsilon_factor = 1.5;
  EXPECT_THROW(SolveMpec(p, o), std::invalid_argument);
  MpecSolverOptions b;
  b.biactive_factor = -1;
  EXPECT_THROW(SolveMpec(p, b), std::invalid_argument);
  MpecSolverOptions w;
  w.warm_start_push_per_epsilon = -0.1;
  EXPECT_THROW(SolveMpec(p, w), std::invalid_argument);
  MpecSolverOptions cp;
  cp.cold_bound_push = -0.1;
  EXPECT_THROW(SolveMpec(p, cp), std::invalid_argument);
  MpecSolverOptions c;
  c.continued_max_iterations = -1;
  EXPECT_THROW(SolveMpec(p, c), std::invalid_argument);
  MpecSolverOptions r;
  r.early_polish_rise_factor = -1;
  EXPECT_THROW(SolveMpec(p, r), std::invalid_argument);
  MpecSolverOptions m;
  m.mumps_mem_percent = 0;  // Ipopt would double 0 to 0 when MUMPS runs out of storage
  EXPECT_THROW(SolveMpec(p, m), std::invalid_argument);
  QuadraticMpec q = Scholtes3();
  q.pairs = {{0, 0}};
  EXPECT_THROW(SolveMpec(q, MpecSolverOptions{}), std::invalid_argument);
  EXPECT_THROW(ParseComplementarityMethod("fischer"), std::invalid_argument);
  EXPECT_EQ(ParseComplementarityMethod("penalty"), ComplementarityMethod::kPenalty);
}

// scholtes3 whose Hessian is 1e4 times too large wherever a side of its pair is exactly 0 —
// only at the polish NLP's iterates (the fixed side is 0; a relaxed iterate is interior). Its
// steps are 1e-4 of Newton's: the polish creeps (the error falls by ~1e-4 per iteration), as a
// polish whose model is poor near a wrongly fixed active set does (docs/estimation.md).
class CreepingPolish : public QuadraticMpec {
 public:
  CreepingPolish() : QuadraticMpec(Scholtes3()) {}
  bool HessianValues(const VectorXd& x, double s, const VectorXd& l, VectorXd* v) const override {
    QuadraticMpec::HessianValues(x, s, l, v);
    if (std::min(x[0], x[1]) == 0.0) *v *= 1e4;
    return true;
  }
};

// The symmetric relaxed iterate x1 = x2 = √0.1 (one stage, ε = 0.1) is far from either
// polished optimum, so the polish must move x2 (or x1) by ~0.7 with 1e-4 steps.
MpecSolverOptions OneStage() {
  MpecSolverOptions o;
  o.epsilon_start = 0.1;
  o.epsilon_end = 0.1;
  o.max_iterations = 3000;
  return o;
}

TEST(MpecSolver, CreepingPolishCreepsWithoutTheStallExit) {
  MpecSolverOptions o = OneStage();
  o.polish_stall_iterations = 0;
  o.max_iterations = 1000;
  const MpecSolution s = SolveMpec(CreepingPolish(), o);
  EXPECT_FALSE(s.polished) << s.reason;
  EXPECT_GE(s.iterations, 1000) << s.reason;  // the polish ran to its iteration limit
}

TEST(MpecSolver, StalledPolishStopsEarlyAndIsNotConverged) {
  MpecSolverOptions o = OneStage();
  int stage_iterations = 0;
  {
    MpecSolverOptions relaxed = o;
    relaxed.polish = false;
    stage_iterations = SolveMpec(CreepingPolish(), relaxed).iterations;
  }
  const MpecSolution s = SolveMpec(CreepingPolish(), o);
  EXPECT_FALSE(s.polished);
  EXPECT_FALSE(s.converged) << s.reason;  // the relaxed iterate is far from complementary
  EXPECT_GT(s.complementarity_violation, 0.1);
  EXPECT_NE(s.reason.find("polish: stalled"), std::string::npos) << s.reason;
  // The polish stopped one window (100 iterations) after its best error, not at 3 000.
  EXPECT_LE(s.iterations - stage_iterations, o.polish_stall_iterations + 2) << s.reason;
  EXPECT_GE(s.iterations - stage_iterations, o.polish_stall_iterations) << s.reason;
}

TEST(MpecSolver, StalledEarlyPolishContinuesTheHomotopy) {
  MpecSolverOptions o;  // ε = 0.1 … 1e-8
  o.early_polish_tolerance = 1e-3;
  std::vector<std::string> lines;
  o.progress = [&](const std::string& line) { lines.push_back(line); };
  const MpecSolution s = SolveMpec(CreepingPolish(), o);
  ASSERT_FALSE(lines.empty());
  int stalled_early = 0, stages_after = 0;
  for (const std::string& line : lines) {
    if (line.rfind("early polish: stalled", 0) == 0) ++stalled_early;
    if (stalled_early > 0 && line.rfind("scholtes eps", 0) == 0) ++stages_after;
  }
  EXPECT_EQ(stalled_early, 1);
  EXPECT_EQ(stages_after, 7) << "ε = 1e-2 … 1e-8 after the stalled attempt";
  EXPECT_LT(s.iterations, 1000);
  // Whatever the final polish does, the result is converged only if complementary.
  if (s.converged) {
    EXPECT_LE(s.complementarity_violation, o.complementarity_tolerance);
  }
}

// A biactive limit: min (x − 1)² + (y − 2)² + c w², x − 2y − w = 0, 0 ≤ x ⊥ y ≥ 0, c = 1e6.
// The stiff w term holds the relaxed iterates on the ray x = 2y, so the Scholtes path ends at
// (√(2ε), √(ε/2)), both sides O(√ε): a C-stationary point whose MPEC multipliers are
// ν_x = ∂f/∂x ≈ −2 and ν_y ≈ −4 (the objective falls as either side leaves 0, faster for y).
// The smaller side is y; the multipliers fix x instead and release y.
QuadraticMpec BiactiveRay() {
  QuadraticMpec p;
  p.P = sim::MatrixXd::Zero(3, 3);
  p.P(0, 0) = 2;
  p.P(1, 1) = 2;
  p.P(2, 2) = 2e6;
  p.c = VectorXd(3);
  p.c << -2, -4, 0;
  p.f0 = 5;
  p.A.resize(1, 3);
  p.A << 1, -2, -1;
  p.g_l = VectorXd::Zero(1);
  p.g_u = VectorXd::Zero(1);
  p.x_l = VectorXd(3);
  p.x_l << 0, 0, -kBig;
  p.x_u = VectorXd::Constant(3, kBig);
  p.x0 = VectorXd(3);
  p.x0 << 0.2, 0.1, 0;
  p.pairs = {{0, 1}};
  return p;
}

TEST(MpecSolver, BiactivePairBranchFromTheMultipliers) {
  const QuadraticMpec p = BiactiveRay();
  MpecSolverOptions relaxed;
  relaxed.polish = false;
  const MpecSolution r = SolveMpec(p, relaxed);
  // The relaxed end point is on the ray, both sides ~√ε_end = 1e-4 (not converged: 1e-4 is
  // above the complementarity tolerance, as at the tossed cube's biactive impact pair).
  EXPECT_FALSE(r.converged) << r.reason;
  // x y = ε_end up to Ipopt's relaxation of the row's bound (1e-8 more), x = 2y + w, w ≈ 0.
  EXPECT_NEAR(r.x[0] * r.x[1], 1.5e-8, 0.6e-8);
  EXPECT_NEAR(r.x[0], 2 * r.x[1], 1e-6);

  MpecSolverOptions multipliers;
  multipliers.biactive_factor = 3;
  const MpecSolution s = SolveMpec(p, multipliers);
  ASSERT_TRUE(s.polished) << s.reason;
  EXPECT_TRUE(s.converged) << s.reason;
  EXPECT_EQ(s.biactive_pairs, 1);
  EXPECT_EQ(s.biactive_switched, 1);
  ASSERT_EQ(s.first_at_zero.size(), 1u);
  EXPECT_TRUE(s.first_at_zero[0]) << "x fixed at 0, y released";
  EXPECT_EQ(s.x[0], 0.0);
  EXPECT_GT(s.x[1], 0.0);

  MpecSolverOptions smaller;  // the default rule: the smaller side (y) fixed
  const MpecSolution t = SolveMpec(p, smaller);
  ASSERT_TRUE(t.polished) << t.reason;
  EXPECT_EQ(t.biactive_pairs, 0);
  EXPECT_FALSE(t.first_at_zero[0]);
  EXPECT_EQ(t.x[1], 0.0);
}

}  // namespace
}  // namespace vinci::estimation
