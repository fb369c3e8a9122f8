// Step sensitivities (sensitivity.cc) internals shared with the rollout gradients
// (sensitivity_rollout.cc): the structured factorization of the active system K and the checks
// and counters of the public entry points. Private to vinci::sim.
#pragma once

#include <Eigen/LU>
#include <Eigen/QR>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "../formulations/sparse_rows.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim::internal {

/// Throws std::invalid_argument unless every selected parameter is differentiable or a motion
/// parameter of a prescribed body.
void CheckSelection(const Simulator& sim, const ParamSelection& selection);

/// Adds one step's status to the matching counter.
void Count(SensitivityStatus s, int* exact, int* degenerate, int* mode_change, int* failed);

// LU with complete pivoting of a small square matrix, P A Q = L U (L unit lower triangular),
// stopped at the first pivot at most `threshold` times the largest one before it: its rank r is
// the number of pivots taken (what Eigen::FullPivLU's rank() gives at the same threshold, the
// remaining Schur complement being as small). Plain loops over column-major storage: at the
// sizes of a step's core (≤ ~30) Eigen's generic visitors and its kernel() cost several times
// the arithmetic.
class CompletePivotLu {
 public:
  void Compute(const MatrixXd& a, double threshold) {
    const int n = static_cast<int>(a.rows());
    n_ = n;
    lu_ = a;
    row_swap_.resize(n);
    col_swap_.resize(n);
    // col_max_[j]: max |entry| of column j over the trailing rows, kept by the updates (the
    // search for the next pivot then reads n numbers, not the trailing block).
    col_max_.resize(n);
    rank_ = 0;
    double* m = lu_.data();
    for (int j = 0; j < n; ++j) col_max_[j] = MaxAbs(m + static_cast<std::ptrdiff_t>(j) * n, n);
    double max_pivot = 0.0;
    for (int k = 0; k < n; ++k) {
      // The pivot: the first column holding the largest |entry| of the trailing block, its
      // first row holding it.
      double best = 0.0;
      int bi = k, bj = k;
      for (int j = k; j < n; ++j)
        if (col_max_[j] > best) {
          best = col_max_[j];
          bj = j;
        }
      if (!(best > threshold * max_pivot) || best == 0.0) break;
      for (const double* c = m + static_cast<std::ptrdiff_t>(bj) * n;
           bi + 1 < n && std::abs(c[bi]) != best;)
        ++bi;
      max_pivot = std::max(max_pivot, best);
      row_swap_[k] = bi;
      col_swap_[k] = bj;
      if (bi != k)
        for (int j = 0; j < n; ++j) std::swap(m[j * n + k], m[j * n + bi]);
      if (bj != k) {
        for (int i = 0; i < n; ++i) std::swap(m[k * n + i], m[bj * n + i]);
        std::swap(col_max_[k], col_max_[bj]);
      }
      double* ck = m + static_cast<std::ptrdiff_t>(k) * n;
      const double inv = 1.0 / ck[k];
      for (int i = k + 1; i < n; ++i) ck[i] *= inv;
      // A column with a 0 in the pivot row keeps its entries and its maximum (the one entry
      // leaving its trailing rows is that 0).
      for (int j = k + 1; j < n; ++j) {
        double* cj = m + static_cast<std::ptrdiff_t>(j) * n;
        const double f = cj[k];
        if (f != 0.0) col_max_[j] = AxpyMaxAbs(cj + k + 1, ck + k + 1, f, n - k - 1);
      }
      ++rank_;
    }
  }
  int rank() const { return rank_; }
  bool invertible() const { return rank_ == n_; }

  /// A solution of A x = b if one exists: the free unknowns (Q's last n − r) 0, the equations
  /// P's last n − r ignored (the caller checks the residual).
  void Solve(const VectorXd& b, VectorXd* x) const {
    VectorXd& c = *x;
    c = b;
    const double* m = lu_.data();
    const int n = n_, r = rank_;
    for (int k = 0; k < r; ++k) std::swap(c[k], c[row_swap_[k]]);
    for (int k = 0; k < r; ++k) {
      const double* ck = m + static_cast<std::ptrdiff_t>(k) * n;
      const double v = c[k];
      if (v != 0.0)
        for (int i = k + 1; i < r; ++i) c[i] -= ck[i] * v;
    }
    for (int i = r; i < n; ++i) c[i] = 0.0;
    BackSubstitute(&c);
    for (int k = r - 1; k >= 0; --k) std::swap(c[k], c[col_swap_[k]]);
  }

