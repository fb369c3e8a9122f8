// Closed-form physics checks of the Stewart–Trinkle stepper (applications.md §A, issue
// "Foundation" item 10), on the bundled example scenes.
#include "vinci/sim/formulations/stewart_trinkle.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_util.h"
#include "vinci/sim/formulations/contact.h"

namespace vinci::sim {
namespace {

using testing::Energy;
using testing::LoadExample;
using testing::WithParams;

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;
constexpr double kTheta = 0.3;  // incline angle of the example scenes (rad)
// Lemke solves to ~1e-12 relative; velocities built from it carry that error.
constexpr double kSolverTol = 1e-9;

// Position of body `name` (x, y[, z]) in state x.
Vector3d Position(const Simulator& sim, const State& x, const std::string& name) {
  const Scene& s = sim.scene();
  const int o = s.index(s.FindBody(name)).q;
  return s.dim == Dim::kPlanar ? Vector3d(x.q[o], x.q[o + 1], 0.0) : Vector3d(x.q.segment<3>(o));
}
Vector3d Velocity(const Simulator& sim, const State& x, const std::string& name) {
  const Scene& s = sim.scene();
  const int o = s.index(s.FindBody(name)).v;
  return s.dim == Dim::kPlanar ? Vector3d(x.v[o], x.v[o + 1], 0.0) : Vector3d(x.v.segment<3>(o));
}

// §A.3: each step removes exactly μ g h of speed until |v| < μ g h, then v = 0; the block
// stops at t = v0 / (μ g).
TEST(StewartTrinkleTest, SlidingBlockLosesMuGhPerStepAndStopsOnTime) {
  Simulator sim(LoadExample("block_sliding.yaml"));
  const double mu = 0.4, v0 = 2.0, h = sim.scene().options.dt;
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 1000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  double t_stop = -1.0;
  for (std::size_t k = 1; k < tr.states.size(); ++k) {
    const double v_prev = Velocity(sim, tr.states[k - 1], "block").x();
    const double v = Velocity(sim, tr.states[k], "block").x();
    if (v_prev > mu * kG * h) {
      EXPECT_NEAR(v_prev - v, mu * kG * h, kSolverTol) << "step " << k;
    } else {
      EXPECT_NEAR(v, 0.0, kSolverTol) << "step " << k;
    }
    if (t_stop < 0 && std::abs(v) < kSolverTol) t_stop = tr.states[k].t;
    // No vertical motion and no rotation while resting on its face.
    EXPECT_NEAR(Velocity(sim, tr.states[k], "block").y(), 0.0, kSolverTol);
  }
  EXPECT_NEAR(t_stop, v0 / (mu * kG), h);
}

// Block on an incline (issue item 10): sticks for μ ≥ tan θ with no creep (< 1e-9 m over 10 s
// at μ = 1.05 tan θ).
TEST(StewartTrinkleTest, BlockOnInclineSticksWithoutCreep) {
  Simulator sim(LoadExample("block_on_incline.yaml"));
  const Params p = WithParams(sim, {{"mu.default", 1.05 * std::tan(kTheta)}});
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(p, x0, 10000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const double creep =
      (Position(sim, tr.states.back(), "block") - Position(sim, x0, "block")).norm();
  EXPECT_LT(creep, 1e-9);
}

// ... and otherwise slides with a = g (sin θ − μ cos θ).
TEST(StewartTrinkleTest, BlockOnInclineSlidesWithClosedFormAcceleration) {
  Simulator sim(LoadExample("block_on_incline.yaml"));
  for (double mu : {0.0, 0.1, 0.2}) {
    const Params p = WithParams(sim, {{"mu.default", mu}});
    const int n = 500;
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), n);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const double a = kG * (std::sin(kTheta) - mu * std::cos(kTheta));
    // Speed along the incline after the first step (the step that establishes contact).
    const double s1 = Velocity(sim, tr.states[1], "block").norm();
    const double sn = Velocity(sim, tr.states[n], "block").norm();
    const double a_sim = (sn - s1) / ((n - 1) * sim.scene().options.dt);
    EXPECT_NEAR(a_sim, a, 1e-6 * kG) << "mu = " << mu;
  }
}

// A sphere rolls down the incline with a = (5/7) g sin θ when μ ≥ (2/7) tan θ, and slides
// with a = g (sin θ − μ cos θ) otherwise.
TEST(StewartTrinkleTest, SphereRollsDownInclineAtFiveSevenths) {
  Simulator sim(LoadExample("sphere_on_incline.yaml"));
  const double mu_roll = 2.0 / 7.0 * std::tan(kTheta);
  const double h = sim.scene().options.dt;
  struct Case {
    double mu, a;
  };
  for (const Case c :
       {Case{1.2 * mu_roll, 5.0 / 7.0 * kG * std::sin(kTheta)},
        Case{0.3, 5.0 / 7.0 * kG * std::sin(kTheta)},
        Case{0.5 * mu_roll, kG * (std::sin(kTheta) - 0.5 * mu_roll * std::cos(kTheta))}}) {
    const Params p = WithParams(sim, {{"mu.default", c.mu}});
    const int n = 500;
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), n);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const double s1 = Velocity(sim, tr.states[1], "ball").norm();
    const double sn = Velocity(sim, tr.states[n], "ball").norm();
    // The first step is a partly-plastic landing (the ball starts touching); after it the
    // acceleration is constant. The rotation is integrated exactly; the rolling constraint is
    // imposed at the end of each step, so the error is O(h).
    EXPECT_NEAR((sn - s1) / ((n - 1) * h), c.a, 2e-3 * c.a) << "mu = " << c.mu;
  }
}

