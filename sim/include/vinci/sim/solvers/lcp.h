// Linear complementarity problems and the solver interface.
//
// LCP(M, q): find z ≥ 0 with w = M z + q ≥ 0 and zᵀw = 0.
// A solver sees only these numbers, never a body.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "vinci/sim/solvers/solver_report.h"

namespace vinci::sim {

using Eigen::MatrixXd;
using Eigen::VectorXd;

/// Standard LCP data.
struct LcpProblem {
  MatrixXd M;
  VectorXd q;
  /// Optional block structure for block-iterative solvers (projected Gauss–Seidel): a partition
  /// of {0..n−1} into groups solved together, e.g. in the Stewart–Trinkle LCP one block per
  /// contact patch holding the friction-cone rows (p_n, p_f,1..n_d, σ) of every contact between
  /// two bodies (StewartTrinkle::LcpBlocks). Empty: every variable is its own block. Direct
  /// solvers (Lemke) ignore it.
  std::vector<std::vector<int>> blocks;
  /// Optional sub-structure of `blocks` (empty, or one entry per block): block_parts[b] lists
  /// the offsets in blocks[b] at which its parts begin (0 first, increasing, each < the block's
  /// size); an empty entry means no parts. A block solver whose solve of block b fails may solve
  /// its parts in turn instead (PGS does, pgs.h). StewartTrinkle::BuildLcp: one part per
  /// contact of a contact-patch block.
  std::vector<std::vector<int>> block_parts;
  int size() const { return static_cast<int>(q.size()); }
};

/// ‖min(z, Mz + q)‖_∞: zero exactly at a solution. Independent of any solver.
double LcpResidual(const LcpProblem& problem, const VectorXd& z);

/// Empty if M is square, matches q and all data are finite; otherwise the reason, for
/// SolverStatus::kInvalidInput reports.
std::string CheckLcpData(const LcpProblem& problem);

/// Interface of an LCP solver. Implementations are stateless and thread-safe.
class LcpSolver {
 public:
  virtual ~LcpSolver() = default;
  virtual std::string_view name() const = 0;
  /// Solves `problem`. `z` is the output; if `warm_start` is non-null and of the right
  /// size it is used as a starting guess (an exact solution must be accepted with 0
  /// iterations). On failure z holds the solver's best iterate (possibly zeros) and the
  /// report says why.
  virtual SolverReport Solve(const LcpProblem& problem, const VectorXd* warm_start,
                             VectorXd* z) const = 0;
};

/// Solver selection by name for scenes and the CLI (see LcpSolverNames()).
/// Throws std::invalid_argument naming the known solvers for anything else.
std::shared_ptr<const LcpSolver> MakeLcpSolver(const std::string& name);
/// The names MakeLcpSolver accepts.
std::vector<std::string> LcpSolverNames();

}  // namespace vinci::sim
