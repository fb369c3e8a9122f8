// The NCP stepper with the quadratic friction cone (ncp.h, docs/formulations.md §2): closed-form
// friction physics, the diagonal push a linearized cone gets wrong, its own step equations and
// the analytic MCP Jacobian.
#include "vinci/sim/formulations/ncp.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_util.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;
using testing::WithParams;

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;
constexpr double kTheta = 0.3;  // incline angle of block_on_incline.yaml (rad)

// A 1 kg box (0.2 × 0.2 × 0.1 m) on a floor, yawed by `yaw`, pushed by a constant horizontal
// force of `force` N at world angle `push` (rad), μ = 0.5.
std::string PushedBox(const std::string& formulation, double yaw, double push, double force,
                      double vx = 0.0, double vy = 0.0, double mu = 0.5) {
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "dimension: 3\n"
                "stepper: {formulation: %s, dt: 0.001, friction_directions: 4, envelope: 0.002}\n"
                "friction: {default: %.17g}\n"
                "bodies:\n"
                "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
                "  - name: box\n"
                "    mass: 1.0\n"
                "    pose: {position: [0, 0, 0.05], rotation: {axis: [0, 0, 1], angle: %.17g}}\n"
                "    velocity: {linear: [%.17g, %.17g, 0]}\n"
                "    force: [%.17g, %.17g, 0]\n"
                "    shapes: [{type: box, half_extents: [0.1, 0.1, 0.05]}]\n",
                formulation.c_str(), mu, yaw, vx, vy, force * std::cos(push),
                force * std::sin(push));
  return buf;
}

Trajectory RunScene(const Scene& scene, int steps) {
  Simulator sim(scene);
  return sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
}

// Direction error (rad) of the displacement from the start to the end of a trajectory.
double DisplacementAngle(const Trajectory& t, double push) {
  const Eigen::Vector2d d = (t.states.back().q.head<2>() - t.states.front().q.head<2>());
  const double a = std::atan2(d.y(), d.x()) - push;
  return std::abs(std::atan2(std::sin(a), std::cos(a)));
}

// Box yawed 15°, pushed along the bisector of its axes (world 60°): the isotropic cone opposes
// the slip exactly; the 4-direction cone's diamond does not.
TEST(NcpTest, DiagonalPushMovesAlongThePushOnlyWithTheQuadraticCone) {
  const double yaw = 15.0 * kPi / 180.0, push = yaw + kPi / 4;
  const Trajectory ncp = RunScene(ParseScene(PushedBox("ncp", yaw, push, 10.0)), 300);
  ASSERT_TRUE(ncp.ok) << ncp.failure;
  const Trajectory st = RunScene(ParseScene(PushedBox("stewart-trinkle", yaw, push, 10.0)), 300);
  ASSERT_TRUE(st.ok) << st.failure;
  const double e_ncp = DisplacementAngle(ncp, push), e_st = DisplacementAngle(st, push);
  char figures[96];
  std::snprintf(figures, sizeof figures, "ncp %.3g rad, st(n_d=4) %.3g rad", e_ncp, e_st);
  RecordProperty("angle_errors", figures);
  // Solver tolerance 1e-10 on ~1e-2 N·s impulses; the issue asks for 1e-6 rad.
  EXPECT_LT(e_ncp, 1e-6);
  // The diamond cone deviates by degrees here (≈ 0.3 rad measured); 0.05 rad is far above noise.
  EXPECT_GT(e_st, 0.05);
  // Speed: (F − μ m g)/m along the push for the isotropic cone.
  const Eigen::Vector2d v = ncp.states.back().v.head<2>();
  EXPECT_NEAR(v.norm(), (10.0 - 0.5 * kG) * 0.3, 1e-6);
  // No yaw rate: the friction of symmetric contacts is exactly opposite the slip.
  // (4 redundant corner contacts: only the ε-regularized split of p_n perturbs it.)
  EXPECT_LT(ncp.states.back().v.tail<3>().norm(), 1e-6);
}

