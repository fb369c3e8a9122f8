// Row-sparse matrices for the step sensitivities (internal): the step equations' Jacobians by
// rows (CSR) and a writer that fills either a dense matrix or such rows from the same calls, so
// a formulation's residual code states its Jacobian once (stewart_trinkle_residuals.cc).
#pragma once

#include <vector>

#include "vinci/sim/formulations/block_diagonal.h"
#include "vinci/sim/types.h"

namespace vinci::sim::internal {

/// A rows × cols matrix by rows (CSR): each row's entries in increasing column order, no entry
/// exactly 0 — the nonzeros of the dense matrix it stands for.
struct SparseRows {
  int cols = 0;
  std::vector<int> ptr = {0};  // row i: entries [ptr[i], ptr[i + 1])
  std::vector<int> col;
  std::vector<double> val;

  int rows() const { return static_cast<int>(ptr.size()) - 1; }
  /// No rows, `cols` columns (storage kept).
  void Reset(int cols);
  /// Appends an entry to the last row (columns increasing, v ≠ 0) / closes the row.
  void Push(int c, double v) {
    col.push_back(c);
    val.push_back(v);
  }
  void EndRow() { ptr.push_back(static_cast<int>(col.size())); }
  /// Row i of the dense matrix: the nonzeros, in column order.
  void AppendRow(const SparseRows& from, int i, int col_end);
  /// The nonzeros of m (exact zeros dropped).
  void FromDense(const MatrixXd& m);
  /// Entry (i, j) (0 where none is stored).
  double At(int i, int j) const;
  /// Σ_k row_i(k) x_k over the stored entries with column < col_end.
  double RowDot(int i, const VectorXd& x, int col_end) const;
  /// out = column j (rows()).
  void Column(int j, VectorXd* out) const;
  /// max |entry| of row i over columns < col_end; *arg: the first column attaining it (0 if the
  /// row has none there).
  double RowMaxAbs(int i, int col_end, int* arg = nullptr) const;
};

/// The destination of a Jacobian's entries: a dense matrix, or a triplet list turned into
/// SparseRows (Finish). Every entry is written at most once (the block writes below overwrite
/// what the dense matrix holds, which is 0 until then); the same entries in both.
///
/// Finish sorts the writes into rows and keeps the result as a row pattern (per output entry,
/// the write it takes its value from): a later Finish whose writes have the same size and the
/// same (row, column) sequence gathers the values through that pattern instead of sorting
/// again. The output is the same either way; only a writer kept between evaluations (one per
/// thread, SparseJacobians) profits.
class JacobianWriter {
 public:
  /// Writes go to *m, first set to 0 (rows × cols).
  void Dense(MatrixXd* m, int rows, int cols);
  /// Writes are collected (rows × cols); Finish() turns them into SparseRows.
  void Sparse(int rows, int cols);
  /// Adds rows (zero) at the bottom.
  void AddRows(int add);
  int rows() const { return rows_; }

  void Set(int i, int j, double v);
  /// The block at (i, j) = sign · S.
  void Block(int i, int j, const SparseMatrixd& S, double sign);
  /// The block at (i, j) = Sᵀ.
  void BlockTransposed(int i, int j, const SparseMatrixd& S);
  /// The block at (i, j) = D (dense).
  template <typename Derived>
  void DenseBlock(int i, int j, const Eigen::MatrixBase<Derived>& D) {
    if (dense_) {
      dense_->block(i, j, D.rows(), D.cols()) = D;
      return;
    }
    for (Eigen::Index c = 0; c < D.cols(); ++c)
      for (Eigen::Index r = 0; r < D.rows(); ++r)
        Set(i + static_cast<int>(r), j + static_cast<int>(c), D(r, c));
  }
  /// The n × n block at (i, j) = I.
  void Identity(int i, int j, int n);
  /// The collected entries by rows (sparse mode), exact zeros dropped.
  void Finish(SparseRows* out);

 private:
  struct Key {
    int row, col;
  };
  void Push(int i, int j, double v) {
    keys_.push_back({i, j});
    vals_.push_back(v);
  }
  /// pattern_* from keys_ (rows_ × cols_): a stable sort by row, then by column, a key written
  /// twice taking its last write.
  void SortPattern();

  MatrixXd* dense_ = nullptr;
  int rows_ = 0, cols_ = 0;
  std::vector<Key> keys_;     // the writes in order
  std::vector<double> vals_;  // their values
  // The pattern of the last sorted writes: output row i holds, in column order, the values of
  // the writes pattern_src_[pattern_ptr_[i] .. pattern_ptr_[i + 1]) (exact zeros dropped).
  int pattern_rows_ = -1, pattern_cols_ = -1;
  std::vector<Key> pattern_keys_;
  std::vector<int> pattern_ptr_, pattern_src_;
  std::vector<int> count_, order_;
};

/// The step equations' Jacobians by rows, columns [z; θ] as StepResiduals' d_ matrices, and the
/// writers that collect them (kept with them: their storage and row patterns are reused by the
/// next evaluation; results do not depend on them).
struct SparseJacobians {
  SparseRows equality, comp_a, comp_b;
  JacobianWriter equality_writer, comp_a_writer, comp_b_writer;
};

}  // namespace vinci::sim::internal
