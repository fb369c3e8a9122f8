#include "mcp_rows.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "solver_util.h"

namespace vinci::sim {
namespace internal::mcp {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// φ(a, b) = λ(√(a² + b²) − a − b) − (1 − λ) a₊ b₊ with partials (da, db). At (a, b) = (0, 0)
// the partials are those of the limit along the direction (xa, xb) and *degenerate is set; at
// a kink of the penalty (a = 0 or b = 0) (x)₊' is 1 iff the direction increases x.
struct FbValue {
  double phi, da, db;
};

FbValue PenalizedFb(double a, double b, double lambda, double xa, double xb, bool* degenerate) {
  const double r = std::hypot(a, b);
  const double s = a + b;
  // √(a² + b²) − (a + b), without cancellation when a + b > 0.
  const double fb = s > 0.0 ? -2.0 * (a / (r + s)) * b : r - s;
  const double ap = std::max(a, 0.0);
  const double bp = std::max(b, 0.0);
  FbValue v;
  v.phi = lambda * fb - (1.0 - lambda) * ap * bp;
  if (r > 0.0) {
    const bool ha = a > 0.0 || (a == 0.0 && xa > 0.0);
    const bool hb = b > 0.0 || (b == 0.0 && xb > 0.0);
    v.da = lambda * (a / r - 1.0) - (1.0 - lambda) * (ha ? bp : 0.0);
    v.db = lambda * (b / r - 1.0) - (1.0 - lambda) * (hb ? ap : 0.0);
  } else {
    *degenerate = true;
    const double rd = std::hypot(xa, xb);
    // Second pass: |xa| = 1. The first pass (direction 0) is overwritten; (1, 1)/√2 is a valid
    // element anyway.
    const double ca = rd > 0.0 ? xa / rd : std::sqrt(0.5);
    const double cb = rd > 0.0 ? xb / rd : std::sqrt(0.5);
    v.da = lambda * (ca - 1.0);
    v.db = lambda * (cb - 1.0);
  }
  return v;
}

}  // namespace

RowKind Classify(double l, double u) {
  const bool lf = std::isfinite(l);
  const bool uf = std::isfinite(u);
  if (lf && uf) return l == u ? RowKind::kFixed : RowKind::kBox;
  if (lf) return RowKind::kLower;
  if (uf) return RowKind::kUpper;
  return RowKind::kFree;
}

// Row i of Φ: value and dΦ_i = alpha dz_i + beta dF_i. (dz, dF) is the direction used where a
// pair is degenerate or the penalty has a kink ((0, 0): the kinks take (x)₊' = 0). Returns true
// iff some pair of the row is degenerate.
bool EvalRow(RowKind kind, double z, double f, double l, double u, double lambda, double dz,
             double df, double* phi, double* alpha, double* beta) {
  bool degenerate = false;
  switch (kind) {
    case RowKind::kFree:
      *phi = -f;
      *alpha = 0.0;
      *beta = -1.0;
      break;
    case RowKind::kFixed:
      *phi = z - l;
      *alpha = 1.0;
      *beta = 0.0;
      break;
    case RowKind::kLower: {
      const FbValue v = PenalizedFb(z - l, f, lambda, dz, df, &degenerate);
      *phi = v.phi;
      *alpha = v.da;
      *beta = v.db;
      break;
    }
    case RowKind::kUpper: {
      // Φ = −φ(c, b), c = u − z, b = −F: dΦ = φ_c dz + φ_b dF.
      const FbValue v = PenalizedFb(u - z, -f, lambda, -dz, -df, &degenerate);
      *phi = -v.phi;
      *alpha = v.da;
      *beta = v.db;
      break;
    }
    case RowKind::kBox: {
      // ψ = φ(u − z, −F), dψ = −ψ_c dz − ψ_b dF; Φ = φ(z − l, ψ).
      const FbValue in = PenalizedFb(u - z, -f, lambda, -dz, -df, &degenerate);
      const double dpsi = -in.da * dz - in.db * df;
      const FbValue out = PenalizedFb(z - l, in.phi, lambda, dz, dpsi, &degenerate);
      *phi = out.phi;
      *alpha = out.da - out.db * in.da;
      *beta = -out.db * in.db;
      break;
    }
  }
  return degenerate;
}

// Natural residual from an evaluated F; NaN if anything is NaN.
double NaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd& l, const VectorXd& u) {
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    const double p = std::min(std::max(z(i) - F(i), l(i)), u(i));
    const double d = std::abs(z(i) - p);
    if (std::isnan(d)) return kNaN;
    r = std::max(r, d);
  }
  return r;
}

