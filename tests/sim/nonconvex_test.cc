// Non-convex non-penetration (docs/formulations.md §7): concave polygons, corner contacts, the snag
// that per-edge constraints produce, and the corner rows of the step equations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>

#include "test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Shoelace mass properties are exact in floating point up to rounding.
constexpr double kExactTol = 1e-12;

Shape ConcavePolygon(std::vector<Vector2d> v) {
  Shape s;
  s.type = ShapeType::kConcavePolygon;
  s.name = "p";
  for (const Vector2d& p : v) s.vertices.push_back(Vector3d(p.x(), p.y(), 0.0));
  return s;
}

// The L of [0,2]x[0,1] ∪ [0,1]x[1,3]: area 4, centroid and inertia by parts.
Shape LShape() { return ConcavePolygon({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 3}, {0, 3}}); }

TEST(ConcavePolygonTest, MassPropertiesOfAnLAreExact) {
  const UnitMassProperties m = ComputeUnitMassProperties(LShape());
  // Parts: A = [0,2]x[0,1] (area 2, centroid (1, 0.5)), B = [0,1]x[1,3] (area 2, (0.5, 2)).
  EXPECT_NEAR(m.volume, 4.0, kExactTol);
  const Vector2d c(0.75, 1.25);
  EXPECT_NEAR(m.centroid_S.x(), c.x(), kExactTol);
  EXPECT_NEAR(m.centroid_S.y(), c.y(), kExactTol);
  // Polar moment per unit area about the centroid: Σ (a (w² + h²)/12 + a |c_i − c|²) / 4.
  const double ja = 2.0 * (4.0 + 1.0) / 12.0 + 2.0 * (Vector2d(1, 0.5) - c).squaredNorm();
  const double jb = 2.0 * (1.0 + 4.0) / 12.0 + 2.0 * (Vector2d(0.5, 2) - c).squaredNorm();
  EXPECT_NEAR(m.inertia_per_mass_S(2, 2), (ja + jb) / 4.0, kExactTol);
  // ∫(y − c_y)² per unit area.
  const double iyy = 2.0 * 1.0 / 12.0 + 2.0 * 0.75 * 0.75 + 2.0 * 4.0 / 12.0 + 2.0 * 0.75 * 0.75;
  EXPECT_NEAR(m.inertia_per_mass_S(0, 0), iyy / 4.0, kExactTol);
}

TEST(ConcavePolygonTest, RejectsNonSimpleOrClockwisePolygons) {
  // A bow tie (self-intersecting) and a clockwise square.
  Shape bowtie = ConcavePolygon({{0, 0}, {1, 1}, {1, 0}, {0, 1}});
  EXPECT_THROW(PrepareShape(&bowtie), std::invalid_argument);
  Shape cw = ConcavePolygon({{0, 0}, {0, 1}, {1, 1}, {1, 0}});
  try {
    PrepareShape(&cw);
    FAIL() << "clockwise polygon accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("counter-clockwise"), std::string::npos) << e.what();
  }
  const std::string yaml = R"(
dimension: 2
bodies:
  - name: g
    kind: static
    shapes: [{type: concave_polygon, vertices: [[0, 0], [1, 1], [1, 0], [0, 1]]}]
)";
  try {
    ParseScene(yaml, "bowtie.yaml");
    FAIL() << "bow tie accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("bowtie.yaml:6"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("intersect"), std::string::npos) << e.what();
  }
}

