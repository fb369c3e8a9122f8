#include "vinci/sim/model/compliance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace vinci::sim {
namespace {

// Exponent n of f ∝ δ^n.
double Exponent(ComplianceLaw law) { return law == ComplianceLaw::kKelvinVoigt ? 1.0 : 1.5; }

std::string Num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

}  // namespace

std::string_view ToString(ComplianceLaw law) {
  switch (law) {
    case ComplianceLaw::kRigid:
      return "rigid";
    case ComplianceLaw::kKelvinVoigt:
      return "kelvin-voigt";
    case ComplianceLaw::kHertz:
      return "hertz";
    case ComplianceLaw::kHuntCrossley:
      return "hunt-crossley";
  }
  return "?";
}

void CheckCompliance(const ContactCompliance& c, const std::string& what) {
  const auto fail = [&](const std::string& field, double v, const std::string& expected) {
    throw std::invalid_argument(what + ": compliance." + field + ": expected " + expected +
                                " for law '" + std::string(ToString(c.law)) + "', got " + Num(v));
  };
  if (c.rigid()) {
    if (c.stiffness != 0.0) fail("stiffness", c.stiffness, "no stiffness (0)");
    if (c.damping != 0.0) fail("damping", c.damping, "no damping (0)");
    if (c.alpha != 0.0) fail("alpha", c.alpha, "no alpha (0)");
    return;
  }
  if (!(std::isfinite(c.stiffness) && c.stiffness > 0.0))
    fail("stiffness", c.stiffness, "a finite number > 0");
  if (!(std::isfinite(c.damping) && c.damping >= 0.0))
    fail("damping", c.damping, "a finite number >= 0");
  if (!(std::isfinite(c.alpha) && c.alpha >= 0.0)) fail("alpha", c.alpha, "a finite number >= 0");
  if (!(std::isfinite(c.min_overlap) && c.min_overlap > 0.0))
    fail("min_overlap", c.min_overlap, "a finite number > 0");
  if (c.law == ComplianceLaw::kHuntCrossley && c.damping != 0.0)
    fail("damping", c.damping, "no damping (Hunt-Crossley damps through alpha)");
  if (c.law != ComplianceLaw::kHuntCrossley && c.alpha != 0.0)
    fail("alpha", c.alpha, "no alpha (only Hunt-Crossley uses it; use damping)");
}

std::string CheckCompliancePair(const ContactCompliance& a, const ContactCompliance& b) {
  if (a.rigid() || b.rigid() || a.law == b.law) return "";
  return "compliant bodies with different laws ('" + std::string(ToString(a.law)) + "' and '" +
         std::string(ToString(b.law)) + "') cannot be combined in series";
}

ContactCompliance CombineCompliance(const ContactCompliance& a, const ContactCompliance& b) {
  if (a.rigid()) return b;
  if (b.rigid()) return a;
  const std::string why = CheckCompliancePair(a, b);
  if (!why.empty()) throw std::invalid_argument("CombineCompliance: " + why);
  const double n = Exponent(a.law);
  const double sa = std::pow(a.stiffness, -1.0 / n), sb = std::pow(b.stiffness, -1.0 / n);
  const double wa = sa / (sa + sb), wb = sb / (sa + sb);
  ContactCompliance c;
  c.law = a.law;
  c.stiffness = std::pow(sa + sb, -n);
  c.damping = wa * wa * a.damping + wb * wb * b.damping;
  c.alpha = wa * wa * a.alpha + wb * wb * b.alpha;
  c.min_overlap = std::min(a.min_overlap, b.min_overlap);
  return c;
}

double NormalForce(const ContactCompliance& c, double overlap, double overlap_rate) {
  if (c.rigid()) throw std::logic_error("NormalForce: a rigid contact has no force law");
  if (overlap <= 0.0) return 0.0;
  double f = 0.0;
  switch (c.law) {
    case ComplianceLaw::kKelvinVoigt:
      f = c.stiffness * overlap + c.damping * overlap_rate;
      break;
    case ComplianceLaw::kHertz:
      f = c.stiffness * std::pow(overlap, 1.5) + c.damping * overlap_rate;
      break;
    case ComplianceLaw::kHuntCrossley:
      f = c.stiffness * std::pow(overlap, 1.5) * (1.0 + c.alpha * overlap_rate);
      break;
    case ComplianceLaw::kRigid:
      break;
  }
  return std::max(f, 0.0);
}

double StaticOverlap(const ContactCompliance& c, double force) {
  if (c.rigid() || force <= 0.0) return 0.0;
  return std::pow(force / c.stiffness, 1.0 / Exponent(c.law));
}

CompliantNormalRow LinearizeNormalLaw(const ContactCompliance& c, double psi, double h) {
  if (!(h > 0.0)) throw std::invalid_argument("LinearizeNormalLaw: step h must be > 0");
  CompliantNormalRow r;
  if (c.rigid()) return r;
  r.compliant = true;
  const double overlap = std::max(-psi, 0.0);
  const bool overlapping = psi < 0.0;  // damping acts only on an existing overlap
  switch (c.law) {
    case ComplianceLaw::kKelvinVoigt:
      r.stiffness = c.stiffness;
      r.damping = overlapping ? c.damping : 0.0;
      break;
    case ComplianceLaw::kHertz:
    case ComplianceLaw::kHuntCrossley:
      if (overlap >= c.min_overlap) {
        const double root = std::sqrt(overlap);
        r.stiffness = 1.5 * c.stiffness * root;  // tangent
        r.force_offset = -0.5 * c.stiffness * overlap * root;
      } else {
        r.stiffness = c.stiffness * std::sqrt(c.min_overlap);  // secant through 0
      }
      if (c.law == ComplianceLaw::kHertz)
        r.damping = overlapping ? c.damping : 0.0;
      else
        r.damping = c.alpha * c.stiffness * overlap * std::sqrt(overlap);
      break;
    case ComplianceLaw::kRigid:
      break;
  }
  const double denom = h * r.stiffness + r.damping;
  r.pos_diagonal = 1.0 / denom;
  r.pos_psi0 = -r.damping / denom;
  r.pos_constant = -h * r.force_offset / denom;
  r.vel_psi = r.stiffness / denom;
  r.vel_diagonal = r.pos_diagonal / h;
  r.vel_constant = r.pos_constant / h;
  return r;
}

}  // namespace vinci::sim
