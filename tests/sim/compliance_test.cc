// The quasi-rigid normal law (compliance.h): pair combination, linearization, scene-file parsing
// and closed-form impacts with the Stewart–Trinkle stepper.
#include "vinci/sim/compliance.h"

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
  // 0 ≤ p_n ⊥ ψ(q_ℓ+1) + p_n/(h k) ≥ 0 (formulations.md §4) and its velocity form.
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

}  // namespace
}  // namespace vinci::sim