// A point (a triangle's tip) against the L: corner contact at the convex corner (2, 1), two
// plain contacts at the reflex corner (1, 1).
TEST(ConcavePolygonTest, CornerContactAtConvexCornersOnly) {
  const Shape L = LShape();
  Shape tip;
  tip.type = ShapeType::kPolygon;
  tip.vertices = {Vector3d(0, 0, 0), Vector3d(0.5, 0.3, 0), Vector3d(-0.5, 0.3, 0)};
  const double env = 0.01;
  std::vector<ContactPoint> out;
  // Tip just right of and level with the convex corner (2, 1): on the top edge's line.
  Isometry3d X = Isometry3d::Identity();
  X.translation() = Vector3d(2.004, 1.0, 0);
  CollideShapes(tip, X, L, Isometry3d::Identity(), env, &out);
  // The contacts of the tip vertex (the others are the L's corner (2, 1) against the tip's
  // edges, a corner of the triangle).
  const auto of_tip = [&](const Vector3d& tip_W) {
    std::vector<ContactPoint> v;
    for (const ContactPoint& c : out)
      if ((c.p_A_W - tip_W).norm() < 1e-12) v.push_back(c);
    return v;
  };
  std::vector<ContactPoint> mine = of_tip(X.translation());
  ASSERT_EQ(mine.size(), 1u);
  EXPECT_TRUE(mine[0].corner);
  EXPECT_NEAR(std::max(mine[0].gap, mine[0].gap2), 0.004, 1e-12);  // the right edge's line
  EXPECT_NEAR(std::min(mine[0].gap, mine[0].gap2), 0.0, 1e-12);    // the top edge's line
  // Tip in the reflex corner (1, 1), slightly inside: two ordinary contacts.
  out.clear();
  X.translation() = Vector3d(1.003, 1.002, 0);
  Shape flat = tip;  // a tip pointing down-left into the corner
  flat.vertices = {Vector3d(0, 0, 0), Vector3d(0.5, 0.1, 0), Vector3d(0.1, 0.5, 0)};
  CollideShapes(flat, X, L, Isometry3d::Identity(), env, &out);
  int corners = 0, plain = 0;
  for (const ContactPoint& c : of_tip(X.translation())) (c.corner ? corners : plain) += 1;
  EXPECT_EQ(corners, 0);
  EXPECT_EQ(plain, 2);
}

double MinGap(const Simulator& sim, const State& x) {
  Workspace ws;
  const Scene& model = sim.Resolve(sim.DefaultParams(), &ws);
  std::vector<Contact> contacts;
  FindContacts(model, ComputeBodyKinematics(model, x), model.options.envelope, &contacts);
  double g = kInf;
  for (const Contact& c : contacts)
    g = std::min(g, c.point.corner ? std::max(c.point.gap, c.point.gap2) : c.point.gap);
  return g;
}

// The block slides left at 1 m/s across the trench [-0.5, 0.5] x [-0.3, 0] (example scene).
// Its leading bottom corner passes the trench's right convex corner (0.5, 0) at t = 1 s and
// meets the left one (-0.5, 0), on the extended line of the left trench wall, at t = 2 s.
TEST(NonconvexCornerTest, VertexSlidesPastCornerWithoutSnag) {
  // Frictionless and the floor flat: the horizontal velocity must stay −1 m/s; the LCP solve
  // is exact up to Lemke's pivoting round-off.
  constexpr double kVelocityTol = 1e-6;
  // Position-level rows keep every gap ≥ 0 up to round-off.
  constexpr double kPenetrationTol = 1e-9;
  // Start 3.0003: crossings fall inside steps. Start 3.0: the leading corner reaches each
  // trench corner exactly at a step's end (a tie of the corner's two predicted gaps, and the
  // block's corner coincides with the floor's).
  for (const double x_start : {3.0003, 3.0}) {
    Scene scene = LoadExample("concave_trench.yaml");
    scene.bodies[1].X_WB0.translation().x() = x_start;
    Simulator sim(scene);
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3000);
    ASSERT_TRUE(tr.ok) << tr.failure;
    double worst_vx = 0.0, worst_vy = 0.0, worst_w = 0.0, min_gap = kInf;
    for (std::size_t k = 1; k < tr.states.size(); ++k) {
      const State& x = tr.states[k];
      worst_vx = std::max(worst_vx, std::abs(x.v[0] + 1.0));
      worst_vy = std::max(worst_vy, std::abs(x.v[1]));
      worst_w = std::max(worst_w, std::abs(x.v[2]));
      if (k % 10 == 0 || (k > 990 && k < 1010) || (k > 1990 && k < 2010))
        min_gap = std::min(min_gap, MinGap(sim, x));
    }
    EXPECT_LT(worst_vx, kVelocityTol) << x_start;
    EXPECT_LT(worst_vy, kVelocityTol) << x_start;
    EXPECT_LT(worst_w, kVelocityTol) << x_start;
    EXPECT_GT(min_gap, -kPenetrationTol) << x_start;
    // It has crossed: 3 m in 3 s, still on the floor.
    EXPECT_NEAR(tr.states.back().q[0], x_start - 3.0, 1e-6);
    EXPECT_NEAR(tr.states.back().q[1], 0.1, 1e-6);
  }
}

