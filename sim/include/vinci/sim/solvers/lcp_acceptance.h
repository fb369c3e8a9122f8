// The acceptance test every LCP solver passes before it reports kSolved (and that `vinci solve`
// applies to any answer): a residual relative to the problem's own scale, which also bounds the
// negative parts of z and w. It does not replace a solver's own (tighter) stopping test; it
// keeps that test honest where an absolute floor such as max(1, ‖q‖∞) would accept z = 0 on a
// problem written in small units.
#pragma once

#include <string>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/solver_report.h"

namespace vinci::sim {

/// Largest relative residual an accepted solution may have (see LcpScaledResidual): violations
/// above 1e-6 of the problem's own scale are "clearly" wrong, while every solver's own test on a
/// well-scaled problem (‖q‖∞ ≥ ~1e-3 in its units) is tighter than this.
constexpr double kLcpAcceptanceTolerance = 1e-6;

/// The scale-aware residual of z for LCP(M, q), w = Mz + q:
///
///   r = max_i |min(z_i / s_z, w_i / s_w)|,
///   s_z = max(‖z‖∞, ‖q‖∞ / ‖M‖∞)   (the size of z, or of the z that q and M imply),
///   s_w = max(max_i (|q_i| + Σ_j |M_ij z_j|), s_z ‖M‖∞)   (the size of the terms whose sum is w),
///
/// with ‖M‖∞ the largest absolute row sum, and x / 0 read as 0 (s_w = 0 only if w ≡ 0, s_z = 0
/// only if z = 0 and q = 0). A negative z_i or w_i contributes its relative size, so r bounds
/// the negative parts of both; r is invariant to scaling q and M together, and to scaling M
/// against q (units of z). It is not invariant to scaling one row of (M, q): a row written in
/// much smaller units than the others is judged against the largest row's scale (the open case
/// fuzz/open/lemke_fb_row_scaled.lcp; a per-row scale changes Lemke's answers on degenerate
/// contact LCPs, fuzz/open/README.md). Infinity if z, w or a scale is not finite (overflow), NaN
/// if z has the wrong size.
/// Example: M = 1e-12·I, q = −1e-12·(1, 1): z = 0 has r = 1 (w = q < 0); z = (1, 1) has r = 0.
double LcpScaledResidual(const LcpProblem& problem, const VectorXd& z);

/// Empty if z passes LcpScaledResidual(problem, z) ≤ kLcpAcceptanceTolerance, else the reason
/// (naming the residual and the tolerance), for a failure report.
std::string CheckLcpSolution(const LcpProblem& problem, const VectorXd& z);

/// The gate every solver runs last: if `report` says kSolved but z fails CheckLcpSolution, the
/// status becomes kNumericalFailure and the message says why. Leaves other reports alone.
void ConfirmSolved(const LcpProblem& problem, const VectorXd& z, SolverReport* report);

}  // namespace vinci::sim
