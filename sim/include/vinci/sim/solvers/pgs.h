// Projected Gauss–Seidel / SOR for the LCP, aware of the friction-cone block structure.
#pragma once

#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim {

struct PgsOptions {
  int max_sweeps = 1000;
  double tolerance = 1e-9;  ///< stop when LcpResidual ≤ tolerance · max(1, ‖q‖_∞)
  double relaxation = 1.0;  ///< SOR factor ω ∈ (0, 2)
  /// Every this many sweeps (0: never), polish the iterate on its active set (subspace
  /// minimization: the minimum-norm Newton correction of the equations the active set implies,
  /// kept only if the residual drops; see the contract below). Off by default (measurements:
  /// bench/README.md, vinci_vs_siconos: PGS).
  int polish_interval = 0;
};

/// Block projected Gauss–Seidel: sweeps over LcpProblem::blocks (scalar PGS when empty),
/// solving each block's small LCP exactly (given the other variables) — so blocks with zero
/// diagonal, like the σ rows of the Stewart–Trinkle LCP, are handled. Approximate: reports
/// kMaxIterations when the tolerance is not reached. PGS is approximate on ill-conditioned
/// contact LCPs: give it the contact-patch blocks of StewartTrinkle::BuildLcp (per-contact blocks
/// stall on stacks; measurements, and where stepping a stack with `solver: pgs` still fails:
/// bench/README.md, vinci_vs_siconos: PGS).
///
/// Details of the contract:
/// - Block B is solved for x given the rest, M_BB x + r_B ⊥ x ≥ 0 with r_B = q_B + M_B,rest
///   z_rest, then relaxed: z_B ← max(0, (1 − ω) z_B + ω x). A scalar block with M_ii > 0 uses
///   x = max(0, −r_i / M_ii); a larger block uses LemkeSolver (residual tolerance
///   1e-3 × min(1e-9, tolerance), warm-started from z_B). A block that already satisfies
///   ‖min(z_B, w_B)‖_∞ ≤ 1e-3 · tolerance is left as it is.
/// - Block robustness: a contact patch's M_BB is singular (its impulses act through the 12
///   velocities of two bodies; its normal forces are statically indeterminate), and Lemke's
///   degenerate bases stop at block residuals of 1e-10…1e-9 on the stack. Such a result is
///   refined on its active set A = {i : x_i > w_i}: x = 0 off A plus the minimum-norm correction
///   of M_AA x_A = −r_A (complete orthogonal decomposition, rank-revealing), projected onto
///   x ≥ 0, at most 3 times, each kept only if the block residual drops. The refined block is
///   accepted if its residual is ≤ min(1e-9, tolerance) · max(1, ‖r_B‖∞).
/// - Fallback to parts: if a block still fails and LcpProblem::block_parts gives it parts
///   (BuildLcp: its contacts), the block is solved part by part (one Gauss–Seidel pass over
///   them, each part a block solve as above) for the rest of the solve; `restarts` counts the
///   blocks that fell back. A block without parts, or a part that fails, stops the solve with
///   kNumericalFailure naming the block.
/// - Polish (polish_interval > 0): the same refinement on the whole LCP after every
///   polish_interval-th sweep (an O(n³) decomposition of the active rows), kept only if the
///   residual drops.
/// - A scalar block with M_ii ≤ 0 gets x = 0 if r_i ≥ 0; if r_i < 0 its 1×1 LCP has no
///   solution, and the solve stops with kNumericalFailure naming the variable (scalar PGS on
///   the Stewart–Trinkle LCP without its blocks ends this way).
/// - The warm start, projected onto z ≥ 0, is the first iterate; if it passes the tolerance
///   it is returned with 0 sweeps. `iterations` counts sweeps.
/// - LcpProblem::blocks must partition {0..n−1} (each index exactly once), and block_parts be
///   empty or fit the blocks (lcp.h), else kInvalidInput.
/// - On failure z holds the iterate with the smallest residual seen at the end of a sweep
///   (or the start), zeros for invalid input.
/// - Invalid options (max_sweeps < 1, negative tolerance, ω ∉ (0, 2), polish_interval < 0) throw
///   std::invalid_argument, as does a null `z`.
class PgsSolver final : public LcpSolver {
 public:
  explicit PgsSolver(PgsOptions options = {}) : options_(options) {}
  std::string_view name() const override { return "pgs"; }
  SolverReport Solve(const LcpProblem& problem, const VectorXd* warm_start,
                     VectorXd* z) const override;
  const PgsOptions& options() const { return options_; }

 private:
  PgsOptions options_;
};

}  // namespace vinci::sim
