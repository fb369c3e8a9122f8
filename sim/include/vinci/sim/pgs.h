// Projected Gauss–Seidel / SOR for the LCP, aware of the friction-cone block structure.
#pragma once

#include "vinci/sim/lcp.h"

namespace vinci::sim {

struct PgsOptions {
  int max_sweeps = 1000;
  double tolerance = 1e-9;  ///< stop when LcpResidual ≤ tolerance · max(1, ‖q‖_∞)
  double relaxation = 1.0;  ///< SOR factor ω ∈ (0, 2)
};

/// Block projected Gauss–Seidel: sweeps over LcpProblem::blocks (scalar PGS when empty),
/// solving each block's small LCP exactly (given the other variables) — so blocks with zero
/// diagonal, like the σ rows of the Stewart–Trinkle LCP, are handled. Approximate: reports
/// kMaxIterations when the tolerance is not reached.
///
/// Accuracy on stacks: PGS is approximate on ill-conditioned contact LCPs. On the 10-box
/// stack (n = 240, contact-matrix eigenvalues 1e-3…94) with one block per contact, 1000
/// sweeps started cold reach a residual of ~1e-5 only (ω = 0.7…1.9 and the sweep order do not
/// change that materially), against the 1e-9 tolerance. Blocks that hold a whole contact patch
/// (every contact between the same two bodies, solved together by Lemke) converge on the same
/// LCP in 585 sweeps (ω = 1) or 319 (ω = 1.3): where the caller can group contacts that way,
/// it should (tests/sim/pgs_test.cc, BoxStackCold*).
///
/// Details of the contract:
/// - Block B is solved for x given the rest, M_BB x + r_B ⊥ x ≥ 0 with r_B = q_B + M_B,rest
///   z_rest, then relaxed: z_B ← max(0, (1 − ω) z_B + ω x). A scalar block with M_ii > 0 uses
///   x = max(0, −r_i / M_ii); a larger block uses LemkeSolver (default options). A block that
///   already satisfies ‖min(z_B, w_B)‖_∞ ≤ 1e-3 · tolerance is left as it is.
/// - A scalar block with M_ii ≤ 0 gets x = 0 if r_i ≥ 0; if r_i < 0 its 1×1 LCP has no
///   solution, and the solve stops with kNumericalFailure naming the variable (scalar PGS on
///   the Stewart–Trinkle LCP without its blocks ends this way). A block on which Lemke fails
///   stops the solve the same way.
/// - The warm start, projected onto z ≥ 0, is the first iterate; if it passes the tolerance
///   it is returned with 0 sweeps. `iterations` counts sweeps.
/// - LcpProblem::blocks must partition {0..n−1} (each index exactly once), else kInvalidInput.
/// - On failure z holds the iterate with the smallest residual seen at the end of a sweep
///   (or the start), zeros for invalid input.
/// - Invalid options (max_sweeps < 1, negative tolerance, ω ∉ (0, 2)) throw
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
