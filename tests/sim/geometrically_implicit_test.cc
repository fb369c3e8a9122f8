// The geometrically implicit stepper (docs/formulations.md §3, issue 4 deliverables 3 and 6):
// equation count, analytic Jacobians against finite differences, rolling transition of a disc,
// no faceting loss, no penetration, resting contact, and the residual face.
#include "vinci/sim/formulations/geometrically_implicit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "test_util.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::sim {
namespace {

using testing::Energy;

constexpr double kG = 9.81;

// A disc of radius 0.1 m, 1 kg, launched along +x at v0 with clockwise spin w0 (rad/s) on the
// half-plane y ≤ 0.
std::string DiscScene(double v0, double w0, double mu, double h, const std::string& shape,
                      double envelope = 0.001) {
  return "name: gi-disc\ndimension: 2\ngravity: [0, -9.81]\n"
         "stepper: {formulation: gi, dt: " +
         std::to_string(h) + ", envelope: " + std::to_string(envelope) +
         "}\nfriction: {default: " + std::to_string(mu) +
         "}\nbodies:\n"
         "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
         "  - name: disc\n    mass: 1.0\n    pose: {position: [0, 0.1]}\n"
         "    velocity: {linear: [" +
         std::to_string(v0) + ", 0], angular: " + std::to_string(-w0) + "}\n    shapes: [" + shape +
         "]\n";
}

Scene Parse(const std::string& text) { return ParseScene(text, "<gi test>"); }

// Central finite differences of the MCP function against its analytic Jacobian.
double JacobianError(const McpProblem& prob, const VectorXd& z) {
  VectorXd F;
  MatrixXd J;
  prob.evaluate(z, &F, &J);
  double worst = 0.0;
  for (int j = 0; j < z.size(); ++j) {
    const double eps = 1e-6 * std::max(1.0, std::abs(z[j]));
    VectorXd zp = z, zm = z, Fp, Fm;
    zp[j] += eps;
    zm[j] -= eps;
    prob.evaluate(zp, &Fp, nullptr);
    prob.evaluate(zm, &Fm, nullptr);
    const VectorXd fd = (Fp - Fm) / (2 * eps);
    worst = std::max(worst, (fd - J.col(j)).cwiseAbs().maxCoeff() /
                                std::max(1.0, J.col(j).cwiseAbs().maxCoeff()));
  }
  return worst;
}

// §3's count: planar disc on a fixed half-plane, one contact: 15 unknowns = 15 rows.
TEST(GiTest, PlanarDiscOnHalfPlaneHasFifteenUnknowns) {
  Simulator sim(Parse(DiscScene(1.0, 0.0, 0.3, 1e-3, "{type: disc, radius: 0.1}")));
  const GeometricallyImplicit gi(sim.scene().options);
  const State x = sim.InitialState();
  EXPECT_EQ(gi.Layout(sim.scene(), x).size(), 15);
  VectorXd z0, F;
  const McpProblem prob = gi.StepProblem(sim.scene(), x, StepInput{}, &z0);
  EXPECT_EQ(prob.size(), 15);
  prob.evaluate(z0, &F, nullptr);
  EXPECT_EQ(F.size(), 15);
}

// A point of the solver form away from its kinks: p_n > 0, sliding, multipliers interior.
VectorXd GenericPoint(const GeometricallyImplicit& gi, const Scene& s, const State& x,
                      const VectorXd& z0) {
  const StepLayout l = gi.Layout(s, x);
  VectorXd z = z0;
  for (int k = 0; k < l.nc; ++k) {
    z[l.pn() + k] = 0.02 + 0.01 * k;
    for (int j = 0; j < l.nd; ++j) z[l.pf() + k * l.nd + j] = 0.003 * (j + 1);
    z[l.sigma() + k] = 0.4;
  }
  // Small deterministic perturbation of everything else (keeps multipliers positive).
  for (int i = 0; i < l.pn(); ++i) z[i] += 1e-3 * std::sin(1.0 + i);
  for (int i = l.pb(); i < l.size(); ++i) z[i] += 1e-4 * std::cos(2.0 + i);
  return z;
}

// Jacobian error tolerance: central differences with step 1e-6 are accurate to ~1e-8 relative.
constexpr double kFdTol = 1e-6;

TEST(GiTest, SolverJacobianMatchesFiniteDifferencesPlanar) {
  for (const std::string shape :
       {"{type: disc, radius: 0.1}", "{type: ellipse, semi_axes: [0.15, 0.08]}",
        "{type: polygon, vertices: [[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]]}"}) {
    Simulator sim(Parse(DiscScene(2.0, 5.0, 0.3, 1e-3, shape, 0.5)));
    const GeometricallyImplicit gi(sim.scene().options);
    State x = sim.InitialState();
    x.q[2] = 0.3;  // tilt the non-round shapes
    if (std::string(shape).find("polygon") != std::string::npos) x.q[1] = 0.1 * std::sqrt(2.0);
    VectorXd z0;
    const McpProblem prob = gi.StepProblem(sim.scene(), x, StepInput{}, &z0);
    ASSERT_GE(gi.Layout(sim.scene(), x).nc, 1) << shape;
    const double err = JacobianError(prob, GenericPoint(gi, sim.scene(), x, z0));
    EXPECT_LT(err, kFdTol) << shape;
  }
}

std::string SpatialScene(const std::string& body_shape, const std::string& pose,
                         const std::string& extra_bodies) {
  return "name: gi-3d\ndimension: 3\ngravity: [0, 0, -9.81]\n"
         "stepper: {formulation: gi, dt: 0.001, envelope: 0.5}\nfriction: {default: 0.4}\n"
         "bodies:\n" +
         extra_bodies + "  - name: body\n    mass: 2.0\n    pose: " + pose +
         "\n    velocity: {linear: [0.5, -0.2, -0.1], angular: [1.0, -2.0, 3.0]}\n"
         "    shapes: [" +
         body_shape + "]\n";
}

TEST(GiTest, SolverJacobianMatchesFiniteDifferencesSpatial) {
  const std::string floor = "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n";
  const std::string ball =
      "  - {name: ball, kind: static, pose: {position: [0, 0, -0.3]}, shapes: [{type: sphere, "
      "radius: 0.3}]}\n"
      "  - {name: free, mass: 1.0, pose: {position: [0.05, 0.3, 0.21]}, velocity: {linear: [0, "
      "0.1, 0], angular: [0, 0, 1]}, shapes: [{type: sphere, radius: 0.1}]}\n";
  const std::string tilted = "{position: [0, 0, 0.2], rotation: {axis: [1, 2, 0.5], angle: 0.4}}";
  for (const auto& [shape, extra] : std::vector<std::pair<std::string, std::string>>{
           {"{type: sphere, radius: 0.2}", floor},
           {"{type: ellipsoid, semi_axes: [0.3, 0.2, 0.1]}", floor},
           {"{type: box, half_extents: [0.2, 0.15, 0.1]}", floor},
           {"{type: box, half_extents: [0.2, 0.15, 0.1]}", ball}}) {
    Simulator sim(Parse(SpatialScene(shape, tilted, extra)));
    const GeometricallyImplicit gi(sim.scene().options);
    const State x = sim.InitialState();
    VectorXd z0;
    const McpProblem prob = gi.StepProblem(sim.scene(), x, StepInput{}, &z0);
    ASSERT_GE(gi.Layout(sim.scene(), x).nc, 1) << shape;
    const double err = JacobianError(prob, GenericPoint(gi, sim.scene(), x, z0));
    EXPECT_LT(err, kFdTol) << shape;
  }
}

// Slip velocity of the disc's contact point (m/s): v_x + ω r (ω counter-clockwise).
double Slip(const State& x) { return x.v[0] + 0.1 * x.v[2]; }

// §B.1: a disc launched with v0 > r ω0 slides until t* = (v0 − r ω0)/(3 μ g), then rolls at
// (2 v0 + r ω0)/3 with constant energy.
TEST(GiTest, DiscRollingTransitionAndSpeed) {
  for (const double h : {1e-3, 4e-3}) {
    const double v0 = 2.0, w0 = 5.0, r = 0.1, mu = 0.3;
    Simulator sim(Parse(DiscScene(v0, w0, mu, h, "{type: disc, radius: 0.1}")));
    const int steps = static_cast<int>(0.4 / h);
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const double t_star = (v0 - r * w0) / (3 * mu * kG);
    const double v_roll = (2 * v0 + r * w0) / 3;
    double t_roll = -1.0;
    int iterations = 0;
    for (std::size_t k = 0; k < tr.states.size(); ++k) {
      if (t_roll < 0 && std::abs(Slip(tr.states[k])) < 1e-6) t_roll = tr.states[k].t;
      if (k > 0) iterations += tr.steps[k - 1].solver.iterations;
    }
    const State& end = tr.states.back();
    ::testing::Test::RecordProperty("t_star_error", std::to_string(t_roll - t_star));
    ::testing::Test::RecordProperty("roll_speed_error", std::to_string(end.v[0] - v_roll));
    ::testing::Test::RecordProperty("newton_per_step", std::to_string(double(iterations) / steps));
    double emin = 1e9, emax = -1e9;
    for (const State& x : tr.states) {
      if (x.t < t_roll + 1e-12) continue;
      const double e = Energy(sim.scene(), x);
      emin = std::min(emin, e);
      emax = std::max(emax, e);
      EXPECT_NEAR(x.q[1], r, 1e-9) << "t = " << x.t;  // rolls on the plane, no bumping
    }
    EXPECT_LT(emax - emin, 1e-9 * emax);  // constant energy while rolling (round-off only)
    EXPECT_NEAR(t_roll, t_star, 2 * h);   // the transition lands on a step boundary: O(h)
    EXPECT_NEAR(end.v[0], v_roll, 2 * mu * kG * h);  // one step's friction impulse: O(h)
  }
}

std::string NGon(int n, double radius) {
  constexpr double kPi = 3.14159265358979323846;
  std::string verts = "{type: polygon, vertices: [";
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n - kPi / 2;  // a vertex at the bottom
    verts += (i ? ", [" : "[") + std::to_string(radius * std::cos(a)) + ", " +
             std::to_string(radius * std::sin(a)) + "]";
  }
  return verts + "]}";
}