// The iterative solvers (PGS with c in the contact's block, Fischer–Burmeister Newton) solve
// the corner LCP too: no snag.
TEST(NonconvexCornerTest, IterativeSolversAlsoSlidePastCorner) {
  constexpr double kVelocityTol = 1e-6;  // iterative solvers' tolerance, accumulated
  for (const char* solver : {"pgs", "fb-newton"}) {
    Scene scene = LoadExample("concave_trench.yaml");
    scene.options.solver = solver;
    Simulator sim(scene);
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3000);
    ASSERT_TRUE(tr.ok) << solver << ": " << tr.failure;
    double worst = 0.0;
    for (const State& x : tr.states)
      worst = std::max({worst, std::abs(x.v[0] + 1.0), std::abs(x.v[1]), std::abs(x.v[2])});
    EXPECT_LT(worst, kVelocityTol) << solver;
    EXPECT_NEAR(tr.states.back().q[0], 0.0003, 1e-6) << solver;
  }
}

// Anitescu–Potra (velocity-level p_n rows; the corner's c row keeps its gaps): no snag either.
TEST(NonconvexCornerTest, AnitescuPotraVertexSlidesPastCornerWithoutSnag) {
  constexpr double kVelocityTol = 1e-6;  // frictionless: vx is conserved up to round-off
  Scene scene = LoadExample("concave_trench.yaml");
  scene.options.formulation = FormulationType::kAnitescuPotra;
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  double worst_vx = 0.0, worst_vy = 0.0;
  for (const State& x : tr.states) {
    worst_vx = std::max(worst_vx, std::abs(x.v[0] + 1.0));
    worst_vy = std::max(worst_vy, std::abs(x.v[1]));
  }
  EXPECT_LT(worst_vx, kVelocityTol);
  EXPECT_LT(worst_vy, kVelocityTol);
  EXPECT_NEAR(tr.states.back().q[0], 0.0003, 1e-6);
}

// With friction μ = 0.1 and v0 = −2 m/s the block decelerates at μ g exactly (each step removes
// μ g h), across both trench corners, and stops at t = 2/(μ g) ≈ 2.04 s after 2.04 m.
TEST(NonconvexCornerTest, SlidingWithFrictionAcrossCornersDeceleratesAtMuG) {
  constexpr double kVelocityTol = 1e-6;  // Lemke round-off accumulated over 2000 steps
  Scene scene = LoadExample("concave_trench.yaml");
  scene.default_mu = 0.1;
  scene.bodies[1].v0_W.x() = -2.0;
  Simulator sim(scene);
  const double h = scene.options.dt, a = 0.1 * 9.81;
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 2000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  for (std::size_t k = 1; k < tr.states.size(); ++k) {
    EXPECT_NEAR(tr.states[k].v[0], -2.0 + a * h * k, kVelocityTol) << "step " << k;
    EXPECT_NEAR(tr.states[k].v[1], 0.0, kVelocityTol) << "step " << k;
  }
  // Passed the second corner: the leading corner (centre − 1.5) is beyond x = −0.5.
  EXPECT_LT(tr.states.back().q[0] - 1.5, -0.5);
}

TEST(NonconvexCornerTest, PerEdgeConstraintsSnag) {
  // The scene file's switch: stepper.nonconvex_corners: false.
  std::ifstream in(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/concave_trench.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string on = "nonconvex_corners: true";
  ASSERT_NE(text.find(on), std::string::npos);
  text.replace(text.rfind(on), on.size(), "nonconvex_corners: false");  // the stepper line
  const Scene scene = ParseScene(text, "per_edge.yaml");
  ASSERT_FALSE(scene.options.nonconvex_corners);
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3000);
  // At the first trench corner (t ≈ 1 s) the per-edge row of the block's left side against
  // the floor's corner vertex, and of the trench wall against the block's corner, act on lines
  // the vertices are already behind: the block is kicked (|vx| jumps above 1.2 m/s) and then
  // stopped dead with its leading corner at the trench edge (centre x ≈ 2.0) — it never crosses
  // (the rollout may also end in a failed LCP, as it does with Lemke).
  double max_speed = 0.0, min_x = kInf;
  for (const State& x : tr.states) {
    max_speed = std::max(max_speed, std::abs(x.v[0]));
    min_x = std::min(min_x, x.q[0]);
  }
  EXPECT_GT(max_speed, 1.2);
  EXPECT_GT(min_x, 1.99);
  EXPECT_LT(std::abs(tr.states.back().v[0]), 0.01);
}

