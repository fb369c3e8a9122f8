// Covariance of the least-squares estimate (least_squares_internal.h).
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <vector>

#include "least_squares_internal.h"

namespace vinci::estimation::internal {

using sim::VectorXd;

// Relative singular-value cut-off of the unit-scaled initial-state Jacobian (EpisodeInformation).
constexpr double kRankTolerance = 1e-6;

// The information about θ of one episode, JθᵀJθ − JθᵀJs (JsᵀJs)⁺ JsᵀJθ (the Schur complement
// that profiles out the episode's free initial-state components), with J the Jacobian of all the
// episode's measured residuals with respect to θ and its free initial-state components s_0,F.
// Later segments' start states are functions of (θ, s_0) through the continuity constraints,
// treated as exact: ds_j+1 = ∂x_end/∂θ dθ + ∂x_end/∂s_j ds_j (chain rule through the
// segments), so single and multiple shooting give the same covariance at a continuous
// solution. Frozen initial-state components (is_free false) are known.
sim::MatrixXd EpisodeInformation(const std::vector<SegmentDerivatives>& chain,
                                 const std::vector<bool>& is_free) {
  const int np = static_cast<int>(chain.front().measured_theta.cols());
  const int ns = static_cast<int>(is_free.size());
  std::vector<int> free;
  for (int j = 0; j < ns; ++j)
    if (is_free[j]) free.push_back(j);
  const int nf = static_cast<int>(free.size());
  int rows = 0;
  for (const SegmentDerivatives& c : chain) rows += static_cast<int>(c.measured_theta.rows());
  // D = ds_j / d(θ, s_0,F), J = d(measured) / d(θ, s_0,F).
  sim::MatrixXd D = sim::MatrixXd::Zero(ns, np + nf);
  for (int f = 0; f < nf; ++f) D(free[f], np + f) = 1.0;
  sim::MatrixXd J(rows, np + nf);
  int row = 0;
  for (const SegmentDerivatives& c : chain) {
    const int m = static_cast<int>(c.measured_theta.rows());
    J.middleRows(row, m) = c.measured_state * D;
    J.block(row, 0, m, np) += c.measured_theta;
    row += m;
    if (c.end_theta.size() == 0) continue;
    sim::MatrixXd next = c.end_state * D;
    next.leftCols(np) += c.end_theta;
    D = std::move(next);
  }
  const sim::MatrixXd Jt = J.leftCols(np);
  if (nf == 0) return Jt.transpose() * Jt;
  // Jθ's part orthogonal to the columns of Js (scaled to unit norm; columns the data do not
  // see are dropped), by a rank-revealing least-squares fit. The rank cut-off must be above
  // the accuracy of the finite-difference columns (relative step 1e-6: round-off ~1e-10 of a
  // column, more through the contact solves): a dependent pair of columns — e.g. on a block
  // sliding on the floor the initial vy, whose only effect is the friction impulse of the
  // first step, is a multiple of vx to ~1e-10 — must count as one direction. With a cut-off
  // of 1e-10 such a pair counted as two in some fits (singular value 1.4e-10) and not in
  // others (3e-11): the spurious direction, pure differencing noise, was projected out of Jθ
  // and the standard error came out 25–90% too large at the same μ̂ (closed form for the
  // noisy block: 0.00130; reported 0.00163 single, 0.00132 multiple shooting, 0.0024 with
  // w = 1e5); with 1e-6 all gave 0.001315. Genuine state directions here have singular
  // values ≥ 0.1.
  sim::MatrixXd Js = J.rightCols(nf);
  for (int f = 0; f < nf; ++f) {
    const double n = Js.col(f).norm();
    Js.col(f) = n > 0 ? sim::MatrixXd(Js.col(f) / n) : sim::MatrixXd::Zero(rows, 1);
  }
  Eigen::CompleteOrthogonalDecomposition<sim::MatrixXd> cod;
  cod.setThreshold(kRankTolerance);
  cod.compute(Js);
  const sim::MatrixXd residual = Jt - Js * cod.solve(Jt);
  return residual.transpose() * residual;
}

bool ParameterVariances(const sim::MatrixXd& information, VectorXd* variances) {
  const VectorXd d = information.diagonal();
  if (!(d.minCoeff() > 0) || !d.allFinite()) return false;
  const VectorXd s = d.cwiseSqrt().cwiseInverse();
  const sim::MatrixXd corr = s.asDiagonal() * information * s.asDiagonal();
  Eigen::SelfAdjointEigenSolver<sim::MatrixXd> eig(corr);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 1e-12)) return false;
  const sim::MatrixXd inv = eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
                            eig.eigenvectors().transpose();
  *variances = s.cwiseProduct(s).cwiseProduct(inv.diagonal());
  return true;
}

}  // namespace vinci::estimation::internal
