// Quasi-rigid (locally compliant) contact: the lumped normal law of a thin compliant layer on a
// rigid core (docs/formulations.md §4; Chakraborty, Berard, Akella, Trinkle, ASME IDETC 2007), in
// the complementarity form a time-stepper imposes. Stepper-agnostic: Stewart–Trinkle, the NCP
// stepper and the geometrically implicit stepper all call these pure functions.
//
// Laws (δ = −ψ_n ≥ 0 the overlap, δ̇ its rate, f the normal force in N):
//   kRigid        δ = 0 (no compliance term; steppers keep their rigid rows unchanged)
//   kKelvinVoigt  f = k δ + c δ̇                 k in N/m,      c in N·s/m
//   kHertz        f = k δ^{3/2} + c δ̇           k in N/m^{3/2}, c in N·s/m
//   kHuntCrossley f = k δ^{3/2} (1 + α δ̇)       k in N/m^{3/2}, α in s/m
// with f ≥ 0 enforced by the complementarity (no adhesion).
//
// Discrete equations (docs/formulations.md §4 gives the linearization in full). The force over
// step ℓ → ℓ+1 is f = p_n/h at the END of the step (δ_ℓ+1 = −ψ_n(q_ℓ+1)); nonlinear laws are
// linearized about the start-of-step overlap δ_ℓ, f ≈ f_0 + k_e δ_ℓ+1 + c_e δ̇_ℓ+1, exact at the
// linearization point (a resting contact sits exactly at the law's static overlap). Damping acts
// only on contacts that overlap at the start of the step. This gives the POSITION form (what a
// geometrically implicit stepper imposes, ψ_n(q_ℓ+1) exact)
//   0 ≤ p_n ⊥ ψ_n(q_ℓ+1) + a p_n + b ψ_ℓ + e ≥ 0
// (for Kelvin–Voigt without damping: ψ_n(q_ℓ+1) + p_n/(h k) ≥ 0) and, with the linearization
// ψ_ℓ+1 = ψ_ℓ + h (G_nᵀ ν_ℓ+1 + ∂ψ_n/∂t) divided by h, the VELOCITY form (Stewart–Trinkle, NCP)
//   0 ≤ p_n ⊥ G_nᵀ ν_ℓ+1 + ∂ψ_n/∂t + β ψ_ℓ + γ p_n + ε ≥ 0
// with the coefficients of CompliantNormalRow. The undamped spring is the backward-Euler
// oscillator: it loses ≈ (π/2) h √(k/m) of the rebound speed per impact, so resolve the contact
// with h √(k/m) ≪ 1.
//
// Pairs: two compliant layers act as springs in series (CombineCompliance: stiffnesses combined
// for the law's exponent, damping by matching the dissipated power); rigid + compliant = the
// compliant one; rigid + rigid = rigid; two compliant bodies with different laws are rejected
// (CheckCompliancePair).
#pragma once

#include <string>
#include <string_view>

namespace vinci::sim {

/// The lumped normal law of a body's compliant layer.
enum class ComplianceLaw { kRigid, kKelvinVoigt, kHertz, kHuntCrossley };

/// "rigid", "kelvin-voigt", "hertz", "hunt-crossley".
std::string_view ToString(ComplianceLaw law);

/// A body's (or, combined, a contact pair's) normal compliance. Default: rigid.
struct ContactCompliance {
  ComplianceLaw law = ComplianceLaw::kRigid;
  double stiffness = 0.0;  ///< k: N/m (Kelvin–Voigt) or N/m^{3/2} (Hertz, Hunt–Crossley); > 0
  double damping = 0.0;    ///< c: N·s/m (Kelvin–Voigt, Hertz); ≥ 0
  double alpha = 0.0;      ///< α: s/m (Hunt–Crossley); ≥ 0
  /// δ_min (m): Hertz-type laws are linearized by the secant through δ_min below this overlap
  /// (the tangent stiffness vanishes at δ = 0); > 0.
  double min_overlap = 1e-6;
  bool rigid() const { return law == ComplianceLaw::kRigid; }
};

/// Throws std::invalid_argument naming `what` if the fields are inconsistent with the law
/// (stiffness ≤ 0 for a compliant law, negative damping/α, a damping field the law does not use,
/// non-finite values).
void CheckCompliance(const ContactCompliance& c, const std::string& what);

/// Empty if bodies with compliances a and b may touch; otherwise the reason (both compliant with
/// different laws).
std::string CheckCompliancePair(const ContactCompliance& a, const ContactCompliance& b);

/// The pair's law (springs in series, see the file comment). Throws std::invalid_argument if
/// CheckCompliancePair fails.
ContactCompliance CombineCompliance(const ContactCompliance& a, const ContactCompliance& b);

/// The exact normal force of the law (N) at overlap δ (m) and overlap rate δ̇ (m/s): 0 for
/// δ ≤ 0, clamped at ≥ 0 (rigid: throws std::logic_error, it has no force law).
double NormalForce(const ContactCompliance& c, double overlap, double overlap_rate);

/// The static overlap under a constant load f ≥ 0 (N): f/k (Kelvin–Voigt), (f/k)^{2/3} (Hertz,
/// Hunt–Crossley). Rigid: 0.
double StaticOverlap(const ContactCompliance& c, double force);

/// The linearized law of one contact over one step (the file comment; docs/formulations.md §4).
struct CompliantNormalRow {
  bool compliant = false;     ///< false: rigid pair, all terms below are unused (zero)
  double stiffness = 0.0;     ///< k_e (N/m)
  double damping = 0.0;       ///< c_e (N·s/m)
  double force_offset = 0.0;  ///< f_0 (N)
  // Position form: 0 ≤ p_n ⊥ ψ_n(q_ℓ+1) + pos_diagonal p_n + pos_psi0 ψ_ℓ + pos_constant ≥ 0.
  double pos_diagonal = 0.0;  ///< a = 1/(h k_e + c_e) (m/(N·s))
  double pos_psi0 = 0.0;      ///< b = −c_e/(h k_e + c_e)
  double pos_constant = 0.0;  ///< e = −h f_0/(h k_e + c_e) (m)
  // Velocity form: 0 ≤ p_n ⊥ G_nᵀν_ℓ+1 + ∂ψ_n/∂t + vel_psi ψ_ℓ + vel_diagonal p_n + vel_constant.
  double vel_psi = 0.0;       ///< β = k_e/(h k_e + c_e) (1/s)
  double vel_diagonal = 0.0;  ///< γ = a/h (m/(N·s²))
  double vel_constant = 0.0;  ///< ε = e/h (m/s)
};

/// Linearizes the pair law `c` (already combined) for a step of length h (s) that starts at gap
/// ψ_ℓ = psi (m). Rigid: compliant = false. Throws std::invalid_argument for h ≤ 0.
CompliantNormalRow LinearizeNormalLaw(const ContactCompliance& c, double psi, double h);

}  // namespace vinci::sim
