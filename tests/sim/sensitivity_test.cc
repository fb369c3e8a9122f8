// Exact step sensitivities (sensitivity.h) against closed forms and central differences.
#include "vinci/sim/simulator/sensitivity.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "test_util.h"
#include "vinci/sim/simulator/finite_difference.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;

// ‖a − b‖∞ ≤ rel · max(1e-3, ‖b‖∞): the comparison used against central differences, whose
// own error is ~1e-8 of the column scale.
void ExpectMatrixNear(const MatrixXd& a, const MatrixXd& b, double rel, const std::string& what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  for (int j = 0; j < a.cols(); ++j) {
    const double scale = std::max(1e-3, b.col(j).cwiseAbs().maxCoeff());
    for (int i = 0; i < a.rows(); ++i)
      EXPECT_NEAR(a(i, j), b(i, j), rel * scale) << what << " (" << i << ", " << j << ")";
  }
}

// One step's exact derivatives against finite differences of Simulator::Step (parameters and
// initial state). At a degenerate step the exact columns are one-sided (along +e_j), so they are
// compared with forward differences there, with central ones otherwise.
void CheckStepAgainstFd(const Simulator& sim, const std::vector<std::string>& names, int warmup,
                        double rel, SensitivityStatus expected) {
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), names);
  State x = sim.InitialState();
  if (warmup > 0) x = sim.Rollout(p, x, warmup).states.back();
  Workspace ws;
  State next;
  ASSERT_TRUE(sim.Step(p, x, {}, &ws, &next).ok);
  const StepSensitivity s = StepDerivatives(sim, p, sel, x, {}, next, true);
  EXPECT_EQ(s.status, expected) << SensitivityStatusName(s.status) << ": " << s.message;
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
  for (int j = 0; j < sel.size(); ++j) {
    const double v = sel.Get(p)[j], h = 1e-7 * std::max(1.0, std::abs(v));
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
    const double h = 1e-7 * std::max(1.0, std::abs(cp));
    cp += h;
    cm -= h;
    const VectorXd fp = run(p, xp);
    d_x.col(i) = central ? (fp - run(p, xm)) / (2 * h) : (fp - base) / h;
  }
  ExpectMatrixNear(s.d_theta, d_theta, rel, "d/dθ");
  // Every state column, a spatial body's raw quaternion entries included.
  ExpectMatrixNear(s.d_x, d_x, rel, "d/dx");
}

// While the block slides each Stewart–Trinkle step removes exactly μ g h of speed:
// ∂x_N/∂μ = −g h² N (N + 1)/2 and ∂v_N/∂μ = −g h N, every step strictly complementary.
TEST(SensitivityTest, SlidingBlockForwardModeMatchesClosedForm) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const double h = sim.scene().options.dt;
  const int n = 300;
  const RolloutSensitivity r =
      RolloutForward(sim, p, sel, sim.InitialState(), std::vector<StepInput>(n), false);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  ASSERT_EQ(static_cast<int>(r.d_state.size()), n + 1);
  EXPECT_EQ(r.exact_steps, n);
  const int nq = sim.scene().num_positions();
  const int qx = sim.scene().index(sim.scene().FindBody("block")).q;
  const int vx = nq + sim.scene().index(sim.scene().FindBody("block")).v;
  const double dx = -kG * h * h * n * (n + 1) / 2.0;
  EXPECT_NEAR(r.d_state.back()(qx, 0), dx, 1e-6 * std::abs(dx));
  EXPECT_NEAR(r.d_state.back()(vx, 0), -kG * h * n, 1e-6 * kG * h * n);
  for (int i = 0; i < r.d_state.back().rows(); ++i)
    if (i != qx && i != vx) {
      EXPECT_NEAR(r.d_state.back()(i, 0), 0.0, 1e-9) << "row " << i;
    }
}

TEST(SensitivityTest, SlidingBlockStepMatchesFiniteDifferences) {
  CheckStepAgainstFd(Simulator(LoadExample("block_sliding.yaml")), {"mu.default", "mass.block"}, 10,
                     1e-6, SensitivityStatus::kExact);
}

// A sphere rolling down the incline (sticking contact: the unloaded friction directions are
// degenerate, the derivative along +e_j is still exact).
TEST(SensitivityTest, RollingSphereStepMatchesFiniteDifferences) {
  const Simulator sim(LoadExample("sphere_on_incline.yaml"));
  CheckStepAgainstFd(sim, sim.scene().param_table().DifferentiableNames(), 50, 1e-6,
                     SensitivityStatus::kDegenerate);
}

