// 2.5D support friction (docs/formulations.md §6): static load distributions, the tilted-plane
// slider with the Stewart–Trinkle stepper, scene-file syntax and the Evaluate() face.
#include "vinci/sim/model/support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Static fractions come from a dual Newton solve to 1e-14 (support.cc).
constexpr double kFractionTol = 1e-10;

std::vector<Vector3d> Points(std::initializer_list<std::pair<double, double>> xy) {
  std::vector<Vector3d> p;
  for (const auto& [x, y] : xy) p.push_back(Vector3d(x, y, 0.0));
  return p;
}

TEST(SupportFractions, ThreePointsAreStaticallyDeterminate) {
  // Triangle (−1, −1), (2, −1), (−1, 2): the origin is its centroid → equal shares.
  const auto f = ComputeSupportFractions(Points({{-1, -1}, {2, -1}, {-1, 2}}), "t");
  for (double x : f) EXPECT_NEAR(x, 1.0 / 3.0, kFractionTol);
  // Points (1, 0), (−1, 1), (−1, −1): moment balance gives f = (1/2, 1/4, 1/4).
  const auto g = ComputeSupportFractions(Points({{1, 0}, {-1, 1}, {-1, -1}}), "t");
  EXPECT_NEAR(g[0], 0.5, kFractionTol);
  EXPECT_NEAR(g[1], 0.25, kFractionTol);
  EXPECT_NEAR(g[2], 0.25, kFractionTol);
}

TEST(SupportFractions, MoreThanThreePointsUseTheMinimumNormDistribution) {
  // Rectangle corners: by symmetry the minimum-norm balanced distribution is uniform.
  const auto f = ComputeSupportFractions(Points({{-2, -1}, {2, -1}, {2, 1}, {-2, 1}}), "t");
  for (double x : f) EXPECT_NEAR(x, 0.25, kFractionTol);
  // Collinear points through the origin: (−1, 0), (1, 0), (3, 0). Minimum norm with
  // f1 + f2 + f3 = 1, −f1 + f2 + 3 f3 = 0 → f = (7/12, 1/3, 1/12); check balance and sign.
  const auto g = ComputeSupportFractions(Points({{-1, 0}, {1, 0}, {3, 0}}), "t");
  EXPECT_NEAR(g[0] + g[1] + g[2], 1.0, kFractionTol);
  EXPECT_NEAR(-g[0] + g[1] + 3 * g[2], 0.0, kFractionTol);
  EXPECT_NEAR(g[0], 7.0 / 12.0, kFractionTol);
  EXPECT_NEAR(g[2], 1.0 / 12.0, kFractionTol);
}

// The minimum-norm distribution with f ≥ 0 against an independent solve of its KKT conditions as
// a mixed complementarity problem (McpSolver), on point sets where some f_k = 0 at the optimum.
TEST(SupportFractions, MinimumNormWithActiveBoundsMatchesTheKktSolution) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int with_zero = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 4 + trial % 5;
    std::vector<Vector3d> p;
    for (int k = 0; k < n; ++k) p.push_back(Vector3d(u(rng), u(rng), 0.0));
    p.push_back(Vector3d(4.0 + u(rng), 0.1 * u(rng), 0.0));  // a far point: often unloaded
    const int m = static_cast<int>(p.size());
    MatrixXd A(3, m);
    for (int k = 0; k < m; ++k) A.col(k) << 1.0, p[k].x(), p[k].y();
    McpProblem mcp;
    const double inf = std::numeric_limits<double>::infinity();
    mcp.lower = VectorXd::Zero(m + 3);
    mcp.lower.tail(3).setConstant(-inf);
    mcp.upper = VectorXd::Constant(m + 3, inf);
    MatrixXd J = MatrixXd::Zero(m + 3, m + 3);
    J.topLeftCorner(m, m).setIdentity();
    J.topRightCorner(m, 3) = -A.transpose();
    J.bottomLeftCorner(3, m) = A;
    VectorXd c = VectorXd::Zero(m + 3);
    c[m] = -1.0;
    mcp.evaluate = [J, c](const VectorXd& z, VectorXd* F, MatrixXd* Jz) {
      *F = J * z + c;
      if (Jz) *Jz = J;
    };
    VectorXd z = VectorXd::Zero(m + 3);
    z.head(m).setConstant(1.0 / m);
    McpOptions options;
    options.tolerance = 1e-13;
    std::vector<double> f;
    try {
      f = ComputeSupportFractions(p, "t");
    } catch (const std::invalid_argument&) {
      // Centre outside the hull: the KKT system must have no solution either.
      EXPECT_FALSE(McpSolver(options).Solve(mcp, &z).ok()) << "trial " << trial;
      continue;
    }
    ASSERT_TRUE(McpSolver(options).Solve(mcp, &z).ok()) << "trial " << trial;
    for (int k = 0; k < m; ++k) {
      EXPECT_GE(f[k], 0.0);
      EXPECT_NEAR(f[k], std::max(0.0, z[k]), 1e-9) << "trial " << trial << " point " << k;
      if (f[k] == 0.0) ++with_zero;
    }
  }
  EXPECT_GT(with_zero, 0);  // the bound f ≥ 0 was active somewhere
}

