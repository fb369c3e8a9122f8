// Lemke on a sparse LCP matrix (solvers/sparse_lemke.h) against the dense LemkeSolver: random
// P-matrix and contact-like LCPs, the recorded hard LCPs, warm starts, and the box stacks'
// Stewart–Trinkle steps through the sparse path against the dense LCP (issue 16).
#include "vinci/sim/solvers/sparse_lemke.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
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
#include "vinci/sim/solvers/lcp_acceptance.h"
#include "vinci/sim/solvers/lcp_file.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

using SpMat = Eigen::SparseMatrix<double>;

using testing::RandomBandedPLcp;

// A Stewart–Trinkle-like contact LCP: nb bodies in a chain (6 velocities each, W = M⁻¹ SPD
// per body), contact c between bodies c−1 and c (body −1 the ground), nd friction directions,
// z = [p_n; p_f; σ], M = [GᵀWG (n, f blocks), E; U, −Eᵀ, 0] (copositive-plus, degenerate:
// friction directions come in ± pairs). q: approach velocities (some contacts separating).
LcpProblem RandomContactLcp(int nc, int nd, std::mt19937* rng) {
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.2, 1.0);
  const int nv = 6 * nc, nf = nc * nd, m = nc + nf + nc;
  MatrixXd G = MatrixXd::Zero(nv, nc + nf);
  for (int c = 0; c < nc; ++c) {
    VectorXd normal = VectorXd::NullaryExpr(6, [&]() { return g(*rng); });
    VectorXd t1 = VectorXd::NullaryExpr(6, [&]() { return g(*rng); });
    VectorXd t2 = VectorXd::NullaryExpr(6, [&]() { return g(*rng); });
    for (int side = 0; side < 2; ++side) {
      const int body = c - side;
      if (body < 0) continue;
      const double sign = side == 0 ? 1.0 : -1.0;
      G.block(6 * body, c, 6, 1) = sign * normal;
      for (int j = 0; j < nd; ++j) {
        const double angle = 2.0 * M_PI * j / nd;
        G.block(6 * body, nc + c * nd + j, 6, 1) =
            sign * (std::cos(angle) * t1 + std::sin(angle) * t2);
      }
    }
  }
  MatrixXd W = MatrixXd::Zero(nv, nv);
  for (int b = 0; b < nc; ++b) {
    const MatrixXd R = MatrixXd::NullaryExpr(6, 6, [&]() { return g(*rng); });
    W.block(6 * b, 6 * b, 6, 6) = R * R.transpose() / 6.0 + 0.5 * MatrixXd::Identity(6, 6);
  }
  LcpProblem p;
  p.M = MatrixXd::Zero(m, m);
  p.M.topLeftCorner(nc + nf, nc + nf) = G.transpose() * W * G;
  for (int c = 0; c < nc; ++c) {
    for (int j = 0; j < nd; ++j) {
      p.M(nc + c * nd + j, nc + nf + c) = 1.0;
      p.M(nc + nf + c, nc + c * nd + j) = -1.0;
    }
    p.M(nc + nf + c, c) = u(*rng);  // μ
  }
  // Approach velocity ν*: contact velocities Gᵀν* with gravity-like bias on the normals.
  const VectorXd v = VectorXd::NullaryExpr(nv, [&]() { return 0.3 * g(*rng); });
  p.q = VectorXd::Zero(m);
  p.q.head(nc + nf) = G.transpose() * v;
  for (int c = 0; c < nc; ++c) p.q(c) -= 1.0;
  return p;
}

SpMat Sparse(const MatrixXd& M) { return M.sparseView(); }