  /// A basis of the null space of the rank-r factorization (n − r columns): the free unknown
  /// j set to 1, the others to 0, the pivot unknowns from U₁₁ y = −U₁₂ e_j.
  void Kernel(MatrixXd* out) const {
    const int n = n_, r = rank_;
    out->setZero(n, n - r);
    VectorXd y(n);
    for (int j = r; j < n; ++j) {
      y.setZero();
      for (int i = 0; i < r; ++i) y[i] = -lu_(i, j);
      y[j] = 1.0;
      BackSubstitute(&y);
      for (int k = r - 1; k >= 0; --k) std::swap(y[k], y[col_swap_[k]]);
      out->col(j - r) = y;
    }
  }

 private:
  // max_i |c[i]| over len entries, two at a time where SSE2 is available (the pivot search is
  // most of a complete-pivoting LU's instructions at these sizes).
  static double MaxAbs(const double* c, int len) {
    int i = 0;
    double m = 0.0;
#ifdef __SSE2__
    const __m128d sign = _mm_set1_pd(-0.0);
    __m128d acc = _mm_setzero_pd();
    for (; i + 1 < len; i += 2) acc = _mm_max_pd(acc, _mm_andnot_pd(sign, _mm_loadu_pd(c + i)));
    double pair[2];
    _mm_storeu_pd(pair, acc);
    m = std::max(pair[0], pair[1]);
#endif
    for (; i < len; ++i) m = std::max(m, std::abs(c[i]));
    return m;
  }
  // y ← y − f x over len entries; returns max_i |y_i| after the update (SSE2 where available,
  // the same numbers: no fused multiply-add either way).
  static double AxpyMaxAbs(double* y, const double* x, double f, int len) {
    int i = 0;
    double m = 0.0;
#ifdef __SSE2__
    const __m128d sign = _mm_set1_pd(-0.0), fv = _mm_set1_pd(f);
    __m128d acc = _mm_setzero_pd();
    for (; i + 1 < len; i += 2) {
      const __m128d v = _mm_sub_pd(_mm_loadu_pd(y + i), _mm_mul_pd(_mm_loadu_pd(x + i), fv));
      _mm_storeu_pd(y + i, v);
      acc = _mm_max_pd(acc, _mm_andnot_pd(sign, v));
    }
    double pair[2];
    _mm_storeu_pd(pair, acc);
    m = std::max(pair[0], pair[1]);
#endif
    for (; i < len; ++i) {
      y[i] -= x[i] * f;
      m = std::max(m, std::abs(y[i]));
    }
    return m;
  }
  // y[0..r) ← U₁₁⁻¹ y[0..r) (U by columns, upper triangle of lu_).
  void BackSubstitute(VectorXd* y) const {
    const double* m = lu_.data();
    const int n = n_;
    for (int k = rank_ - 1; k >= 0; --k) {
      const double* ck = m + static_cast<std::ptrdiff_t>(k) * n;
      const double v = ((*y)[k] /= ck[k]);
      if (v != 0.0)
        for (int i = 0; i < k; ++i) (*y)[i] -= ck[i] * v;
    }
  }
  int n_ = 0, rank_ = 0;
  MatrixXd lu_;
  // Step k swapped row k with row row_swap_[k], then column k with column col_swap_[k].
  std::vector<int> row_swap_, col_swap_;
  std::vector<double> col_max_;
};

