// Standard errors of the MPEC estimator: the Laplace approximation at the solution (the
// reduced-Hessian inverse through a quasi-definite KKT factorization) (mpec_estimator.h).
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "mpec_problem.h"

namespace vinci::estimation {

using mpec_internal::kDefaultSigma;
using mpec_internal::kInf;
using mpec_internal::ParallelFor;
using mpec_internal::ResidualRow;
using mpec_internal::StepBlock;
using sim::Params;
using sim::State;
using sim::VectorXd;

bool MpecEstimationProblem::ParameterVariances(const VectorXd& x,
                                               const std::vector<bool>& first_at_zero,
                                               VectorXd* variances) const {
  const Impl& I = *impl_;
  variances->setConstant(I.ntheta, std::numeric_limits<double>::quiet_NaN());
  std::vector<char> fixed(I.n, 0);
  // The zero side of every pair is held at zero. A biactive pair (both sides zero) is held at
  // zero on both sides — the tightened NLP of MPEC theory — rather than on the side the
  // solver's last digits happened to make smaller (`first_at_zero` compares two ~1e-12 values
  // there). Sides are compared in the solver's scaled unknowns (typical magnitude 1), where a
  // bound-active side sits at ≲ 1e-8 (Ipopt's bound push).
  for (std::size_t k = 0; k < I.pairs.size(); ++k) {
    const auto [a, b] = I.pairs[k];
    if (std::max(x[a], x[b]) <= mpec_internal::kBiactive) {
      fixed[a] = fixed[b] = 1;
    } else if (k < first_at_zero.size()) {
      fixed[first_at_zero[k] ? a : b] = 1;
    } else {
      fixed[x[a] <= x[b] ? a : b] = 1;
    }
  }
  for (int i = 0; i < I.ntheta; ++i)
    if (x[i] <= I.x_l[i] + 1e-12 || x[i] >= I.x_u[i] - 1e-12) fixed[i] = 1;
  VectorXd J;
  if (!JacobianValues(x, &J)) return false;
  // Unknowns that nothing depends on at x (no objective term, all Jacobian entries zero) are
  // undetermined and irrelevant: left out.
  std::vector<char> used(I.n, 0);
  for (const Entry& h : I.hess) used[h.row] = used[h.col] = 1;
  for (std::size_t e = 0; e < I.jac.size(); ++e)
    if (J[static_cast<int>(e)] != 0.0) used[I.jac[e].col] = 1;
  std::vector<int> map(I.n, -1);
  int nf = 0;
  for (int i = 0; i < I.n; ++i)
    if (!fixed[i] && used[i]) map[i] = nf++;
  std::vector<Eigen::Triplet<double>> tr;
  for (std::size_t e = 0; e < I.hess.size(); ++e) {
    const int r = map[I.hess[e].row], c = map[I.hess[e].col];
    if (r < 0 || c < 0) continue;
    const double h = 0.5 * I.hess_obj[static_cast<int>(e)];
    tr.emplace_back(r, c, h);
    if (r != c) tr.emplace_back(c, r, h);
  }
  for (std::size_t e = 0; e < I.jac.size(); ++e) {
    const int c = map[I.jac[e].col];
    if (c < 0 || J[static_cast<int>(e)] == 0.0) continue;
    tr.emplace_back(nf + I.jac[e].row, c, J[static_cast<int>(e)]);
    tr.emplace_back(c, nf + I.jac[e].row, J[static_cast<int>(e)]);
  }
  // Quasi-definite regularization [H + δ₁ I, J_Fᵀ; J_F, −δ₂ I] (H is only semi-definite: the
  // impulses have no objective term) so that a sparse LDLᵀ exists for any ordering; δ₁ = 1e-9 of
  // H's largest diagonal, δ₂ = 1e-12: the variances change by ~δ relative.
  double hmax = 0.0;
  for (const Eigen::Triplet<double>& t : tr)
    if (t.row() == t.col() && t.row() < nf) hmax = std::max(hmax, std::abs(t.value()));
  for (int i = 0; i < nf; ++i) tr.emplace_back(i, i, 1e-9 * std::max(hmax, 1.0));
  for (int j = 0; j < I.m; ++j) tr.emplace_back(nf + j, nf + j, -1e-12);
  sim::SparseMatrixXd K(nf + I.m, nf + I.m);
  K.setFromTriplets(tr.begin(), tr.end());
  Eigen::SimplicialLDLT<sim::SparseMatrixXd, Eigen::Lower> lu;
  lu.compute(K);
  if (lu.info() != Eigen::Success) return false;
  for (int i = 0; i < I.ntheta; ++i) {
    if (map[i] < 0) continue;
    VectorXd rhs = VectorXd::Zero(nf + I.m);
    rhs[map[i]] = 1.0;
    const VectorXd sol = lu.solve(rhs);
    if (lu.info() != Eigen::Success || !sol.allFinite()) return false;
    (*variances)[i] = sol[map[i]];
  }
  return true;
}

}  // namespace vinci::estimation
