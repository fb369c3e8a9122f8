// Simulator-level properties: prescribed bodies, moving floors, momentum, determinism,
// quaternion normalization, and the formulation's residual face (issue "Foundation" items 5, 10).
#include "vinci/sim/simulator/simulator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "test_util.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/formulations/stewart_trinkle.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;
using testing::WithParams;

constexpr double kG = 9.81;
constexpr double kSolverTol = 1e-9;  // Lemke's accuracy carried into velocities
constexpr double kHalfPi = 1.57079632679489661923;

double Vx(const Simulator& sim, const State& x, const std::string& name) {
  return x.v[sim.scene().index(sim.scene().FindBody(name)).v];
}
double Qx(const Simulator& sim, const State& x, const std::string& name) {
  return x.q[sim.scene().index(sim.scene().FindBody(name)).q];
}

// §A.2: with μ = 0 the horizontal momentum of block + pendulum is conserved.
TEST(SimulatorTest, FrictionlessPendulumOnBlockConservesHorizontalMomentum) {
  Simulator sim(LoadExample("pendulum_on_block.yaml"));
  const Scene& s = sim.scene();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  double block_travel = 0.0;
  for (const State& x : tr.states) {
    double px = 0.0;
    for (int bi : s.dynamic_bodies()) px += s.bodies[bi].mass * x.v[s.index(bi).v];
    ASSERT_NEAR(px, 0.0, 1e-8) << "t = " << x.t;
    block_travel = std::max(block_travel, std::abs(Qx(sim, x, "block")));
  }
  EXPECT_GT(block_travel, 1e-2);  // the block does move (the check above is not vacuous)
}

// §A.2/3: with large μ the block sticks while the pendulum swings.
TEST(SimulatorTest, BlockSticksUnderSwingingPendulumWithFriction) {
  Simulator sim(LoadExample("pendulum_on_block_friction.yaml"));
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 3000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  double swing = 0.0;
  for (const State& x : tr.states) {
    EXPECT_NEAR(Qx(sim, x, "block"), Qx(sim, x0, "block"), 1e-9) << "t = " << x.t;
    swing = std::max(swing, std::abs(Vx(sim, x, "link2")));
  }
  EXPECT_GT(swing, 1.0);
}

// §A.4: a position-controlled body follows its prescription exactly and pushes through ∂ψ/∂t.
TEST(SimulatorTest, PrescribedPusherFollowsMotionAndPushesBlock) {
  Simulator sim(LoadExample("pendulum_pusher.yaml"));
  const Scene& s = sim.scene();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 2000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const int pusher = s.FindBody("pusher");
  for (const State& x : tr.states) {
    const auto kin = ComputeBodyKinematics(s, x);
    EXPECT_DOUBLE_EQ(kin[pusher].X_WB.translation().x(), -0.7 + 0.5 * x.t);
    // The block (half-width 0.5 m) never overlaps the pusher (radius 0.1 m) by more than its
    // rocking (< 1e-5 rad under the pendulum's swing) moves the edge.
    EXPECT_GT(Qx(sim, x, "block") - 0.5 - (kin[pusher].X_WB.translation().x() + 0.1), -1e-6);
  }
  // Every contact gap at the start of every step — pusher, floor — is non-negative to solver
  // tolerance: the prescribed motion entered the constraints through ∂ψ/∂t.
  for (const StepInfo& info : tr.steps) EXPECT_GT(info.min_gap, -1e-9);
  // The pusher reached the block (gap 0.1 m at 0.5 m/s → t = 0.2 s) and moved it.
  EXPECT_GT(Qx(sim, tr.states.back(), "block"), 0.5);
}

