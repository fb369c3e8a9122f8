// Box-constrained mixed complementarity problems and the semismooth Newton solver that plays
// the role of PATH for the nonlinear steppers (NCP, geometrically implicit, quasistatic).
//
// MCP(F, l, u): find z with l ≤ z ≤ u such that for each i
//   z_i = l_i ⇒ F_i(z) ≥ 0,   l_i < z_i < u_i ⇒ F_i(z) = 0,   z_i = u_i ⇒ F_i(z) ≤ 0.
// l_i = −∞, u_i = +∞ makes row i an equation; l_i = 0, u_i = +∞ an NCP row.
#pragma once

#include <Eigen/SparseCore>
#include <functional>
#include <string_view>

#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim {

/// The problem: bounds and a function evaluating F(z) and (optionally) its Jacobian.
struct McpProblem {
  VectorXd lower, upper;  ///< ±infinity allowed
  /// Evaluates F(z) into *F; if J is non-null also the dense Jacobian ∂F/∂z.
  std::function<void(const VectorXd& z, VectorXd* F, MatrixXd* J)> evaluate;
  /// Optional sparse Jacobian (used instead of the dense one when set and
  /// McpOptions::sparse is true).
  std::function<void(const VectorXd& z, Eigen::SparseMatrix<double>* J)> sparse_jacobian;
  int size() const { return static_cast<int>(lower.size()); }
};

/// Natural residual ‖z − mid(l, u, z − F(z))‖_∞: zero exactly at a solution. Independent of any
/// solver. NaN if F(z) has a NaN. Throws std::invalid_argument for mismatched sizes or a missing
/// evaluate; exceptions thrown by evaluate propagate.
double McpResidual(const McpProblem& problem, const VectorXd& z);

/// The scale-aware residual of z (the MCP form of LcpScaledResidual, lcp_acceptance.h), with
/// F linearized at z, F(z) = J z + c (J = ∂F/∂z, c = F(z) − J z; for an LCP J = M, c = q):
///   r = max_i |ẑ_i − mid(l_i / s_z, u_i / s_z, ẑ_i − F_i(z) / s_w)|,   ẑ = z / s_z,
///   s_z = max(‖z‖∞, ‖c‖∞ / ‖J‖∞),   s_i = s_w = max(max_k (|c_k| + Σ_j |J_kj z_j|), s_z ‖J‖∞).
/// Like the LCP's, it bounds how far z leaves the box and how far F_i has the wrong sign,
/// relative to the problem's own scale (invariant to scaling F as a whole and to the units of
/// z). An MCP in small units, e.g. F(z) = 1e-12 (z − 1) on z ≥ 0, has a tiny natural residual at
/// z = 0 (1e-12) but r = 1 there. Uses sparse_jacobian if set, else the dense Jacobian of
/// evaluate. Infinity if anything is not finite. Throws as McpResidual.
double McpScaledResidual(const McpProblem& problem, const VectorXd& z);

/// The penalized Fischer–Burmeister reformulation Φ(z) = 0 of MCP(F, l, u) that McpSolver
/// drives to zero (exposed for tests and callers that want the merit ½‖Φ‖²). With
/// φ(a, b) = λ(√(a² + b²) − a − b) − (1 − λ) a₊ b₊ (zero iff a ≥ 0, b ≥ 0, ab = 0), row i is
///   l, u infinite:         −F_i                    (equation)
///   l finite, u infinite:   φ(z_i − l_i, F_i)
///   l infinite, u finite:  −φ(u_i − z_i, −F_i)
///   both finite, l < u:     φ(z_i − l_i, φ(u_i − z_i, −F_i))
///   l = u:                  z_i − l_i               (fixed variable)
/// If J is non-null it receives the element of the generalized Jacobian the solver uses: the
/// classical Jacobian where Φ is differentiable; where a Fischer–Burmeister pair is (0, 0) the
/// direction-based element (De Luca, Facchinei, Kanzow 1996): with d = Σ e_i over such rows i,
/// those rows are the directional derivatives Φ_i'(z; d) (including the penalty's kinks in
/// them). Elsewhere a kink of the penalty a₊b₊ alone (a = 0 or b = 0) takes (x)₊' = 0 at 0.
/// Calls problem.evaluate once (with the dense Jacobian iff J is non-null). 0 < λ ≤ 1.
VectorXd McpFischerBurmeister(const McpProblem& problem, const VectorXd& z, double lambda,
                              MatrixXd* J);

struct McpOptions {
  int max_iterations = 200;
  double tolerance = 1e-10;    ///< natural residual
  double lambda = 0.95;        ///< penalized Fischer–Burmeister weight
  int nonmonotone_memory = 5;  ///< line search compares with the max of the last M merits
  bool sparse = false;         ///< use McpProblem::sparse_jacobian
  int max_restarts = 2;        ///< restarts of a stalled solve (crash point, then perturbed)
  /// An attempt counts as stalled (and restarts) when its best merit has not dropped by 10%
  /// within this many consecutive iterations.
  int stall_iterations = 30;
  /// Where the Newton step is unusable (H singular, not a descent direction, or its line search
  /// fails), try a Levenberg–Marquardt step before the projected gradient (see Solve).
  bool levenberg_marquardt = true;
};

