// The shared scale-aware acceptance test (lcp_acceptance.h).
#include "vinci/sim/solvers/lcp_acceptance.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "solver_util.h"

namespace vinci::sim {

double LcpScaledResidual(const LcpProblem& problem, const VectorXd& z) {
  const Eigen::Index n = problem.q.size();
  if (problem.M.rows() != n || problem.M.cols() != n || z.size() != n)
    return std::numeric_limits<double>::quiet_NaN();
  if (n == 0) return 0.0;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (!z.allFinite()) return kInf;
  const double m_norm = problem.M.cwiseAbs().rowwise().sum().maxCoeff();
  const double q_norm = problem.q.lpNorm<Eigen::Infinity>();
  const double z_norm = z.lpNorm<Eigen::Infinity>();
  const VectorXd w = problem.M * z + problem.q;
  const double s_w = std::max(q_norm, m_norm * z_norm);
  const double s_z = std::max(z_norm, m_norm > 0.0 ? q_norm / m_norm : 0.0);
  if (!w.allFinite() || !std::isfinite(s_w) || !std::isfinite(s_z)) return kInf;
  const auto ratio = [](double x, double s) { return s > 0.0 ? x / s : 0.0; };
  double r = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)
    r = std::max(r, std::abs(std::min(ratio(z(i), s_z), ratio(w(i), s_w))));
  return r;
}

std::string CheckLcpSolution(const LcpProblem& problem, const VectorXd& z) {
  const double r = LcpScaledResidual(problem, z);
  if (r <= kLcpAcceptanceTolerance) return {};
  if (std::isinf(r)) return "z or w = Mz + q is not finite (overflow at the problem's scale)";
  if (std::isnan(r)) return "z does not match the problem size";
  return "the scale-aware residual max_i |min(z_i/s_z, w_i/s_w)| = " + internal::FormatDouble(r) +
         " exceeds " + internal::FormatDouble(kLcpAcceptanceTolerance) +
         " (z or w is negative, or they are not complementary, at the problem's own scale)";
}

void ConfirmSolved(const LcpProblem& problem, const VectorXd& z, SolverReport* report) {
  if (!report->ok()) return;
  const std::string why = CheckLcpSolution(problem, z);
  if (why.empty()) return;
  report->status = SolverStatus::kNumericalFailure;
  report->message = "rejected by the acceptance check: " + why +
                    (report->message.empty() ? "" : " (solver: " + report->message + ")");
}

}  // namespace vinci::sim