// McpScaledResidual (mcp.h) from F and the dense or sparse Jacobian at z: c = F − J z,
// row terms |c_i| + Σ_j |J_ij z_j|, row norms Σ_j |J_ij|.
// Its vectors in this thread's storage (allocation reuse only: each call overwrites them).
double ScaledResidual(const VectorXd& z, const VectorXd& F, const VectorXd& l, const VectorXd& u,
                      const MatrixXd* J, const Eigen::SparseMatrix<double>* Js) {
  const Eigen::Index n = z.size();
  thread_local VectorXd jz, terms, norms, c_buffer;
  jz.setZero(n);
  terms.setZero(n);
  norms.setZero(n);
  const auto add = [&](Eigen::Index i, Eigen::Index j, double v) {
    jz(i) += v * z(j);
    terms(i) += std::abs(v * z(j));
    norms(i) += std::abs(v);
  };
  if (Js != nullptr) {
    for (Eigen::Index j = 0; j < Js->outerSize(); ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(*Js, j); it; ++it)
        add(it.row(), it.col(), it.value());
  } else {
    for (Eigen::Index j = 0; j < n; ++j)
      for (Eigen::Index i = 0; i < n; ++i) add(i, j, (*J)(i, j));
  }
  VectorXd& c = c_buffer;
  c = F - jz;
  terms += c.cwiseAbs();
  return internal::ScaledNaturalResidual(z, F, &l, &u, terms, norms, c.lpNorm<Eigen::Infinity>());
}

void CheckProblem(const McpProblem& p, const char* who) {
  if (p.upper.size() != p.lower.size()) {
    throw std::invalid_argument(std::string(who) + ": upper has size " +
                                std::to_string(p.upper.size()) + " but lower has size " +
                                std::to_string(p.lower.size()) + "; expected equal sizes");
  }
  if (!p.evaluate) {
    throw std::invalid_argument(std::string(who) + ": McpProblem::evaluate is empty");
  }
}

}  // namespace internal::mcp

using internal::mcp::CheckProblem;
using internal::mcp::Classify;
using internal::mcp::FbRows;
using internal::mcp::NaturalResidual;
using internal::mcp::RowKind;
using internal::mcp::ScaledResidual;

double McpResidual(const McpProblem& problem, const VectorXd& z) {
  CheckProblem(problem, "McpResidual");
  const Eigen::Index n = problem.lower.size();
  if (z.size() != n) {
    throw std::invalid_argument("McpResidual: z has size " + std::to_string(z.size()) +
                                " but the problem has size " + std::to_string(n));
  }
  VectorXd F = VectorXd::Zero(n);
  problem.evaluate(z, &F, nullptr);
  if (F.size() != n) {
    throw std::invalid_argument("McpResidual: evaluate returned F of size " +
                                std::to_string(F.size()) + "; expected " + std::to_string(n));
  }
  return NaturalResidual(z, F, problem.lower, problem.upper);
}

double McpScaledResidual(const McpProblem& problem, const VectorXd& z) {
  CheckProblem(problem, "McpScaledResidual");
  const Eigen::Index n = problem.lower.size();
  if (z.size() != n) {
    throw std::invalid_argument("McpScaledResidual: z has size " + std::to_string(z.size()) +
                                " but the problem has size " + std::to_string(n));
  }
  VectorXd F = VectorXd::Zero(n);
  if (problem.sparse_jacobian) {
    Eigen::SparseMatrix<double> Js(n, n);
    problem.evaluate(z, &F, nullptr);
    problem.sparse_jacobian(z, &Js);
    if (F.size() != n || Js.rows() != n || Js.cols() != n)
      throw std::invalid_argument("McpScaledResidual: evaluate returned F/J of the wrong size");
    return ScaledResidual(z, F, problem.lower, problem.upper, nullptr, &Js);
  }
  MatrixXd J = MatrixXd::Zero(n, n);
  problem.evaluate(z, &F, &J);
  if (F.size() != n || J.rows() != n || J.cols() != n)
    throw std::invalid_argument("McpScaledResidual: evaluate returned F/J of the wrong size");
  return ScaledResidual(z, F, problem.lower, problem.upper, &J, nullptr);
}

VectorXd McpFischerBurmeister(const McpProblem& problem, const VectorXd& z, double lambda,
                              MatrixXd* J) {
  CheckProblem(problem, "McpFischerBurmeister");
  const Eigen::Index n = problem.lower.size();
  if (z.size() != n) {
    throw std::invalid_argument("McpFischerBurmeister: z has size " + std::to_string(z.size()) +
                                " but the problem has size " + std::to_string(n));
  }
  if (!(lambda > 0.0 && lambda <= 1.0)) {
    throw std::invalid_argument("McpFischerBurmeister: lambda = " + std::to_string(lambda) +
                                "; expected 0 < lambda <= 1");
  }
  std::vector<RowKind> kinds(n);
  for (Eigen::Index i = 0; i < n; ++i) kinds[i] = Classify(problem.lower(i), problem.upper(i));
  VectorXd F = VectorXd::Zero(n);
  MatrixXd jf;
  if (J != nullptr) jf.setZero(n, n);
  problem.evaluate(z, &F, J != nullptr ? &jf : nullptr);
  if (F.size() != n || (J != nullptr && (jf.rows() != n || jf.cols() != n))) {
    throw std::invalid_argument("McpFischerBurmeister: evaluate returned F/J of the wrong size");
  }
  VectorXd phi(n), alpha(n), beta(n), d(n), jd(n);
  const auto jf_times = [&](const VectorXd& dir, VectorXd* out) {
    if (J != nullptr) out->noalias() = jf * dir;
  };
  FbRows(kinds, z, F, problem.lower, problem.upper, lambda, jf_times, &phi, &alpha, &beta, &d, &jd);
  if (J != nullptr) {
    *J = beta.asDiagonal() * jf;
    J->diagonal() += alpha;
  }
  return phi;
}

}  // namespace vinci::sim