// §A.5: a floor accelerating at |a| ≤ μ g carries the block without slip; above μ g the block
// slips with relative acceleration of magnitude μ g.
TEST(SimulatorTest, MovingFloorCarriesOrSlipsBlock) {
  Simulator sim(LoadExample("moving_floor.yaml"));
  const Scene& s = sim.scene();
  const double h = s.options.dt, f = 2.0, w = 2 * 3.14159265358979323846 * f;
  const double mu = 0.2;
  // Peak acceleration A w² = 0.5 μ g: sticks.
  {
    const double A = 0.5 * mu * kG / (w * w);
    const Params p =
        WithParams(sim, {{"motion.floor.x.amplitude0", A}, {"motion.floor.x.phase0", kHalfPi}});
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), 2000);
    ASSERT_TRUE(tr.ok) << tr.failure;
    for (std::size_t k = 1; k < tr.states.size(); ++k) {
      const State& x = tr.states[k];
      const double floor_x = A * (std::cos(w * x.t) - 1.0);  // the floor starts at rest
      EXPECT_NEAR(Qx(sim, x, "block") - floor_x, 0.0, kSolverTol) << "t = " << x.t;
    }
  }
  // Peak acceleration 3 μ g: slips; whenever the relative velocity is non-zero over a step, the
  // block's acceleration is ±μ g exactly.
  {
    const double A = 3 * mu * kG / (w * w);
    const Params p =
        WithParams(sim, {{"motion.floor.x.amplitude0", A}, {"motion.floor.x.phase0", kHalfPi}});
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), 2000);
    ASSERT_TRUE(tr.ok) << tr.failure;
    int slipping_steps = 0;
    for (std::size_t k = 1; k < tr.states.size(); ++k) {
      const State& x = tr.states[k];
      // Secant floor velocity over the step that produced x (what ∂ψ/∂t uses).
      const double v_floor = A * (std::cos(w * x.t) - std::cos(w * (x.t - h))) / h;
      const double v_rel = Vx(sim, x, "block") - v_floor;
      if (std::abs(v_rel) > 1e-6) {
        const double a = (Vx(sim, x, "block") - Vx(sim, tr.states[k - 1], "block")) / h;
        EXPECT_NEAR(std::abs(a), mu * kG, 1e-6) << "t = " << x.t;
        ++slipping_steps;
      }
    }
    EXPECT_GT(slipping_steps, 100);
  }
}

// Quaternions stay unit (to round-off) for a tumbling sphere and a box.
TEST(SimulatorTest, QuaternionsStayUnit) {
  Scene scene = LoadExample("ball_drop.yaml");
  scene.bodies[1].w0_W = Vector3d(3.0, -7.0, 11.0);
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 1000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  for (const State& x : tr.states) EXPECT_NEAR(x.q.segment<4>(3).norm(), 1.0, 1e-14);
}

// Same inputs → bit-identical rollouts.
TEST(SimulatorTest, RolloutIsBitForBitDeterministic) {
  for (const char* file : {"box_stack.yaml", "full_planar.yaml"}) {
    Simulator sim(LoadExample(file));
    const Trajectory a = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 300);
    const Trajectory b = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 300);
    ASSERT_TRUE(a.ok) << a.failure;
    ASSERT_EQ(a.states.size(), b.states.size());
    for (std::size_t k = 0; k < a.states.size(); ++k) {
      ASSERT_EQ(a.states[k].q.size(), b.states[k].q.size());
      EXPECT_EQ(0, std::memcmp(a.states[k].q.data(), b.states[k].q.data(),
                               sizeof(double) * a.states[k].q.size()))
          << file << " step " << k;
      EXPECT_EQ(0, std::memcmp(a.states[k].v.data(), b.states[k].v.data(),
                               sizeof(double) * a.states[k].v.size()))
          << file << " step " << k;
    }
  }
}

