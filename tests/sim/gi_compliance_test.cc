// Quasi-rigid contact with the geometrically implicit stepper (issue 4 deliverable 4,
// docs/formulations.md §4; compliance.h's position form): static overlap of a resting disc/sphere,
// duration and rebound of an undamped impact, and the GI step equations with a compliant pair.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "test_util.h"
#include "vinci/sim/formulations/geometrically_implicit.h"
#include "vinci/sim/model/compliance.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::sim {
namespace {

constexpr double kG = 9.81;
constexpr double kPi = 3.14159265358979323846;

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// A 1 kg disc (planar) or sphere (spatial) of radius 0.1 m, centre at height y0 with vertical
// velocity vy0, on a floor (y ≤ 0 / z ≤ 0) with the given compliance (a YAML map).
std::string Scene(bool spatial, const std::string& compliance, double h, double y0, double vy0,
                  bool gravity) {
  const std::string g = gravity ? "-9.81" : "0";
  return std::string("name: gi-compliant\ndimension: ") + (spatial ? "3" : "2") +
         "\ngravity: " + (spatial ? "[0, 0, " + g + "]" : "[0, " + g + "]") +
         "\nstepper: {formulation: gi, dt: " + Num(h) +
         ", envelope: 0.001}\nfriction: {default: 0.3}\nbodies:\n"
         "  - {name: floor, kind: static, compliance: " +
         compliance + ", shapes: [{type: " + (spatial ? "halfspace" : "halfplane") +
         "}]}\n"
         "  - {name: ball, mass: 1.0, pose: {position: " +
         (spatial ? "[0, 0, " + Num(y0) + "]" : "[0, " + Num(y0) + "]") + "}, velocity: {linear: " +
         (spatial ? "[0, 0, " + Num(vy0) + "]" : "[0, " + Num(vy0) + "]") +
         "}, shapes: [{type: " + (spatial ? "sphere" : "disc") + ", radius: 0.1}]}\n";
}

// Height of the centre (planar q = (x, y, θ); spatial q = (p, quaternion)).
double Height(bool spatial, const State& x) { return spatial ? x.q[2] : x.q[1]; }
double VerticalSpeed(bool spatial, const State& x) { return spatial ? x.v[2] : x.v[1]; }

// A damped ball released at first touch settles at the law's static overlap under m g: the
// linearized law is exact at its linearization point, so the resting overlap is exact up to the
// solver tolerance and the solver-form normal compliance (h² κ_n m g / r ≈ 1e-13 m).
TEST(GiComplianceTest, RestingOverlapMatchesStaticLaw) {
  struct Case {
    bool spatial;
    std::string compliance;
    ContactCompliance law;
  };
  ContactCompliance kv;
  kv.law = ComplianceLaw::kKelvinVoigt;
  kv.stiffness = 1e4;  // N/m: δ = m g / k = 9.81e-4 m
  ContactCompliance hertz;
  hertz.law = ComplianceLaw::kHertz;
  hertz.stiffness = 1e6;  // N/m^1.5: δ = (m g / k)^(2/3) = 4.58e-4 m
  // Damping near critical for the (tangent) stiffness, so 0.6 s is many time constants.
  const std::vector<Case> cases = {
      {false, "{law: kelvin-voigt, stiffness: 1.0e4, damping: 200}", kv},
      {false, "{law: hertz, stiffness: 1.0e6, damping: 300}", hertz},
      {true, "{law: kelvin-voigt, stiffness: 1.0e4, damping: 200}", kv},
  };
  for (const Case& cs : cases) {
    Simulator sim(ParseScene(Scene(cs.spatial, cs.compliance, 1e-3, 0.1, 0.0, true), "<test>"));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 600);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const double overlap = 0.1 - Height(cs.spatial, tr.states.back());
    const double expected = StaticOverlap(cs.law, 1.0 * kG);
    // 1e-6 relative: the resting state is an exact fixed point (see above) and the damped
    // transient (time constant ≤ 0.01 s) has decayed by e^-60 after 0.6 s.
    EXPECT_NEAR(overlap / expected, 1.0, 1e-6)
        << cs.compliance << (cs.spatial ? " sphere" : " disc") << ": overlap " << overlap;
    EXPECT_LT(std::abs(VerticalSpeed(cs.spatial, tr.states.back())), 1e-9);  // at rest
    std::printf("[gi compliance] %s %s: overlap %.9e m, law %.9e m, rel. error %.2e\n",
                cs.spatial ? "sphere" : "disc", cs.compliance.c_str(), overlap, expected,
                overlap / expected - 1.0);
  }
}

