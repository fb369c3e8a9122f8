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
///   r = max_i |min(z_i / s_z, w_i / s_i)|,
///   s_z = max(‖z‖∞, ‖q‖∞ / ‖M‖∞)              (the size of z, or of the z that q and M imply),
///   s_i = max(|q_i| + Σ_j |M_ij z_j|, s_z Σ_j |M_ij|)   (the size of the terms whose sum is w_i),
///
/// with ‖M‖∞ the largest absolute row sum, and x / 0 read as 0 (s_i = 0 only if row i of M and
/// q_i are zero, so w_i = 0; s_z = 0 only if z = 0 and q = 0). It is a mixed backward error: r ≤ ε
/// means z is, up to ε s_z per entry, the solution of an LCP whose row i differs from (M, q)'s
/// by ε relative to its own terms. A negative z_i or w_i contributes its relative size, so r
/// bounds the negative parts of both. Invariances: scaling q and M together, scaling M against q
/// (units of z), and scaling any row i of M and q_i by a positive factor (the same LCP) leave r
/// unchanged; a global scale for w would let a row written in small units be violated by 100 %
/// of its own size. The floor s_z Σ_j |M_ij| is what z's roundoff-level entries (|z_j| ~ ε s_z)
/// can make of w_i: a row whose terms are all roundoff is not judged against itself.
/// Infinity if z, w or a scale is not finite (overflow), NaN if z has the wrong size.
/// Examples: M = 1e-12·I, q = −1e-12·(1, 1): z = 0 has r = 1 (w = q < 0); z = (1, 1) has r = 0.
/// M = [[1e-12, 1], [0, 1e-12]], q = (−1e-12, −1e-19): z = (4e-10, 1e-12) has w_2 ≈ −1e-19 and
/// r ≈ 1 (row 2 is violated by its whole size), the solution z = (0, 1e-7) has r ≈ 0.
double LcpScaledResidual(const LcpProblem& problem, const VectorXd& z);

/// Empty if z passes LcpScaledResidual(problem, z) ≤ kLcpAcceptanceTolerance, else the reason
/// (naming the residual and the tolerance), for a failure report.
std::string CheckLcpSolution(const LcpProblem& problem, const VectorXd& z);

/// The gate every solver runs last: if `report` says kSolved but z fails CheckLcpSolution, the
/// status becomes kNumericalFailure and the message says why. Leaves other reports alone.
void ConfirmSolved(const LcpProblem& problem, const VectorXd& z, SolverReport* report);

}  // namespace vinci::sim