// Params change the physics without rebuilding the scene; bad params are rejected.
TEST(SimulatorTest, ParamsAreAppliedAndValidated) {
  Simulator sim(LoadExample("block_sliding.yaml"));
  const Trajectory slow =
      sim.Rollout(WithParams(sim, {{"mu.default", 0.8}}), sim.InitialState(), 100);
  const Trajectory fast =
      sim.Rollout(WithParams(sim, {{"mu.default", 0.1}}), sim.InitialState(), 100);
  ASSERT_TRUE(slow.ok && fast.ok);
  EXPECT_NEAR(Vx(sim, fast.states.back(), "block") - Vx(sim, slow.states.back(), "block"),
              0.7 * kG * 100 * sim.scene().options.dt, 1e-9);
  EXPECT_THROW(sim.Rollout(WithParams(sim, {{"mu.default", -1.0}}), sim.InitialState(), 1),
               std::invalid_argument);
  EXPECT_THROW(WithParams(sim, {{"mu.nonexistent", 1.0}}), std::invalid_argument);
  Params wrong;
  wrong.values = VectorXd::Zero(1);
  EXPECT_THROW(sim.Rollout(wrong, sim.InitialState(), 1), std::invalid_argument);
}

// The formulation's residual face: a simulated trajectory satisfies its own step equations to
// solver tolerance, and the analytic Jacobians match finite differences.
StepResiduals EvaluateStep(const Simulator& sim, const Params& p, const State& x0,
                           const State& x1) {
  Workspace ws;
  const Scene& model = sim.Resolve(p, &ws);
  const StepLayout l = sim.formulation().Layout(model, x0);
  VectorXd z = VectorXd::Zero(l.size());
  z.segment(l.q1(), l.nq) = x1.q;
  z.segment(l.v1(), l.nv) = x1.v;
  // The step's LCP solution (p_n, p_f, σ) is the next state's warm start; p_b is recovered from
  // the dynamics equations by least squares (it does not enter the LCP).
  const int ncomp = l.nc + l.nc * l.nd + l.nc;
  if (ncomp > 0) z.segment(l.pn(), ncomp) = x1.warm_start;
  if (l.nb > 0) {
    StepResiduals r = sim.formulation().Evaluate(model, p, x0, StepInput{}, z);
    const MatrixXd Gb = -r.d_equality.block(0, l.pb(), l.nv, l.nb);
    z.segment(l.pb(), l.nb) = Gb.colPivHouseholderQr().solve(r.equality.head(l.nv));
  }
  return sim.formulation().Evaluate(model, p, x0, StepInput{}, z);
}

TEST(SimulatorTest, TrajectoriesSatisfyTheirStepEquations) {
  for (const char* file : {"box_on_plane.yaml", "block_on_incline.yaml", "pendulum_pusher.yaml",
                           "box_stack.yaml", "moving_floor.yaml"}) {
    Simulator sim(LoadExample(file));
    const Params p = sim.DefaultParams();
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), 200);
    ASSERT_TRUE(tr.ok) << file << ": " << tr.failure;
    for (std::size_t k = 0; k + 1 < tr.states.size(); k += 20) {
      const StepResiduals r = EvaluateStep(sim, p, tr.states[k], tr.states[k + 1]);
      EXPECT_LT(r.Violation(), 1e-8) << file << " step " << k;
      // Complementarity pairs are individually non-negative (within tolerance).
      for (int i = 0; i < r.comp_a.size(); ++i) {
        EXPECT_GT(r.comp_a[i], -1e-8);
        EXPECT_GT(r.comp_b[i], -1e-8);
      }
    }
  }
}

