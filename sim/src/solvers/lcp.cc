// LCP helpers shared by every complementarity solver.
#include "vinci/sim/solvers/lcp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace vinci::sim {

std::string_view ToString(SolverStatus s) {
  switch (s) {
    case SolverStatus::kSolved:
      return "solved";
    case SolverStatus::kSecondaryRay:
      return "secondary ray";
    case SolverStatus::kMaxIterations:
      return "max iterations";
    case SolverStatus::kNumericalFailure:
      return "numerical failure";
    case SolverStatus::kInvalidInput:
      return "invalid input";
    case SolverStatus::kStalled:
      return "stalled";
  }
  return "unknown";
}

double LcpResidual(const LcpProblem& problem, const VectorXd& z) {
  const Eigen::Index n = problem.q.size();
  if (problem.M.rows() != n || problem.M.cols() != n) {
    throw std::invalid_argument("LcpResidual: M is " + std::to_string(problem.M.rows()) + "x" +
                                std::to_string(problem.M.cols()) + " but q has size " +
                                std::to_string(n) + "; expected a square M matching q");
  }
  if (z.size() != n) {
    throw std::invalid_argument("LcpResidual: z has size " + std::to_string(z.size()) +
                                " but the problem has size " + std::to_string(n));
  }
  // w = M z + q in a per-thread buffer: the product, then the sum (as Eigen evaluates the
  // expression, without its temporaries).
  thread_local VectorXd w;
  w.noalias() = problem.M * z;
  w += problem.q;
  double residual = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double w_i = w(i);
    const double z_i = z(i);
    // A NaN anywhere must not be hidden by std::min / std::max ordering.
    if (std::isnan(w_i) || std::isnan(z_i)) return std::numeric_limits<double>::quiet_NaN();
    residual = std::max(residual, std::abs(std::min(z_i, w_i)));
  }
  return residual;
}

std::string CheckLcpData(const LcpProblem& problem) {
  const Eigen::Index n = problem.q.size();
  if (problem.M.rows() != n || problem.M.cols() != n)
    return "M is " + std::to_string(problem.M.rows()) + "x" + std::to_string(problem.M.cols()) +
           " but q has size " + std::to_string(n) + "; expected a square M matching q";
  if (!problem.M.allFinite() || !problem.q.allFinite()) return "M or q contains NaN or Inf";
  return {};
}

}  // namespace vinci::sim