// A block pressed into the reflex corner of an L-shaped floor + wall by tilted gravity stays
// put: no drift, no penetration.
TEST(NonconvexCornerTest, BlockRestsInConcaveCorner) {
  constexpr double kDriftTol = 1e-9;  // exact rest: the LCP gives ν = 0 up to round-off
  const std::string yaml = R"(
dimension: 2
gravity: [-3.0, -9.81]
stepper: {dt: 0.001, envelope: 0.002}
friction: {default: 0.5}
bodies:
  - name: floor_and_wall
    kind: static
    shapes:
      - type: concave_polygon
        vertices: [[-2, -1], [2, -1], [2, 0], [-1, 0], [-1, 1], [-2, 1]]
  - name: block
    mass: 2.0
    pose: {position: [-0.8, 0.1]}
    shapes: [{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], [-0.2, 0.1]]}]
)";
  Simulator sim(ParseScene(yaml, "corner.yaml"));
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 1000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  EXPECT_LT((tr.states.back().q - x0.q).cwiseAbs().maxCoeff(), kDriftTol);
  EXPECT_LT(tr.states.back().v.cwiseAbs().maxCoeff(), kDriftTol);
  EXPECT_GT(MinGap(sim, tr.states.back()), -kDriftTol);
  EXPECT_GE(tr.steps.back().contacts, 3);  // floor (2 corners), wall
}

// Each planar kind dropped into the reflex corner of a static L (floor y = 0 for x > −1, wall
// x = −1), pressed in by tilted gravity, comes to rest flush in the corner: disc (exact
// distance to each edge), rounded segment (end discs), box (vertex features) and a dynamic L
// (concave against concave, inertia from its outline).
TEST(NonconvexCornerTest, EachPlanarKindSettlesInAReflexCorner) {
  constexpr double kRestTol = 1e-6;  // settled after 1.5 s: round-off and the last bounce
  struct Case {
    std::string shape;
    Vector2d rest;  // body origin at rest
  };
  const std::vector<Case> cases = {
      {"{type: disc, radius: 0.1}", {-0.9, 0.1}},
      {"{type: segment, half_length: 0.2, radius: 0.05}", {-0.75, 0.05}},
      {"{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], [-0.2, 0.1]]}",
       {-0.8, 0.1}},
      // The L [0,0.2]x[0,0.1] ∪ [0,0.1]x[0.1,0.3] about its centroid (0.075, 0.125).
      {"{type: concave_polygon, vertices: [[-0.075, -0.125], [0.125, -0.125], [0.125, -0.025], "
       "[0.025, -0.025], [0.025, 0.175], [-0.075, 0.175]]}",
       {-0.925, 0.125}},
  };
  for (const Case& c : cases) {
    const std::string yaml = R"(
dimension: 2
gravity: [-3.0, -9.81]
stepper: {dt: 0.001, envelope: 0.002}
friction: {default: 0.3}
bodies:
  - name: floor_and_wall
    kind: static
    shapes:
      - type: concave_polygon
        vertices: [[-2, -1], [2, -1], [2, 0], [-1, 0], [-1, 1], [-2, 1]]
  - name: body
    mass: 1.0
    pose: {position: [)" + std::to_string(c.rest.x() + 0.001) +
                             ", " + std::to_string(c.rest.y() + 0.001) + R"(]}
    shapes: [)" + c.shape + "]\n";
    Simulator sim(ParseScene(yaml, "settle.yaml"));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 1500);
    ASSERT_TRUE(tr.ok) << c.shape << ": " << tr.failure;
    const State& end = tr.states.back();
    EXPECT_NEAR(end.q[0], c.rest.x(), kRestTol) << c.shape;
    EXPECT_NEAR(end.q[1], c.rest.y(), kRestTol) << c.shape;
    EXPECT_LT(end.v.cwiseAbs().maxCoeff(), kRestTol) << c.shape;
    EXPECT_GT(MinGap(sim, end), -kRestTol) << c.shape;
  }
}

