// Step sensitivities (sensitivity.cc) internals shared with the rollout gradients
// (sensitivity_rollout.cc): the structured factorization of the active system K and the checks
// and counters of the public entry points. Private to vinci::sim.
#pragma once

#include <Eigen/LU>
#include <Eigen/QR>
#include <vector>

#include "../formulations/sparse_rows.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim::internal {

/// Throws std::invalid_argument unless every selected parameter is differentiable or a motion
/// parameter of a prescribed body.
void CheckSelection(const Simulator& sim, const ParamSelection& selection);

/// Adds one step's status to the matching counter.
void Count(SensitivityStatus s, int* exact, int* degenerate, int* mode_change, int* failed);

// A square system K dz = b factored structurally: singleton rows (a held impulse, dp = 0; a
// variable fixed by one row) are eliminated first, then singleton columns (a variable that only
// one remaining row reads, e.g. q_ℓ+1 in its kinematics row, recovered last), and the small core
// left (the dynamics and the loaded contacts' rows) is factored by LU with complete pivoting,
// which reveals its rank. Only a rank-deficient core (redundant contacts: a box face on a plane,
// its four corners loaded) is factored by the complete orthogonal decomposition, whose solution
// is the minimum-norm one of the core. The caller checks the residual of every solution (an
// inconsistent singular system is not solvable).
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
    if (nr == nc && nr > 0) {
      lu_.setThreshold(1e-10);
      lu_.compute(core_);
      use_lu_ = lu_.isInvertible();
    }
    if (!use_lu_ && nr > 0 && nc > 0) {
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
      const VectorXd xc = use_lu_ ? VectorXd(lu_.solve(bc)) : VectorXd(cod_.solve(bc));
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
    const MatrixXd Nc = lu_.kernel();
    if (lu_.rank() == static_cast<int>(cols_.size())) return MatrixXd(n, 0);
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
  Eigen::FullPivLU<MatrixXd> lu_;
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod_;
};

}  // namespace vinci::sim::internal