// §B.1: a disc rolling without slip keeps its energy under GI; a 20-gon under Stewart–Trinkle
// loses energy at every facet impact.
TEST(GiTest, GiDiscKeepsEnergyWhileNGonLosesIt) {
  const double v0 = 1.0, w0 = 10.0;  // r ω0 = v0: rolling from the start
  Simulator gi(Parse(DiscScene(v0, w0, 0.3, 1e-3, "{type: disc, radius: 0.1}")));
  std::string text = DiscScene(v0, w0, 0.3, 1e-3, NGon(20, 0.1));
  text.replace(text.find("formulation: gi"), 15, "formulation: stewart-trinkle");
  Simulator st(Parse(text));
  const Trajectory a = gi.Rollout(gi.DefaultParams(), gi.InitialState(), 1000);
  const Trajectory b = st.Rollout(st.DefaultParams(), st.InitialState(), 1000);
  ASSERT_TRUE(a.ok) << a.failure;
  ASSERT_TRUE(b.ok) << b.failure;
  const double e0 = Energy(gi.scene(), a.states.front());
  double drift = 0.0;
  for (const State& x : a.states) drift = std::max(drift, std::abs(Energy(gi.scene(), x) - e0));
  EXPECT_LT(drift, 1e-9 * e0);  // round-off only: no faceting, no numerical damping when rolling
  EXPECT_NEAR(a.states.back().q[0], v0 * 1.0, 1e-9);  // rolled v0·t
  const double loss =
      1.0 - Energy(st.scene(), b.states.back()) / Energy(st.scene(), b.states.front());
  EXPECT_GT(loss, 0.1);  // measured ≈ 34% for the 20-gon after 1 s
}