// A box sliding at 1.2 m/s with its four corners within the contact envelope. The corners'
// friction directions against the slip have p_f = 0 = w_j (σ equal to the slip speed) while their
// normal impulse is held at 0: 0.8 mm above the floor the contacts are separated and the step is
// free flight (∂ν_x/∂ν_x = 1, not the 0.375 of friction at unloaded corners); resting on its face
// one corner is touching and unloaded, and would slide with the others if it took load (its
// friction then ∂ω_z/∂ν_x = −6 where the differences are 0). Both on the general path
// (`lcp_basis` off), the first also on the basis path.
std::string SlidingBox(double z) {
  return "dimension: 3\n"
         "stepper: {dt: 0.002, duration: 0.1, friction_directions: 8, envelope: 0.002}\n"
         "friction: {default: 0.4}\n"
         "bodies:\n"
         "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
         "  - name: box\n"
         "    mass: 1.0\n"
         "    pose: {position: [0, 0, " +
         std::to_string(z) +
         "]}\n"
         "    velocity: {linear: [1.2, 0, 0]}\n"
         "    shapes: [{type: box, half_extents: [0.1, 0.1, 0.05]}]\n";
}

// The first step's state Jacobian against forward differences of 1e-5 (the step's LCP leaves
// ~1e-8 of noise in ν, so smaller differences are noise; the errors fixed were 0.4 … 1200).
MatrixXd FirstStepJacobian(const Simulator& sim, const SensitivityOptions& options,
                           SensitivityStatus* status, MatrixXd* forward) {
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const State x = sim.InitialState();
  const auto step = [&](const State& from) {
    Workspace ws;
    State next;
    EXPECT_TRUE(sim.Step(p, from, {}, &ws, &next).ok);
    return next;
  };
  const State next = step(x);
  const StepSensitivity s = StepDerivatives(sim, p, sel, x, {}, next, true, options);
  *status = s.status;
  const int nq = static_cast<int>(x.q.size()), nx = nq + static_cast<int>(x.v.size());
  forward->resize(nx, nx);
  for (int j = 0; j < nx; ++j) {
    State xp = x;
    (j < nq ? xp.q[j] : xp.v[j - nq]) += 1e-5;
    const State n = step(xp);
    forward->col(j) << (n.q - next.q) / 1e-5, (n.v - next.v) / 1e-5;
  }
  return s.d_x;
}

TEST(SensitivityTest, UnloadedSlidingCornersCarryNoFriction) {
  SensitivityOptions general;
  general.lcp_basis = false;
  for (const bool basis : {false, true}) {
    // Free flight within the envelope: ∂x_ℓ+1/∂ν_ℓ = [h I; I] in the body's block (the basis
    // path's rows by central differences: to ~1e-9).
    SensitivityOptions options;
    options.lcp_basis = basis;
    const Simulator above(ParseScene(SlidingBox(0.0508), "above.yaml"));
    SensitivityStatus status;
    MatrixXd fd;
    const MatrixXd d = FirstStepJacobian(above, options, &status, &fd);
    EXPECT_EQ(status, SensitivityStatus::kExact) << basis;
    const int nq = above.scene().num_positions(), nv = above.scene().num_velocities();
    EXPECT_LT((d.bottomRightCorner(nv, nv) - MatrixXd::Identity(nv, nv)).cwiseAbs().maxCoeff(),
              1e-8)
        << basis;
    const double h = above.scene().options.dt;
    EXPECT_LT((d.block(0, nq, 3, 3) - h * MatrixXd::Identity(3, 3)).cwiseAbs().maxCoeff(), 1e-10)
        << basis;
  }
  const Simulator resting(ParseScene(SlidingBox(0.05), "resting.yaml"));
  SensitivityStatus status;
  MatrixXd fd;
  const MatrixXd d = FirstStepJacobian(resting, general, &status, &fd);
  EXPECT_EQ(status, SensitivityStatus::kDegenerate);  // the touching unloaded corner's normal
  ExpectMatrixNear(d, fd, 1e-3, "resting box, d/dx");
}

