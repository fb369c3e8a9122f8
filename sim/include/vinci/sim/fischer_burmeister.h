// Semismooth Newton on the Fischer–Burmeister reformulation of the LCP.
#pragma once

#include "vinci/sim/lcp.h"

namespace vinci::sim {

struct FischerBurmeisterOptions {
  int max_iterations = 100;
  double tolerance = 1e-10;  ///< on LcpResidual, scaled by max(1, ‖q‖_∞)
  double lambda = 0.95;      ///< penalized FB: λ φ_FB + (1 − λ) max(0,a)max(0,b) (1 = plain FB)
};

/// φ(a, b) = √(a² + b²) − a − b applied to (z, Mz + q); Newton with a generalized Jacobian,
/// Armijo / non-monotone line search on ½‖Φ‖², gradient fallback.
class FischerBurmeisterSolver final : public LcpSolver {
 public:
  explicit FischerBurmeisterSolver(FischerBurmeisterOptions options = {}) : options_(options) {}
  std::string_view name() const override { return "fb-newton"; }
  SolverReport Solve(const LcpProblem& problem, const VectorXd* warm_start,
                     VectorXd* z) const override;

 private:
  FischerBurmeisterOptions options_;
};

}  // namespace vinci::sim
