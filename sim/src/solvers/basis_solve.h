// The warm-start basis solve shared by LemkeSolver's warm stage (lemke_stages.cc) and
// SolveOnWarmBasis (warm_basis.cc), so both give the same bits for the same M_BB (internal).
#pragma once

#include <Eigen/Core>
#include <Eigen/QR>
#include <algorithm>

namespace vinci::sim::internal {

// Pivots of M_BB's column-pivoted QR at or below this fraction of the largest are treated as
// zero. A basis holding every contact of a statically indeterminate support (a box face on a
// face: four corners with one normal, rank 3) has an exactly singular M_BB whose smallest pivot
// is round-off (~1e-16 relative); Eigen's solve divides by it and throws the guess away (z_B
// off by 1e-2 on a 5-box stack). With the pivot dropped, that unknown keeps its guessed value.
constexpr double kBasisRankTolerance = 1e-10;

// δ with M_BB δ = rhs in the least-squares sense of the rank-revealing QR: the basic solution
// over the pivots above kBasisRankTolerance, δ = 0 on the others. Bitwise Eigen's
// ColPivHouseholderQR::solve when no pivot is dropped. `qr` and `c` are scratch: the steps of
// ColPivHouseholderQR::_solve_impl are done in their storage, so a call whose size matches the
// previous one allocates nothing. `factorized`: *qr already holds this m_bb's factorization (of
// the same bits: the caller checked), so only the solve is done.
inline void SolveBasisBlock(const Eigen::MatrixXd& m_bb, const Eigen::VectorXd& rhs,
                            Eigen::ColPivHouseholderQR<Eigen::MatrixXd>* qr, Eigen::VectorXd* c,
                            Eigen::VectorXd* delta, bool factorized = false) {
  const Eigen::Index nb = m_bb.cols();
  if (!factorized) {
    qr->setThreshold(kBasisRankTolerance);
    qr->compute(m_bb);
  }
  const Eigen::Index nz = qr->nonzeroPivots();
  const Eigen::Index rank = std::min(qr->rank(), nz);
  *c = rhs;
  // c ← Qᵀ c: the reflectors k = 0..nz−1 applied as HouseholderSequence::applyThisOnTheLeft and
  // MatrixBase::applyHouseholderOnTheLeft do (same operations, same order), without the
  // temporary Eigen's outer product allocates per reflector.
  for (Eigen::Index k = 0; k < nz; ++k) {
    const Eigen::Index len = nb - k;
    const double tau = qr->hCoeffs()(k);
    if (len == 1) {
      (*c)(k) *= 1.0 - tau;
    } else if (tau != 0.0) {
      const auto essential = qr->matrixQR().col(k).tail(len - 1);
      auto bottom = c->segment(k + 1, len - 1);
      double tmp = 0.0;
      tmp += 1.0 * essential.dot(bottom);
      tmp += (*c)(k);
      (*c)(k) -= tau * tmp;
      for (Eigen::Index i = 0; i < len - 1; ++i) bottom(i) -= tmp * (tau * essential(i));
    }
  }
  if (rank > 0)
    qr->matrixQR()
        .topLeftCorner(rank, rank)
        .template triangularView<Eigen::Upper>()
        .solveInPlace(c->topRows(rank));
  delta->resize(nb);
  const auto& perm = qr->colsPermutation().indices();
  for (Eigen::Index i = 0; i < nb; ++i) (*delta)(perm(i)) = i < rank ? (*c)(i) : 0.0;
}

inline void SolveBasisBlock(const Eigen::MatrixXd& m_bb, const Eigen::VectorXd& rhs,
                            Eigen::VectorXd* delta) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
  Eigen::VectorXd c;
  SolveBasisBlock(m_bb, rhs, &qr, &c, delta);
}

}  // namespace vinci::sim::internal
