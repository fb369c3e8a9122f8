// Lemke's method on a sparse LCP matrix: for the large, sparse contact LCPs of many-body scenes
// (a 40-box stack: n = 960, a few percent nonzeros), where the dense solver's n × n basis
// inverse makes every pivot O(n²).
#pragma once

#include <Eigen/SparseCore>

#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/solver_report.h"

namespace vinci::sim {

/// LCPs with more unknowns than this are solved by SolveSparseLemke in the Stewart–Trinkle
/// steppers (when the solver is Lemke and the assembly has plain contacts only); smaller ones
/// by the dense LemkeSolver, for which a dense basis inverse is cheaper than a sparse LU.
inline constexpr int kSparseLemkeMinSize = 64;

/// Lemke's method (lemke.h) on LCP(M, q) with M sparse (column major), without forming any
/// dense n × n matrix:
///
/// - The basis B (columns e_i for a basic w_i, −M_j for a basic z_j, −d for z0, d the
///   covering vector) is factored as B_0 E_1 ⋯ E_k: B_0 by a sparse LU (Eigen::SparseLU,
///   COLAMD) of its reduced block — the rows of the nonbasic w against the basic z and z0 —
///   and one product-form (eta) factor E_i per pivot. B_0 is refactored every
///   `options.refactor_interval` pivots (0: 40) and after a pivot below 1e-9 of its column's
///   largest entry, and the basic values recomputed from it.
/// - A pivot costs one solve with B (the entering column d = B⁻¹ a), the ratio test on d and
///   the basic values x, and, only where the lexicographic rule must break a tie, rows (one
///   transposed solve per tied row, up to 16 ties) or columns of B⁻¹. The ratio test is the
///   dense solver's (lemke_internal.h: Harris' two-pass test, the tie tolerances, the
///   lexicographic rule), as are the symmetric power-of-two scaling (options.scale), the
///   iterative refinement at termination and the acceptance test (τ(z) of lemke.h and the
///   scale-aware check of lcp_acceptance.h, computed in O(nnz(M))).
/// - Warm start: with `warm_start` of size n, B = {i : warm_i > 0} (z_i basic, w_i otherwise)
///   and the covering vector d = B·1, so that z0's column in basis coordinates is −1 and the
///   first pivot makes the basis feasible (a cold start is B = I, d = 1). A numerically
///   singular guess (the spread normal impulses of a box resting on several others are
///   linearly dependent) is first made nonsingular: the z_i whose columns of M(S, S),
///   S = {i : warm_i > 0}, a rank-revealing sparse QR finds dependent (relative 1e-10) leave
///   for their w_i. If B⁻¹q ≥ 0 the warm basis is the answer (0 pivots); if B_0 is singular
///   or the warm run fails, a cold run follows. A step whose active set changed a little
///   needs a few pivots instead of a cold run's hundreds.
///
/// - If every run fails the tests, up to 32 principal pivots (w_i ↔ z_i of the most negative
///   basic value, the basis refactored each time) from each terminated run's terminal basis,
///   keeping the iterate with the smallest residual: a degenerate terminal basis whose values
///   are a few tie tolerances below 0 (pivot columns of 1e6) becomes one within the tolerance.
///   A run that passes is never polished.
///
/// Returns kSolved (iterations = pivots of all runs) iff z passes both acceptance tests. There
/// are no regularized retries, Fischer–Burmeister polish or Newton fallback: on failure the
/// report says why (z, status, residual: those of the run, warm or cold, whose last iterate,
/// clamped to z ≥ 0, has the smaller residual) and a caller needing LemkeSolver's full robustness
/// solves the dense LCP with it. Invalid input (sizes, non-finite entries) is kInvalidInput,
/// invalid options throw std::invalid_argument as LemkeSolver's, a null z throws. No state survives
/// the call (thread-safe; same inputs, same bits).
SolverReport SolveSparseLemke(const Eigen::SparseMatrix<double>& M, const Eigen::VectorXd& q,
                              const Eigen::VectorXd* warm_start, const LemkeOptions& options,
                              Eigen::VectorXd* z);

/// LcpScaledResidual (lcp_acceptance.h) of z for a sparse M, in O(nnz(M)).
double SparseLcpScaledResidual(const Eigen::SparseMatrix<double>& M, const Eigen::VectorXd& q,
                               const Eigen::VectorXd& z);

}  // namespace vinci::sim
