#include "sparse_rows.h"

#include <cmath>
#include <cstring>

namespace vinci::sim::internal {

void SparseRows::Reset(int c) {
  cols = c;
  ptr.assign(1, 0);
  col.clear();
  val.clear();
}

void SparseRows::AppendRow(const SparseRows& from, int i, int col_end) {
  for (int k = from.ptr[i]; k < from.ptr[i + 1] && from.col[k] < col_end; ++k)
    Push(from.col[k], from.val[k]);
  EndRow();
}

void SparseRows::FromDense(const MatrixXd& m) {
  const int nr = static_cast<int>(m.rows()), nc = static_cast<int>(m.cols());
  Reset(nc);
  // By columns (m is column-major), counted per row first.
  ptr.assign(nr + 1, 0);
  for (int j = 0; j < nc; ++j) {
    const double* c = m.data() + static_cast<Eigen::Index>(j) * nr;
    for (int i = 0; i < nr; ++i)
      if (c[i] != 0.0) ++ptr[i + 1];
  }
  for (int i = 0; i < nr; ++i) ptr[i + 1] += ptr[i];
  col.resize(ptr[nr]);
  val.resize(ptr[nr]);
  std::vector<int> fill(ptr.begin(), ptr.end() - 1);
  for (int j = 0; j < nc; ++j) {
    const double* c = m.data() + static_cast<Eigen::Index>(j) * nr;
    for (int i = 0; i < nr; ++i)
      if (c[i] != 0.0) {
        col[fill[i]] = j;
        val[fill[i]++] = c[i];
      }
  }
}

double SparseRows::At(int i, int j) const {
  for (int k = ptr[i]; k < ptr[i + 1]; ++k)
    if (col[k] == j) return val[k];
  return 0.0;
}

double SparseRows::RowDot(int i, const VectorXd& x, int col_end) const {
  double sum = 0.0;
  for (int k = ptr[i]; k < ptr[i + 1] && col[k] < col_end; ++k) sum += val[k] * x[col[k]];
  return sum;
}

void SparseRows::Column(int j, VectorXd* out) const {
  out->setZero(rows());
  for (int i = 0; i < rows(); ++i) (*out)[i] = At(i, j);
}

double SparseRows::RowMaxAbs(int i, int col_end, int* arg) const {
  double m = 0.0;
  if (arg) *arg = 0;
  for (int k = ptr[i]; k < ptr[i + 1] && col[k] < col_end; ++k)
    if (std::abs(val[k]) > m) {
      m = std::abs(val[k]);
      if (arg) *arg = col[k];
    }
  return m;
}

void JacobianWriter::Dense(MatrixXd* m, int rows, int cols) {
  dense_ = m;
  rows_ = rows;
  cols_ = cols;
  // One memset (+0.0 has all bits zero): setZero's element loop was ~10 % of a resting box's
  // step derivative.
  m->resize(rows, cols);
  if (m->size() > 0)
    std::memset(m->data(), 0, sizeof(double) * static_cast<std::size_t>(m->size()));
}

void JacobianWriter::Sparse(int rows, int cols) {
  dense_ = nullptr;
  rows_ = rows;
  cols_ = cols;
  keys_.clear();
  vals_.clear();
}

void JacobianWriter::AddRows(int add) {
  if (dense_) {
    dense_->conservativeResize(rows_ + add, cols_);
    dense_->bottomRows(add).setZero();
  }
  rows_ += add;
}

void JacobianWriter::Set(int i, int j, double v) {
  if (dense_)
    (*dense_)(i, j) = v;
  else
    Push(i, j, v);
}

void JacobianWriter::Block(int i, int j, const SparseMatrixd& S, double sign) {
  if (dense_) {
    dense_->block(i, j, S.rows(), S.cols()) = sign * S;
    return;
  }
  for (int c = 0; c < S.outerSize(); ++c)
    for (SparseMatrixd::InnerIterator it(S, c); it; ++it)
      Push(i + static_cast<int>(it.row()), j + c, sign * it.value());
}

void JacobianWriter::BlockTransposed(int i, int j, const SparseMatrixd& S) {
  if (dense_) {
    dense_->block(i, j, S.cols(), S.rows()) = S.transpose();
    return;
  }
  for (int c = 0; c < S.outerSize(); ++c)
    for (SparseMatrixd::InnerIterator it(S, c); it; ++it)
      Push(i + c, j + static_cast<int>(it.row()), it.value());
}

void JacobianWriter::Identity(int i, int j, int n) {
  if (dense_) {
    dense_->block(i, j, n, n).setIdentity();
    return;
  }
  for (int k = 0; k < n; ++k) Push(i + k, j + k, 1.0);
}

void JacobianWriter::SortPattern() {
  // Stable counting sort of the writes by row, then each row by column (insertion: short rows,
  // mostly written in column order already, stable); of equal keys the last write is kept.
  const int n = static_cast<int>(keys_.size());
  count_.assign(rows_ + 1, 0);
  for (const Key& k : keys_) ++count_[k.row + 1];
  for (int i = 0; i < rows_; ++i) count_[i + 1] += count_[i];
  pattern_ptr_.assign(count_.begin(), count_.end());  // row starts in order_
  order_.resize(n);
  for (int k = 0; k < n; ++k) order_[count_[keys_[k].row]++] = k;
  pattern_src_.clear();
  int w = 0;
  for (int i = 0; i < rows_; ++i) {
    const int b = pattern_ptr_[i], e = pattern_ptr_[i + 1];
    for (int k = b + 1; k < e; ++k) {
      if (keys_[order_[k - 1]].col <= keys_[order_[k]].col) continue;
      const int x = order_[k], xc = keys_[x].col;
      int m = k;
      for (; m > b && keys_[order_[m - 1]].col > xc; --m) order_[m] = order_[m - 1];
      order_[m] = x;
    }
    pattern_ptr_[i] = w;
    for (int k = b; k < e; ++k) {
      if (k + 1 < e && keys_[order_[k + 1]].col == keys_[order_[k]].col) continue;
      pattern_src_.push_back(order_[k]);
      ++w;
    }
  }
  pattern_ptr_[rows_] = w;
  pattern_keys_.assign(keys_.begin(), keys_.end());
  pattern_rows_ = rows_;
  pattern_cols_ = cols_;
}

void JacobianWriter::Finish(SparseRows* out) {
  const std::size_t n = keys_.size();
  const bool same =
      rows_ == pattern_rows_ && cols_ == pattern_cols_ && n == pattern_keys_.size() &&
      (n == 0 || std::memcmp(keys_.data(), pattern_keys_.data(), n * sizeof(Key)) == 0);
  if (!same) SortPattern();
  const int slots = static_cast<int>(pattern_src_.size());
  out->cols = cols_;
  out->ptr.resize(rows_ + 1);
  out->col.resize(slots);
  out->val.resize(slots);
  int w = 0;
  out->ptr[0] = 0;
  for (int i = 0; i < rows_; ++i) {
    for (int k = pattern_ptr_[i]; k < pattern_ptr_[i + 1]; ++k) {
      const int e = pattern_src_[k];
      if (vals_[e] == 0.0) continue;
      out->col[w] = keys_[e].col;
      out->val[w++] = vals_[e];
    }
    out->ptr[i + 1] = w;
  }
  out->col.resize(w);
  out->val.resize(w);
}

}  // namespace vinci::sim::internal