// A dynamic L-shaped body (inertia from its outline) dropped flat onto a half-plane settles on
// its base: concave polygon against a half-plane (its convex vertices).
TEST(NonconvexCornerTest, DynamicConcaveBodyRestsOnHalfPlane) {
  constexpr double kRestTol = 1e-6;  // settled after 1 s
  const std::string yaml = R"(
dimension: 2
gravity: [0, -9.81]
stepper: {dt: 0.001, envelope: 0.002}
bodies:
  - {name: floor, kind: static, shapes: [{type: halfplane}]}
  - name: l
    mass: 1.0
    pose: {position: [0, 0.135]}
    shapes:
      - type: concave_polygon
        vertices: [[-0.075, -0.125], [0.125, -0.125], [0.125, -0.025], [0.025, -0.025],
                   [0.025, 0.175], [-0.075, 0.175]]
)";
  Simulator sim(ParseScene(yaml, "l.yaml"));
  // Inertia from the outline: the L of the mass-properties test scaled by 0.1, mass 1 kg.
  EXPECT_NEAR(sim.scene().bodies[1].inertia(2, 2),
              ComputeUnitMassProperties(sim.scene().bodies[1].shapes[0]).inertia_per_mass_S(2, 2),
              1e-15);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 1000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const State& end = tr.states.back();
  EXPECT_NEAR(end.q[0], 0.0, kRestTol);
  EXPECT_NEAR(end.q[1], 0.125, kRestTol);
  EXPECT_NEAR(end.q[2], 0.0, kRestTol);
  EXPECT_LT(end.v.cwiseAbs().maxCoeff(), kRestTol);
}

// The residual face: corner unknowns c at the end of z; a simulated step satisfies it.
TEST(NonconvexCornerTest, TrajectorySatisfiesStepEquationsWithCornerRows) {
  constexpr double kResidualTol = 1e-8;  // Lemke solution, residual scaled by 1/h
  for (const FormulationType f :
       {FormulationType::kStewartTrinkle, FormulationType::kAnitescuPotra}) {
    Scene scene = LoadExample("concave_trench.yaml");
    scene.options.formulation = f;
    Simulator sim(scene);
    const Params p = sim.DefaultParams();
    const Trajectory tr = sim.Rollout(p, sim.InitialState(), 2100);
    ASSERT_TRUE(tr.ok) << tr.failure;
    int steps_with_corners = 0;
    for (std::size_t k = 900; k + 1 < tr.states.size(); k += 50) {
      const State& x0 = tr.states[k];
      const State& x1 = tr.states[k + 1];
      Workspace ws;
      const Scene& model = sim.Resolve(p, &ws);
      const StepLayout l = sim.formulation().Layout(model, x0);
      VectorXd z = VectorXd::Zero(l.size());
      z.segment(l.q1(), l.nq) = x1.q;
      z.segment(l.v1(), l.nv) = x1.v;
      const int ncomp = l.nc + l.nc * l.nd + l.nc;
      ASSERT_EQ(x1.warm_start.size(), ncomp + l.nk);
      z.segment(l.pn(), ncomp) = x1.warm_start.head(ncomp);
      z.segment(l.corner(), l.nk) = x1.warm_start.tail(l.nk);
      const StepResiduals r = sim.formulation().Evaluate(model, p, x0, StepInput{}, z);
      EXPECT_LT(r.Violation(), kResidualTol) << sim.formulation().name() << " step " << k;
      ASSERT_EQ(r.comp_a.size(), ncomp + l.nk);
      steps_with_corners += l.nk > 0 ? 1 : 0;
      // Jacobian columns of c: identity in comp_a, and in comp_b one 1 on its own row and one on
      // its contact's normal row.
      for (int k2 = 0; k2 < l.nk; ++k2) {
        EXPECT_EQ(r.d_comp_a(ncomp + k2, l.corner() + k2), 1.0);
        EXPECT_EQ(r.d_comp_b.col(l.corner() + k2).sum(), 2.0);
      }
    }
    EXPECT_GT(steps_with_corners, 0);
  }
}

