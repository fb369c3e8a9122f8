// The quasi-rigid normal law (compliance.h): pair combination, linearization, scene-file parsing
// and closed-form impacts with the Stewart–Trinkle stepper.
#include "vinci/sim/model/compliance.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_util.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Pure arithmetic on a handful of doubles.
constexpr double kRoundoff = 1e-12;

ContactCompliance Kv(double k, double c = 0.0) {
  ContactCompliance cc;
  cc.law = ComplianceLaw::kKelvinVoigt;
  cc.stiffness = k;
  cc.damping = c;
  return cc;
}

ContactCompliance Hertz(double k) {
  ContactCompliance cc;
  cc.law = ComplianceLaw::kHertz;
  cc.stiffness = k;
  return cc;
}

TEST(ComplianceLaw, RigidPlusCompliantIsTheCompliantOne) {
  const ContactCompliance rigid;
  const ContactCompliance kv = Kv(1e4, 3.0);
  const ContactCompliance c = CombineCompliance(rigid, kv);
  EXPECT_EQ(c.law, ComplianceLaw::kKelvinVoigt);
  EXPECT_EQ(c.stiffness, 1e4);
  EXPECT_EQ(c.damping, 3.0);
  EXPECT_TRUE(CombineCompliance(rigid, rigid).rigid());
  EXPECT_EQ(CombineCompliance(kv, rigid).stiffness, 1e4);
}

TEST(ComplianceLaw, SpringsInSeries) {
  // Linear: 1/k = 1/k_a + 1/k_b; damping weighted by the squared deflection shares.
  const ContactCompliance c = CombineCompliance(Kv(1e4, 2.0), Kv(3e4, 4.0));
  EXPECT_NEAR(c.stiffness, 1.0 / (1.0 / 1e4 + 1.0 / 3e4), kRoundoff * 1e4);
  EXPECT_NEAR(c.damping, 0.75 * 0.75 * 2.0 + 0.25 * 0.25 * 4.0, kRoundoff);
  // Hertz: deflections (f/k)^{2/3} add at a common force.
  const ContactCompliance h = CombineCompliance(Hertz(1e6), Hertz(2e6));
  const double f = 50.0;
  EXPECT_NEAR(StaticOverlap(h, f), StaticOverlap(Hertz(1e6), f) + StaticOverlap(Hertz(2e6), f),
              kRoundoff);
  // Different compliant laws are rejected.
  EXPECT_THROW(CombineCompliance(Kv(1e4), Hertz(1e6)), std::invalid_argument);
}

TEST(ComplianceLaw, KelvinVoigtRowIsTheSpecEquation) {
  // 0 ≤ p_n ⊥ ψ(q_ℓ+1) + p_n/(h k) ≥ 0 (docs/formulations.md §4) and its velocity form.
  const double k = 2e4, h = 1e-3, psi = -1e-3;
  const CompliantNormalRow r = LinearizeNormalLaw(Kv(k), psi, h);
  ASSERT_TRUE(r.compliant);
  EXPECT_NEAR(r.pos_diagonal, 1.0 / (h * k), kRoundoff);
  EXPECT_EQ(r.pos_psi0, 0.0);
  EXPECT_EQ(r.pos_constant, 0.0);
  EXPECT_NEAR(r.vel_psi, 1.0 / h, kRoundoff);
  EXPECT_NEAR(r.vel_diagonal, 1.0 / (h * h * k), kRoundoff);
  EXPECT_FALSE(LinearizeNormalLaw(ContactCompliance{}, psi, h).compliant);
}

TEST(ComplianceLaw, DampingOnlyOnAnExistingOverlap) {
  const double h = 1e-3;
  EXPECT_EQ(LinearizeNormalLaw(Kv(1e4, 10.0), 1e-4, h).damping, 0.0);
  const CompliantNormalRow r = LinearizeNormalLaw(Kv(1e4, 10.0), -1e-4, h);
  EXPECT_EQ(r.damping, 10.0);
  // Solving the velocity row for p_n at w = 0 reproduces f = k δ_ℓ+1 + c δ̇_ℓ+1.
  const double psi_dot = -0.3, psi1 = -1e-4 + h * psi_dot;
  const double pn = -(psi_dot + r.vel_psi * -1e-4 + r.vel_constant) / r.vel_diagonal;
  EXPECT_NEAR(pn / h, 1e4 * -psi1 + 10.0 * -psi_dot, 1e-9);
}

