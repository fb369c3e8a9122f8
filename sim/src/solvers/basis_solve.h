// The warm-start basis solve shared by LemkeSolver's warm stage (lemke_stages.cc) and
// SolveOnWarmBasis (warm_basis.cc), so both give the same bits for the same M_BB (internal).
#pragma once

#include <Eigen/Core>
#include <Eigen/QR>

namespace vinci::sim::internal {

// Pivots of M_BB's column-pivoted QR at or below this fraction of the largest are treated as
// zero. A basis holding every contact of a statically indeterminate support (a box face on a
// face: four corners with one normal, rank 3) has an exactly singular M_BB whose smallest pivot
// is round-off (~1e-16 relative); Eigen's solve divides by it and throws the guess away (z_B
// off by 1e-2 on a 5-box stack). With the pivot dropped, that unknown keeps its guessed value.
constexpr double kBasisRankTolerance = 1e-10;

// δ with M_BB δ = rhs in the least-squares sense of the rank-revealing QR: the basic solution
// over the pivots above kBasisRankTolerance, δ = 0 on the others. Bitwise Eigen's
// ColPivHouseholderQR::solve when no pivot is dropped.
inline void SolveBasisBlock(const Eigen::MatrixXd& m_bb, const Eigen::VectorXd& rhs,
                            Eigen::VectorXd* delta) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(m_bb);
  qr.setThreshold(kBasisRankTolerance);
  const Eigen::Index rank = qr.rank();
  if (rank == qr.nonzeroPivots()) {
    *delta = qr.solve(rhs);
    return;
  }
  Eigen::VectorXd c = rhs;
  c.applyOnTheLeft(qr.householderQ().setLength(qr.nonzeroPivots()).adjoint());
  qr.matrixQR()
      .topLeftCorner(rank, rank)
      .template triangularView<Eigen::Upper>()
      .solveInPlace(c.head(rank));
  delta->setZero(m_bb.cols());
  for (Eigen::Index i = 0; i < rank; ++i) (*delta)(qr.colsPermutation().indices()(i)) = c(i);
}

}  // namespace vinci::sim::internal