// A box sliding at 2 m/s in an arbitrary direction loses μ g h of speed per step and stops at
// v0/(μ g) (applications.md §A.3), keeping its direction.
TEST(NcpTest, SlidingBoxDeceleratesAtMuGAndStopsOnTime) {
  const double v0 = 2.0, mu = 0.4, h = 1e-3, dir = 0.7;
  const Trajectory t = RunScene(
      ParseScene(PushedBox("ncp", 0.2, 0.0, 0.0, v0 * std::cos(dir), v0 * std::sin(dir), mu)), 700);
  ASSERT_TRUE(t.ok) << t.failure;
  const double t_stop = v0 / (mu * kG);
  double t_stopped = -1.0;
  for (std::size_t k = 1; k < t.states.size(); ++k) {
    const Eigen::Vector2d v = t.states[k].v.head<2>();
    const double expected = std::max(v0 - mu * kG * t.states[k].t, 0.0);
    // The ε_σ cone term biases |p_f| by ~1e-9 relative per step: < 1e-7 m/s over 700 steps.
    EXPECT_NEAR(v.norm(), expected, 1e-7) << "t = " << t.states[k].t;
    if (v.norm() > 1e-6) {
      EXPECT_NEAR(std::atan2(v.y(), v.x()), dir, 1e-8);
    }
    if (t_stopped < 0 && v.norm() < 1e-9) t_stopped = t.states[k].t;
  }
  EXPECT_NEAR(t_stopped, t_stop, h);
}

// Planar scene through the same equations (p_o fixed at 0): the 2D cone is exact.
TEST(NcpTest, PlanarSlidingBlockStopsOnTime) {
  Scene s = LoadExample("block_sliding.yaml");
  s.options.formulation = FormulationType::kNcp;
  const Trajectory t = RunScene(s, 600);
  ASSERT_TRUE(t.ok) << t.failure;
  const double t_stop = 2.0 / (0.4 * kG);
  double t_stopped = -1.0;
  for (const State& x : t.states)
    if (t_stopped < 0 && std::abs(x.v[0]) < 1e-9) t_stopped = x.t;
  EXPECT_NEAR(t_stopped, t_stop, 1e-3);
}

// Block on incline (θ = 0.3): sticks iff μ ≥ tan θ; slides with a = g (sin θ − μ cos θ).
TEST(NcpTest, BlockOnInclineSticksIffMuAtLeastTanTheta) {
  Scene s = LoadExample("block_on_incline.yaml");
  s.options.formulation = FormulationType::kNcp;
  Simulator sim(s);
  const int n = 1000;
  for (double ratio : {1.05, 0.95, 0.5}) {
    SCOPED_TRACE(ratio);
    const double mu = ratio * std::tan(kTheta);
    const Trajectory t = sim.Rollout(WithParams(sim, {{"mu.default", mu}}), sim.InitialState(), n);
    ASSERT_TRUE(t.ok) << t.failure;
    const double moved = (t.states.back().q.head<3>() - t.states.front().q.head<3>()).norm();
    if (ratio >= 1.0) {
      // Sticking creep is bounded by ε_t = 1e-10 m/s.
      EXPECT_LT(moved, 1e-8);
    } else {
      const double a = kG * (std::sin(kTheta) - mu * std::cos(kTheta));
      const double T = t.states.back().t;
      // The first step starts the slide: distance = a h² n(n+1)/2 exactly.
      EXPECT_NEAR(moved, a * 1e-6 * n * (n + 1) / 2.0, 1e-6 * a * T * T);
      // ε_σ biases the friction by ~1e-9 relative per step (accumulated over 1000 steps).
      EXPECT_NEAR(t.states.back().v.head<3>().norm(), a * T, 1e-6 * a * T);
    }
  }
}

// A simulated NCP trajectory satisfies its own step equations (Evaluate) to solver tolerance.
TEST(NcpTest, TrajectorySatisfiesItsStepEquations) {
  const double yaw = 0.3, push = 1.0;
  for (double force : {10.0, 1.0}) {  // sliding, sticking
    SCOPED_TRACE(force);
    Simulator sim(ParseScene(PushedBox("ncp", yaw, push, force)));
    const Params p = sim.DefaultParams();
    const Trajectory t = sim.Rollout(p, sim.InitialState(), 50);
    ASSERT_TRUE(t.ok) << t.failure;
    for (std::size_t k = 0; k + 1 < t.states.size(); ++k) {
      const State& x = t.states[k];
      const State& x1 = t.states[k + 1];
      const StepLayout l = sim.formulation().Layout(sim.scene(), x);
      ASSERT_EQ(l.nd, 2);
      VectorXd z(l.size());
      z << x1.q, x1.v, x1.warm_start;
      const StepResiduals r = sim.formulation().Evaluate(sim.scene(), p, x, StepInput{}, z);
      // MCP tolerance 1e-10 plus the ε regularization (≤ 1e-10 · impulses ~1e-2).
      EXPECT_LT(r.Violation(), 1e-9) << "step " << k;
    }
  }
}

