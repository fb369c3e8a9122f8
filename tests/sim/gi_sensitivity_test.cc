// Step sensitivities of the geometrically implicit stepper (sensitivity.h, docs/sensitivity.md):
// implicit differentiation of its mixed NCP at the step's solution against central differences
// of Simulator::Step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

// The GI step's MCP solution is accurate to ~1e-14 (absolute, on poses and velocities of order
// 0.1–1): a difference with step h carries up to kSolveNoise / h of round-off of its own.
constexpr double kSolveNoise = 5e-14;

// ‖a − b‖∞ ≤ rel · max(1e-3, ‖b‖∞) + noise[j] per column (noise: the reference's own error).
void ExpectMatrixNear(const MatrixXd& a, const MatrixXd& b, double rel, const VectorXd& noise,
                      const std::string& what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  for (int j = 0; j < a.cols(); ++j) {
    const double scale = std::max(1e-3, b.col(j).cwiseAbs().maxCoeff());
    for (int i = 0; i < a.rows(); ++i)
      EXPECT_NEAR(a(i, j), b(i, j), rel * scale + noise[j])
          << what << " (" << i << ", " << j << ")";
  }
}

// One GI step's derivatives (parameters and every raw state entry, a sphere's quaternion
// included) against differences of Simulator::Step: central ones at an exact step, forward ones
// (the one-sided derivative along +e_j) at a degenerate one.
void CheckGiStep(const Simulator& sim, const std::vector<std::string>& names, const State& x,
                 double rel, SensitivityStatus expected) {
  ASSERT_EQ(sim.formulation().name(), "geometrically-implicit");
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), names);
  Workspace ws;
  State next;
  ASSERT_TRUE(sim.Step(p, x, {}, &ws, &next).ok);
  const StepSensitivity s = StepDerivatives(sim, p, sel, x, {}, next, true);
  ASSERT_EQ(s.status, expected) << SensitivityStatusName(s.status) << ": " << s.message;
  const bool central = s.status == SensitivityStatus::kExact;
  const int nq = static_cast<int>(x.q.size()), nx = nq + static_cast<int>(x.v.size());
  const auto run = [&](const Params& pp, const State& xx) {
    Workspace w;
    State n;
    EXPECT_TRUE(sim.Step(pp, xx, {}, &w, &n).ok);
    VectorXd out(nx);
    out << n.q, n.v;
    return out;
  };
  VectorXd base(nx);
  base << next.q, next.v;
  MatrixXd d_theta(nx, sel.size()), d_x(nx, nx);
  VectorXd noise_theta(sel.size()), noise_x(nx);
  for (int j = 0; j < sel.size(); ++j) {
    const double v = sel.Get(p)[j], h = 1e-6 * std::max(1.0, std::abs(v));
    noise_theta[j] = kSolveNoise / h;
    VectorXd up = sel.Get(p), down = up;
    up[j] += h;
    down[j] -= h;
    const VectorXd fp = run(sel.Set(p, up), x);
    d_theta.col(j) = central ? (fp - run(sel.Set(p, down), x)) / (2 * h) : (fp - base) / h;
  }
  for (int i = 0; i < nx; ++i) {
    State xp = x, xm = x;
    double& cp = i < nq ? xp.q[i] : xp.v[i - nq];
    double& cm = i < nq ? xm.q[i] : xm.v[i - nq];
    // Small enough that the ψ/h of a resting contact stays in its branch, large enough for the
    // MCP's convergence (its solutions are ~1e-14 accurate).
    const double h = 1e-7 * std::max(1.0, std::abs(cp));
    noise_x[i] = kSolveNoise / h;
    cp += h;
    cm -= h;
    const VectorXd fp = run(p, xp);
    d_x.col(i) = central ? (fp - run(p, xm)) / (2 * h) : (fp - base) / h;
  }
  ExpectMatrixNear(s.d_theta, d_theta, rel, noise_theta, "d/dθ");
  if (s.near_kink_columns == 0) {
    ExpectMatrixNear(s.d_x, d_x, rel, noise_x, "d/dx");
  } else {
    // Some state column's active set holds only within < 1e-6: the differences (step 1e-7)
    // see another branch there; the parameter columns above are still compared.
    EXPECT_EQ(s.status, SensitivityStatus::kDegenerate);
  }
}