// The unique solution of random P-matrix LCPs: sparse Lemke (cold and warm-started from a
// perturbed problem's solution) gives dense Lemke's z.
TEST(SparseLemkeTest, RandomPMatrixMatchesDenseLemke) {
  std::mt19937 rng(11);
  const LemkeSolver dense;
  int checked = 0, warm_pivots = 0, cold_pivots = 0;
  for (int n : {20, 70, 150, 300}) {
    for (int trial = 0; trial < 4; ++trial) {
      const LcpProblem p = RandomBandedPLcp(n, &rng);
      VectorXd z_dense;
      ASSERT_TRUE(dense.Solve(p, nullptr, &z_dense).ok());
      const SpMat Ms = Sparse(p.M);
      VectorXd z;
      const SolverReport cold = SolveSparseLemke(Ms, p.q, nullptr, dense.options(), &z);
      ASSERT_TRUE(cold.ok()) << cold.message;
      EXPECT_LE(cold.residual, cold.tolerance);
      EXPECT_TRUE(CheckLcpSolution(p, z).empty());
      // Unique solution: the same z up to roundoff.
      EXPECT_LE((z - z_dense).lpNorm<Eigen::Infinity>(), 1e-9 * (1.0 + z_dense.norm()))
          << "n = " << n << " trial " << trial;
      // Warm start from the solution of a perturbed q (a neighbouring step): fewer pivots.
      LcpProblem p2 = p;
      p2.q += 0.05 * VectorXd::NullaryExpr(n, [&]() { return std::normal_distribution<>()(rng); });
      VectorXd z2_dense, z2;
      ASSERT_TRUE(dense.Solve(p2, nullptr, &z2_dense).ok());
      const SolverReport warm = SolveSparseLemke(Ms, p2.q, &z, dense.options(), &z2);
      ASSERT_TRUE(warm.ok()) << warm.message;
      EXPECT_LE((z2 - z2_dense).lpNorm<Eigen::Infinity>(), 1e-9 * (1.0 + z2_dense.norm()));
      VectorXd z2_cold;
      const SolverReport cold2 = SolveSparseLemke(Ms, p2.q, nullptr, dense.options(), &z2_cold);
      ASSERT_TRUE(cold2.ok());
      warm_pivots += warm.iterations;
      cold_pivots += cold2.iterations;
      // The exact solution as warm start: no pivots.
      VectorXd z3;
      const SolverReport exact = SolveSparseLemke(Ms, p.q, &z, dense.options(), &z3);
      ASSERT_TRUE(exact.ok());
      EXPECT_EQ(exact.iterations, 0);
      EXPECT_LE((z3 - z_dense).lpNorm<Eigen::Infinity>(), 1e-9 * (1.0 + z_dense.norm()));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 16);
  // A neighbouring problem's basis saves most of a cold start's pivots.
  EXPECT_LT(warm_pivots, cold_pivots / 2);
}

// Contact-like (copositive-plus, degenerate) LCPs: the solution need not be unique, so the
// sparse solution is checked by the acceptance tests, and against the dense solver's z where
// both pivot from the same start by the same rules.
TEST(SparseLemkeTest, ContactLikeLcpsSolveAsDenseLemke) {
  std::mt19937 rng(5);
  const LemkeSolver dense;
  int checked = 0, same = 0;
  for (int nc : {12, 30, 60}) {
    for (int trial = 0; trial < 4; ++trial) {
      const LcpProblem p = RandomContactLcp(nc, 4, &rng);
      VectorXd z_dense;
      const SolverReport rd = dense.Solve(p, nullptr, &z_dense);
      ASSERT_TRUE(rd.ok()) << rd.message;
      VectorXd z;
      const SolverReport rs = SolveSparseLemke(Sparse(p.M), p.q, nullptr, dense.options(), &z);
      ASSERT_TRUE(rs.ok()) << "nc = " << nc << ": " << rs.message;
      EXPECT_LE(LcpResidual(p, z), rs.tolerance);
      EXPECT_TRUE(CheckLcpSolution(p, z).empty());
      const int nf = nc * 4;
      // Cold, the sparse variant pivots by the dense solver's rules from the same start: the same
      // z unless roundoff resolves a tie differently.
      if ((z - z_dense).lpNorm<Eigen::Infinity>() <= 1e-8 * (1.0 + z_dense.norm())) ++same;
      // Warm-started from the dense solution of a perturbed problem.
      LcpProblem p2 = p;
      p2.q.head(nc + nf) += 0.02 * VectorXd::NullaryExpr(nc + nf, [&]() {
                              return std::normal_distribution<>()(rng);
                            });
      VectorXd z2;
      const SolverReport r2 = SolveSparseLemke(Sparse(p2.M), p2.q, &z_dense, dense.options(), &z2);
      ASSERT_TRUE(r2.ok()) << r2.message;
      EXPECT_TRUE(CheckLcpSolution(p2, z2).empty());
      ++checked;
    }
  }
  EXPECT_EQ(checked, 12);
  EXPECT_GE(same, 9);
}

// The recorded hard LCPs (degenerate box stacks and piles, a sliding box, the feeder): where
// plain Lemke solves them (no polish, retry or Newton fallback in the dense report), so does the
// sparse variant, to the same acceptance tests.
TEST(SparseLemkeTest, RecordedLcps) {
  const LemkeSolver dense;
  int solved = 0, plain = 0;
  for (const char* name :
       {"box_pile_step0", "box_pile_tilted_cold_step232", "box_pile_tilted_step216",
        "box_pile_tilted_step233", "box_stack_cold_step1410", "box_stack_cold_step425",
        "box_stack_cold_step7724", "feeder_deep_penetration_step110", "feeder_tumbling_step107",
        "incline_sliding_step9744"}) {
    const LcpProblem p =
        ReadLcpFile(std::string(VINCI_SOURCE_DIR "/tests/data/lcp/") + name + ".lcp");
    VectorXd z_dense;
    const SolverReport rd = dense.Solve(p, nullptr, &z_dense);
    VectorXd z;
    const SolverReport rs = SolveSparseLemke(Sparse(p.M), p.q, nullptr, dense.options(), &z);
    const bool dense_plain = rd.ok() && rd.message.empty();
    if (dense_plain) {
      ++plain;
      EXPECT_TRUE(rs.ok()) << name << ": " << rs.message;
    }
    if (rs.ok()) {
      ++solved;
      EXPECT_LE(LcpResidual(p, z), rs.tolerance) << name;
      EXPECT_TRUE(CheckLcpSolution(p, z).empty()) << name;
    } else {
      EXPECT_NE(rs.message, "") << name;  // a failure says why
    }
  }
  EXPECT_GE(plain, 3);  // 4 of the 10 need no polish or fallback in the dense solver
  EXPECT_GE(solved, plain);
}

TEST(SparseLemkeTest, TrivialInvalidAndInfeasible) {
  const LemkeOptions options;
  VectorXd z;
  const SpMat I = Sparse(MatrixXd::Identity(3, 3));
  // q ≥ 0: z = 0, no pivots.
  SolverReport r = SolveSparseLemke(I, Eigen::Vector3d(1, 0, 2), nullptr, options, &z);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(z, Eigen::Vector3d::Zero());
  // M = I, q = (−1, 2, −3): z = (1, 0, 3).
  r = SolveSparseLemke(I, Eigen::Vector3d(-1, 2, -3), nullptr, options, &z);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(z[0], 1.0, 1e-15);
  EXPECT_EQ(z[1], 0.0);
  EXPECT_NEAR(z[2], 3.0, 1e-15);
  // Infeasible: M = −I, q = −1 (w = −z − 1 < 0 for every z ≥ 0): fails, says why.
  r = SolveSparseLemke(Sparse(-MatrixXd::Identity(2, 2)), Eigen::Vector2d(-1, -1), nullptr, options,
                       &z);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message.find("secondary ray"), std::string::npos) << r.message;
  // Wrong size, non-finite data: kInvalidInput; bad options and a null z throw.
  r = SolveSparseLemke(I, Eigen::Vector2d(-1, 1), nullptr, options, &z);
  EXPECT_EQ(r.status, SolverStatus::kInvalidInput);
  r = SolveSparseLemke(I, Eigen::Vector3d(-1, std::nan(""), 1), nullptr, options, &z);
  EXPECT_EQ(r.status, SolverStatus::kInvalidInput);
  LemkeOptions bad;
  bad.pivot_tolerance = -1.0;
  EXPECT_THROW(SolveSparseLemke(I, Eigen::Vector3d(-1, 1, 1), nullptr, bad, &z),
               std::invalid_argument);
  EXPECT_THROW(SolveSparseLemke(I, Eigen::Vector3d(-1, 1, 1), nullptr, options, nullptr),
               std::invalid_argument);
}