TEST(ComplianceLaw, HertzLinearizationIsExactAtItsPoint) {
  const double k = 1e7, h = 1e-3;
  for (double delta : {2e-6, 1e-4, 3e-3}) {
    const CompliantNormalRow r = LinearizeNormalLaw(Hertz(k), -delta, h);
    // Row at ψ_ℓ+1 = ψ_ℓ (ψ̇ = 0): p_n/h must equal k δ^{3/2}.
    const double pn = -(r.vel_psi * -delta + r.vel_constant) / r.vel_diagonal;
    EXPECT_NEAR(pn / h, NormalForce(Hertz(k), delta, 0.0), 1e-9 * k * std::pow(delta, 1.5));
    EXPECT_NEAR(r.stiffness, 1.5 * k * std::sqrt(delta), kRoundoff * r.stiffness);
  }
  // Below min_overlap: the secant through 0, positive stiffness.
  const CompliantNormalRow r0 = LinearizeNormalLaw(Hertz(k), 0.0, h);
  EXPECT_NEAR(r0.stiffness, k * std::sqrt(1e-6), kRoundoff * r0.stiffness);
  EXPECT_EQ(r0.force_offset, 0.0);
}

TEST(ComplianceLaw, ChecksRejectBadFields) {
  EXPECT_THROW(CheckCompliance(Kv(0.0), "body 'b'"), std::invalid_argument);
  EXPECT_THROW(CheckCompliance(Kv(1.0, -1.0), "body 'b'"), std::invalid_argument);
  ContactCompliance hc;
  hc.law = ComplianceLaw::kHuntCrossley;
  hc.stiffness = 1e6;
  hc.damping = 1.0;
  try {
    CheckCompliance(hc, "body 'b'");
    FAIL() << "expected a throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("compliance.damping"), std::string::npos);
  }
  EXPECT_NO_THROW(CheckCompliance(Kv(1e3, 1.0), "body 'b'"));
}

// A 1 kg sphere (r = 0.1 m) thrown at 1 m/s onto a compliant static floor, without gravity, so
// the contact is a free linear (or Hertz) oscillator half-cycle.
std::string BallScene(const std::string& formulation, const std::string& compliance, double h,
                      double v0, bool gravity, double z0) {
  return "dimension: 3\n"
         "stepper: {formulation: " +
         formulation + ", dt: " + std::to_string(h) +
         ", envelope: 0.002, friction_directions: 4}\n"
         "bodies:\n"
         "  - {name: floor, kind: static, shapes: [{type: halfspace}], compliance: " +
         compliance +
         "}\n"
         "  - name: ball\n"
         "    mass: 1.0\n"
         "    gravity: " +
         (gravity ? "true" : "false") + "\n    pose: {position: [0, 0, " + std::to_string(z0) +
         "]}\n"
         "    velocity: {linear: [0, 0, " +
         std::to_string(v0) +
         "]}\n"
         "    shapes: [{type: sphere, radius: 0.1}]\n";
}

struct Impact {
  double duration = 0.0;  // s, between the linearly interpolated crossings of z = r
  double rebound = 0.0;   // m/s, vertical speed after the contact
  double max_overlap = 0.0;
  bool ok = false;
};

