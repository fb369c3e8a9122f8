// The first-order (damping-dominated) model, docs/formulations.md §8: closed-form checks.
#include <gtest/gtest.h>

#include <cmath>
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

// ν = C⁻¹F is one linear solve; Lemke's answer is exact up to round-off.
constexpr double kExactTol = 1e-12;
// Contact steps: the LCP is solved to Lemke's residual tolerance (1e-9, scaled by h).
constexpr double kLcpTol = 1e-8;

// A planar block (0.4 x 0.2) under constant force, damping C, no gravity; optional static
// half-plane floor at y = 0 (normal +y) and wall at x = 0 (normal +x).
std::string BlockYaml(const std::string& damping, const std::string& force, const std::string& pos,
                      double mu, bool floor, bool wall, const std::string& torque = "0") {
  std::string y = "dimension: 2\ngravity: [0, 0]\n";
  y += "stepper: {formulation: first-order, dt: 0.01, envelope: 0.005}\n";
  y += "friction: {default: " + std::to_string(mu) + "}\nbodies:\n";
  if (floor) y += "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n";
  if (wall) {
    y += "  - {name: wall, kind: static, pose: {position: [0, 0], angle: -1.5707963267948966},\n";
    y += "     shapes: [{type: halfplane}]}\n";
  }
  y += "  - name: block\n    mass: 1.0\n    damping: " + damping + "\n    force: " + force +
       "\n    torque: " + torque + "\n    pose: {position: " + pos + "}\n";
  y += "    shapes: [{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], [-0.2, "
       "0.1]]}]\n";
  return y;
}

TEST(FirstOrderTest, FreeBodyMovesAtCInverseF) {
  // Full symmetric positive definite C, force (1, −2), torque 0.3.
  Simulator sim(ParseScene(BlockYaml("[[2.0, 0.5, 0.0], [0.5, 4.0, 0.2], [0.0, 0.2, 0.5]]",
                                     "[1.0, -2.0]", "[0, 5]", 0.5, false, false, "0.3"),
                           "free.yaml"));
  EXPECT_EQ(sim.formulation().name(), "first-order");
  Eigen::Matrix3d C;
  C << 2.0, 0.5, 0.0, 0.5, 4.0, 0.2, 0.0, 0.2, 0.5;
  const Vector3d expected = C.inverse() * Vector3d(1.0, -2.0, 0.3);
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, 50);
  ASSERT_TRUE(tr.ok) << tr.failure;
  for (std::size_t k = 1; k < tr.states.size(); ++k) {
    EXPECT_LT((tr.states[k].v - expected).cwiseAbs().maxCoeff(), kExactTol) << "step " << k;
  }
  // Position after 50 steps of h = 0.01: q0 + 0.5 ν (explicit in ν_ℓ+1, exact here).
  EXPECT_LT((tr.states.back().q - x0.q - 0.5 * expected).cwiseAbs().maxCoeff(), 1e-12);
}

// Spatial: a box on a half-space with weight, pushed sideways beyond friction, C 6x6 diagonal.
// Slides at (F_t − μ m g)/C_x with no vertical motion; ν = C⁻¹F while in the air first.
TEST(FirstOrderTest, SpatialBoxFallsThenSlidesAtClosedFormSpeed) {
  const std::string yaml = R"(
dimension: 3
gravity: [0, 0, -9.81]
stepper: {formulation: first-order, dt: 0.01, envelope: 0.005}
friction: {default: 0.2}
bodies:
  - {name: table, kind: static, shapes: [{type: halfspace}]}
  - name: box
    mass: 1.0
    damping: [4.0, 4.0, 9.81, 1.0, 1.0, 1.0]
    force: [3.0, 0.0, 0.0]
    pose: {position: [0, 0, 0.15]}
    shapes: [{type: box, half_extents: [0.2, 0.2, 0.1]}]
)";
  Simulator sim(ParseScene(yaml, "box.yaml"));
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 60);
  ASSERT_TRUE(tr.ok) << tr.failure;
  // In the air: ν = C⁻¹(3, 0, −9.81) = (0.75, 0, −1) m/s: falls 0.05 m in 5 steps.
  EXPECT_NEAR(tr.states[1].v[0], 0.75, kExactTol);
  EXPECT_NEAR(tr.states[1].v[2], -1.0, kExactTol);
  const State& end = tr.states.back();
  EXPECT_NEAR(end.v[0], (3.0 - 0.2 * 9.81) / 4.0, kLcpTol);  // sliding on the table
  EXPECT_NEAR(end.v[2], 0.0, kLcpTol);
  EXPECT_NEAR(end.q[2], 0.1, kLcpTol);
}

TEST(FirstOrderTest, PushedIntoWallStopsWithoutPenetration) {
  // Force −1 N along x toward the wall at x = 0; block face starts 0.3 m away: free speed
  // 1/C_x = 0.5 m/s, arrival after 0.6 s, then at rest against the wall.
  Simulator sim(ParseScene(
      BlockYaml("[2.0, 2.0, 0.5]", "[-1.0, 0.0]", "[0.5, 1.0]", 0.3, false, true), "wall.yaml"));
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 150);
  ASSERT_TRUE(tr.ok) << tr.failure;
  EXPECT_NEAR(tr.states[10].v[0], -0.5, kExactTol);  // free motion before contact
  const State& end = tr.states.back();
  // Left face at x = q_x − 0.2: exactly on the wall (no penetration, no gap).
  EXPECT_NEAR(end.q[0] - 0.2, 0.0, kLcpTol);
  EXPECT_LT(end.v.cwiseAbs().maxCoeff(), kLcpTol);
  double min_face = kInf;
  for (const State& x : tr.states) min_face = std::min(min_face, x.q[0] - 0.2);
  EXPECT_GT(min_face, -kLcpTol);
  // Contact force = −F: the two corner impulses sum to h·1 N.
  const StepLayout l = sim.formulation().Layout(sim.scene(), tr.states[tr.states.size() - 2]);
  ASSERT_EQ(l.nc, 2);
  EXPECT_NEAR(end.warm_start.head(2).sum(), 0.01 * 1.0, kLcpTol);
}

