// Semismooth Newton on the Fischer–Burmeister reformulation of the LCP.
#pragma once

#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim {

struct FischerBurmeisterOptions {
  int max_iterations = 100;
  double tolerance = 1e-10;  ///< on LcpResidual, scaled by max(1, ‖q‖_∞)
  /// Penalized FB weight λ ∈ (0, 1]: φ_λ = λ φ_FB − (1 − λ) max(0,a) max(0,b) (1 = plain FB).
  double lambda = 0.95;
  /// When Newton fails (iteration limit, line-search failure, stationary point), run Lemke
  /// warm-started at the best iterate and polish its answer with Newton (reported).
  bool lemke_fallback = true;
  /// When Newton fails, run proximal-point outer iterations (LCP(M + cI, q − c z_k), each
  /// solved by this Newton, see below) from the best iterate before the Lemke fallback
  /// (reported).
  bool proximal_fallback = true;
};

/// Semismooth Newton on Φ(z) = 0 with, for a = z_i and b = (Mz + q)_i,
///
///   φ_λ(a, b) = λ (√(a² + b²) − a − b) − (1 − λ) max(0, a) max(0, b).
///
/// Sign convention: φ_FB(a, b) = √(a² + b²) − a − b, which is ≤ 0 on the orthant a, b ≥ 0, so
/// the penalty enters with a minus sign. This is −1 times the penalized FB function of Chen,
/// Chen & Kanzow (Math. Program. 88, 2000) written with φ_FB = a + b − √(a² + b²); the two
/// terms must have the same sign on the orthant (mixing the conventions gives a spurious root
/// at a = b = λ(2 − √2)/(1 − λ)). Ψ = ½‖Φ‖² is the same either way.
///
/// Details of the contract:
/// - Generalized Jacobian H = D_a + D_b M; at a = b = 0 the unit vector (1, 1)/√2 is taken
///   in the subdifferential of √(a² + b²).
/// - Direction: H d = −Φ by partial-pivoting LU; when LU's condition estimate says H is
///   singular, the minimum-norm least-squares solution (complete orthogonal decomposition:
///   column-pivoting QR + RZ), which suits the non-isolated solutions of degenerate contact
///   LCPs; −∇Ψ = −HᵀΦ when d is not a sufficient descent direction (∇Ψᵀd > −10⁻¹⁰‖d‖^2.1) or
///   its line search fails.
/// - Non-monotone Armijo backtracking on Ψ against the largest Ψ of the last 5 iterates.
/// - Stops when LcpResidual(max(z, 0)) ≤ tolerance · max(1, ‖q‖_∞); the returned z is the
///   projection max(z, 0) of the iterate with the smallest residual. An exact warm start is
///   returned with 0 iterations.
/// - kMaxIterations at the iteration limit; kNumericalFailure when the line search finds no
///   decrease or Ψ is stationary at a non-solution (e.g. an infeasible LCP); kInvalidInput for
///   a malformed problem (z = 0). `iterations` counts accepted Newton or gradient steps; the
///   message counts the least-squares directions and gradient steps when there were any.
/// - Proximal-point fallback (proximal_fallback, on by default): if Newton fails, the
///   proximal-point method (Rockafellar 1976; for LCPs Facchinei & Pang 2003, §12.3) is run from
///   its best iterate: z_{k+1} solves LCP(M + c I, q − c z_k) by this Newton (no fallbacks),
///   warm-started at z_k, with at most 20 Newton steps per subproblem. A fixed point solves the
///   LCP. M + cI is strictly copositive where M is copositive and moves Newton's Jacobian away
///   from the singular H of degenerate contact LCPs (redundant contacts: non-isolated
///   solutions), so Newton converges on the subproblems where it stalls on the original.
///   The weight starts at c = 1e-5·s, s = max(1, max_i |M_ii|); it is divided by 10 (down to
///   1e-10·s) when an outer step does not halve the residual (a smaller c takes longer steps)
///   and multiplied by 10 (up to 0.1·s, then the loop stops) when a subproblem is not solved.
///   At most 30 outer steps and max_iterations Newton steps in all. The best iterate on the
///   original problem is kept. Reported: restarts = 1; the message says "proximal-point
///   fallback" with the outer and Newton steps and the range of c; `iterations` includes the
///   subproblems' Newton steps. (The LCPs it is needed on: bench/README.md, vinci_vs_siconos: "The
///   tilted pile".)
/// - Lemke fallback (lemke_fallback, on by default): if Newton and the proximal fallback fail,
///   LemkeSolver is run warm-started at the best iterate, and Newton (without fallbacks) from
///   Lemke's answer; the result is kSolved if it passes the tolerance above. The report then
///   has restarts = 2 (1 with proximal_fallback off), the message names both fallbacks, and
///   `iterations` includes Lemke's pivots and the polishing Newton steps.
/// - Invalid options throw std::invalid_argument, as does a null `z`.
class FischerBurmeisterSolver final : public LcpSolver {
 public:
  explicit FischerBurmeisterSolver(FischerBurmeisterOptions options = {}) : options_(options) {}
  std::string_view name() const override { return "fb-newton"; }
  SolverReport Solve(const LcpProblem& problem, const VectorXd* warm_start,
                     VectorXd* z) const override;
  const FischerBurmeisterOptions& options() const { return options_; }

 private:
  FischerBurmeisterOptions options_;
};

}  // namespace vinci::sim
