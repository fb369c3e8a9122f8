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

/// Relative floor of every row's scale in LcpScaledResidual: a row is judged at its own scale,
/// but never at less than 1e-8 of the problem's, so no row must be right to better than
/// kLcpAcceptanceTolerance · 1e-8 = 1e-14 of the problem's scale (~100 ulps, the accuracy of
/// data formed at that scale). A row of pure roundoff (zero in exact arithmetic, entries ~1e-16
/// of the others: a degenerate friction direction of the sensitivity LCP in sensitivity.cc)
/// passes; a row written 1e-10 below the others but violated by its whole size (the finding
/// fuzz/crashes/lcp/lemke_fb_row_scaled.lcp) fails.
constexpr double kLcpRoundoffFloor = 1e-8;

/// The scale-aware residual of z for LCP(M, q), w = Mz + q, row by row:
///
///   r = max_i |min(z_i / s_z, w_i / s_i)|,
///   s_z = max(‖z‖∞, ‖q‖∞ / ‖M‖∞)   (the size of z, or of the z that q and M imply),
///   s_i = max(t_i, s_z Σ_j |M_ij|, kLcpRoundoffFloor · s_w),   t_i = |q_i| + Σ_j |M_ij z_j|,
///   s_w = max(max_i t_i, s_z ‖M‖∞)   (the problem's scale of w),
///
/// with ‖M‖∞ the largest absolute row sum and x / 0 read as 0 (s_i = 0 only if w ≡ 0; s_z = 0
/// only if z = 0 and q = 0, then r = 0). As a backward error: r ≤ ε means (to first order) that z
/// moved by at most ε s_z per entry solves the LCP with every row i of (M, q) perturbed by at most
/// ε times its own terms t_i (componentwise relative, as Oettli–Prager for linear systems), plus
/// ε · kLcpRoundoffFloor · s_w absolute. A negative z_i or w_i contributes its relative size, so r
/// bounds the negative parts of both. r is invariant to scaling q and M together, to scaling M
/// against q (units of z), and to scaling one row of (M, q) as long as that row's scale stays
/// above kLcpRoundoffFloor of the largest. Infinity if z, w or a scale is not finite (overflow),
/// NaN if z has the wrong size.
/// Examples: M = 1e-12·I, q = −1e-12·(1, 1): z = 0 has r = 1 (w = q < 0); z = (1, 1) has r = 0.
/// M = [[1e-12, 1], [0, 1e-12]], q = (−1e-12, −1e-19): z = (4e-10, 1e-12) has w_2 = −1e-19, r =
/// 0.025 (the global scale s_w = 4e-10 alone passed it at 2.5e-10); the solution
/// z = (0, 1e-7) has r ≈ 1e-16.
double LcpScaledResidual(const LcpProblem& problem, const VectorXd& z);

/// Empty if z passes LcpScaledResidual(problem, z) ≤ kLcpAcceptanceTolerance, else the reason
/// (naming the residual and the tolerance), for a failure report.
std::string CheckLcpSolution(const LcpProblem& problem, const VectorXd& z);

/// The gate every solver runs last: if `report` says kSolved but z fails CheckLcpSolution, the
/// status becomes kNumericalFailure and the message says why. Leaves other reports alone.
void ConfirmSolved(const LcpProblem& problem, const VectorXd& z, SolverReport* report);

}  // namespace vinci::sim