TEST(SimulatorTest, StepEquationJacobiansMatchFiniteDifferences) {
  for (const char* file : {"block_on_incline.yaml", "pendulum_pusher.yaml", "ball_drop.yaml"}) {
    Scene scene = LoadExample(file);
    if (std::string(file) == "ball_drop.yaml") {
      scene.bodies[1].X_WB0.translation().z() = 0.1005;  // in the envelope: one contact
      scene.bodies[1].w0_W = Vector3d(1.0, 2.0, -0.5);
    }
    Simulator sim(scene);
    Params p = sim.DefaultParams();
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), 30);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const State& x0 = tr.states[20];
    Workspace ws;
    const Scene& model = sim.Resolve(p, &ws);
    const StepLayout l = sim.formulation().Layout(model, x0);
    ASSERT_GT(l.nc, 0) << file;
    // A generic point (not a solution): random but fixed.
    std::srand(7);
    VectorXd z = VectorXd::Random(l.size());
    z.segment(l.q1(), l.nq) = tr.states[21].q;
    const StepResiduals r = sim.formulation().Evaluate(model, p, x0, StepInput{}, z);
    const int np = static_cast<int>(r.param_columns.size());
    ASSERT_EQ(r.d_equality.cols(), l.size() + np);
    ASSERT_GE(np, 2);  // μ and at least one mass
    const double eps = 1e-6;
    for (int j = 0; j < l.size() + np; ++j) {
      VectorXd zp = z, zm = z;
      Params pp = p, pm = p;
      const Scene* mp = &model;
      const Scene* mm = &model;
      Workspace wp, wm;
      if (j < l.size()) {
        zp[j] += eps;
        zm[j] -= eps;
      } else {
        const int pi = r.param_columns[j - l.size()];
        pp.values[pi] += eps;
        pm.values[pi] -= eps;
        mp = &sim.Resolve(pp, &wp);
        mm = &sim.Resolve(pm, &wm);
      }
      const StepResiduals rp = sim.formulation().Evaluate(*mp, pp, x0, StepInput{}, zp);
      const StepResiduals rm = sim.formulation().Evaluate(*mm, pm, x0, StepInput{}, zm);
      const VectorXd fd_eq = (rp.equality - rm.equality) / (2 * eps);
      const VectorXd fd_b = (rp.comp_b - rm.comp_b) / (2 * eps);
      const VectorXd fd_a = (rp.comp_a - rm.comp_a) / (2 * eps);
      EXPECT_LT((fd_eq - r.d_equality.col(j)).lpNorm<Eigen::Infinity>(), 1e-6)
          << file << " col " << j;
      EXPECT_LT((fd_b - r.d_comp_b.col(j)).lpNorm<Eigen::Infinity>(), 1e-6) << file << " col " << j;
      EXPECT_LT((fd_a - r.d_comp_a.col(j)).lpNorm<Eigen::Infinity>(), 1e-6) << file << " col " << j;
    }
  }
}

}  // namespace
}  // namespace vinci::sim

namespace vinci::sim {
namespace {

// ∂(step equations)/∂x_ℓ: the dynamics rows depend on ν_ℓ through −M (planar: no gyroscopic
// term), and the normal rows on the height through ψ_n/h: ∂/∂y = 1/h per corner contact.
TEST(SimulatorTest, StateJacobiansHaveTheClosedFormEntries) {
  Simulator sim(testing::LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), 10);
  ASSERT_TRUE(tr.ok);
  Workspace ws;
  const Scene& model = sim.Resolve(p, &ws);
  const State& x0 = tr.states[5];
  const StepLayout l = sim.formulation().Layout(model, x0);
  ASSERT_EQ(l.nc, 2);
  VectorXd z = VectorXd::Zero(l.size());
  z.segment(l.v1(), l.nv) = tr.states[6].v;
  const StateJacobians J = sim.formulation().EvaluateStateJacobians(model, p, x0, StepInput{}, z);
  ASSERT_TRUE(J.contact_set_stable);
  const double h = model.options.dt, m = 1.0;
  // Columns: [x, y, θ, vx, vy, ω]. Dynamics rows 0..2 w.r.t. ν_ℓ: −M.
  EXPECT_NEAR(J.d_equality(0, 3), -m, 1e-6);
  EXPECT_NEAR(J.d_equality(1, 4), -m, 1e-6);
  EXPECT_NEAR(J.d_equality(2, 5), -model.bodies[1].inertia(2, 2), 1e-6);
  // Kinematics rows 3..5 w.r.t. q_ℓ: −I.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(J.d_equality(3 + i, i), -1.0, 1e-6);
  // Normal rows: ψ_n/h with ψ_n = y − 0.1 for both corners.
  for (int c = 0; c < 2; ++c) {
    EXPECT_NEAR(J.d_comp_b(c, 1), 1.0 / h, 1e-3);
    EXPECT_NEAR(J.d_comp_b(c, 0), 0.0, 1e-6);  // sliding along the floor changes no gap
  }
}

}  // namespace
}  // namespace vinci::sim