// A resting box and the 10-box stack do not drift over 10⁴ steps; penetration stays bounded.
TEST(StewartTrinkleTest, RestingBoxDoesNotDrift) {
  Simulator sim(LoadExample("box_on_plane.yaml"));
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 10000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  EXPECT_LT((Position(sim, tr.states.back(), "box") - Position(sim, x0, "box")).norm(), 1e-9);
  for (const StepInfo& s : tr.steps) {
    EXPECT_EQ(s.contacts, 4);
    EXPECT_GT(s.min_gap, -1e-9);
  }
}

TEST(StewartTrinkleTest, TenBoxStackStands) {
  Simulator sim(LoadExample("box_stack.yaml"));
  const State x0 = sim.InitialState();
  const int n = 2000;  // the 10⁴-step run is StewartTrinkleSlowTest.TenBoxStackStandsLong
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, n);
  ASSERT_TRUE(tr.ok) << tr.failure;
  for (int i = 0; i < 10; ++i) {
    const std::string name = "box" + std::to_string(i);
    EXPECT_LT((Position(sim, tr.states.back(), name) - Position(sim, x0, name)).norm(), 1e-6)
        << name;
  }
  double worst = 0.0;
  for (const StepInfo& s : tr.steps) worst = std::min(worst, s.min_gap);
  EXPECT_GT(worst, -1e-6);
}

// §A.1: the 2-bar pendulum's energy never grows. The stepper is semi-implicit (forces at ℓ,
// positions updated with ν_ℓ+1), so the energy carries an O(h) oscillation step to step; what
// must not happen is growth: the energy stays below its initial value plus that O(h) band, and
// the band's ceiling does not rise from one second to the next. Joint drift stays bounded.
TEST(StewartTrinkleTest, TwoBarPendulumEnergyNeverGrowsAndJointsHold) {
  Simulator sim(LoadExample("pendulum_2bar.yaml"));
  const Scene& s = sim.scene();
  const double h = s.options.dt;
  const int steps_per_window = static_cast<int>(std::lround(1.0 / h));
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 5 * steps_per_window);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const double e0 = Energy(s, tr.states[0]);
  // Energy scale: the pendulum's potential drop m g L over the two links (≈ 40 J).
  const double scale = 2.0 * kG * 2.0;
  std::vector<double> window_max(5, -1e300);
  for (std::size_t k = 1; k < tr.states.size(); ++k) {
    const double e = Energy(s, tr.states[k]);
    EXPECT_LE(e, e0 + 5.0 * h * scale) << "step " << k;
    const std::size_t w = std::min<std::size_t>(4, (k - 1) / steps_per_window);
    window_max[w] = std::max(window_max[w], e);
    // Joint drift: the elbow ends coincide and the shoulder stays at the origin.
    const Vector3d p1 = Position(sim, tr.states[k], "link1");
    const Vector3d p2 = Position(sim, tr.states[k], "link2");
    const double th1 = tr.states[k].q[s.index(s.FindBody("link1")).q + 2];
    const double th2 = tr.states[k].q[s.index(s.FindBody("link2")).q + 2];
    const Vector3d e1 = p1 + 0.5 * Vector3d(std::cos(th1), std::sin(th1), 0);
    const Vector3d e2 = p2 - 0.5 * Vector3d(std::cos(th2), std::sin(th2), 0);
    ASSERT_LT((e1 - e2).norm(), 1e-3) << "step " << k;
    const Vector3d s1 = p1 - 0.5 * Vector3d(std::cos(th1), std::sin(th1), 0);
    ASSERT_LT(s1.norm(), 1e-3) << "step " << k;
  }
  for (int w = 1; w < 5; ++w) EXPECT_LE(window_max[w], window_max[0] + 1e-6) << "second " << w;
}