// A block pressed onto a floor (normal force F_n = 1 N) and pushed along it by F_t: with
// Coulomb friction μ = 0.5 it sticks iff F_t ≤ μ F_n, otherwise slides at (F_t − μ F_n)/C_x.
TEST(FirstOrderTest, PushedAlongWallSlidesIffTangentialForceExceedsFriction) {
  const double mu = 0.5, fn = 1.0, cx = 2.0;
  for (const double ft : {0.0, 0.2, 0.45, 0.55, 0.8, 1.5}) {
    Simulator sim(ParseScene(
        BlockYaml("[2.0, 2.0, 0.5]", "[" + std::to_string(ft) + ", " + std::to_string(-fn) + "]",
                  "[0, 0.1]", mu, true, false),
        "floor.yaml"));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 40);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const double expected = ft > mu * fn ? (ft - mu * fn) / cx : 0.0;
    for (std::size_t k = 1; k < tr.states.size(); ++k) {
      const State& x = tr.states[k];
      EXPECT_NEAR(x.v[0], expected, kLcpTol) << "F_t = " << ft << ", step " << k;
      EXPECT_NEAR(x.v[1], 0.0, kLcpTol) << "F_t = " << ft;
      EXPECT_NEAR(x.v[2], 0.0, kLcpTol) << "F_t = " << ft;  // no tipping: μ·0.1 < 0.2
      EXPECT_NEAR(x.q[1], 0.1, kLcpTol);                    // on the floor, no penetration
    }
  }
}

TEST(FirstOrderTest, ExampleSceneSlidesAlongWallAtClosedFormSpeed) {
  Simulator sim(LoadExample("first_order_push.yaml"));
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 200);
  ASSERT_TRUE(tr.ok) << tr.failure;
  EXPECT_NEAR(tr.states[5].v[0], 0.5, kExactTol);  // free: C⁻¹F = (0.5, −0.25)
  EXPECT_NEAR(tr.states[5].v[1], -0.25, kExactTol);
  const State& end = tr.states.back();
  EXPECT_NEAR(end.v[0], (1.0 - 0.5 * 0.5) / 2.0, kLcpTol);  // (F_t − μ F_n)/C_x
  EXPECT_NEAR(end.v[1], 0.0, kLcpTol);
  EXPECT_NEAR(end.q[1], 0.1, kLcpTol);  // resting on the wall y = 0
}

// The residual face: a first-order trajectory satisfies its own step equations, with the
// dynamics rows h C ν_ℓ+1 − G p − h F (no ν_ℓ).
TEST(FirstOrderTest, TrajectorySatisfiesStepEquations) {
  Simulator sim(LoadExample("first_order_push.yaml"));
  const Params p = sim.DefaultParams();
  const Trajectory tr = sim.Rollout(p, sim.InitialState(), 100);
  ASSERT_TRUE(tr.ok) << tr.failure;
  int with_contacts = 0;
  for (std::size_t k = 0; k + 1 < tr.states.size(); k += 9) {
    const State& x0 = tr.states[k];
    const State& x1 = tr.states[k + 1];
    Workspace ws;
    const Scene& model = sim.Resolve(p, &ws);
    const StepLayout l = sim.formulation().Layout(model, x0);
    VectorXd z = VectorXd::Zero(l.size());
    z.segment(l.q1(), l.nq) = x1.q;
    z.segment(l.v1(), l.nv) = x1.v;
    if (x1.warm_start.size() > 0) z.segment(l.pn(), x1.warm_start.size()) = x1.warm_start;
    const StepResiduals r = sim.formulation().Evaluate(model, p, x0, StepInput{}, z);
    EXPECT_LT(r.Violation(), kLcpTol) << "step " << k;
    with_contacts += l.nc > 0 ? 1 : 0;
    // ∂(dynamics)/∂ν_ℓ+1 = h C.
    EXPECT_NEAR(r.d_equality(0, l.v1()), 0.01 * 2.0, kExactTol);
    // A velocity perturbation at x0 changes nothing (no ν_ℓ term).
    State xv = x0;
    xv.v.setConstant(3.0);
    const StepResiduals rv = sim.formulation().Evaluate(model, p, xv, StepInput{}, z);
    EXPECT_LT((rv.equality - r.equality).cwiseAbs().maxCoeff(), kExactTol);
  }
  EXPECT_GT(with_contacts, 0);
}

TEST(FirstOrderTest, MissingDampingIsRejected) {
  const std::string yaml = R"(
dimension: 2
stepper: {formulation: first-order}
bodies:
  - name: block
    mass: 1.0
    shapes: [{type: disc, radius: 0.1}]
)";
  try {
    ParseScene(yaml, "nodamp.yaml");
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("damping"), std::string::npos) << e.what();
  }
  const std::string bad = R"(
dimension: 2
stepper: {formulation: first-order}
bodies:
  - name: block
    mass: 1.0
    damping: [1.0, -1.0, 1.0]
    shapes: [{type: disc, radius: 0.1}]
)";
  EXPECT_THROW(ParseScene(bad, "negdamp.yaml"), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::sim
