// A forward-mode step derivative on the step LCP's own basis (internal to sensitivity.cc): the
// strictly complementary Stewart–Trinkle-family steps, where the general path's linearization of
// the whole step system reduces to the LCP's basic block.
#pragma once

#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim::internal {

// PropagateStep (sensitivity.h) on the step LCP's basis, where that gives the general path's
// derivative: a Stewart–Trinkle, Anitescu–Potra or first-order step on plain contacts (no
// joints, corners, support friction or compliant pairs, no contact at a feature switch), every
// selected parameter a friction coefficient, no smoothing, each contact of its LCP solution z*
// clearly in one mode (each pair's nonzero side above 10³ times the general path's activity
// tolerance, SensitivityOptions::active_tol), and no column near a kink (kMinStableRadius):
//   separated   p_n = 0 < w_n: its entries held at 0;
//   sliding     σ > 0, every friction pair strictly complementary: B ∋ p_n, σ, the loaded p_f;
//   sticking    σ = 0 < w_σ = μ p_n − Σ p_f (strictly inside the cone), every slip rate w_f = 0:
//               B ∋ p_n and the directions of a basis of its tangent space (loaded ones first),
//               held at zero slip with free-signed impulses; its other directions' slip rates
//               are combinations of those and stay zero (checked per column), so the derivative
//               is two-sided though those pairs are degenerate (flagged kDegenerate, as the
//               general path flags them).
// Then the solution is locally z_B = −M_BB⁻¹ q_B, z_N = 0, and along a column (s, θ-part e):
//
//   dg  = ∂(M z* + q)/∂x · s + ∂(M z*)/∂θ · e        (z* held; ∂M/∂μ_c = 1 at (σ_c, p_n,c))
//   dz_B = −M_BB⁻¹ dg_B,   dz_N = 0,   dw_N = dg_N + M_NB dz_B
//   dν_ℓ+1 = ∂ν_after(x, z*)/∂x · s + W G dz           (ν_after = ν* + W G z)
//   dq_ℓ+1 = ∂Int(q, ν_ℓ+1)/∂(q, ν_ℓ+1) · (s_q, dν_ℓ+1)
//
// M_BB singular (redundant contacts: a box's four corners) is taken only without a sliding
// contact, where M_BB = G_Bᵀ W G_B and every solution of a consistent system (checked per column)
// gives the same dν; with more held rows than velocities and G_B of full row rank that dν is
// P⁻¹ G_B r (P = G_B G_Bᵀ, r = −dg_B) and dz_B the minimum-norm one, else the full-pivoting LU's.
// Rates of the rows outside B come from dν (G_iᵀ dν and the σ couplings), M(:, B) is not formed.
// The x parts are central differences along the unit direction s/‖s‖∞ (step
// SensitivityOptions::state_step · max(1, ‖x‖∞), the general path's), of M(x) z* + q(x) and
// ν_after(x, z*) at the frozen model's contacts moved along s; the positions' part of Int is
// exact, a quaternion's a central difference in (q, h ω) along its unit direction. Returns false
// (nothing written) where it does not apply; *st and *S_next are then the general path's to
// fill.
bool PropagateOnLcpBasis(const Simulator& sim, const Params& params,
                         const ParamSelection& selection, const State& x, const StepInput& u,
                         const State& next, const MatrixXd& S, MatrixXd* S_next,
                         const SensitivityOptions& options, Workspace* ws, StepSensitivity* st);

}  // namespace vinci::sim::internal
