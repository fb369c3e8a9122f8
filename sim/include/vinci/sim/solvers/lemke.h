// Lemke's complementary pivoting method for the LCP, the reference solver for the
// Stewart–Trinkle step (copositive-plus, non-symmetric, often degenerate matrices).
#pragma once

#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim {

struct LemkeOptions {
  int max_pivots = 0;              ///< 0: 50·n + 100
  double pivot_tolerance = 1e-12;  ///< smallest admissible |pivot| in the ratio test
  /// Accept z when LcpResidual(z) ≤ residual_tolerance · max(b, min(‖M‖∞‖z‖∞, 1000·b)),
  /// b = max(1, ‖q‖∞) (see below).
  double residual_tolerance = 1e-9;
  bool lexicographic = true;  ///< lexicographic ratio test (anti-cycling)
  bool scale = true;          ///< row/column equilibration before pivoting
  /// On failure, retry with M + εI for ε in this sequence (0 disables); the report says so.
  double regularization = 1e-10;
  /// Recompute the explicit basis inverse from scratch every this many pivots to bound the
  /// drift of the rank-1 updates (0: max(50, n)).
  int refactor_interval = 0;
  /// When every Lemke attempt fails (secondary ray or numerical failure, not the pivot
  /// limit), solve by Fischer–Burmeister Newton from z = 0 and accept it if it passes τ.
  bool newton_fallback = true;
  /// Polish a terminated run that misses the acceptance test (see below) before the retries;
  /// false: go straight to the retries (for callers that have a cheaper fallback of their own).
  bool polish = true;
};

/// Lemke with covering vector e, lexicographic anti-cycling, optional scaling, warm start
/// from a guessed basis (z_i > 0 → basic), and a reported regularized retry.
///
/// Details of the contract:
/// - Acceptance: z solves the LCP iff LcpResidual(z) ≤ τ(z) with
///     τ(z) = residual_tolerance · max(b, min(‖M‖∞ ‖z‖∞, 1000·b)),   b = max(1, ‖q‖∞),
///   with ‖M‖∞ = max_i Σ_j |M_ij|, reported as SolverReport::tolerance. The ‖M‖∞‖z‖∞ term is the
///   size of the terms whose cancellation gives w = Mz + q, so the test is invariant to scaling z
///   (units of impulse). The warm-start check, the secondary-ray acceptance and the choice among
///   retries all use this τ. The cap 1000·b keeps a huge z from passing with a large residual (a
///   regularized retry of an infeasible LCP returns ‖z‖ ~ ‖q‖/ε).
/// - Polish: a run that terminates (z0 leaves) with a residual above τ, from roundoff in a
///   degenerate basis, is handed to FischerBurmeisterSolver (with its proximal-point fallback,
///   without its Lemke fallback) as a warm start, with FB's tolerance set to τ/2 at the start
///   point so that it stops where this test would accept; its result is kept if it passes τ,
///   and the report's message says so and carries FB's own message (its Newton steps are not
///   counted in `iterations`). Only then the retries below run.
/// - Newton fallback (newton_fallback): if the plain, unscaled and regularized attempts all
///   fail with a secondary ray or a numerical failure, FischerBurmeisterSolver (without its
///   own Lemke fallback) is run from z = 0; a result passing τ is returned as kSolved with
///   restarts = 1 and a message naming the fallback (and FB's proximal-point fallback if it
///   ran). An infeasible LCP still fails. Why the polish and the fallback exist (degenerate
///   box-pile LCPs on which every Lemke attempt fails): bench/README.md, vinci_vs_siconos: "The
///   tilted pile".
/// - Scaling is symmetric, D M D with z = D z̃ and D a power-of-two diagonal (so the scaling
///   is exact), because a symmetric scaling keeps M copositive-plus / PSD and hence keeps
///   Lemke's termination guarantee.
/// - Warm start: with B = {i : warm_i > 0}, z_B solves M_BB z_B = −q_B (anchored at the
///   guess where M_BB is singular) and is accepted with 0 iterations if z_B ≥ −tol,
///   w_N ≥ −tol and the residual passes; otherwise Lemke runs cold.
/// - The pivot tolerance is relative: a ratio-test entry d_i is admissible only if
///   d_i > pivot_tolerance · max(1, ‖d‖_∞).
/// - The retry sequence is ε = r, 1e3·r, 1e6·r (r = regularization); it stops at the first ε
///   for which Lemke terminates on M + εI. The z returned is the one of the attempts with the
///   smallest residual on the original problem; `regularized` is true iff it came from a retry.
///   The status is kSolved iff that residual passes, otherwise the first attempt's status.
/// - `iterations` counts all pivots, including those of retries. On failure z holds the last
///   almost-complementary iterate (clamped to z ≥ 0), or zeros for invalid input.
/// - Invalid options (negative tolerances or limits) throw std::invalid_argument, as does a
///   null `z`.
/// - Threads: Solve may run concurrently on several threads. Each thread reuses a scratch
///   workspace across solves (basis inverse and pivoting vectors, not allocated per solve),
///   which keeps 8n² bytes for the largest n solved on that thread (2 MB at n = 500), 24n² once
///   a refactorization of the basis ran (basis matrix and its LU factors).
class LemkeSolver final : public LcpSolver {
 public:
  explicit LemkeSolver(LemkeOptions options = {}) : options_(options) {}
  std::string_view name() const override { return "lemke"; }
  SolverReport Solve(const LcpProblem& problem, const VectorXd* warm_start,
                     VectorXd* z) const override;
  const LemkeOptions& options() const { return options_; }

 private:
  LemkeOptions options_;
};

}  // namespace vinci::sim