// SparseLcpScaledResidual is LcpScaledResidual.
TEST(SparseLemkeTest, SparseScaledResidualMatchesDense) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const LcpProblem p = RandomContactLcp(8, 4, &rng);
    const VectorXd z = VectorXd::NullaryExpr(
        p.size(), [&]() { return std::max(0.0, std::normal_distribution<>()(rng)); });
    const double dense = LcpScaledResidual(p, z);
    EXPECT_NEAR(SparseLcpScaledResidual(Sparse(p.M), p.q, z), dense, 1e-12 * (1.0 + dense));
  }
}

// The Stewart–Trinkle LCP (nd = 4, μ = 0.6, h = 1 ms, gravity) of five 0.2 m unit-mass cubes at
// rest: four on the floor in a 2 × 2 block, one centred on top of them (four corners of a
// quadrant on each), all turned by a generic rotation so that exact linear dependences are
// broken by round-off only. 32 contacts, 32 normal columns of rank 15: every set of loaded
// normals of a pair is independent (rank 3 for 4 coplanar corners only when all 4 are loaded),
// globally they are not.
LcpProblem RestingPyramidLcp() {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()) *
                             Eigen::AngleAxisd(0.7, Eigen::Vector3d(-2, 1, 0.5).normalized()))
                                .toRotationMatrix();
  const Eigen::Vector3d n = R.col(2), t1 = R.col(0), t2 = R.col(1);
  std::vector<Eigen::Vector3d> centers;
  for (int i = 0; i < 4; ++i)
    centers.push_back(R * Eigen::Vector3d(i % 2 ? 0.1 : -0.1, i / 2 ? 0.1 : -0.1, 0.1));
  centers.push_back(R * Eigen::Vector3d(0.0, 0.0, 0.3));
  // Contacts (body above, body below or −1 for the floor, point).
  struct Contact {
    int above, below;
    Eigen::Vector3d p;
  };
  std::vector<Contact> contacts;
  for (int i = 0; i < 4; ++i)
    for (double sx : {-0.1, 0.1})
      for (double sy : {-0.1, 0.1})
        contacts.push_back({i, -1, centers[i] + R * Eigen::Vector3d(sx, sy, -0.1)});
  for (int i = 0; i < 4; ++i)
    for (double fx : {0.0, 1.0})
      for (double fy : {0.0, 1.0})
        contacts.push_back(
            {4, i, R * Eigen::Vector3d(fx * (i % 2 ? 0.1 : -0.1), fy * (i / 2 ? 0.1 : -0.1), 0.2)});
  const int nc = static_cast<int>(contacts.size()), nd = 4, nf = nc * nd, nv = 30;
  MatrixXd G = MatrixXd::Zero(nv, nc + nf);
  const auto column = [&](int c, int col, const Eigen::Vector3d& dir) {
    const Contact& k = contacts[c];
    G.block<3, 1>(6 * k.above, col) += dir;
    G.block<3, 1>(6 * k.above + 3, col) += (k.p - centers[k.above]).cross(dir);
    if (k.below >= 0) {
      G.block<3, 1>(6 * k.below, col) -= dir;
      G.block<3, 1>(6 * k.below + 3, col) -= (k.p - centers[k.below]).cross(dir);
    }
  };
  for (int c = 0; c < nc; ++c) {
    column(c, c, n);
    for (int j = 0; j < nd; ++j) {
      const double phi = 2.0 * M_PI * j / nd;
      column(c, nc + c * nd + j, std::cos(phi) * t1 + std::sin(phi) * t2);
    }
  }
  // W = M⁻¹ per cube: 1/m and (a²/6 · m)⁻¹ (any orientation).
  VectorXd w(nv);
  for (int b = 0; b < 5; ++b) w.segment(6 * b, 6) << 1, 1, 1, 150, 150, 150;
  const double h = 1e-3, g = 9.81, mu = 0.6;
  LcpProblem p;
  const int m = nc + nf + nc;
  p.M = MatrixXd::Zero(m, m);
  p.M.topLeftCorner(nc + nf, nc + nf) = G.transpose() * w.asDiagonal() * G;
  for (int c = 0; c < nc; ++c) {
    for (int j = 0; j < nd; ++j) {
      p.M(nc + c * nd + j, nc + nf + c) = 1.0;
      p.M(nc + nf + c, nc + c * nd + j) = -1.0;
    }
    p.M(nc + nf + c, c) = mu;
  }
  VectorXd v_star = VectorXd::Zero(nv);
  for (int b = 0; b < 5; ++b) v_star.segment<3>(6 * b) = -h * g * n;
  p.q = VectorXd::Zero(m);
  p.q.head(nc + nf) = G.transpose() * v_star;
  return p;
}