State After(const Simulator& sim, int steps) {
  const Trajectory t = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
  EXPECT_TRUE(t.ok) << t.failure;
  return t.states.back();
}

// The disc launched along the plane slides for 0.09 s (slip: σ > 0 on the cone's boundary):
// strictly complementary.
TEST(GiSensitivityTest, SlidingDiscStepMatchesFiniteDifferences) {
  const Simulator sim(LoadExample("disc_on_plane.yaml"));
  CheckGiStep(sim, {"mu.default", "mass.disc"}, After(sim, 20), 1e-6, SensitivityStatus::kExact);
}

// Then it rolls (sticking inside the cone: σ = 0 < μ² p_n² − ‖p_t‖²): still strict.
TEST(GiSensitivityTest, RollingDiscStepMatchesFiniteDifferences) {
  const Simulator sim(LoadExample("disc_on_plane.yaml"));
  CheckGiStep(sim, {"mu.default", "mass.disc"}, After(sim, 300), 1e-6, SensitivityStatus::kExact);
}

std::string DiscAtRest(const std::string& gravity, double height) {
  return "name: gi-disc-rest\ndimension: 2\ngravity: " + gravity +
         "\nstepper: {formulation: gi, dt: 0.001}\nfriction: {default: 0.5}\nbodies:\n"
         "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
         "  - {name: disc, mass: 2.0, pose: {position: [0, " +
         std::to_string(height) + "]}, shapes: [{type: disc, radius: 0.1}]}\n";
}

// A disc resting on the plane: x_ℓ+1 depends on x_ℓ only through ψ/h and the velocities.
TEST(GiSensitivityTest, RestingDiscStepMatchesFiniteDifferences) {
  const Simulator sim(ParseScene(DiscAtRest("[0, -9.81]", 0.1), "<gi rest>"));
  CheckGiStep(sim, {"mu.default", "mass.disc"}, After(sim, 50), 1e-6, SensitivityStatus::kExact);
}

// A frictionless disc resting on the floor and just touching a wall (the wall's pair has
// p_n = ψ = 0, its cone pair is inert): the degenerate pair is flagged, and the derivative along
// +e_j is the one-sided one (along +x, +v_x the disc leaves the wall).
TEST(GiSensitivityTest, DiscTouchingAWallIsFlaggedDegenerate) {
  const std::string text =
      "name: gi-disc-wall\ndimension: 2\ngravity: [0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001}\nfriction: {default: 0.0}\nbodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
      "  - {name: wall, kind: static, pose: {position: [-0.1, 0], angle: -1.5707963267948966}, "
      "shapes: [{type: halfplane}]}\n"
      "  - {name: disc, mass: 2.0, pose: {position: [0, 0.1]}, shapes: [{type: disc, radius: "
      "0.1}]}\n";
  const Simulator sim(ParseScene(text, "<gi wall>"));
  CheckGiStep(sim, {"mu.default", "mass.disc"}, After(sim, 50), 1e-6,
              SensitivityStatus::kDegenerate);
}

// A sphere rolling down an incline (spatial, sticking strictly inside the cone: exact). Its end
// orientation R_ℓ Exp(φ) depends on x_ℓ explicitly: the raw quaternion columns check that term.
TEST(GiSensitivityTest, RollingSphereStepMatchesFiniteDifferences) {
  const std::string text =
      "name: gi-sphere-incline\ndimension: 3\ngravity: [0, 0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001, envelope: 0.002}\nfriction: {default: 0.3}\n"
      "bodies:\n"
      "  - {name: incline, kind: static, pose: {rotation: {axis: [0, 1, 0], angle: 0.3}}, "
      "shapes: [{type: halfspace}]}\n"
      "  - {name: ball, mass: 1.0, pose: {position: [0.0295520207, 0, 0.0955336489]}, shapes: "
      "[{type: sphere, radius: 0.1}]}\n";
  const Simulator sim(ParseScene(text, "<gi incline>"));
  CheckGiStep(sim, {"mu.default", "mass.ball"}, After(sim, 100), 1e-6, SensitivityStatus::kExact);
}

