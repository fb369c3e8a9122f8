#include "vinci/sim/solvers/semidefinite_ldlt.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>

namespace vinci::sim {
namespace {

// A pivot below −kIndefiniteTolerance · a_kk is not round-off of a semidefinite matrix.
constexpr double kIndefiniteTolerance = 1e-8;

}  // namespace

void CompressedColumns::Reset(int size) {
  n = size;
  col_start.assign(static_cast<std::size_t>(size) + 1, 0);
  row.clear();
  value.clear();
}

bool CompressedColumns::IsSymmetric(std::vector<int>* cursor) const {
  // Columns j in ascending order visit the entries (j, i) of column i in ascending row order:
  // each must be the next entry of column i.
  cursor->assign(col_start.begin(), col_start.end() - 1);
  for (int j = 0; j < n; ++j)
    for (int p = col_start[j]; p < col_start[j + 1]; ++p) {
      const int i = row[p];
      int& c = (*cursor)[i];
      if (c >= col_start[i + 1] || row[c] != j || !(value[c] == value[p])) return false;
      ++c;
    }
  for (int i = 0; i < n; ++i)
    if ((*cursor)[i] != col_start[i + 1]) return false;
  return true;
}

void CompressedColumns::Multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
  y->setZero(n);
  for (int j = 0; j < n; ++j) {
    const double xj = x(j);
    for (int p = col_start[j]; p < col_start[j + 1]; ++p) (*y)(row[p]) += value[p] * xj;
  }
}

void SemidefiniteLdlt::Analyze(const CompressedColumns& A) {
  const int n = A.n;
  n_ = n;
  pattern_start_ = A.col_start;
  pattern_row_ = A.row;
  // The fill-reducing ordering: approximate minimum degree of A's (symmetric) pattern.
  p_.resize(n);
  pinv_.resize(n);
  if (n > 0) {
    Eigen::SparseMatrix<double, Eigen::ColMajor, int> pattern(n, n);
    pattern.resizeNonZeros(static_cast<Eigen::Index>(A.row.size()));
    for (int j = 0; j <= n; ++j) pattern.outerIndexPtr()[j] = A.col_start[j];
    for (std::size_t p = 0; p < A.row.size(); ++p) {
      pattern.innerIndexPtr()[p] = A.row[p];
      pattern.valuePtr()[p] = 1.0;
    }
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> perm;
    Eigen::AMDOrdering<int>()(pattern.selfadjointView<Eigen::Lower>(), perm);
    // perm.indices()(k): the original index of the k-th pivot (CSparse's convention).
    for (int k = 0; k < n; ++k) p_[k] = perm.indices()(k);
  }
  for (int k = 0; k < n; ++k) pinv_[p_[k]] = k;
  // The elimination tree of P A Pᵀ and the column counts of L: row k of L is the set of
  // nodes reached from the above-diagonal entries of column k by walking up the tree.
  parent_.assign(n, -1);
  flag_.assign(n, -1);
  l_count_.assign(n, 0);
  for (int k = 0; k < n; ++k) {
    flag_[k] = k;
    const int col = p_[k];
    for (int p = A.col_start[col]; p < A.col_start[col + 1]; ++p) {
      for (int i = pinv_[A.row[p]]; i < k && flag_[i] != k; i = parent_[i]) {
        if (parent_[i] == -1) parent_[i] = k;
        ++l_count_[i];
        flag_[i] = k;
      }
    }
  }
  l_start_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (int k = 0; k < n; ++k) l_start_[k + 1] = l_start_[k] + l_count_[k];
  l_row_.resize(l_start_[n]);
  l_value_.resize(l_start_[n]);
  d_.resize(n);
  dropped_.resize(n);
  stack_.resize(n);
  y_.resize(n);
  work_.resize(n);
  analyzed_ = true;
}

bool SemidefiniteLdlt::Factorize(const CompressedColumns& A, double drop_tolerance) {
  reused_ = analyzed_ && A.n == n_ && A.col_start == pattern_start_ && A.row == pattern_row_;
  if (!reused_) Analyze(A);
  const int n = n_;
  rank_ = 0;
  std::fill(y_.begin(), y_.end(), 0.0);
  std::fill(flag_.begin(), flag_.end(), -1);
  std::fill(l_count_.begin(), l_count_.end(), 0);
  // Row k of L by the triangular solve L_{0:k,0:k} D y = A_{0:k,k} over the pattern of row k
  // (the tree walks from column k's entries, in topological order), then d_k = a_kk − Σ l_ki y_i.
  for (int k = 0; k < n; ++k) {
    flag_[k] = k;
    int top = n;
    const int col = p_[k];
    for (int p = A.col_start[col]; p < A.col_start[col + 1]; ++p) {
      int i = pinv_[A.row[p]];
      if (i > k) continue;
      y_[i] += A.value[p];
      int len = 0;
      for (; flag_[i] != k; i = parent_[i]) {
        stack_[len++] = i;
        flag_[i] = k;
      }
      while (len > 0) stack_[--top] = stack_[--len];
    }
    const double a_kk = y_[k];
    double d = a_kk;
    y_[k] = 0.0;
    for (; top < n; ++top) {
      const int i = stack_[top];
      const double yi = y_[i];
      y_[i] = 0.0;
      const int end = l_start_[i] + l_count_[i];
      double l_ki = 0.0;
      // A dropped pivot's column of L is zero: nothing to propagate.
      if (!dropped_[i]) {
        for (int p = l_start_[i]; p < end; ++p) y_[l_row_[p]] -= l_value_[p] * yi;
        l_ki = yi / d_[i];
        d -= l_ki * yi;
      }
      l_row_[end] = k;
      l_value_[end] = l_ki;
      ++l_count_[i];
    }
    if (!std::isfinite(d) || d < -kIndefiniteTolerance * a_kk || a_kk < 0.0) return false;
    if (d <= drop_tolerance * a_kk) {
      dropped_[k] = 1;
      d_[k] = 0.0;
    } else {
      dropped_[k] = 0;
      d_[k] = d;
      ++rank_;
    }
  }
  return true;
}

void SemidefiniteLdlt::Solve(const Eigen::VectorXd& b, Eigen::VectorXd* x) {
  const int n = n_;
  for (int k = 0; k < n; ++k) work_(k) = b(p_[k]);
  // L w = Pb, then D, then Lᵀ; dropped pivots (zero columns of L) give w_k = 0.
  for (int j = 0; j < n; ++j) {
    if (dropped_[j]) continue;
    const double wj = work_(j);
    for (int p = l_start_[j]; p < l_start_[j + 1]; ++p) work_(l_row_[p]) -= l_value_[p] * wj;
  }
  for (int j = 0; j < n; ++j) work_(j) = dropped_[j] ? 0.0 : work_(j) / d_[j];
  for (int j = n - 1; j >= 0; --j) {
    if (dropped_[j]) continue;
    double wj = work_(j);
    for (int p = l_start_[j]; p < l_start_[j + 1]; ++p) wj -= l_value_[p] * work_(l_row_[p]);
    work_(j) = wj;
  }
  x->resize(n);
  for (int k = 0; k < n; ++k) (*x)(p_[k]) = work_(k);
}

}  // namespace vinci::sim