Impact SimulateImpact(const Scene& scene, double t_end) {
  Simulator sim(scene);
  const double h = scene.options.dt, r = 0.1;
  const Trajectory traj =
      sim.Rollout(sim.DefaultParams(), sim.InitialState(), static_cast<int>(t_end / h));
  Impact out;
  if (!traj.ok) return out;
  double t_in = -1.0, t_out = -1.0;
  for (std::size_t k = 1; k < traj.states.size(); ++k) {
    const double z0 = traj.states[k - 1].q[2] - r, z1 = traj.states[k].q[2] - r;
    out.max_overlap = std::max(out.max_overlap, -z1);
    const double t0 = traj.states[k - 1].t;
    if (t_in < 0 && z0 >= 0 && z1 < 0) t_in = t0 + h * z0 / (z0 - z1);
    if (t_in >= 0 && t_out < 0 && z0 < 0 && z1 >= 0) {
      t_out = t0 + h * z0 / (z0 - z1);
      out.rebound = traj.states[k].v[2];
    }
  }
  out.duration = t_out - t_in;
  out.ok = t_in >= 0 && t_out >= 0;
  return out;
}

// Backward-Euler in the overlap loses ≈ (π/2) h ω of the rebound speed: 0.8% at h ω = 0.005;
// the issue asks for 2%.
constexpr double kImpactTol = 0.02;

TEST(CompliantImpact, KelvinVoigtLastsHalfAPeriodAndRebounds) {
  const double k = 1e4, m = 1.0, v0 = 1.0, h = 5e-5;
  for (const char* formulation : {"stewart-trinkle", "anitescu-potra", "ncp"}) {
    SCOPED_TRACE(formulation);
    const Scene scene = ParseScene(
        BallScene(formulation, "{law: kelvin-voigt, stiffness: 1.0e4}", h, -v0, false, 0.1005));
    const Impact imp = SimulateImpact(scene, 0.045);
    ASSERT_TRUE(imp.ok);
    const double t_closed = kPi * std::sqrt(m / k);
    EXPECT_NEAR(imp.duration, t_closed, kImpactTol * t_closed);
    EXPECT_NEAR(imp.rebound, v0, kImpactTol * v0);
    EXPECT_LT(imp.rebound, v0);  // the implicit spring never gains energy
    EXPECT_NEAR(imp.max_overlap, v0 * std::sqrt(m / k), kImpactTol * v0 * std::sqrt(m / k));
  }
}

TEST(CompliantImpact, DampingLowersTheRestitutionMonotonically) {
  const double v0 = 1.0, h = 5e-5;
  double previous = 2.0;
  for (double c : {0.0, 5.0, 20.0, 50.0}) {
    SCOPED_TRACE(c);
    const Scene scene = ParseScene(
        BallScene("stewart-trinkle",
                  "{law: kelvin-voigt, stiffness: 1.0e4, damping: " + std::to_string(c) + "}", h,
                  -v0, false, 0.1005));
    const Impact imp = SimulateImpact(scene, 0.06);
    ASSERT_TRUE(imp.ok);
    const double e = imp.rebound / v0;
    EXPECT_LT(e, 1.0);
    EXPECT_LT(e, previous);
    if (c > 0) {
      // A clear drop per damping level (not roundoff): ζ = c/(2√(km)) ≥ 0.025 removes > 5%.
      EXPECT_LT(e, previous - 0.05);
    }
    previous = e;
  }
}

// Overlap of a resting ball after settling, from a touching start (damped to settle fast).
double RestingOverlap(const std::string& compliance, const std::string& formulation) {
  Simulator sim(ParseScene(BallScene(formulation, compliance, 1e-3, 0.0, true, 0.1)));
  const Trajectory traj = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 1500);
  EXPECT_TRUE(traj.ok) << traj.failure;
  return 0.1 - traj.states.back().q[2];
}

// The linearized laws are exact at rest, so only the settling transient remains
// (measured ≤ 1e-9 relative after 1.5 s; the issue asks for 1%).
constexpr double kStaticTol = 1e-6;

TEST(CompliantStatics, KelvinVoigtOverlapIsMgOverK) {
  const double expected = 9.81 / 1e4;
  for (const char* f : {"stewart-trinkle", "anitescu-potra", "ncp"}) {
    SCOPED_TRACE(f);
    const double d = RestingOverlap("{law: kelvin-voigt, stiffness: 1.0e4, damping: 100}", f);
    EXPECT_NEAR(d, expected, kStaticTol * expected);
  }
}

