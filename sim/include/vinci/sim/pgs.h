// Projected Gauss–Seidel / SOR for the LCP, aware of the friction-cone block structure.
#pragma once

#include "vinci/sim/lcp.h"

namespace vinci::sim {

struct PgsOptions {
  int max_sweeps = 1000;
  double tolerance = 1e-9;   ///< stop when LcpResidual ≤ tolerance · max(1, ‖q‖_∞)
  double relaxation = 1.0;   ///< SOR factor ω ∈ (0, 2)
};

/// Block projected Gauss–Seidel: sweeps over LcpProblem::blocks (scalar PGS when empty),
/// solving each block's small LCP exactly (given the other variables) — so blocks with zero
/// diagonal, like the σ rows of the Stewart–Trinkle LCP, are handled. Approximate: reports
/// kMaxIterations when the tolerance is not reached.
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