// A planar ellipse dropped flat (or standing on end) comes to rest at the height of the semi-axis
// that points down.
TEST(GiTest, EllipseSettlesAtItsSemiAxis) {
  for (const auto& [axes, height] : std::vector<std::pair<std::string, double>>{
           {"[0.15, 0.08]", 0.08}, {"[0.08, 0.15]", 0.15}}) {
    std::string text = DiscScene(0.0, 0.0, 0.5, 1e-3, "{type: ellipse, semi_axes: " + axes + "}");
    text.replace(text.find("position: [0, 0.1]"), 18, "position: [0, 0.3]");
    Simulator sim(Parse(text));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 600);
    ASSERT_TRUE(tr.ok) << tr.failure;
    for (const State& x : tr.states) ASSERT_GT(x.q[1], height - 1e-9) << "t = " << x.t;
    const State& end = tr.states.back();
    EXPECT_NEAR(end.q[1], height, 1e-9);  // solver tolerance
    EXPECT_NEAR(end.v.norm(), 0.0, 1e-9);
  }
}

// A sphere dropped onto two fixed spheres rests at distance r + R from both centres and never
// penetrates.
TEST(GiTest, SphereComesToRestOnTwoSpheres) {
  for (const char* mu : {"0.0", "0.3"}) {
    const double r = 0.1, R = 0.2, d = 0.25;
    const std::string text =
        "name: gi-three-spheres\ndimension: 3\ngravity: [0, 0, -9.81]\n"
        "stepper: {formulation: gi, dt: 0.001, envelope: 0.001}\nfriction: {default: " +
        std::string(mu) +
        "}\n"
        "bodies:\n"
        "  - {name: left, kind: static, pose: {position: [-0.25, 0, 0]}, shapes: [{type: sphere, "
        "radius: 0.2}]}\n"
        "  - {name: right, kind: static, pose: {position: [0.25, 0, 0]}, shapes: [{type: sphere, "
        "radius: 0.2}]}\n"
        "  - {name: ball, mass: 1.0, pose: {position: [0, 0, 0.5]}, shapes: [{type: sphere, "
        "radius: "
        "0.1}]}\n";
    Simulator sim(Parse(text));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 1000);
    ASSERT_TRUE(tr.ok) << tr.failure;
    double min_gap = 1e9;
    for (const State& x : tr.states) {
      const Vector3d c = x.q.head<3>();
      for (const double cx : {-d, d})
        min_gap = std::min(min_gap, (c - Vector3d(cx, 0, 0)).norm() - r - R);
    }
    EXPECT_GT(min_gap, -1e-8);  // no penetration at any step
    const Vector3d c = tr.states.back().q.head<3>();
    EXPECT_NEAR((c - Vector3d(-d, 0, 0)).norm(), r + R, 1e-6);
    EXPECT_NEAR((c - Vector3d(d, 0, 0)).norm(), r + R, 1e-6);
    EXPECT_LT(tr.states.back().v.norm(), 1e-6);
    ::testing::Test::RecordProperty(std::string("min_gap_mu_") + mu, std::to_string(min_gap));
  }
}