// §A.1: small-angle period of one uniform rod of length L is 2π √(2L / (3g)).
TEST(StewartTrinkleTest, RodPendulumSmallAnglePeriod) {
  Scene scene = LoadExample("pendulum_2bar.yaml");
  scene.bodies.pop_back();  // keep link1 only
  scene.joints.pop_back();
  const double L = 1.0, a0 = 0.05;  // rad below horizontal → hang angle
  // Start hanging straight down, displaced by a0.
  const double th = -kPi / 2 + a0;
  scene.bodies[0].X_WB0 = PlanarPose(0.5 * L * std::cos(th), 0.5 * L * std::sin(th), th);
  scene.options.dt = 1e-4;
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 30000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  // Period from successive upward zero crossings of the angle deviation.
  std::vector<double> crossings;
  for (std::size_t k = 1; k < tr.states.size(); ++k) {
    const double d0 = tr.states[k - 1].q[2] + kPi / 2, d1 = tr.states[k].q[2] + kPi / 2;
    if (d0 < 0 && d1 >= 0)
      crossings.push_back(tr.states[k - 1].t +
                          (tr.states[k].t - tr.states[k - 1].t) * (-d0) / (d1 - d0));
  }
  ASSERT_GE(crossings.size(), 2u);
  const double period = (crossings.back() - crossings.front()) / (crossings.size() - 1);
  const double expected = 2 * kPi * std::sqrt(2 * L / (3 * kG));
  // Finite amplitude (0.05 rad) lengthens the period by a0²/16 ≈ 1.6e-4; implicit Euler adds O(h).
  EXPECT_NEAR(period, expected, 1e-3 * expected);
}

}  // namespace
}  // namespace vinci::sim

namespace vinci::sim {
namespace {

// The Anitescu–Potra option imposes the normal constraint at velocity level (no ψ_n/h): the ball
// is stopped wherever it is when its contact enters the step — at most one step's travel
// v·h below the surface (it falls 4.4 mm per step at impact, more than the 2 mm envelope) — and
// that gap is then held, never corrected; Stewart–Trinkle's ψ_n/h closes the gap to 0.
TEST(StewartTrinkleTest, AnitescuPotraStopsAtVelocityLevel) {
  Scene st_scene = testing::LoadExample("ball_drop.yaml");
  Scene ap_scene = st_scene;
  ap_scene.options.formulation = FormulationType::kAnitescuPotra;
  Simulator st(st_scene), ap(ap_scene);
  EXPECT_EQ(ap.formulation().name(), "anitescu-potra");
  const Trajectory a = st.Rollout(st.DefaultParams(), st.InitialState(), 1000);
  const Trajectory b = ap.Rollout(ap.DefaultParams(), ap.InitialState(), 1000);
  ASSERT_TRUE(a.ok && b.ok);
  const double eps = st_scene.options.envelope, r = 0.1;
  EXPECT_NEAR(a.states.back().q[2] - r, 0.0, 1e-9);
  const double v_impact = std::sqrt(2 * kG * (1.0 - r)), h = st_scene.options.dt;
  const double gap_ap = b.states.back().q[2] - r;
  EXPECT_GE(gap_ap, -v_impact * h);
  EXPECT_LE(gap_ap, eps);
  EXPECT_GT(std::abs(gap_ap), 1e-6);                   // genuinely different from Stewart–Trinkle
  EXPECT_NEAR(b.states[500].q[2] - r, gap_ap, 1e-12);  // held, not corrected
  EXPECT_NEAR(b.states.back().v.norm(), 0.0, 1e-9);
}

}  // namespace
}  // namespace vinci::sim