// Columns whose degenerate-pair right-hand side q is the K solve's round-off (a rolling sphere's
// state columns: q ~ 1e-19 for ‖dz‖∞ ~ 1e-2) keep λ = 0; their sensitivity LCP, often infeasible
// at unit scale, was flagged unsolved on 24 columns per 50 sphere steps before (bench/README.md,
// session 19). Along the sphere's and a resting box's rollouts, no column is unsolved.
TEST(SensitivityTest, RoundoffColumnsAreNotUnsolvedLcps) {
  for (const char* scene : {"sphere_on_incline.yaml", "box_on_plane.yaml"}) {
    SCOPED_TRACE(scene);
    const Simulator sim(LoadExample(scene));
    const Params p = sim.DefaultParams();
    const ParamSelection sel(sim.scene().param_table(),
                             SensitivityParameterNames(sim.scene().param_table()));
    const Trajectory traj = sim.Rollout(p, sim.InitialState(), 50);
    ASSERT_EQ(traj.states.size(), 51u);
    int degenerate_steps = 0;
    for (int l = 0; l < 50; ++l) {
      const StepSensitivity d =
          StepDerivatives(sim, p, sel, traj.states[l], {}, traj.states[l + 1], true);
      ASSERT_NE(d.status, SensitivityStatus::kFailed) << "step " << l << ": " << d.message;
      EXPECT_EQ(d.unsolved_columns, 0) << "step " << l << ": " << d.message;
      EXPECT_TRUE(d.d_x.allFinite()) << "step " << l;
      if (d.status == SensitivityStatus::kDegenerate) ++degenerate_steps;
    }
    EXPECT_EQ(degenerate_steps, 50);  // sticking contacts: the sensitivity LCP's branch
  }
}

