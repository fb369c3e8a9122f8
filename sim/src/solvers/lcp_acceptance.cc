// The shared scale-aware acceptance test (lcp_acceptance.h).
#include "vinci/sim/solvers/lcp_acceptance.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "solver_util.h"

namespace vinci::sim {

namespace internal {

namespace {

// max_i |ẑ_i − mid(l_i / s_z, u_i / s_z, ẑ_i − F_i / s_i)| with s_i = row_scale(i) (x / 0 as 0).
template <typename RowScale>
double NaturalResidualAtScales(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                               const VectorXd* upper, double s_z, const RowScale& row_scale) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    const double s_i = row_scale(i);
    const double f = s_i > 0.0 ? F(i) / s_i : 0.0;
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

// s_z = max(‖z‖∞, c_norm / j_norm), 1 if that is 0; infinity if not finite.
double UnknownScale(const VectorXd& z, double j_norm, double c_norm) {
  const double s_z = std::max(z.lpNorm<Eigen::Infinity>(), j_norm > 0.0 ? c_norm / j_norm : 0.0);
  if (!std::isfinite(s_z)) return std::numeric_limits<double>::infinity();
  return s_z > 0.0 ? s_z : 1.0;  // z = 0 and c = 0: F = 0
}

}  // namespace

double ScaledNaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                             const VectorXd* upper, const VectorXd& row_terms,
                             const VectorXd& row_norms, double c_norm) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (z.size() == 0) return 0.0;
  if (!z.allFinite() || !F.allFinite() || !row_terms.allFinite() || !row_norms.allFinite() ||
      !std::isfinite(c_norm))
    return kInf;
  const double j_norm = row_norms.maxCoeff();
  const double s_z = UnknownScale(z, j_norm, c_norm);
  if (!std::isfinite(s_z)) return kInf;
  // Each row at its own scale, floored by the problem's (lcp_acceptance.h).
  const double s_w = std::max(row_terms.maxCoeff(), s_z * j_norm);
  if (!std::isfinite(s_w)) return kInf;
  const double floor = kLcpRoundoffFloor * s_w;
  return NaturalResidualAtScales(z, F, lower, upper, s_z, [&](Eigen::Index i) {
    return std::max({row_terms(i), s_z * row_norms(i), floor});
  });
}

double ScaledNaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                             const VectorXd* upper, const VectorXd& row_terms, double j_norm,
                             double c_norm) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (z.size() == 0) return 0.0;
  if (!z.allFinite() || !F.allFinite() || !row_terms.allFinite() || !std::isfinite(j_norm) ||
      !std::isfinite(c_norm))
    return kInf;
  const double s_z = UnknownScale(z, j_norm, c_norm);
  if (!std::isfinite(s_z)) return kInf;
  // Without the row norms: one scale for every row (the largest row's).
  const double s_w = std::max(row_terms.maxCoeff(), s_z * j_norm);
  if (!std::isfinite(s_w)) return kInf;
  return NaturalResidualAtScales(z, F, lower, upper, s_z, [&](Eigen::Index) { return s_w; });
}

}  // namespace internal

double LcpScaledResidual(const LcpProblem& problem, const VectorXd& z) {
  const Eigen::Index n = problem.q.size();
  if (problem.M.rows() != n || problem.M.cols() != n || z.size() != n)
    return std::numeric_limits<double>::quiet_NaN();
  if (n == 0) return 0.0;
  if (!z.allFinite()) return std::numeric_limits<double>::infinity();
  // Per-thread buffers (w: the product, then the sum, as Eigen evaluates M z + q).
  thread_local VectorXd w, terms, norms;
  w.noalias() = problem.M * z;
  w += problem.q;
  // Column by column (M is column-major): t_i = |q_i| + Σ_j |M_ij z_j| and Σ_j |M_ij|.
  terms = problem.q.cwiseAbs();
  norms.setZero(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double zj = std::abs(z(j));
    for (Eigen::Index i = 0; i < n; ++i) {
      const double m = std::abs(problem.M(i, j));
      norms(i) += m;
      terms(i) += m * zj;
    }
  }
  return internal::ScaledNaturalResidual(z, w, nullptr, nullptr, terms, norms,
                                         problem.q.lpNorm<Eigen::Infinity>());
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
