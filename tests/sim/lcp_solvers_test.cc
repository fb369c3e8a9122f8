// Cross-solver tests: the registry by name, agreement of Lemke, block PGS and FB Newton on
// well-posed LCPs (same z where it is unique, same contact velocities on the degenerate
// Stewart–Trinkle LCP), and each solver driving the simulator on a resting box.
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_util.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/fischer_burmeister.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/pgs.h"

namespace vinci::sim {
namespace {

// The loosest default tolerance of the three solvers (Lemke and PGS 1e-9, FB 1e-10).
constexpr double kTol = 1e-9;

LcpProblem Make(const MatrixXd& M, const VectorXd& q) { return LcpProblem{M, q}; }

// Symmetric positive definite M (eigenvalues ≥ 0.5): unique solution, and PGS converges.
LcpProblem RandomSpdLcp(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatrixXd A(n, n);
  VectorXd q(n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) A(i, j) = u(*rng);
  }
  for (int i = 0; i < n; ++i) q(i) = u(*rng);
  return Make(A * A.transpose() / n + 0.5 * MatrixXd::Identity(n, n), q);
}

std::vector<std::shared_ptr<const LcpSolver>> AllSolvers() {
  std::vector<std::shared_ptr<const LcpSolver>> s;
  for (const std::string& name : LcpSolverNames()) s.push_back(MakeLcpSolver(name));
  return s;
}

TEST(LcpSolversTest, RegistryNamesConstruct) {
  const std::vector<std::string> names = LcpSolverNames();
  EXPECT_EQ(names, (std::vector<std::string>{"lemke", "pgs", "fb-newton"}));
  for (const std::string& name : names) {
    const std::shared_ptr<const LcpSolver> solver = MakeLcpSolver(name);
    ASSERT_NE(solver, nullptr) << name;
    EXPECT_EQ(solver->name(), name);
  }
  EXPECT_NE(dynamic_cast<const PgsSolver*>(MakeLcpSolver("pgs").get()), nullptr);
  EXPECT_NE(dynamic_cast<const FischerBurmeisterSolver*>(MakeLcpSolver("fb-newton").get()),
            nullptr);
}

TEST(LcpSolversTest, UnknownNameThrowsListingTheNames) {
  try {
    MakeLcpSolver("path");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("'path'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("lemke, pgs, fb-newton"), std::string::npos) << msg;
  }
}

// Unique solutions: all three return the same z (and hence the same w).
TEST(LcpSolversTest, AgreeOnRandomSpdProblems) {
  std::mt19937 rng(424242);
  for (int n : {10, 50}) {
    for (int trial = 0; trial < 2; ++trial) {
      const LcpProblem p = RandomSpdLcp(n, &rng);
      VectorXd z_ref;
      for (const auto& solver : AllSolvers()) {
        VectorXd z;
        const SolverReport r = solver->Solve(p, nullptr, &z);
        ASSERT_TRUE(r.ok()) << solver->name() << ", n = " << n << ": " << r.message;
        EXPECT_EQ(r.residual, LcpResidual(p, z)) << solver->name();
        EXPECT_LE(LcpResidual(p, z), kTol) << solver->name();
        EXPECT_GE(z.minCoeff(), 0.0) << solver->name();
        if (z_ref.size() == 0) {
          z_ref = z;
          continue;
        }
        // Smallest eigenvalue ≥ 0.5: a residual of 1e-9 moves z by a few 1e-9.
        EXPECT_LE((z - z_ref).lpNorm<Eigen::Infinity>(), 1e-8) << solver->name();
        EXPECT_LE((p.M * (z - z_ref)).lpNorm<Eigen::Infinity>(), 1e-7) << solver->name();
      }
    }
  }
}

// The box-on-plane Stewart–Trinkle LCP is degenerate (4 normal impulses for 3 supported
// directions, opposite friction directions): z is not unique, but the step velocity is.
TEST(LcpSolversTest, AgreeOnStewartTrinkleStepVelocity) {
  for (const char* scene : {"box_on_plane.yaml", "block_sliding.yaml", "sphere_on_incline.yaml"}) {
    Simulator sim(testing::LoadExample(scene));
    State x = sim.InitialState();
    Workspace ws;
    for (int k = 0; k < 5; ++k) {
      State next;
      ASSERT_TRUE(sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next).ok) << scene;
      x = next;
    }
    const auto& st = dynamic_cast<const StewartTrinkle&>(sim.formulation());
    const StewartTrinkle::Assembly a = st.Assemble(sim.scene(), x, StepInput{});
    VectorXd v_star;
    StewartTrinkle::JointElimination joints;
    const LcpProblem lcp = st.BuildLcp(sim.scene(), a, x.v, &v_star, &joints);
    ASSERT_GT(lcp.size(), 0) << scene;
    const int nc = static_cast<int>(a.contacts.size()), nf = nc * a.nd;
    VectorXd v_ref, w_ref;
    for (const auto& solver : AllSolvers()) {
      VectorXd z;
      const SolverReport r = solver->Solve(lcp, nullptr, &z);
      ASSERT_TRUE(r.ok()) << scene << ", " << solver->name() << ": " << r.message;
      EXPECT_LE(LcpResidual(lcp, z), kTol * std::max(1.0, lcp.q.lpNorm<Eigen::Infinity>()));
      const VectorXd v = st.VelocityAfter(a, v_star, z, joints);
      // Contact-velocity rows of w (normal: G_nᵀν + ψ/h; friction: G_fᵀν + Eσ).
      const VectorXd w = (lcp.M * z + lcp.q).head(nc + nf);
      if (v_ref.size() == 0) {
        v_ref = v;
        w_ref = w;
        continue;
      }
      // Residuals of ≤ 1e-9 on ~1 kg bodies of ~0.1 m: velocities agree to ~1e-8.
      EXPECT_LE((v - v_ref).lpNorm<Eigen::Infinity>(), 1e-7) << scene << ", " << solver->name();
      EXPECT_LE((w.head(nc) - w_ref.head(nc)).lpNorm<Eigen::Infinity>(), 1e-7)
          << scene << ", " << solver->name();
    }
  }
}

// Each solver, selected through the scene, keeps the box at rest: no drift over 1000 steps.
TEST(LcpSolversTest, RestingBoxDoesNotDriftWithEverySolver) {
  for (const std::string& name : LcpSolverNames()) {
    Scene scene = testing::LoadExample("box_on_plane.yaml");
    scene.options.solver = name;
    Simulator sim(std::move(scene));
    const State x0 = sim.InitialState();
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 1000);
    ASSERT_TRUE(tr.ok) << name << ": " << tr.failure;
    ASSERT_EQ(tr.states.size(), 1001u);
    const int o = sim.scene().index(sim.scene().FindBody("box")).q;
    const double drift = (tr.states.back().q.segment<3>(o) - x0.q.segment<3>(o)).norm();
    EXPECT_LT(drift, 1e-6) << name;
    for (const StepInfo& s : tr.steps) {
      ASSERT_EQ(s.contacts, 4) << name;
      ASSERT_TRUE(s.solver.ok()) << name;
      EXPECT_GT(s.min_gap, -1e-6) << name;
    }
  }
}

}  // namespace
}  // namespace vinci::sim
