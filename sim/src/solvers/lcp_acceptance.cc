// The shared scale-aware acceptance test (lcp_acceptance.h).
#include "vinci/sim/solvers/lcp_acceptance.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "solver_util.h"

namespace vinci::sim {

namespace internal {

double ScaledNaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                             const VectorXd* upper, const VectorXd& row_terms,
                             const VectorXd& row_norms, double c_norm) {
  if (z.size() == 0) return 0.0;
  if (!row_norms.allFinite()) return std::numeric_limits<double>::infinity();
  return ScaledNaturalResidual(z, F, lower, upper, row_terms, row_norms.maxCoeff(), c_norm);
}

double ScaledNaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                             const VectorXd* upper, const VectorXd& row_terms, double j_norm,
                             double c_norm) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Eigen::Index n = z.size();
  if (n == 0) return 0.0;
  if (!z.allFinite() || !F.allFinite() || !row_terms.allFinite() || !std::isfinite(j_norm) ||
      !std::isfinite(c_norm))
    return kInf;
  double s_z = std::max(z.lpNorm<Eigen::Infinity>(), j_norm > 0.0 ? c_norm / j_norm : 0.0);
  if (!std::isfinite(s_z)) return kInf;
  if (!(s_z > 0.0)) s_z = 1.0;  // z = 0 and c = 0: F = 0
  // One scale for every row (the largest row's). LcpScaledResidual judges each row at its own
  // scale (lcp_acceptance.h); the MCP measure keeps the global one (docs/fuzzing.md).
  const double s_w = std::max(row_terms.maxCoeff(), s_z * j_norm);
  if (!std::isfinite(s_w)) return kInf;
  double r = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double f = s_w > 0.0 ? F(i) / s_w : 0.0;
    const double zi = z(i) / s_z;
    const double l = lower != nullptr ? (*lower)(i) / s_z : 0.0;
    const double u = upper != nullptr ? (*upper)(i) / s_z : kInf;
    const double mid = std::min(std::max(zi - f, l), u);
    const double ri = std::abs(zi - mid);
    if (std::isnan(ri)) return kInf;
    r = std::max(r, ri);
  }
  return r;
}

}  // namespace internal

double LcpScaledResidual(const LcpProblem& problem, const VectorXd& z) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Eigen::Index n = problem.q.size();
  if (problem.M.rows() != n || problem.M.cols() != n || z.size() != n)
    return std::numeric_limits<double>::quiet_NaN();
  if (n == 0) return 0.0;
  if (!z.allFinite()) return kInf;
  const VectorXd w = problem.M * z + problem.q;
  // Column by column (M is column-major): t_i = |q_i| + Σ_j |M_ij z_j| and Σ_j |M_ij|.
  VectorXd terms = problem.q.cwiseAbs();
  VectorXd norms = VectorXd::Zero(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double zj = std::abs(z(j));
    for (Eigen::Index i = 0; i < n; ++i) {
      const double m = std::abs(problem.M(i, j));
      norms(i) += m;
      terms(i) += m * zj;
    }
  }
  if (!w.allFinite() || !terms.allFinite() || !norms.allFinite()) return kInf;
  const double m_norm = norms.maxCoeff();
  const double q_norm = problem.q.lpNorm<Eigen::Infinity>();
  double s_z = std::max(z.lpNorm<Eigen::Infinity>(), m_norm > 0.0 ? q_norm / m_norm : 0.0);
  if (!std::isfinite(s_z)) return kInf;
  if (!(s_z > 0.0)) return 0.0;  // z = 0 and q = 0: w = 0
  const double s_w = std::max(terms.maxCoeff(), s_z * m_norm);
  if (!std::isfinite(s_w)) return kInf;
  const double floor = kLcpRoundoffFloor * s_w;
  double r = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double s_i = std::max({terms(i), s_z * norms(i), floor});
    const double ri = std::abs(std::min(z(i) / s_z, s_i > 0.0 ? w(i) / s_i : 0.0));
    if (std::isnan(ri)) return kInf;
    r = std::max(r, ri);
  }
  return r;
}

std::string CheckLcpSolution(const LcpProblem& problem, const VectorXd& z) {
  const double r = LcpScaledResidual(problem, z);
  if (r <= kLcpAcceptanceTolerance) return {};
  if (std::isinf(r)) return "z or w = Mz + q is not finite (overflow at the problem's scale)";
  if (std::isnan(r)) return "z does not match the problem size";
  return "the scale-aware residual max_i |min(z_i/s_z, w_i/s_i)| = " + internal::FormatDouble(r) +
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
