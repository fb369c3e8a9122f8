// A symmetric indefinite sparse LDLᵀ by sequential MUMPS (the library Ipopt factors with), for
// the estimator's KKT solves (mpec_covariance.cc).
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include "vinci/sim/formulations/step_model.h"

namespace vinci::estimation::mpec_internal {

class MumpsLdlt {
 public:
  MumpsLdlt();
  ~MumpsLdlt();
  MumpsLdlt(const MumpsLdlt&) = delete;
  MumpsLdlt& operator=(const MumpsLdlt&) = delete;

  /// Factors the symmetric K (its lower triangle is read) with 2×2 pivoting, QAMD ordering
  /// (deterministic) and null-pivot detection: a pivot below MUMPS' threshold is set aside and
  /// its unknown set to 0 by solve, so a singular K with b in its range still yields a solution
  /// (one of them). false if MUMPS failed (error, or memory after two enlargements).
  bool Compute(const sim::SparseMatrixXd& K);
  /// K⁻¹ b on the factored K (the null pivots' unknowns 0). Valid after a true Compute.
  sim::VectorXd solve(const sim::VectorXd& b) const;
  /// Null pivots set aside by the last Compute (MUMPS INFOG(28)).
  int null_pivots() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// MUMPS' analysis alone of a symmetric pattern of dimension n (0-based (row, col) entries of
/// its lower triangle, row ≥ col, the diagonal included) ordered by ICNTL(7) = `ordering` (3:
/// SCOTCH, 6: QAMD): the factorization's estimated floating-point operations (RINFOG(1)),
/// before numerical pivoting; NaN if MUMPS failed.
double EstimatedFactorizationFlops(int n, const std::vector<std::pair<int, int>>& lower,
                                   int ordering);

}  // namespace vinci::estimation::mpec_internal