// A resting stack carries no tangential load: ∂x/∂μ = 0 after any number of steps.
TEST(SensitivityTest, RestingStackHasZeroFrictionDerivative) {
  const Simulator sim(LoadExample("box_stack.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const State x0 = sim.Rollout(p, sim.InitialState(), 300).states.back();
  const RolloutSensitivity r = RolloutForward(sim, p, sel, x0, std::vector<StepInput>(5), false);
  ASSERT_TRUE(r.trajectory.ok);
  EXPECT_EQ(r.failed_steps, 0);
  EXPECT_LT(r.d_state.back().cwiseAbs().maxCoeff(), 1e-9);
}

// A box resting on a plane: four corners on a plane are redundant (the impulses are not unique)
// and the unloaded friction directions degenerate; the state derivative is still the finite
// difference's, and the step is flagged degenerate, never exact.
TEST(SensitivityTest, RedundantRestingContactsAreFlaggedAndStillRight) {
  CheckStepAgainstFd(Simulator(LoadExample("box_on_plane.yaml")), {"mu.default", "mass.box"}, 100,
                     1e-6, SensitivityStatus::kDegenerate);
}

// The NCP stepper (quadratic cone, its own MCP frozen model, the general path): a sliding
// block's step and the pushed box's (four sliding corners on the floor: redundant normals, so
// K is singular, but every pair strictly complementary and ν_ℓ+1 unique — exact), against
// differences of Simulator::Step.
Scene WithNcp(const char* file) {
  Scene s = LoadExample(file);
  s.options.formulation = FormulationType::kNcp;
  return s;
}
TEST(SensitivityTest, NcpSlidingBlockStepMatchesFiniteDifferences) {
  CheckStepAgainstFd(Simulator(WithNcp("block_sliding.yaml")), {"mu.default", "mass.block"}, 10,
                     1e-6, SensitivityStatus::kExact);
}
TEST(SensitivityTest, NcpPushedBoxStepMatchesFiniteDifferences) {
  CheckStepAgainstFd(Simulator(LoadExample("box_diagonal_push.yaml")), {"mu.default", "mass.box"},
                     20, 1e-6, SensitivityStatus::kExact);
}

// The NCP box pushed along 60° slides along the push (the round cone opposes the velocity
// exactly), each step removing μ g h of speed along it: over N steps from sliding,
// ∂s_N/∂μ = −g h² N (N + 1)/2 and ∂v_N/∂μ = −g h N along the push, nothing across it.
TEST(SensitivityTest, NcpPushedBoxForwardModeMatchesClosedForm) {
  const Simulator sim(LoadExample("box_diagonal_push.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const double h = sim.scene().options.dt;
  const State x0 = sim.Rollout(p, sim.InitialState(), 20).states.back();
  const int n = 200;
  const RolloutSensitivity r = RolloutForward(sim, p, sel, x0, std::vector<StepInput>(n), false);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_EQ(r.failed_steps, 0);
  const int nq = sim.scene().num_positions();
  const BodyIndex& box = sim.scene().index(sim.scene().FindBody("box"));
  const double c = std::cos(kPi / 3), sn = std::sin(kPi / 3);
  const MatrixXd& d = r.d_state.back();
  const double ds = -kG * h * h * n * (n + 1) / 2.0, dv = -kG * h * n;
  EXPECT_NEAR(d(box.q, 0), c * ds, 1e-6 * std::abs(ds));
  EXPECT_NEAR(d(box.q + 1, 0), sn * ds, 1e-6 * std::abs(ds));
  EXPECT_NEAR(d(nq + box.v, 0), c * dv, 1e-6 * std::abs(dv));
  EXPECT_NEAR(d(nq + box.v + 1, 0), sn * dv, 1e-6 * std::abs(dv));
  for (int i : {box.q + 2, nq + box.v + 2, nq + box.v + 3, nq + box.v + 4, nq + box.v + 5})
    EXPECT_NEAR(d(i, 0), 0.0, 1e-9) << "row " << i;
}

// A step's derivative taken right after the step in its workspace freezes the step's own
// assembly (copied from the thread's NCP step record) into the thread's model, refrozen in
// place; with a workspace of its own (another scene owner: no record applies) it assembles
// afresh. Both are the same numbers, bitwise, step after step (the reused model alternating
// between the two).
TEST(SensitivityTest, NcpStepRecordGivesTheFreshAssemblysDerivatives) {
  const Simulator sim(LoadExample("box_diagonal_push.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default", "mass.box"});
  State x = sim.Rollout(p, sim.InitialState(), 20).states.back();
  Workspace ws;
  for (int k = 0; k < 10; ++k) {
    State next;
    ASSERT_TRUE(sim.Step(p, x, StepInput{}, &ws, &next).ok);
    const StepSensitivity recorded =
        StepDerivatives(sim, p, sel, x, StepInput{}, next, true, {}, &ws);
    Workspace other;
    const StepSensitivity fresh =
        StepDerivatives(sim, p, sel, x, StepInput{}, next, true, {}, &other);
    ASSERT_EQ(recorded.status, SensitivityStatus::kExact)
        << "step " << k << ": " << recorded.message;
    EXPECT_EQ(recorded.status, fresh.status);
    EXPECT_EQ(recorded.d_theta, fresh.d_theta) << "step " << k;
    EXPECT_EQ(recorded.d_x, fresh.d_x) << "step " << k;
    x = next;
  }
}

// Reverse mode gives the forward-mode gradient of the same objective, and both match central
// differences along random directions of (θ, x_0).
TEST(SensitivityTest, ReverseModeMatchesForwardModeAndFiniteDifferences) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default", "mass.block"});
  const int nq = sim.scene().num_positions(), nv = sim.scene().num_velocities();
  const int qx = sim.scene().index(sim.scene().FindBody("block")).q;
  const std::vector<StepInput> inputs(200);
  // g = (x_N − 0.3)², a stopping-distance objective.
  const TerminalObjective g = [&](const State& xN, VectorXd* grad) {
    grad->setZero(nq + nv);
    (*grad)[qx] = 2.0 * (xN.q[qx] - 0.3);
    return (xN.q[qx] - 0.3) * (xN.q[qx] - 0.3);
  };
  const State x0 = sim.InitialState();
  const RolloutGradient rev = RolloutReverse(sim, p, sel, x0, inputs, g);
  ASSERT_TRUE(rev.ok) << rev.failure;
  const RolloutSensitivity fwd = RolloutForward(sim, p, sel, x0, inputs, true);
  VectorXd dg(nq + nv);
  g(fwd.trajectory.states.back(), &dg);
  const VectorXd full = fwd.d_state.back().transpose() * dg;
  for (int j = 0; j < sel.size(); ++j)
    EXPECT_NEAR(rev.d_theta[j], full[j], 1e-8 * std::max(1.0, std::abs(full[j])));
  for (int i = 0; i < nq + nv; ++i)
    EXPECT_NEAR(rev.d_x0[i], full[sel.size() + i], 1e-8 * std::max(1.0, std::abs(full[i])));

  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  for (int trial = 0; trial < 3; ++trial) {
    VectorXd dtheta(sel.size()), dx(nq + nv);
    for (int j = 0; j < dtheta.size(); ++j) dtheta[j] = n01(rng);
    for (int i = 0; i < dx.size(); ++i) dx[i] = 0.1 * n01(rng);
    const double eps = 1e-6;
    const auto value = [&](double s) {
      const Params ps = sel.Set(p, sel.Get(p) + s * dtheta);
      State xs = x0;
      xs.q += s * dx.head(nq);
      xs.v += s * dx.tail(nv);
      const Trajectory tr = sim.Rollout(ps, xs, inputs);
      VectorXd unused(nq + nv);
      return g(tr.states.back(), &unused);
    };
    const double fd = (value(eps) - value(-eps)) / (2 * eps);
    const double exact = rev.d_theta.dot(dtheta) + rev.d_x0.dot(dx);
    EXPECT_NEAR(exact, fd, 1e-5 * std::max(1e-3, std::abs(fd))) << "trial " << trial;
  }
}

// A ball landing on the floor: the step whose contact set changes is flagged, never exact.
TEST(SensitivityTest, LandingStepIsFlaggedAsModeChange) {
  const Simulator sim(LoadExample("ball_drop.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(),
                           sim.scene().param_table().DifferentiableNames());
  const int steps =
      static_cast<int>(std::lround(sim.scene().options.duration / sim.scene().options.dt));
  const RolloutSensitivity r =
      RolloutForward(sim, p, sel, sim.InitialState(), std::vector<StepInput>(steps), false);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_GT(r.mode_change_steps, 0);
  EXPECT_GT(r.exact_steps, 0);  // free flight
  EXPECT_EQ(r.failed_steps, 0);
}

// The smoothed derivative: finite, and tends to the exact one where the step is strictly
// complementary as ε → 0.
TEST(SensitivityTest, SmoothedDerivativeConvergesToExactOnAStrictStep) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  const State x = sim.Rollout(p, sim.InitialState(), 10).states.back();
  Workspace ws;
  State next;
  ASSERT_TRUE(sim.Step(p, x, {}, &ws, &next).ok);
  const StepSensitivity exact = StepDerivatives(sim, p, sel, x, {}, next, false);
  double previous = std::numeric_limits<double>::infinity();
  for (double eps : {1e-6, 1e-8, 1e-10}) {
    SensitivityOptions o;
    o.smoothing = eps;
    const StepSensitivity s = StepDerivatives(sim, p, sel, x, {}, next, false, o);
    ASSERT_NE(s.status, SensitivityStatus::kFailed) << s.message;
    const double err = (s.d_theta - exact.d_theta).cwiseAbs().maxCoeff();
    EXPECT_LE(err, previous);
    previous = err;
  }
  EXPECT_LT(previous, 1e-4 * exact.d_theta.cwiseAbs().maxCoeff());
}

TEST(SensitivityTest, RejectsSizesAndPoses) {
  const Simulator sim(LoadExample("ball_drop.yaml"));
  const Params p = sim.DefaultParams();
  std::string size_name;
  for (int i = 0; i < sim.scene().param_table().size(); ++i)
    if (sim.scene().param_table().info(i).name.rfind("size.", 0) == 0)
      size_name = sim.scene().param_table().info(i).name;
  ASSERT_FALSE(size_name.empty());
  const ParamSelection sel(sim.scene().param_table(), {size_name});
  Workspace ws;
  State next;
  const State x = sim.InitialState();
  ASSERT_TRUE(sim.Step(p, x, {}, &ws, &next).ok);
  try {
    StepDerivatives(sim, p, sel, x, {}, next, false);
    FAIL() << "a size parameter was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(size_name), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mu."), std::string::npos) << e.what();
  }
}

// A part on a plate vibrating at 20 Hz (x: 1.2665 mm, y: 0.3166 mm a quarter cycle later, the
// field of plate_disc_planar.yaml).
std::string PlateScene(const std::string& part, double mu, double amp_x, double amp_y) {
  return "name: plate-part\ndimension: 2\ngravity: [0, -9.81]\n"
         "stepper: {dt: 2.0e-4, duration: 0.05, envelope: 0.002, prescribed_velocity: exact}\n"
         "friction: {default: " +
         std::to_string(mu) +
         "}\nbodies:\n"
         "  - name: plate\n    kind: prescribed\n    shapes: [{type: halfplane}]\n"
         "    motion:\n      frequency: 20\n"
         "      x: {harmonics: [{order: 1, amplitude: " +
         std::to_string(amp_x) +
         ", phase: 0}]}\n"
         "      y: {harmonics: [{order: 1, amplitude: " +
         std::to_string(amp_y) + ", phase: 1.5707963267948966}]}\n" + part;
}

// Central differences of x_N along each selected parameter (relative step 1e-6, at least 1e-6
// for a zero value such as a phase) and initial-state entry (step 1e-8: the state enters through
// the penetration ψ/h, so a larger step moves the stick–slip switching times).
MatrixXd RolloutCentralDifferences(const Simulator& sim, const Params& p, const ParamSelection& sel,
                                   const State& x0, int steps) {
  const int nq = static_cast<int>(x0.q.size()), nx = nq + static_cast<int>(x0.v.size());
  const auto run = [&](const Params& pp, const State& xx) {
    const Trajectory t = sim.Rollout(pp, xx, steps);
    EXPECT_TRUE(t.ok) << t.failure;
    VectorXd out(nx);
    out << t.states.back().q, t.states.back().v;
    return out;
  };
  MatrixXd fd(nx, sel.size() + nx);
  for (int j = 0; j < sel.size(); ++j) {
    VectorXd up = sel.Get(p), down = up;
    const double h = up[j] == 0.0 ? 1e-6 : 1e-6 * std::abs(up[j]);
    up[j] += h;
    down[j] -= h;
    fd.col(j) = (run(sel.Set(p, up), x0) - run(sel.Set(p, down), x0)) / (2 * h);
  }
  for (int i = 0; i < nx; ++i) {
    State xp = x0, xm = x0;
    const double h = 1e-8;
    (i < nq ? xp.q[i] : xp.v[i - nq]) += h;
    (i < nq ? xm.q[i] : xm.v[i - nq]) -= h;
    fd.col(sel.size() + i) = (run(p, xp) - run(p, xm)) / (2 * h);
  }
  return fd;
}

// A disc on the vibrating plate over one cycle (250 steps): it sticks and rolls, slips, and
// sticks again, and no step changes its contact set; forward-mode derivatives of x_N with
// respect to μ, the plate's amplitudes and phases and x_0 equal central differences of the
// rollout to 1e-6 relative — sticking steps are degenerate (unloaded friction direction) and
// still exact along every column.
TEST(SensitivityTest, PlateCycleMatchesCentralDifferences) {
  const Simulator sim(
      ParseScene(PlateScene("  - name: disc\n    mass: 0.02\n    pose: {position: [0.0, 0.02]}\n"
                            "    shapes: [{type: disc, radius: 0.02}]\n",
                            0.3, 1.2665e-3, 3.166e-4)));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(),
                           {"mu.default", "motion.plate.x.amplitude0", "motion.plate.y.amplitude0",
                            "motion.plate.x.phase0", "motion.plate.y.phase0"});
  const int steps = 250;  // one cycle of 20 Hz at h = 0.2 ms
  const State x0 = sim.InitialState();
  const RolloutSensitivity r = RolloutForward(sim, p, sel, x0, std::vector<StepInput>(steps), true);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_EQ(r.failed_steps, 0);
  EXPECT_EQ(r.mode_change_steps, 0);
  EXPECT_GT(r.degenerate_steps, 0);  // sticking phases
  EXPECT_GT(r.exact_steps, 0);       // slipping phases
  ExpectMatrixNear(r.d_state.back(), RolloutCentralDifferences(sim, p, sel, x0, steps), 1e-6,
                   "plate cycle");
}