// Undamped Kelvin–Voigt impact without gravity: a half period π √(m/k) of contact and a rebound
// at the impact speed, up to backward Euler's loss ≈ (π/2) h √(k/m) = 0.8% at h = 5e-5.
TEST(GiComplianceTest, UndampedImpactDurationAndRebound) {
  const double k = 1e4, m = 1.0, v0 = 1.0, h = 5e-5;
  for (bool spatial : {false, true}) {
    Simulator sim(ParseScene(
        Scene(spatial, "{law: kelvin-voigt, stiffness: 1.0e4}", h, 0.1 + 0.5 * h * v0, -v0, false),
        "<test>"));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 800);
    ASSERT_TRUE(tr.ok) << tr.failure;
    // Contact interval: the states with overlap (centre below 0.1 m); the touch and release
    // instants are interpolated linearly between states.
    int first = -1, last = -1;
    for (std::size_t i = 0; i < tr.states.size(); ++i) {
      if (Height(spatial, tr.states[i]) < 0.1) {
        if (first < 0) first = static_cast<int>(i);
        last = static_cast<int>(i);
      }
    }
    ASSERT_GT(first, 0);
    ASSERT_LT(last + 1, static_cast<int>(tr.states.size()));
    const auto crossing = [&](int i0, int i1) {
      const double y0 = Height(spatial, tr.states[i0]) - 0.1;
      const double y1 = Height(spatial, tr.states[i1]) - 0.1;
      return tr.states[i0].t + (tr.states[i1].t - tr.states[i0].t) * y0 / (y0 - y1);
    };
    const double duration = crossing(last, last + 1) - crossing(first - 1, first);
    const double rebound = VerticalSpeed(spatial, tr.states.back());
    const double expected = kPi * std::sqrt(m / k);
    EXPECT_NEAR(duration / expected, 1.0, 0.02) << (spatial ? "sphere" : "disc");  // brief: 2%
    EXPECT_NEAR(rebound / v0, 1.0, 0.02) << (spatial ? "sphere" : "disc");
    EXPECT_LT(rebound, v0);  // backward Euler dissipates, never gains
    std::printf("[gi compliance] %s: duration %.6f s (π√(m/k) = %.6f), rebound %.6f m/s\n",
                spatial ? "sphere" : "disc", duration, expected, rebound);
  }
}

// The residual face with compliant pairs: damped Kelvin–Voigt (b ≠ 0) and Hertz (tangent
// linearization, e ≠ 0) drops satisfy the GI step equations (Evaluate) to solver tolerance.
TEST(GiComplianceTest, TrajectorySatisfiesStepEquations) {
  for (const std::string& law : {std::string("{law: kelvin-voigt, stiffness: 1.0e4, damping: 20}"),
                                 std::string("{law: hertz, stiffness: 1.0e6, damping: 30}")}) {
    for (bool spatial : {false, true}) {
      Simulator sim(ParseScene(Scene(spatial, law, 1e-3, 0.11, 0.0, true), "<test>"));
      const auto& gi = dynamic_cast<const GeometricallyImplicit&>(sim.formulation());
      const Params params = sim.DefaultParams();
      const Trajectory tr = sim.Rollout(params, sim.InitialState(), 200);
      ASSERT_TRUE(tr.ok) << tr.failure;
      double worst = 0.0, max_overlap = 0.0;
      for (std::size_t k = 0; k + 1 < tr.states.size(); ++k) {
        const VectorXd z = gi.UnknownsFromStep(sim.scene(), tr.states[k], tr.states[k + 1]);
        const StepResiduals r = gi.Evaluate(sim.scene(), params, tr.states[k], StepInput{}, z);
        worst = std::max(worst, r.Violation());
        max_overlap = std::max(max_overlap, 0.1 - Height(spatial, tr.states[k + 1]));
      }
      std::printf("[gi compliance] %s %s: worst step-equation violation %.2e, max overlap %.3e m\n",
                  spatial ? "sphere" : "disc", law.c_str(), worst, max_overlap);
      EXPECT_LT(worst, 1e-8) << law;        // McpSolver tolerance 1e-10 on rows scaled by 1/h = 1e3
      EXPECT_GT(max_overlap, 1e-4) << law;  // the compliant contact was loaded (δ ≈ 1e-3 m)
    }
  }
}

}  // namespace
}  // namespace vinci::sim