// A square system K dz = b factored structurally: singleton rows (a held impulse, dp = 0; a
// variable fixed by one row) are eliminated first, then singleton columns (a variable that only
// one remaining row reads, e.g. q_ℓ+1 in its kinematics row, recovered last), and the small core
// left (the dynamics and the loaded contacts' rows) is factored by LU with complete pivoting,
// which reveals its rank. A rank-deficient core (redundant contacts: a box face on a plane, its
// four corners loaded) takes the minimum-norm solution: the LU's particular solution (free
// unknowns 0) projected off the LU's kernel (x − N Nᵀ x, N orthonormal) — for a consistent
// right side the same solution as a complete orthogonal decomposition's, which only a core that
// is not square takes. The caller checks the residual of every solution (an inconsistent
// singular system is not solvable).
class StructuredSolver {
 public:
  /// Factors K (square, by rows; kept by pointer: it must outlive this solver's use).
  void Compute(const SparseRows& K) {
    K_ = &K;
    const int n = K.rows();
    // K's nonzero pattern by rows (K itself: CSR) and by columns (col_ptr_, col_row_, each
    // column's rows increasing): the eliminations, the singleton solves and products are
    // O(nonzeros).
    std::vector<int>& row_count = row_count_;
    std::vector<int>& col_count = col_count_;
    row_count.assign(n, 0);
    col_count.assign(n, 0);
    for (int i = 0; i < n; ++i) {
      row_count[i] = K.ptr[i + 1] - K.ptr[i];
      for (int k = K.ptr[i]; k < K.ptr[i + 1]; ++k) ++col_count[K.col[k]];
    }
    col_ptr_.assign(n + 1, 0);
    for (int j = 0; j < n; ++j) col_ptr_[j + 1] = col_ptr_[j] + col_count[j];
    col_row_.resize(K.col.size());
    fill_.assign(col_ptr_.begin(), col_ptr_.end() - 1);
    for (int i = 0; i < n; ++i)  // rows in order: each column's entries sorted by row
      for (int k = K.ptr[i]; k < K.ptr[i + 1]; ++k) col_row_[fill_[K.col[k]]++] = i;
    const std::vector<int>& row_ptr_ = K.ptr;
    const std::vector<int>& row_col_ = K.col;
    std::vector<char>& row_done = row_done_;
    std::vector<char>& col_done = col_done_;
    row_done.assign(n, 0);
    col_done.assign(n, 0);
    ops_.clear();
    bool changed = true;
    while (changed) {
      changed = false;
      for (int i = 0; i < n; ++i) {
        if (row_done[i] || row_count[i] != 1) continue;
        int j = -1;  // the first column not eliminated with K(i, j) ≠ 0
        for (int k = row_ptr_[i]; k < row_ptr_[i + 1] && j < 0; ++k)
          if (!col_done[row_col_[k]]) j = row_col_[k];
        ops_.push_back({i, j, true, K.At(i, j)});
        row_done[i] = col_done[j] = 1;
        for (int k = col_ptr_[j]; k < col_ptr_[j + 1]; ++k)
          if (!row_done[col_row_[k]]) --row_count[col_row_[k]];
        changed = true;
      }
      for (int j = 0; j < n; ++j) {
        if (col_done[j] || col_count[j] != 1) continue;
        int i = -1;  // the first row not eliminated with K(i, j) ≠ 0
        for (int k = col_ptr_[j]; k < col_ptr_[j + 1] && i < 0; ++k)
          if (!row_done[col_row_[k]]) i = col_row_[k];
        ops_.push_back({i, j, false, K.At(i, j)});
        row_done[i] = col_done[j] = 1;
        for (int k = row_ptr_[i]; k < row_ptr_[i + 1]; ++k)
          if (!col_done[row_col_[k]]) --col_count[row_col_[k]];
        changed = true;
      }
    }
    // The core: rows and columns not eliminated; an emptied row (a duplicate of a singleton) or
    // column (a free variable) leaves it (the residual check decides consistency; free: 0).
    rows_.clear();
    cols_.clear();
    for (int i = 0; i < n; ++i)
      if (!row_done[i] && row_count[i] > 0) rows_.push_back(i);
    for (int j = 0; j < n; ++j)
      if (!col_done[j] && col_count[j] > 0) cols_.push_back(j);
    const int nr = static_cast<int>(rows_.size()), nc = static_cast<int>(cols_.size());
    core_.setZero(nr, nc);
    core_col_.assign(n, -1);
    for (int c = 0; c < nc; ++c) core_col_[cols_[c]] = c;
    for (int r = 0; r < nr; ++r)
      for (int k = K.ptr[rows_[r]]; k < K.ptr[rows_[r] + 1]; ++k)
        if (core_col_[K.col[k]] >= 0) core_(r, core_col_[K.col[k]]) = K.val[k];
    use_lu_ = false;
    null_basis_.resize(nc, 0);
    if (nr == nc && nr > 0) {
      lu_.Compute(core_, 1e-10);
      use_lu_ = lu_.invertible();
      if (!use_lu_) {
        // The core's null space, orthonormalized (modified Gram–Schmidt, twice): a solution's
        // projection off it is the minimum-norm solution of the (consistent) core system.
        lu_.Kernel(&null_basis_);
        for (int k = 0; k < null_basis_.cols(); ++k)
          for (int pass = 0; pass < 2; ++pass) {
            for (int j = 0; j < k; ++j)
              null_basis_.col(k) -= null_basis_.col(j).dot(null_basis_.col(k)) * null_basis_.col(j);
            null_basis_.col(k).normalize();
          }
      }
    } else if (nr > 0 && nc > 0) {
      cod_.setThreshold(1e-12);
      cod_.compute(core_);
    }
  }