// A warm start whose basis is singular (every normal of the resting pyramid loaded, as a spread
// of its statically indeterminate impulses leaves them; the 100-box pile dropped with 1 mm gaps
// failed its step 20 on such a basis: basic values of 1e2, a first pivot on 6e16, then a cold run
// of 6573 pivots ending on a secondary ray): the solver drops the dependent normals from the
// basis and pivots from the rest, in fewer pivots than a cold start, to an accepted solution.
TEST(SparseLemkeTest, SingularWarmBasisIsRepaired) {
  const LcpProblem p = RestingPyramidLcp();
  const SpMat Ms = Sparse(p.M);
  const int nc = 32;
  // The normal block's rank: 3 per cube.
  Eigen::JacobiSVD<MatrixXd> svd(p.M.topLeftCorner(nc, nc));
  int rank = 0;
  for (Eigen::Index i = 0; i < svd.singularValues().size(); ++i)
    rank += svd.singularValues()(i) > 1e-10 * svd.singularValues()(0);
  ASSERT_EQ(rank, 15);
  const LemkeOptions options;
  VectorXd z_cold;
  const SolverReport cold = SolveSparseLemke(Ms, p.q, nullptr, options, &z_cold);
  ASSERT_TRUE(cold.ok()) << cold.message;
  VectorXd warm = VectorXd::Zero(p.size());
  warm.head(nc).setConstant(0.25 * 9.81e-3);
  VectorXd z;
  const SolverReport r = SolveSparseLemke(Ms, p.q, &warm, options, &z);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.message.rfind("pivoted from the warm-start basis", 0), 0u) << r.message;
  EXPECT_LT(r.iterations, cold.iterations);
  EXPECT_TRUE(CheckLcpSolution(p, z).empty());
  // Resting: the normal impulses carry the weight (5 m g h along n; friction not needed).
  EXPECT_NEAR(z.head(16).sum(), 5 * 9.81e-3, 1e-12);
}