/// Details of one McpSolver::Solve beyond the SolverReport.
struct McpSolveStats {
  int restarts = 0;              ///< crash/restart attempts used (≤ max_restarts)
  int newton_steps = 0;          ///< accepted (projected) semismooth Newton steps
  int lm_steps = 0;              ///< accepted Levenberg–Marquardt steps
  int gradient_steps = 0;        ///< accepted projected-gradient fallback steps
  int function_evaluations = 0;  ///< calls of McpProblem::evaluate
  double merit = 0.0;            ///< Ψ = ½‖Φ‖² at the returned z
};

class McpSolver {
 public:
  explicit McpSolver(McpOptions options = {}) : options_(options) {}
  std::string_view name() const { return "semismooth-newton"; }
  /// Solves from *z (the starting point; projected onto [l, u]); *z is overwritten with the
  /// solution or the best iterate. Never throws on numerical trouble.
  ///
  /// Details of the contract:
  /// - Every iterate, trial point and restart point lies in [l, u] (F is never evaluated
  ///   outside the box). Steps: z⁺ = P[z + t d] with the semismooth Newton direction
  ///   H d = −Φ(z), H from McpFischerBurmeister; if H is (numerically) singular, d is not finite
  ///   or ∇Ψᵀd > −10⁻¹⁰‖d‖^2.1, or the Newton line search fails, a projected-gradient step
  ///   z⁺ = P[z − t ∇Ψ], ∇Ψ = Hᵀ Φ. Non-monotone Armijo test against the max of the last
  ///   `nonmonotone_memory` merits. Newton systems: PartialPivLU (dense) or SparseLU when
  ///   options.sparse and problem.sparse_jacobian are set.
  /// - Levenberg–Marquardt (options.levenberg_marquardt, on by default): where the Newton step
  ///   is unusable, first d from (HᵀH + m I) d = −∇Ψ, m = min(1, ‖Φ‖²) · max_i (HᵀH)_ii
  ///   (Yamashita–Fukushima 2001: μ ~ ‖Φ‖², superlinear near non-isolated solutions under a
  ///   local error bound), LDLT (dense) or SimplicialLDLT (sparse), with the same line search;
  ///   only if that fails the projected gradient. It matters near nearly non-isolated
  ///   solutions (singular values of H far below ‖Φ‖/‖d‖: the Newton step is rejected by the
  ///   descent test and the gradient crawls), e.g. the redundant corner contacts of a box in the
  ///   NCP stepper (bench/README.md); where Newton works the iterates are unchanged.
  /// - Stopping test: convergence (McpResidual ≤ tolerance and the acceptance test below). A
  ///   starting point that passes takes 0
  ///   iterations. `iterations` counts Newton/gradient iterations over all restarts and is
  ///   bounded by max_iterations in total.
  /// - Restart when an attempt stalls (both line searches fail, a stationary point of Ψ on the
  ///   box, or no progress within stall_iterations): restart 1 from the crash point
  ///   P[z₀ − F(z₀)] (the projected start shifted toward the bounds F points at), later ones
  ///   from deterministic perturbations of the best point so far.
  /// - Acceptance: a point is converged iff McpResidual ≤ tolerance and McpScaledResidual ≤
  ///   kLcpAcceptanceTolerance (lcp_acceptance.h; the gate every LCP solver passes too): the
  ///   absolute tolerance alone would accept z = 0 on a problem in small units. A point that
  ///   passes only the first is iterated on.
  /// - *z receives the first converged point, else the iterate with the smallest natural
  ///   residual; `residual` is its McpResidual. kSolved iff it is converged; kMaxIterations if the
  ///   budget ran out; kStalled if every attempt (the first and max_restarts restarts) stalled;
  ///   kNumericalFailure if evaluate threw (message contains what()) or returned a non-finite
  ///   F/J at an accepted point (a non-finite trial point is backtracked).
  /// - SolverReport::restarts = McpSolveStats::restarts: the restarts used, on success too.
  /// - Throws std::invalid_argument for a null z, mismatched sizes (including F/J returned by
  ///   evaluate), NaN bounds, l > u, a non-finite starting point, a missing evaluate or invalid
  ///   options.
  SolverReport Solve(const McpProblem& problem, VectorXd* z) const;
  /// As above, also filling *stats (may be null).
  SolverReport Solve(const McpProblem& problem, VectorXd* z, McpSolveStats* stats) const;
  const McpOptions& options() const { return options_; }

 private:
  McpOptions options_;
};

}  // namespace vinci::sim