// A box (intersection of six half-spaces) resting on a plane stays put.
TEST(GiTest, BoxRestsOnPlaneWithoutDrift) {
  const std::string text =
      "name: gi-box\ndimension: 3\ngravity: [0, 0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001, envelope: 0.001}\nfriction: {default: 0.5}\n"
      "bodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
      "  - {name: box, mass: 2.0, pose: {position: [0.3, -0.2, 0.1]}, shapes: [{type: box, "
      "half_extents: [0.2, 0.15, 0.1]}]}\n";
  Simulator sim(Parse(text));
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 500);
  ASSERT_TRUE(tr.ok) << tr.failure;
  double drift = 0.0;
  for (const State& x : tr.states) drift = std::max(drift, (x.q - x0.q).cwiseAbs().maxCoeff());
  EXPECT_LT(drift, 1e-9);  // solver tolerance; no creep
  // At rest the previous step's solution (State::warm_start) solves the next step exactly.
  // (from step 3: the first steps start from closest points and settle the contact point)
  for (std::size_t k = 3; k < tr.steps.size(); ++k)
    EXPECT_EQ(tr.steps[k].solver.iterations, 0) << "step " << k;
}

// The residual face: every step of a GI trajectory satisfies the GI step equations (§2's
// friction rows, not the solver's projection form) to solver tolerance.
TEST(GiTest, TrajectorySatisfiesStepEquations) {
  const std::string tilted_box =
      "name: gi-box-drop\ndimension: 3\ngravity: [0, 0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001, envelope: 0.001}\nfriction: {default: 0.5}\n"
      "bodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
      "  - {name: box, mass: 2.0, pose: {position: [0, 0, 0.3], rotation: {axis: [1, 1, 0], "
      "angle: 0.5}}, velocity: {linear: [0.5, 0, 0], angular: [0, 0, 2]}, shapes: [{type: box, "
      "half_extents: [0.2, 0.15, 0.1]}]}\n";
  // A disc sliding then rolling (250 steps); a tilted spinning box dropped on a floor: impact
  // on a corner, edge and face contacts (intersection multipliers), spatial rotation (400 steps).
  for (const auto& [text, steps] : std::vector<std::pair<std::string, int>>{
           {DiscScene(2.0, 5.0, 0.3, 1e-3, "{type: disc, radius: 0.1}"), 250}, {tilted_box, 400}}) {
    Simulator sim(Parse(text));
    const GeometricallyImplicit& gi = dynamic_cast<const GeometricallyImplicit&>(sim.formulation());
    const Params params = sim.DefaultParams();
    const Trajectory tr = sim.Rollout(params, sim.InitialState(), steps);
    ASSERT_TRUE(tr.ok) << tr.failure;
    double worst = 0.0, max_pn = 0.0;
    for (std::size_t k = 0; k + 1 < tr.states.size(); ++k) {
      const VectorXd z = gi.UnknownsFromStep(sim.scene(), tr.states[k], tr.states[k + 1]);
      const StepResiduals r = gi.Evaluate(sim.scene(), params, tr.states[k], StepInput{}, z);
      worst = std::max(worst, r.Violation());
      if (r.layout.nc > 0)
        max_pn = std::max(max_pn, z.segment(r.layout.pn(), r.layout.nc).maxCoeff());
    }
    EXPECT_LT(worst, 1e-8);  // McpSolver tolerance 1e-10 on the rows scaled by 1/h = 1e3
    EXPECT_GT(max_pn, 0.0);  // contact did happen
  }
}