// A k-box stack of 0.2 m cubes on a floor (4 friction directions), dropped from rest with 5 mm
// gaps between the cubes (impacts: the active set changes while it settles).
Scene Stack(int k) {
  const Scene scene = ParseScene(bench::StackYaml(k, 6, 0.005), "stack");
  return scene.ApplyParams(scene.DefaultParams());
}

// Lemke under another type: the Stewart–Trinkle step then always solves the dense LCP.
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

// The settling k-box stacks (LCP size 24 k > kSparseLemkeMinSize): step by step from the dense
// trajectory, the step through the sparse path (warm basis, else sparse Lemke) gives the dense
// LCP's velocities to solver tolerance; the steps whose basis changed pivot from the warm
// basis with few pivots.
TEST(SparseLemkeTest, BoxStackStepsMatchDenseLcp) {
  for (int k : {5, 20}) {
    const Scene model = Stack(k);
    const StewartTrinkle sparse(model.options, std::make_shared<LemkeSolver>());
    const StewartTrinkle dense(model.options, std::make_shared<DenseLemke>());
    State x = Simulator(model).InitialState();
    Workspace ws_a, ws_b;
    double worst = 0.0;
    int pivoted = 0, pivots = 0;
    for (int step = 0; step < 200; ++step) {
      State a, b;
      StepInfo ia, ib;
      sparse.Step(model, x, StepInput{}, &ws_a, &a, &ia);
      dense.Step(model, x, StepInput{}, &ws_b, &b, &ib);
      ASSERT_TRUE(ia.ok) << ia.failure;
      ASSERT_TRUE(ib.ok) << ib.failure;
      worst = std::max(worst, (a.v - b.v).lpNorm<Eigen::Infinity>());
      if (ia.solver.iterations > 0 && x.warm_start.size() == a.warm_start.size()) {
        ++pivoted;
        pivots += ia.solver.iterations;
      }
      x = std::move(b);
    }
    EXPECT_LT(worst, 1e-8) << k << "-box stack";
    EXPECT_GT(pivoted, 0) << k;
  }
}

}  // namespace
}  // namespace vinci::sim