// Evaluate's Jacobian matches central differences of its residuals.
TEST(NcpTest, EvaluateJacobianMatchesFiniteDifferences) {
  Simulator sim(ParseScene(PushedBox("ncp", 0.3, 1.0, 10.0)));
  const Params p = sim.DefaultParams();
  const Trajectory t = sim.Rollout(p, sim.InitialState(), 3);
  ASSERT_TRUE(t.ok);
  const State& x = t.states[1];
  VectorXd z(sim.formulation().Layout(sim.scene(), x).size());
  z << t.states[2].q, t.states[2].v, t.states[2].warm_start;
  const StepResiduals r = sim.formulation().Evaluate(sim.scene(), p, x, StepInput{}, z);
  const double eps = 1e-7;
  for (int j = 0; j < z.size(); ++j) {
    VectorXd zp = z, zm = z;
    zp[j] += eps;
    zm[j] -= eps;
    const StepResiduals rp = sim.formulation().Evaluate(sim.scene(), p, x, StepInput{}, zp);
    const StepResiduals rm = sim.formulation().Evaluate(sim.scene(), p, x, StepInput{}, zm);
    // Central differences of smooth residuals: O(eps²) truncation + roundoff/eps ≈ 1e-8.
    EXPECT_LT(((rp.equality - rm.equality) / (2 * eps) - r.d_equality.col(j)).cwiseAbs().maxCoeff(),
              1e-6)
        << "column " << j;
    EXPECT_LT(((rp.comp_b - rm.comp_b) / (2 * eps) - r.d_comp_b.col(j)).cwiseAbs().maxCoeff(), 1e-6)
        << "column " << j;
    EXPECT_LT(((rp.comp_a - rm.comp_a) / (2 * eps) - r.d_comp_a.col(j)).cwiseAbs().maxCoeff(), 1e-6)
        << "column " << j;
  }
  // Parameter columns (μ, masses): difference through the params-resolved scene.
  ASSERT_FALSE(r.param_columns.empty());
  for (std::size_t k = 0; k < r.param_columns.size(); ++k) {
    const int i = r.param_columns[k], col = z.size() + static_cast<int>(k);
    Params pp = p, pm = p;
    const double step = 1e-7 * std::max(1.0, std::abs(p.values[i]));
    pp.values[i] += step;
    pm.values[i] -= step;
    const Scene mp = sim.scene().ApplyParams(pp), mm = sim.scene().ApplyParams(pm);
    const StepResiduals rp = sim.formulation().Evaluate(mp, pp, x, StepInput{}, z);
    const StepResiduals rm = sim.formulation().Evaluate(mm, pm, x, StepInput{}, z);
    EXPECT_LT(
        ((rp.equality - rm.equality) / (2 * step) - r.d_equality.col(col)).cwiseAbs().maxCoeff(),
        1e-6)
        << sim.scene().param_table().info(i).name;
    EXPECT_LT(((rp.comp_b - rm.comp_b) / (2 * step) - r.d_comp_b.col(col)).cwiseAbs().maxCoeff(),
              1e-6)
        << sim.scene().param_table().info(i).name;
  }
}

// Resting on the floor, the warm start makes the MCP nearly free: ≤ 2 Newton steps per step and
// never another start.
TEST(NcpTest, WarmStartKeepsRestingStepsCheap) {
  Simulator sim(ParseScene(PushedBox("ncp", 0.3, 0.0, 0.0)));
  State x = sim.InitialState(), next;
  Workspace ws;
  for (int k = 0; k < 200; ++k) {
    const StepInfo info = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << info.failure;
    if (k >= 10) {
      EXPECT_LE(info.solver.iterations, 2) << "step " << k;
      EXPECT_EQ(info.solver.message.find("retried"), std::string::npos) << info.solver.message;
    }
    x = next;
  }
  EXPECT_LT(x.v.norm(), 1e-9);  // no drift at rest
}