namespace vinci::sim {
namespace {

// A scene built in code: a convex polyhedron (a square pyramid) and a capsule dropped on a
// floor come to rest — the pyramid on its base (four corner contacts at height 0), the capsule
// lying down at height r — and the polyhedron's size parameter scales its geometry.
TEST(SimulatorTest, PolyhedronAndCapsuleComeToRestOnTheFloor) {
  Scene s;
  s.dim = Dim::kSpatial;
  s.options.dt = 1e-3;
  s.options.envelope = 2e-3;
  Body floor;
  floor.name = "floor";
  floor.kind = BodyKind::kStatic;
  floor.shapes.push_back(Shape{ShapeType::kHalfSpace});
  s.bodies.push_back(floor);
  Body pyramid;
  pyramid.name = "pyramid";
  pyramid.mass = 1.0;
  Shape p;
  p.type = ShapeType::kPolyhedron;
  // Base at z = −0.05, apex at z = 0.15 (the body origin is the centroid: 1/4 of the height).
  p.vertices = {
      {-0.1, -0.1, -0.05}, {0.1, -0.1, -0.05}, {0.1, 0.1, -0.05}, {-0.1, 0.1, -0.05}, {0, 0, 0.15}};
  pyramid.shapes.push_back(p);
  pyramid.X_WB0.translation() = Vector3d(0, 0, 0.3);
  s.bodies.push_back(pyramid);
  Body capsule;
  capsule.name = "capsule";
  capsule.mass = 0.5;
  Shape c;
  c.type = ShapeType::kCapsule;
  c.radius = 0.05;
  c.half_length = 0.1;
  capsule.shapes.push_back(c);
  capsule.X_WB0.translation() = Vector3d(1.0, 0, 0.3);
  capsule.X_WB0.linear() = Eigen::AngleAxisd(1.4, Vector3d::UnitY()).toRotationMatrix();
  s.bodies.push_back(capsule);
  Simulator sim(s);
  for (double scale : {1.0, 2.0}) {
    const Params prm = WithParams(sim, {{"size.pyramid.s0.scale", scale}});
    const Trajectory tr = sim.Rollout(prm, sim.InitialState(), 2000);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const State& x = tr.states.back();
    EXPECT_NEAR(x.q[2], 0.05 * scale, 1e-6) << "scale " << scale;  // resting on its base
    EXPECT_NEAR(x.v.head<6>().norm(), 0.0, 1e-6);
    EXPECT_NEAR(x.q[7 + 2], 0.05, 1e-6);  // capsule lying at its radius
    EXPECT_EQ(tr.steps.back().contacts, 4 + 2);
  }
}

}  // namespace
}  // namespace vinci::sim

namespace vinci::sim {
namespace {

TEST(SimulatorTest, OffCentreShapesWithComputedInertiaAreRejected) {
  Scene s;
  s.dim = Dim::kSpatial;
  Body b;
  b.name = "lopsided";
  Shape sphere;
  sphere.type = ShapeType::kSphere;
  sphere.radius = 0.1;
  sphere.X_BS.translation() = Vector3d(0.2, 0, 0);
  b.shapes.push_back(sphere);
  s.bodies.push_back(b);
  try {
    Simulator sim(s);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'lopsided'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("centre of mass"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vinci::sim
