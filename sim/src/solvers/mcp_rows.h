// The rows of the MCP reformulation Φ(z) = 0 (internal to vinci::solvers): the penalized
// Fischer–Burmeister row per bound pattern, its residuals and the problem checks, shared by the
// semismooth Newton solver (mcp.cc) and the public residual functions (mcp_rows.cc).
#pragma once

#include <Eigen/SparseCore>
#include <vector>

#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim::internal::mcp {

// How row i of Φ is built from its bounds.
enum class RowKind : unsigned char { kFree, kLower, kUpper, kBox, kFixed };

// The kind of a row with bounds [l, u].
RowKind Classify(double l, double u);

// Row i of Φ: value and dΦ_i = alpha dz_i + beta dF_i. (dz, dF) is the direction used where a
// pair is degenerate or the penalty has a kink ((0, 0): the kinks take (x)₊' = 0). Returns true
// iff some pair of the row is degenerate.
bool EvalRow(RowKind kind, double z, double f, double l, double u, double lambda, double dz,
             double df, double* phi, double* alpha, double* beta);

// Natural residual from an evaluated F; NaN if anything is NaN.
double NaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd& l, const VectorXd& u);

inline void ProjectInPlace(const VectorXd& l, const VectorXd& u, VectorXd* z) {
  *z = z->cwiseMax(l).cwiseMin(u);
}

// McpScaledResidual (mcp.h) from F and the dense or sparse Jacobian at z: c = F − J z,
// row terms |c_i| + Σ_j |J_ij z_j|, row norms Σ_j |J_ij|.
// Its vectors in this thread's storage (allocation reuse only: each call overwrites them).
double ScaledResidual(const VectorXd& z, const VectorXd& F, const VectorXd& l, const VectorXd& u,
                      const MatrixXd* J, const Eigen::SparseMatrix<double>* Js);

// Throws std::invalid_argument (naming `who`) unless the bounds agree in size and evaluate is set.
void CheckProblem(const McpProblem& p, const char* who);

// Computes Φ and the (alpha, beta) of every row. `jf_times` computes J_F·d (used only if a row
// is degenerate); may be empty when no Jacobian is wanted.
template <typename JfTimes>
void FbRows(const std::vector<RowKind>& kinds, const VectorXd& z, const VectorXd& F,
            const VectorXd& l, const VectorXd& u, double lambda, const JfTimes& jf_times,
            VectorXd* phi, VectorXd* alpha, VectorXd* beta, VectorXd* d, VectorXd* jd) {
  const Eigen::Index n = z.size();
  bool any = false;
  d->setZero(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (EvalRow(kinds[i], z(i), F(i), l(i), u(i), lambda, 0.0, 0.0, &(*phi)(i), &(*alpha)(i),
                &(*beta)(i))) {
      (*d)(i) = 1.0;
      any = true;
    }
  }
  if (!any) return;
  jf_times(*d, jd);
  for (Eigen::Index i = 0; i < n; ++i) {
    if ((*d)(i) == 0.0) continue;
    EvalRow(kinds[i], z(i), F(i), l(i), u(i), lambda, 1.0, (*jd)(i), &(*phi)(i), &(*alpha)(i),
            &(*beta)(i));
  }
}

}  // namespace vinci::sim::internal::mcp