TEST(CompliantStatics, HertzOverlapIsMgOverKToTwoThirds) {
  const double expected = std::pow(9.81 / 1e6, 2.0 / 3.0);
  const double d = RestingOverlap("{law: hertz, stiffness: 1.0e6, damping: 50}", "stewart-trinkle");
  EXPECT_NEAR(d, expected, kStaticTol * expected);
  EXPECT_NEAR(RestingOverlap("{law: hertz, stiffness: 1.0e6, damping: 50}", "ncp"), expected,
              kStaticTol * expected);
  const double d_hc =
      RestingOverlap("{law: hunt-crossley, stiffness: 1.0e6, alpha: 5}", "stewart-trinkle");
  EXPECT_NEAR(d_hc, expected, kStaticTol * expected);
}

TEST(CompliantStatics, RigidScenesAreUnchanged) {
  // A rigid ball rests at overlap 0 (to the solver tolerance): the compliance path is off.
  const double d = RestingOverlap("{law: rigid}", "stewart-trinkle");
  EXPECT_NEAR(d, 0.0, 1e-9);
}

TEST(ComplianceSceneFile, ParsesAndRejects) {
  const Scene s = ParseScene(BallScene(
      "stewart-trinkle", "{law: hertz, stiffness: 2.0e6, damping: 3}", 1e-3, 0.0, true, 0.1));
  const Body& floor = s.bodies[s.FindBody("floor")];
  EXPECT_EQ(floor.compliance.law, ComplianceLaw::kHertz);
  EXPECT_EQ(floor.compliance.stiffness, 2e6);
  EXPECT_EQ(floor.compliance.damping, 3.0);
  EXPECT_TRUE(s.bodies[s.FindBody("ball")].compliance.rigid());
  const auto expect_error = [](const std::string& compliance, const std::string& needle) {
    try {
      ParseScene(BallScene("stewart-trinkle", compliance, 1e-3, 0.0, true, 0.1), "scene.yaml");
      ADD_FAILURE() << "no error for " << compliance;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error("{law: kelvin-voigt}", "bodies[0].compliance.stiffness");
  expect_error("{law: kelvin-voigt, stiffness: -1}", "a finite number > 0");
  expect_error("{law: hunt-crossley, stiffness: 1, damping: 1}", "hunt-crossley");
  expect_error("{law: hertz, stiffness: 1, alpha: 1}", "alpha");
  expect_error("{law: soft, stiffness: 1}", "a compliance law");
  expect_error("{law: rigid, stiffness: 1}", "rigid");
}

// A compliant impact trajectory satisfies its formulation's step equations (Evaluate carries the
// same compliance term as the solved LCP/MCP).
TEST(CompliantImpact, TrajectorySatisfiesItsStepEquations) {
  for (const char* formulation : {"stewart-trinkle", "ncp"}) {
    SCOPED_TRACE(formulation);
    Simulator sim(ParseScene(BallScene(
        formulation, "{law: kelvin-voigt, stiffness: 1.0e4, damping: 10}", 1e-4, -1.0, true, 0.1)));
    const Params p = sim.DefaultParams();
    const Trajectory t = sim.Rollout(p, sim.InitialState(), 200);
    ASSERT_TRUE(t.ok) << t.failure;
    int compliant_steps = 0;
    for (std::size_t k = 0; k + 1 < t.states.size(); ++k) {
      const State& x = t.states[k];
      const StepLayout l = sim.formulation().Layout(sim.scene(), x);
      if (l.nc == 0) continue;
      VectorXd z(l.size());
      z << t.states[k + 1].q, t.states[k + 1].v, t.states[k + 1].warm_start;
      const StepResiduals r = sim.formulation().Evaluate(sim.scene(), p, x, StepInput{}, z);
      // Lemke/MCP solve to ~1e-10 on impulses ~1e-3 N·s.
      EXPECT_LT(r.Violation(), 1e-9) << "step " << k;
      compliant_steps += z[l.pn()] > 0 ? 1 : 0;
    }
    EXPECT_GT(compliant_steps, 100);  // the contact is active for most of the run
  }
}

}  // namespace
}  // namespace vinci::sim