// The analytic MCP Jacobian matches central differences of F at a generic point.
TEST(NcpTest, McpJacobianMatchesFiniteDifferences) {
  Scene planar = LoadExample("block_sliding.yaml");
  planar.options.formulation = FormulationType::kNcp;
  planar.Finalize();
  const Scene spatial = ParseScene(PushedBox("ncp", 0.3, 1.0, 10.0));
  for (const Scene* scene : std::vector<const Scene*>{&spatial, &planar}) {
    for (bool scaled : {false, true}) {
      for (double e_o : {1.0, 0.6}) {
        SCOPED_TRACE(std::string(scene == &planar ? "planar" : "spatial") +
                     (scaled ? " scaled" : "") + " e_o " + std::to_string(e_o));
        NcpOptions o;
        o.scale_rows = scaled;
        o.e_t = 1.3;
        o.e_o = e_o;
        const NcpStepper stepper(scene->options, o);
        const NcpStepper::StepProblem sp =
            stepper.Build(*scene, Simulator(*scene).InitialState(), StepInput{});
        const int n = sp.mcp.size(), nc = n / 4;
        ASSERT_GT(nc, 0);
        VectorXd z(n);
        for (int i = 0; i < n; ++i) z[i] = 0.01 * std::sin(1.0 + 3.7 * i) + (i < nc ? 0.02 : 0.0);
        z.tail(nc).setConstant(0.3);
        VectorXd F;
        MatrixXd J;
        sp.mcp.evaluate(z, &F, &J);
        const double eps = 1e-6;
        MatrixXd J_fd(n, n);
        for (int j = 0; j < n; ++j) {
          VectorXd zp = z, zm = z, Fp, Fm;
          zp[j] += eps;
          zm[j] -= eps;
          sp.mcp.evaluate(zp, &Fp, nullptr);
          sp.mcp.evaluate(zm, &Fm, nullptr);
          J_fd.col(j) = (Fp - Fm) / (2 * eps);
        }
        // F is quadratic in z: central differences are exact up to roundoff (1e-16/1e-6 · |F|).
        EXPECT_LT((J - J_fd).cwiseAbs().maxCoeff(), 1e-8 * std::max(1.0, J.cwiseAbs().maxCoeff()));
        // The sparse Jacobian is the same matrix (same operations up to summation order).
        Eigen::SparseMatrix<double> Js;
        sp.mcp.sparse_jacobian(z, &Js);
        EXPECT_LT((MatrixXd(Js) - J).cwiseAbs().maxCoeff(), 1e-14 * J.cwiseAbs().maxCoeff());
      }
    }
  }
}

TEST(NcpTest, JointsAreSupported) {
  Scene s = LoadExample("pendulum_on_block.yaml");
  s.options.formulation = FormulationType::kNcp;
  Simulator sim(s);
  const Trajectory t = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 300);
  ASSERT_TRUE(t.ok) << t.failure;
  const StepLayout l = sim.formulation().Layout(sim.scene(), t.states[100]);
  EXPECT_GT(l.nb, 0);
  VectorXd z(l.size());
  z << t.states[101].q, t.states[101].v, t.states[101].warm_start.head(4 * l.nc),
      VectorXd::Zero(l.nb);
  // p_b is eliminated by the stepper and not stored; check the kinematics and cone rows only.
  const StepResiduals r =
      sim.formulation().Evaluate(sim.scene(), sim.DefaultParams(), t.states[100], StepInput{}, z);
  for (int i = 0; i < r.comp_a.size(); ++i)
    EXPECT_LT(std::abs(std::min(r.comp_a[i], r.comp_b[i])), 1e-9);
}