// A box sticking to a plate vibrating horizontally (μ = 1, peak acceleration 3.2 m/s² < μ g),
// started with the plate's velocity A ω: with the exact prescribed velocity its velocity after
// each step is the plate's, so
//   x_N = x_0 + h Σ_{k=1..N} A ω cos(ω k h + φ),  ω = 2π f,
// and ∂x_N/∂A, ∂x_N/∂φ, ∂v_N/∂A, ∂v_N/∂φ have closed forms. Two corners carry the box: the
// friction columns are redundant and the unloaded directions degenerate.
// The same cycle with the NCP stepper (its quadratic cone pairs). Where the disc sticks close
// to its cone's edge (step 151: |p_t| at 99.7 % of μ p_n, the slack μ² p_n² − p_t² ≈ 2e-12 in
// N²s², below the tolerance the velocity rows' residuals set) the pair was taken as degenerate
// and the directional rule chose the slipping branch, which the step does not reach for small
// perturbations: ∂x_N/∂A_x was 1.7 % off and ∂x_N/∂φ_x 3 % (forward, backward and central
// differences of the rollout agree with each other down to 1e-9). The cone slack is judged by
// its distance to the cone's surface in impulse units since (Linearization::Compute).
TEST(SensitivityTest, NcpPlateCycleMatchesCentralDifferences) {
  std::string text = PlateScene(
      "  - name: disc\n    mass: 0.02\n    pose: {position: [0.0, 0.02]}\n"
      "    shapes: [{type: disc, radius: 0.02}]\n",
      0.3, 1.2665e-3, 3.166e-4);
  text.replace(text.find("{dt:"), 4, "{formulation: ncp, dt:");
  const Simulator sim(ParseScene(text));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(),
                           {"mu.default", "motion.plate.x.amplitude0", "motion.plate.y.amplitude0",
                            "motion.plate.x.phase0", "motion.plate.y.phase0"});
  const int steps = 250;
  const State x0 = sim.InitialState();
  const RolloutSensitivity r = RolloutForward(sim, p, sel, x0, std::vector<StepInput>(steps), true);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_EQ(r.failed_steps, 0);
  EXPECT_EQ(r.mode_change_steps, 0);
  EXPECT_GT(r.exact_steps, 200);
  ExpectMatrixNear(r.d_state.back(), RolloutCentralDifferences(sim, p, sel, x0, steps), 1e-6,
                   "NCP plate cycle");
}