// §B.1 in 3D (the quadratic cone): a sphere launched with v0 > r ω0 slides until
// t* = 2 (v0 − r ω0)/(7 μ g) and then rolls at (5 v0 + 2 r ω0)/7.
TEST(GiTest, SphereRollingTransitionAndSpeed) {
  const double v0 = 2.0, w0 = 5.0, r = 0.1, mu = 0.3, h = 1e-3;
  const std::string text =
      "name: gi-sphere\ndimension: 3\ngravity: [0, 0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001, envelope: 0.001}\nfriction: {default: 0.3}\n"
      "bodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
      "  - {name: ball, mass: 1.0, pose: {position: [0, 0, 0.1]}, velocity: {linear: [2, 0, 0], "
      "angular: [0, 5, 0]}, shapes: [{type: sphere, radius: 0.1}]}\n";
  Simulator sim(Parse(text));
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 300);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const auto slip = [&](const State& x) {
    const Isometry3d X = PoseFromQ(Dim::kSpatial, x.q.data());
    const Vector3d w_W = X.linear() * x.v.segment<3>(3);
    return Vector3d(x.v[0] - r * w_W.y(), x.v[1] + r * w_W.x(), 0.0).norm();
  };
  double t_roll = -1.0;
  for (const State& x : tr.states)
    if (t_roll < 0 && slip(x) < 1e-6) t_roll = x.t;
  const double t_star = 2 * (v0 - r * w0) / (7 * mu * kG);
  EXPECT_NEAR(t_roll, t_star, 2 * h);  // the transition lands on a step boundary: O(h)
  EXPECT_NEAR(tr.states.back().v[0], (5 * v0 + 2 * r * w0) / 7, 2 * mu * kG * h);
  EXPECT_NEAR(tr.states.back().v[1], 0.0, 1e-9);  // friction stays in the plane of the slip
  for (const State& x : tr.states) EXPECT_NEAR(x.q[2], r, 1e-9) << "t = " << x.t;
}

// Prescribed bodies enter through their pose at t + h and their velocity over the step (∂ψ/∂t):
// a box on a floor that moves along (0.5, 0.1) m/s is lifted and dragged until it moves with it.
TEST(GiTest, BoxIsCarriedByMovingFloor) {
  const std::string text =
      "name: gi-moving-floor\ndimension: 2\ngravity: [0, -9.81]\n"
      "stepper: {formulation: gi, dt: 0.001, envelope: 0.001}\nfriction: {default: 0.5}\n"
      "bodies:\n"
      "  - {name: floor, kind: prescribed, shapes: [{type: halfplane}], motion: {x: {velocity: "
      "0.5}, y: {velocity: 0.1}}}\n"
      "  - {name: box, mass: 1.0, pose: {position: [0, 0.1]}, shapes: [{type: polygon, vertices: "
      "[[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], [-0.2, 0.1]]}]}\n";
  Simulator sim(Parse(text));
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 400);
  ASSERT_TRUE(tr.ok) << tr.failure;
  for (const State& x : tr.states) ASSERT_GT(x.q[1] - 0.1 * x.t, 0.1 - 1e-9) << "t = " << x.t;
  const State& end = tr.states.back();
  EXPECT_NEAR(end.v[0], 0.5, 1e-6);  // sticks after t = 0.5/(μ g) ≈ 0.1 s (creep ≤ 3e-8 m/s)
  EXPECT_NEAR(end.v[1], 0.1, 1e-9);
  EXPECT_NEAR(end.q[1] - 0.1 * end.t, 0.1, 1e-9);  // resting on the floor
  EXPECT_NEAR(end.q[2], 0.0, 1e-9);
}