TEST(NcpTest, AFailedSolveIsReportedNotAccepted) {
  Scene s = ParseScene(PushedBox("ncp", 0.3, 1.0, 10.0, 1.0, 0.0));
  NcpOptions o;
  o.mcp.max_iterations = 1;
  const NcpStepper stepper(s.options, o);
  s.Finalize();
  Simulator sim(s);
  State next;
  StepInfo info;
  Workspace ws;
  stepper.Step(s, sim.InitialState(), StepInput{}, &ws, &next, &info);
  EXPECT_FALSE(info.ok);
  EXPECT_NE(info.failure.find("MCP failed from every start"), std::string::npos) << info.failure;
  EXPECT_NE(info.failure.find("LCP start"), std::string::npos) << info.failure;
  EXPECT_NE(info.failure.find("free-slip start"), std::string::npos) << info.failure;
  EXPECT_EQ(info.solver.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(next.t, 0.0);  // *next == x
}

TEST(NcpTest, SceneFileSelectsNcp) {
  const Scene s = ParseScene(PushedBox("ncp", 0.0, 0.0, 0.0));
  EXPECT_EQ(s.options.formulation, FormulationType::kNcp);
  EXPECT_EQ(MakeFormulation(s.options)->name(), "ncp");
}

// Elliptic cone (e_t ≠ e_o): the step equations hold along the trajectory, the friction sits on
// the ellipse while sliding, and a push between the cone's axes no longer moves the box along
// the push (it does for e_t = e_o).
TEST(NcpTest, EllipticConeSlidesOnTheEllipse) {
  Scene s = ParseScene(PushedBox("ncp", 0.0, 1.0, 10.0));
  s.Finalize();
  const Params p = s.DefaultParams();
  for (double e_o : {1.0, 0.5}) {
    SCOPED_TRACE(e_o);
    NcpOptions o;
    o.e_t = 1.0;
    o.e_o = e_o;
    o.scale_rows = true;  // also exercises the scaled rows
    const NcpStepper stepper(s.options, o);
    State x = Simulator(s).InitialState(), next;
    const State x0 = x;
    for (int k = 0; k < 100; ++k) {
      StepInfo info;
      stepper.Step(s, x, StepInput{}, nullptr, &next, &info);
      ASSERT_TRUE(info.ok) << info.failure;
      VectorXd z(stepper.Layout(s, x).size());
      z << next.q, next.v, next.warm_start;
      const StepResiduals r = stepper.Evaluate(s, p, x, StepInput{}, z);
      EXPECT_LT(r.Violation(), 1e-9) << "step " << k;  // as for the isotropic cone
      if (k == 99) {
        // Sliding: each contact's friction on the ellipse (p_t/e_t)² + (p_o/e_o)² = (μ p_n)².
        const int nc = stepper.Layout(s, x).nc;
        for (int c = 0; c < nc; ++c) {
          const double pn = next.warm_start[c], pt = next.warm_start[nc + 2 * c],
                       po = next.warm_start[nc + 2 * c + 1];
          EXPECT_NEAR(std::hypot(pt, po / e_o), 0.5 * pn, 1e-8 * pn);
        }
      }
      x = next;
    }
    const Eigen::Vector2d d = x.q.head<2>() - x0.q.head<2>();
    const double err = std::abs(std::atan2(d.y(), d.x()) - 1.0);
    if (e_o == 1.0) {
      EXPECT_LT(err, 1e-6);
    } else {
      EXPECT_GT(err, 0.01);  // the anisotropic cone steers the slip (≈ 0.1 rad here)
    }
  }
}

TEST(NcpTest, RejectsBadEllipticity) {
  NcpOptions o;
  o.e_t = 0.0;
  EXPECT_THROW(NcpStepper(StepperOptions{}, o), std::invalid_argument);
}

// The sparse Newton path (used from NcpOptions::sparse_min_contacts contacts) reproduces the
// dense one on the 40-contact box stack.
TEST(NcpTest, SparseAndDenseNewtonAgreeOnTheBoxStack) {
  Scene s = LoadExample("box_stack.yaml");
  s.options.formulation = FormulationType::kNcp;
  s.Finalize();
  NcpOptions dense_options, sparse_options;
  dense_options.sparse_min_contacts = 1000000;
  sparse_options.sparse_min_contacts = 1;
  const NcpStepper dense(s.options, dense_options), sparse(s.options, sparse_options);
  State xd = Simulator(s).InitialState(), xs = xd, next;
  for (int k = 0; k < 100; ++k) {
    StepInfo info;
    dense.Step(s, xd, StepInput{}, nullptr, &next, &info);
    ASSERT_TRUE(info.ok) << info.failure;
    xd = next;
    sparse.Step(s, xs, StepInput{}, nullptr, &next, &info);
    ASSERT_TRUE(info.ok) << info.failure;
    xs = next;
  }
  // Both solve each step to 1e-10; the stack is at rest, so the states agree to ~1e-9.
  EXPECT_LT((xd.q - xs.q).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((xd.v - xs.v).cwiseAbs().maxCoeff(), 1e-7);
}

// ---- Redundant corner contacts on a vibrating plate (docs/field.md) --------------------------

// plate_box.yaml with the plate's x vibration split 30° between x and y: the friction-cone
// study's configuration (examples/plate_error_study.cc), under ncp.
Scene ConveyedBoxAt30Degrees() {
  Scene s = LoadExample("plate_box.yaml");
  s.options.formulation = FormulationType::kNcp;
  PrescribedMotion& m = s.bodies[0].motion;
  const Harmonic hx = m.dofs[0].harmonics[0];
  m.dofs[0].harmonics[0].amplitude = hx.amplitude * std::cos(kPi / 6);
  m.dofs[1].harmonics = {hx};
  m.dofs[1].harmonics[0].amplitude = hx.amplitude * std::sin(kPi / 6);
  return s;
}

// The rigid box on four corners (p_n and, while it sticks, p_t not unique) slides and sticks
// on the plate: every step of the study's 20 cycles solves (this failed at step 0 before the
// MCP was nondimensionalized and McpSolver got its Levenberg–Marquardt step), and each step
// satisfies its own equations.
TEST(NcpTest, BoxOnTheVibratingPlateNeverFailsAndSatisfiesItsStepEquations) {
  Simulator sim(ConveyedBoxAt30Degrees());
  const Params p = sim.DefaultParams();
  State x = sim.InitialState(), next;
  Workspace ws;
  const int steps = 20 * 160;  // 20 plate cycles at h = T/160, as the study
  double worst = 0.0, slid = 0.0;
  for (int k = 0; k < steps; ++k) {
    const StepInfo info = sim.Step(p, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    ASSERT_EQ(info.contacts, 4) << "step " << k;
    if (k % 8 == 0) {  // every 8th step (Evaluate builds dense Jacobians)
      VectorXd z(sim.formulation().Layout(sim.scene(), x).size());
      z << next.q, next.v, next.warm_start;
      worst = std::max(worst,
                       sim.formulation().Evaluate(sim.scene(), p, x, StepInput{}, z).Violation());
    }
    slid = std::max(slid, next.warm_start.tail(4).maxCoeff());  // σ: slip speed
    x = next;
  }
  // Scaled MCP tolerance 1e-10 · (V ≤ 0.2 m/s on normal rows, P V ~ 1e-5 on friction rows)
  // plus ε_n ≈ 1e-10 · 600 /kg · p_n ≤ 1e-5 N·s: every row ≤ 1e-10 in its own units.
  EXPECT_LT(worst, 1e-10);
  EXPECT_GT(slid, 0.05);  // the box really slides (plate speed ~0.16 m/s) as well as sticks
  // It is conveyed: moved more than 1 cm in 20 cycles (the study's speed is ~0.067 m/s).
  EXPECT_GT(std::hypot(x.q[sim.scene().index(1).q], x.q[sim.scene().index(1).q + 1]), 0.01);
}

// plate_box.yaml and plate_tripod.yaml for their full duration under ncp.
TEST(NcpTest, PlateSceneExamplesRunTheirFullDuration) {
  for (const char* name : {"plate_box.yaml", "plate_tripod.yaml"}) {
    SCOPED_TRACE(name);
    Scene s = LoadExample(name);
    s.options.formulation = FormulationType::kNcp;
    const int steps = static_cast<int>(std::lround(s.options.duration / s.options.dt));
    const Trajectory t = RunScene(s, steps);
    EXPECT_TRUE(t.ok) << t.failure;
    EXPECT_EQ(static_cast<int>(t.states.size()), steps + 1);
  }
}

// The resting box on a plane stays exactly at rest under ncp (scaling changes no exact zero).
TEST(NcpTest, RestingBoxOnAPlaneStaysExactlyAtRest) {
  Scene s = LoadExample("box_on_plane.yaml");
  s.options.formulation = FormulationType::kNcp;
  const Trajectory t = RunScene(s, 1000);
  ASSERT_TRUE(t.ok) << t.failure;
  const State& x0 = t.states.front();
  const State& x1 = t.states.back();
  // Rest: no drift beyond rounding (ε_t creep needs a tangential load; there is none).
  EXPECT_LT((x1.q - x0.q).lpNorm<Eigen::Infinity>(), 1e-12);
  EXPECT_LT(x1.v.lpNorm<Eigen::Infinity>(), 1e-12);
}

}  // namespace
}  // namespace vinci::sim