TEST(SensitivityTest, StickingBoxFollowsPlateAmplitudeAndPhase) {
  const double A = 2e-4, f = 20.0, w = 2 * M_PI * f;
  const Simulator sim(ParseScene(PlateScene(
      "  - name: box\n    mass: 0.02\n    pose: {position: [0.0, 0.005]}\n"
      "    shapes: [{type: polygon, vertices: [[-0.02, -0.005], [0.02, -0.005], [0.02, 0.005], "
      "[-0.02, 0.005]]}]\n",
      1.0, A, 0.0)));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(),
                           {"motion.plate.x.amplitude0", "motion.plate.x.phase0"});
  const double h = sim.scene().options.dt;
  const int steps = 230;  // most of a cycle: the closed forms are not zero
  State x0 = sim.InitialState();
  const int nq = sim.scene().num_positions();
  const int qx = sim.scene().index(sim.scene().FindBody("box")).q, vx = nq + qx;
  x0.v[qx] = A * w;
  const RolloutSensitivity r =
      RolloutForward(sim, p, sel, x0, std::vector<StepInput>(steps), false);
  ASSERT_TRUE(r.trajectory.ok) << r.trajectory.failure;
  EXPECT_EQ(r.failed_steps, 0);
  EXPECT_EQ(r.mode_change_steps, 0);
  EXPECT_EQ(r.exact_steps, 0);  // every step sticks
  double dx_dA = 0.0, dx_dphi = 0.0;
  for (int k = 1; k <= steps; ++k) {
    dx_dA += h * w * std::cos(w * k * h);
    dx_dphi -= h * A * w * std::sin(w * k * h);
  }
  const double dv_dA = w * std::cos(w * steps * h), dv_dphi = -A * w * std::sin(w * steps * h);
  const MatrixXd& S = r.d_state.back();
  EXPECT_NEAR(S(qx, 0), dx_dA, 1e-6 * std::abs(dx_dA));
  EXPECT_NEAR(S(qx, 1), dx_dphi, 1e-6 * std::abs(dx_dphi));
  EXPECT_NEAR(S(vx, 0), dv_dA, 1e-6 * std::abs(dv_dA));
  EXPECT_NEAR(S(vx, 1), dv_dphi, 1e-6 * std::abs(dv_dphi) + 1e-9);
}

}  // namespace
}  // namespace vinci::sim
