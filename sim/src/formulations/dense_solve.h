// Dense solves into the caller's storage (internal header): Eigen's LDLT::solve and
// MatrixXd::inverse() evaluate through temporaries (the transpositions' products, the
// decomposition of the inverse), so a step that calls them allocates on every call. These do the
// same operations in the same order in storage the caller keeps, so they give the same bits and
// allocate nothing once the sizes have been seen.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <limits>

#include "vinci/sim/types.h"

namespace vinci::sim::internal {

/// *dst ← A⁻¹ *dst for the factored A = Pᵀ L D Lᵀ P: LDLT::solve's steps
/// (LDLT::_solve_impl_transposed) in place — P, L⁻¹, D's pseudo-inverse (entries at or below
/// numeric_limits::min() give 0), L⁻ᵀ, Pᵀ. Bitwise `ldlt.solve(*dst)`.
template <typename Derived>
void LdltSolveInPlace(const Eigen::LDLT<MatrixXd>& ldlt, Eigen::MatrixBase<Derived>& dst) {
  const auto& tr = ldlt.transpositionsP();
  const Eigen::Index n = tr.size();
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index j = tr.coeff(k);
    if (j != k) dst.row(k).swap(dst.row(j));
  }
  ldlt.matrixL().solveInPlace(dst);
  const auto d = ldlt.vectorD();
  const double tolerance = (std::numeric_limits<double>::min)();
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (std::abs(d(i)) > tolerance)
      dst.row(i) /= d(i);
    else
      dst.row(i).setZero();
  }
  ldlt.matrixL().transpose().solveInPlace(dst);
  for (Eigen::Index k = n - 1; k >= 0; --k) {
    const Eigen::Index j = tr.coeff(k);
    if (j != k) dst.row(k).swap(dst.row(j));
  }
}

/// *out ← rhs, then LdltSolveInPlace: bitwise `ldlt.solve(rhs)` into out's storage.
template <typename Rhs, typename Out>
void LdltSolveInto(const Eigen::LDLT<MatrixXd>& ldlt, const Rhs& rhs, Out* out) {
  *out = rhs;
  LdltSolveInPlace(ldlt, *out);
}

/// *dst ← A⁻¹ for A = *a (square, dynamic size), factored into *lu: MatrixXd::inverse()'s steps
/// for a dynamic size (its PartialPivLU, then P·I and the two triangular solves in place, as
/// PartialPivLU::_solve_impl). Bitwise `dst = a.inverse()`; `dst` may be a block.
template <typename Dst>
void LuInverseInto(const MatrixXd& a, Eigen::PartialPivLU<MatrixXd>* lu, Dst&& dst) {
  lu->compute(a);
  const auto& perm = lu->permutationP().indices();
  dst.setZero();
  for (Eigen::Index i = 0; i < perm.size(); ++i) dst(perm(i), i) = 1.0;
  lu->matrixLU().template triangularView<Eigen::UnitLower>().solveInPlace(dst);
  lu->matrixLU().template triangularView<Eigen::Upper>().solveInPlace(dst);
}

}  // namespace vinci::sim::internal