// A solve that cannot converge is reported, not accepted; unsupported scenes throw.
TEST(GiTest, FailuresAreReported) {
  Simulator sim(Parse(DiscScene(2.0, 5.0, 0.3, 1e-3, "{type: disc, radius: 0.1}")));
  McpOptions tight;
  tight.max_iterations = 1;
  tight.max_restarts = 0;
  const GeometricallyImplicit gi(sim.scene().options, tight);
  State x = sim.InitialState(), next;
  x.v[1] = -3.0;  // an impact: more than one Newton step
  StepInfo info;
  gi.Step(sim.scene(), x, StepInput{}, nullptr, &next, &info);
  EXPECT_FALSE(info.ok);
  EXPECT_NE(info.failure.find("MCP solver failed"), std::string::npos) << info.failure;
  EXPECT_EQ(next.q, x.q);  // *next == x on failure

  Scene capsule = Parse(
      "name: c\ndimension: 3\nstepper: {formulation: gi}\nbodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
      "  - {name: pill, mass: 1.0, pose: {position: [0, 0, 1]}, shapes: [{type: capsule, radius: "
      "0.1, "
      "half_length: 0.2}]}\n");
  // Rejected when the Simulator is built (capabilities.h), naming the body and the feature.
  EXPECT_THROW(
      {
        try {
          Simulator with_capsule(capsule);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("body 'pill'"), std::string::npos) << e.what();
          EXPECT_NE(std::string(e.what()).find("capsule"), std::string::npos) << e.what();
          throw;
        }
      },
      std::invalid_argument);
  EXPECT_THROW(Parse("name: s\ndimension: 2\nstepper: {formulation: gi, solver: pgs}\n"
                     "bodies:\n  - {name: d, shapes: [{type: disc, radius: 0.1}]}\n"),
               std::invalid_argument);
}

// The residual face's Jacobians (unknowns and the μ, mass parameter columns) match finite
// differences.
TEST(GiTest, EvaluateJacobiansMatchFiniteDifferences) {
  Simulator sim(Parse(DiscScene(2.0, 5.0, 0.3, 1e-3,
                                "{type: polygon, vertices: [[-0.1, -0.1], [0.1, -0.1], [0.1, "
                                "0.1], [-0.1, 0.1]]}",
                                0.5)));
  const GeometricallyImplicit gi(sim.scene().options);
  State x = sim.InitialState();
  x.q[1] = 0.12;
  x.q[2] = 0.3;
  VectorXd z0;
  gi.StepProblem(sim.scene(), x, StepInput{}, &z0);
  const VectorXd z = GenericPoint(gi, sim.scene(), x, z0);
  const Params params = sim.DefaultParams();
  const StepResiduals r = gi.Evaluate(sim.scene(), params, x, StepInput{}, z);
  ASSERT_EQ(r.layout.size(), z.size());
  ASSERT_EQ(r.d_equality.cols(), z.size() + static_cast<int>(r.param_columns.size()));
  double worst = 0.0;
  const auto compare = [&](const StepResiduals& p, const StepResiduals& m, double step, int col) {
    const VectorXd de = (p.equality - m.equality) / (2 * step);
    const VectorXd db = (p.comp_b - m.comp_b) / (2 * step);
    const VectorXd da = (p.comp_a - m.comp_a) / (2 * step);
    worst = std::max(worst, (de - r.d_equality.col(col)).cwiseAbs().maxCoeff());
    worst = std::max(worst, (db - r.d_comp_b.col(col)).cwiseAbs().maxCoeff());
    worst = std::max(worst, (da - r.d_comp_a.col(col)).cwiseAbs().maxCoeff());
  };
  for (int j = 0; j < z.size(); ++j) {
    const double eps = 1e-6;
    VectorXd zp = z, zm = z;
    zp[j] += eps;
    zm[j] -= eps;
    compare(gi.Evaluate(sim.scene(), params, x, StepInput{}, zp),
            gi.Evaluate(sim.scene(), params, x, StepInput{}, zm), eps, j);
  }
  for (std::size_t k = 0; k < r.param_columns.size(); ++k) {
    const double eps = 1e-6;
    Params pp = params, pm = params;
    pp.values[r.param_columns[k]] += eps;
    pm.values[r.param_columns[k]] -= eps;
    compare(gi.Evaluate(sim.scene().ApplyParams(pp), pp, x, StepInput{}, z),
            gi.Evaluate(sim.scene().ApplyParams(pm), pm, x, StepInput{}, z), eps,
            z.size() + static_cast<int>(k));
  }
  EXPECT_LT(worst, kFdTol);
}

}  // namespace
}  // namespace vinci::sim