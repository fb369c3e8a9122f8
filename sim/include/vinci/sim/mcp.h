// Box-constrained mixed complementarity problems and the semismooth Newton solver that plays
// the role of PATH for the nonlinear steppers (NCP, geometrically implicit, quasistatic).
//
// MCP(F, l, u): find z with l ≤ z ≤ u such that for each i
//   z_i = l_i ⇒ F_i(z) ≥ 0,   l_i < z_i < u_i ⇒ F_i(z) = 0,   z_i = u_i ⇒ F_i(z) ≤ 0.
// l_i = −∞, u_i = +∞ makes row i an equation; l_i = 0, u_i = +∞ an NCP row.
#pragma once

#include <functional>
#include <string_view>

#include <Eigen/SparseCore>

#include "vinci/sim/lcp.h"

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
/// solver.
double McpResidual(const McpProblem& problem, const VectorXd& z);

struct McpOptions {
  int max_iterations = 200;
  double tolerance = 1e-10;       ///< natural residual
  double lambda = 0.95;           ///< penalized Fischer–Burmeister weight
  int nonmonotone_memory = 5;     ///< line search compares with the max of the last M merits
  bool sparse = false;            ///< use McpProblem::sparse_jacobian
  int max_restarts = 2;           ///< crash/restart attempts from perturbed starting points
};

class McpSolver {
 public:
  explicit McpSolver(McpOptions options = {}) : options_(options) {}
  std::string_view name() const { return "semismooth-newton"; }
  /// Solves from *z (the starting point; projected onto [l, u]); *z is overwritten with the
  /// solution or the best iterate. Never throws on numerical trouble.
  SolverReport Solve(const McpProblem& problem, VectorXd* z) const;
  const McpOptions& options() const { return options_; }

 private:
  McpOptions options_;
};

}  // namespace vinci::sim
