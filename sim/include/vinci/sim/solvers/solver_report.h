// What every complementarity solve reports: numbers only, no scene.
#pragma once

#include <string>
#include <string_view>

namespace vinci::sim {

/// Outcome of a complementarity solve.
enum class SolverStatus {
  kSolved,            ///< residual ≤ tolerance
  kSecondaryRay,      ///< Lemke terminated on a secondary ray (problem may be infeasible)
  kMaxIterations,     ///< iteration limit reached
  kNumericalFailure,  ///< singular pivot / NaN
  kInvalidInput,      ///< malformed problem (size mismatch, NaN in data)
  kStalled,           ///< no progress at a non-solution in every attempt (McpSolver restarts)
};
std::string_view ToString(SolverStatus s);

/// What every solve reports.
struct SolverReport {
  SolverStatus status = SolverStatus::kNumericalFailure;
  int iterations = 0;     ///< pivots (Lemke) or sweeps/Newton steps (iterative)
  double residual = 0.0;  ///< complementarity residual ‖min(z, Mz+q)‖_∞ of the returned z
  /// The acceptance threshold `residual` was compared with (kSolved iff residual ≤ tolerance).
  /// Each solver documents its own: Lemke scales residual_tolerance by max(1, ‖q‖∞, ‖M‖∞‖z‖∞)
  /// capped at 1000·max(1, ‖q‖∞) (lemke.h); 0 where a solver does not set it.
  double tolerance = 0.0;
  double time_s = 0.0;          ///< wall time of the solve (s); 0 where not timed (warm_basis.h)
  bool regularized = false;     ///< true if the solution came from a regularized retry M + εI
  double regularization = 0.0;  ///< the ε used, if regularized
  /// Extra attempts after the first one failed: McpSolver restarts, FB Newton's Lemke
  /// fallback, Lemke's Newton fallback, PGS blocks that fell back to their parts (0: the first
  /// attempt decided the outcome).
  int restarts = 0;
  std::string message;  ///< human-readable detail on failure
  bool ok() const { return status == SolverStatus::kSolved; }
};

}  // namespace vinci::sim