  /// K x (over K's nonzeros).
  void Multiply(const VectorXd& x, VectorXd* y) const {
    const int n = K_->rows();
    y->resize(n);
    for (int i = 0; i < n; ++i) (*y)[i] = RowDot(i, x);
  }

  /// Columns of the core factored (a diagnostic) and whether it needed the rank-revealing path.
  int core_size() const { return static_cast<int>(cols_.size()); }
  bool singular() const { return !use_lu_ && !cols_.empty(); }

  VectorXd Solve(const VectorXd& b) const {
    VectorXd x = VectorXd::Zero(b.size());
    for (const Op& op : ops_)
      if (op.row_singleton) x[op.col] = (b[op.row] - RowDot(op.row, x)) / op.pivot;
    if (!cols_.empty() && !rows_.empty()) {
      VectorXd bc(rows_.size());
      for (std::size_t r = 0; r < rows_.size(); ++r) bc[r] = b[rows_[r]] - RowDot(rows_[r], x);
      VectorXd xc;
      if (rows_.size() != cols_.size()) {
        xc = cod_.solve(bc);
      } else {
        lu_.Solve(bc, &xc);  // singular: the particular solution whose free unknowns are 0
        if (!use_lu_) xc -= null_basis_ * (null_basis_.transpose() * xc);
      }
      for (std::size_t c = 0; c < cols_.size(); ++c) x[cols_[c]] = xc[c];
    }
    for (auto it = ops_.rbegin(); it != ops_.rend(); ++it)
      if (!it->row_singleton) x[it->col] = (b[it->row] - RowDot(it->row, x)) / it->pivot;
    return x;
  }

  /// A basis of K's null space from the core's (columns; none if the core is regular or was not
  /// square): the core's null vectors with the eliminated unknowns recovered (a singleton row's
  /// unknown is 0, a singleton column's from its row).
  MatrixXd NullSpace() const {
    const int n = K_->rows();
    if (use_lu_ || cols_.empty() || rows_.size() != cols_.size()) return MatrixXd(n, 0);
    if (lu_.rank() == static_cast<int>(cols_.size())) return MatrixXd(n, 0);
    MatrixXd Nc;
    lu_.Kernel(&Nc);
    MatrixXd N = MatrixXd::Zero(n, Nc.cols());
    for (int k = 0; k < Nc.cols(); ++k) {
      VectorXd x = VectorXd::Zero(n);
      for (std::size_t c = 0; c < cols_.size(); ++c) x[cols_[c]] = Nc(c, k);
      for (auto it = ops_.rbegin(); it != ops_.rend(); ++it)
        if (!it->row_singleton) x[it->col] = -RowDot(it->row, x) / it->pivot;
      N.col(k) = x;
    }
    return N;
  }

  MatrixXd Solve(const MatrixXd& B) const {
    MatrixXd X(B.rows(), B.cols());
    for (int j = 0; j < B.cols(); ++j) X.col(j) = Solve(VectorXd(B.col(j)));
    return X;
  }

 private:
  struct Op {
    int row, col;
    bool row_singleton;  // else a column singleton (recovered after the core)
    double pivot;        // K(row, col)
  };
  // Row i of K times x over its nonzeros (x's entries not yet set are 0).
  double RowDot(int i, const VectorXd& x) const {
    double sum = 0.0;
    for (int k = K_->ptr[i]; k < K_->ptr[i + 1]; ++k) sum += K_->val[k] * x[K_->col[k]];
    return sum;
  }
  const SparseRows* K_ = nullptr;
  std::vector<int> col_ptr_, col_row_, fill_, row_count_, col_count_, core_col_;
  std::vector<char> row_done_, col_done_;
  std::vector<Op> ops_;
  std::vector<int> rows_, cols_;
  MatrixXd core_;
  bool use_lu_ = false;
  CompletePivotLu lu_;
  MatrixXd null_basis_;  // a square singular core's null space, orthonormal columns
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod_;  // a core that is not square
};

}  // namespace vinci::sim::internal