// A sphere resting in the groove between two fixed spheres is statically indeterminate (it can
// roll along the groove: six contact constraints of rank five); the solver form's compliances
// (κ_n = 1e-8, κ_t = 1e-5) pick the impulse split, so ∂p/∂z_ℓ ~ 1e8 and the friction cone is
// reached after ~1e-11 m: the z column's derivative is that of the step's own branch (the
// regularized one), not of steps perturbed by 1e-7. Such columns are flagged (degenerate, never
// exact); the parameter columns are still the differences'.
TEST(GiSensitivityTest, SphereInAGrooveIsFlaggedNearAKink) {
  const std::string text =
      "name: gi-three-spheres\ndimension: 3\ngravity: [0, 0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001, envelope: 0.001}\nfriction: {default: 0.3}\n"
      "bodies:\n"
      "  - {name: left, kind: static, pose: {position: [-0.25, 0, 0]}, shapes: [{type: sphere, "
      "radius: 0.2}]}\n"
      "  - {name: right, kind: static, pose: {position: [0.25, 0, 0]}, shapes: [{type: sphere, "
      "radius: 0.2}]}\n"
      "  - {name: ball, mass: 1.0, pose: {position: [0, 0, 0.5]}, shapes: [{type: sphere, "
      "radius: 0.1}]}\n";
  const Simulator sim(ParseScene(text, "<gi spheres>"));
  CheckGiStep(sim, {"mu.default", "mass.ball"}, After(sim, 1000), 1e-6,
              SensitivityStatus::kDegenerate);
  Workspace ws;
  const State x = After(sim, 1000);
  State next;
  ASSERT_TRUE(sim.Step(sim.DefaultParams(), x, {}, &ws, &next).ok);
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const StepSensitivity s = StepDerivatives(sim, sim.DefaultParams(), sel, x, {}, next, true);
  EXPECT_GT(s.near_kink_columns, 0) << s.message;
}

// Forward mode through the disc's slide: ∂x_N/∂(μ, x_0) against central differences of the
// rollout.
TEST(GiSensitivityTest, SlidingDiscRolloutMatchesCentralDifferences) {
  const Simulator sim(LoadExample("disc_on_plane.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const int steps = 40, nq = sim.scene().num_positions(), nx = nq + sim.scene().num_velocities();
  const State x0 = After(sim, 5);
  const RolloutSensitivity r = RolloutForward(sim, p, sel, x0, std::vector<StepInput>(steps), true);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_EQ(r.exact_steps, steps);
  const auto run = [&](const Params& pp, const State& xx) {
    const Trajectory t = sim.Rollout(pp, xx, steps);
    EXPECT_TRUE(t.ok) << t.failure;
    VectorXd out(nx);
    out << t.states.back().q, t.states.back().v;
    return out;
  };
  MatrixXd fd(nx, 1 + nx);
  const double hm = 1e-6;
  VectorXd up = sel.Get(p), down = up;
  up[0] += hm;
  down[0] -= hm;
  fd.col(0) = (run(sel.Set(p, up), x0) - run(sel.Set(p, down), x0)) / (2 * hm);
  for (int i = 0; i < nx; ++i) {
    State xp = x0, xm = x0;
    const double h = 1e-7;
    (i < nq ? xp.q[i] : xp.v[i - nq]) += h;
    (i < nq ? xm.q[i] : xm.v[i - nq]) -= h;
    fd.col(1 + i) = (run(p, xp) - run(p, xm)) / (2 * h);
  }
  VectorXd noise(1 + nx);
  noise[0] = kSolveNoise / hm;
  noise.tail(nx).setConstant(kSolveNoise / 1e-7);
  ExpectMatrixNear(r.d_state.back(), fd, 1e-6, noise, "rollout");
}

}  // namespace
}  // namespace vinci::sim