// The analytic Jacobians of the corner rows (columns ν_ℓ+1 and c) match central differences
// of Evaluate at a generic point.
TEST(NonconvexCornerTest, CornerRowJacobiansMatchFiniteDifferences) {
  constexpr double kFdTol = 1e-6;  // central differences of rows linear in ν and c: round-off
  Simulator sim(LoadExample("concave_trench.yaml"));
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), 1000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const State& x0 = tr.states[999];
  Workspace ws;
  const Scene& model = sim.Resolve(p, &ws);
  const StepLayout l = sim.formulation().Layout(model, x0);
  ASSERT_GT(l.nk, 0);
  std::srand(11);
  VectorXd z = VectorXd::Random(l.size());
  const StepResiduals r = sim.formulation().Evaluate(model, p, x0, StepInput{}, z);
  const double eps = 1e-6;
  std::vector<int> cols;
  for (int j = 0; j < l.nv; ++j) cols.push_back(l.v1() + j);
  for (int j = 0; j < l.nk; ++j) cols.push_back(l.corner() + j);
  for (int j = 0; j < l.nc; ++j) cols.push_back(l.pn() + j);
  for (int j : cols) {
    VectorXd zp = z, zm = z;
    zp[j] += eps;
    zm[j] -= eps;
    const StepResiduals rp = sim.formulation().Evaluate(model, p, x0, StepInput{}, zp);
    const StepResiduals rm = sim.formulation().Evaluate(model, p, x0, StepInput{}, zm);
    const VectorXd fd_b = (rp.comp_b - rm.comp_b) / (2 * eps);
    const VectorXd fd_a = (rp.comp_a - rm.comp_a) / (2 * eps);
    const VectorXd fd_e = (rp.equality - rm.equality) / (2 * eps);
    EXPECT_LT((fd_b - r.d_comp_b.col(j)).cwiseAbs().maxCoeff(), kFdTol) << "column " << j;
    EXPECT_LT((fd_a - r.d_comp_a.col(j)).cwiseAbs().maxCoeff(), kFdTol) << "column " << j;
    EXPECT_LT((fd_e - r.d_equality.col(j)).cwiseAbs().maxCoeff(), kFdTol) << "column " << j;
  }
}

// A small block slides off the trench's edge, tumbles in and comes to rest on the trench floor
// between its reflex corners; no step fails and nothing penetrates beyond round-off.
TEST(NonconvexCornerTest, SmallBlockFallsIntoTrenchAndRests) {
  constexpr double kRestTol = 1e-6;  // at rest after 3 s
  Scene scene = LoadExample("concave_trench.yaml");
  Body& b = scene.bodies[1];
  b.shapes[0].vertices = {Vector3d(-0.15, -0.05, 0), Vector3d(0.15, -0.05, 0),
                          Vector3d(0.15, 0.05, 0), Vector3d(-0.15, 0.05, 0)};
  b.X_WB0.translation() = Vector3d(1.5, 0.05, 0);
  b.v0_W = Vector3d(-3.0, 0, 0);
  scene.default_mu = 0.3;
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3000);
  ASSERT_TRUE(tr.ok) << tr.failure;
  double min_gap = kInf;
  for (std::size_t k = 0; k < tr.states.size(); k += 5)
    min_gap = std::min(min_gap, MinGap(sim, tr.states[k]));
  EXPECT_GT(min_gap, -1e-3);  // impacts resolved within one step (position-level rows)
  const State& end = tr.states.back();
  EXPECT_LT(end.v.cwiseAbs().maxCoeff(), kRestTol);
  EXPECT_GT(end.q[0], -0.5 + 0.05);  // inside the trench
  EXPECT_LT(end.q[0], 0.5 - 0.05);
  // Lying flat (θ a multiple of π/2 with the matching half-height) on the floor y = −0.3.
  const double c = std::abs(std::cos(end.q[2])), half = c > 0.5 ? 0.05 : 0.15;
  EXPECT_NEAR(end.q[1], -0.3 + half, 1e-4);
  EXPECT_GT(MinGap(sim, end), -kRestTol);
}

}  // namespace
}  // namespace vinci::sim