TEST(SupportFractions, CentreOutsideTheSupportHullThrows) {
  EXPECT_THROW(
      {
        try {
          ComputeSupportFractions(Points({{1, 0}, {2, 0}, {1, 1}}), "body 'b'");
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("outside their convex hull"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
}

// A square slider on a plane tilted by `tilt`, supports at its four corners (static loads).
std::string SliderScene(double tilt, double mu_s, const std::string& formulation = "", int nd = 8) {
  return "dimension: 2\nplane: {tilt: " + std::to_string(tilt) + ", g: 9.81}\nstepper: {dt: 0.01" +
         (formulation.empty() ? "" : ", formulation: " + formulation) +
         "}\nbodies:\n"
         "  - name: slider\n"
         "    mass: 2.0\n"
         "    shapes: [{type: polygon, vertices: [[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], "
         "[-0.1, 0.1]]}]\n"
         "    support: {points: [[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]], "
         "normal_forces: static, mu: " +
         std::to_string(mu_s) + ", directions: " + std::to_string(nd) + "}\n";
}

TEST(SupportSceneFile, ParsesSupportsAndPlane) {
  const Scene s = ParseScene(SliderScene(0.3, 0.4));
  EXPECT_NEAR(s.plane.tilt, 0.3, 1e-12);
  EXPECT_NEAR(s.gravity_W.y(), -9.81 * std::sin(0.3), 1e-12);
  const Body& b = s.bodies[0];
  ASSERT_EQ(b.support.points_B.size(), 4u);
  EXPECT_TRUE(b.support.static_distribution);
  const std::vector<double> N = SupportNormalForces(s, b);
  for (double n : N) EXPECT_NEAR(n, 2.0 * 9.81 * std::cos(0.3) / 4, 1e-9);
  // Explicit forces.
  const Scene t = ParseScene(
      "dimension: 2\nplane: {}\nbodies:\n  - name: b\n    mass: 1\n    inertia: 0.1\n"
      "    support: {points: [[0, 0], [1, 0]], normal_forces: [2, 3], mu: 0.2}\n");
  EXPECT_EQ(SupportNormalForces(t, t.bodies[0]), (std::vector<double>{2.0, 3.0}));
}

TEST(SupportSceneFile, RejectsBadSupports) {
  const auto expect_error = [](const std::string& text, const std::string& fragment) {
    try {
      ParseScene(text, "s.yaml");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  const std::string head =
      "dimension: 2\nplane: {}\nbodies:\n  - name: b\n    mass: 1\n"
      "    inertia: 0.1\n";
  expect_error(head + "    support: {points: [[0, 0]], normal_forces: [1, 2]}\n",
               "bodies[0].support.normal_forces: expected a list of 1 numbers");
  expect_error(head + "    support: {points: [[0, 0]], directions: 2}\n", "an integer >= 3");
  expect_error(head + "    support: {points: [[0, 0]], mu: -1}\n", "support.mu");
  expect_error(head + "    support: {points: [[1, 0], [2, 0]]}\n", "outside their convex hull");
  expect_error(
      "dimension: 2\nbodies:\n  - name: b\n    mass: 1\n    inertia: 0.1\n"
      "    support: {points: [[0, 0]]}\n",
      "a support without 'plane'");
  expect_error(
      "dimension: 2\ngravity: [0, 0]\nplane: {}\nbodies:\n  - name: b\n    mass: 1\n"
      "    inertia: 0.1\n",
      "no gravity together with 'plane'");
  expect_error(
      "dimension: 2\nplane: {}\nbodies:\n  - {name: b, kind: static, support: {points: "
      "[[0, 0]]}}\n",
      "no 'support' on a static body");
}

// Relative accuracy of the sliding acceleration: the linearized disk contains the downhill
// direction exactly (n_d = 8), so only rounding remains.
constexpr double kAccelRelTol = 1e-6;

TEST(SupportTiltedPlane, SliderSticksIffMuAtLeastTanTilt) {
  const double tilt = 0.3;  // tan = 0.3093
  for (double mu_s : {0.32, 0.5, 1.0}) {
    Simulator sim(ParseScene(SliderScene(tilt, mu_s)));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 100);
    ASSERT_TRUE(tr.ok) << tr.failure;
    // Sticking: the support friction holds the slider exactly (to LCP rounding).
    EXPECT_LT(tr.states.back().v.norm(), 1e-12) << "mu_s " << mu_s;
    EXPECT_LT(tr.states.back().q.norm(), 1e-12) << "mu_s " << mu_s;
  }
}

TEST(SupportTiltedPlane, SlidingAccelerationIsGTimesSinMinusMuCos) {
  const double g = 9.81;
  for (double tilt : {0.3, 0.6}) {
    for (double mu_s : {0.0, 0.1, 0.25}) {
      Simulator sim(ParseScene(SliderScene(tilt, mu_s)));
      const int steps = 50;
      const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
      ASSERT_TRUE(tr.ok) << tr.failure;
      const double expected = g * (std::sin(tilt) - mu_s * std::cos(tilt));
      const VectorXd& v = tr.states.back().v;
      const double a = -v.y() / (steps * 0.01);
      EXPECT_NEAR(a, expected, kAccelRelTol * expected) << "tilt " << tilt << " mu " << mu_s;
      EXPECT_NEAR(v.x(), 0.0, 1e-12);
      EXPECT_NEAR(v.z(), 0.0, 1e-12);  // symmetric loads: no spin
    }
  }
}

TEST(SupportTiltedPlane, ExactDiskStepperMatchesTheClosedForm) {
  const double g = 9.81, tilt = 0.6;
  for (double mu_s : {0.1, 0.25, 0.7}) {  // sliding, sliding, sticking (tan 0.6 = 0.684)
    Simulator sim(ParseScene(SliderScene(tilt, mu_s, "dynamic-dqc")));
    const int steps = 50;
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const double expected = std::max(0.0, g * (std::sin(tilt) - mu_s * std::cos(tilt)));
    const double a = -tr.states.back().v.y() / (steps * 0.01);
    EXPECT_NEAR(a, expected, kAccelRelTol * std::max(expected, 1.0)) << "mu " << mu_s;
  }
}

// A slider launched on a level table in a direction between the linearized disk's directions:
// the exact disk decelerates it at μ_s g along a straight line; the n_d = 8 polygon bends it.
TEST(SupportLevelTable, ExactDiskKeepsTheSlidingDirection) {
  const double g = 9.81, mu_s = 0.3, phi = 0.3, speed = 1.0;  // φ not a multiple of 2π/8
  for (const std::string formulation : {"dynamic-dqc", "stewart-trinkle"}) {
    Scene scene = ParseScene(SliderScene(0.0, mu_s, formulation));
    scene.bodies[0].v0_W = Vector3d(speed * std::cos(phi), speed * std::sin(phi), 0.0);
    Simulator sim(scene);
    const int steps = 20;  // 0.2 s < stopping time 1/(μ g) = 0.34 s
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const VectorXd& v = tr.states.back().v;
    const double direction_error = std::abs(std::atan2(v.y(), v.x()) - phi);
    if (formulation == "dynamic-dqc") {
      // Exact disk: the MCP tolerance (1e-10) only.
      EXPECT_LT(direction_error, 1e-9);
      EXPECT_NEAR(v.head<2>().norm(), speed - mu_s * g * steps * 0.01, 1e-8);
      EXPECT_NEAR(v.z(), 0.0, 1e-9);
    } else {
      // Linearized: friction along a polygon vertex, not against the velocity.
      EXPECT_GT(direction_error, 1e-2);
    }
  }
}

// Step equations hold at the simulated step (the estimator's constraints).
constexpr double kResidualTol = 1e-9;

TEST(SupportEvaluate, SimulatedStepSatisfiesTheStepEquations) {
  for (double mu_s : {0.1, 0.5}) {  // sliding and sticking
    Simulator sim(ParseScene(SliderScene(0.3, mu_s)));
    State x = sim.InitialState();
    x.v << 0.3, -0.2, 1.0;  // slip in an arbitrary direction, with spin
    Workspace ws;
    State next;
    const StepInfo info = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << info.failure;
    const Formulation& f = sim.formulation();
    const StepLayout l = f.Layout(sim.scene(), x);
    EXPECT_EQ(l.ns, 4);
    EXPECT_EQ(l.nps, 32);
    VectorXd z(l.size());
    z << next.q, next.v, next.warm_start;
    const StepResiduals r = f.Evaluate(sim.scene(), sim.DefaultParams(), x, StepInput{}, z);
    EXPECT_LT(r.Violation(), kResidualTol) << "mu_s " << mu_s;
    EXPECT_EQ(r.comp_a.size(), 36);
    // Jacobian w.r.t. z against central differences.
    for (int j = 0; j < l.size(); ++j) {
      VectorXd zp = z, zm = z;
      zp[j] += 1e-6;
      zm[j] -= 1e-6;
      const StepResiduals rp = f.Evaluate(sim.scene(), sim.DefaultParams(), x, {}, zp);
      const StepResiduals rm = f.Evaluate(sim.scene(), sim.DefaultParams(), x, {}, zm);
      EXPECT_LT(((rp.comp_b - rm.comp_b) / 2e-6 - r.d_comp_b.col(j)).norm(), 1e-6);
      EXPECT_LT(((rp.equality - rm.equality) / 2e-6 - r.d_equality.col(j)).norm(), 1e-6);
    }
    // Parameter columns (friction coefficients, masses) against central differences.
    for (std::size_t c = 0; c < r.param_columns.size(); ++c) {
      const int i = r.param_columns[c];
      Params pp = sim.DefaultParams(), pm = pp;
      const double d = 1e-6 * std::max(1.0, std::abs(pp.values[i]));
      pp.values[i] += d;
      pm.values[i] -= d;
      const StepResiduals rp = f.Evaluate(sim.scene().ApplyParams(pp), pp, x, {}, z);
      const StepResiduals rm = f.Evaluate(sim.scene().ApplyParams(pm), pm, x, {}, z);
      const int col = l.size() + static_cast<int>(c);
      EXPECT_LT(((rp.comp_b - rm.comp_b) / (2 * d) - r.d_comp_b.col(col)).norm(), 1e-6)
          << sim.scene().param_table().info(i).name;
      EXPECT_LT(((rp.equality - rm.equality) / (2 * d) - r.d_equality.col(col)).norm(), 1e-6)
          << sim.scene().param_table().info(i).name;
    }
  }
}

}  // namespace
}  // namespace vinci::sim
