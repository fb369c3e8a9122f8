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
  entries_.clear();
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
    entries_.push_back({i, j, v});
}

void JacobianWriter::Block(int i, int j, const SparseMatrixd& S, double sign) {
  if (dense_) {
    dense_->block(i, j, S.rows(), S.cols()) = sign * S;
    return;
  }
  for (int c = 0; c < S.outerSize(); ++c)
    for (SparseMatrixd::InnerIterator it(S, c); it; ++it)
      entries_.push_back({i + static_cast<int>(it.row()), j + c, sign * it.value()});
}

void JacobianWriter::BlockTransposed(int i, int j, const SparseMatrixd& S) {
  if (dense_) {
    dense_->block(i, j, S.cols(), S.rows()) = S.transpose();
    return;
  }
  for (int c = 0; c < S.outerSize(); ++c)
    for (SparseMatrixd::InnerIterator it(S, c); it; ++it)
      entries_.push_back({i + c, j + static_cast<int>(it.row()), it.value()});
}

void JacobianWriter::Identity(int i, int j, int n) {
  if (dense_) {
    dense_->block(i, j, n, n).setIdentity();
    return;
  }
  for (int k = 0; k < n; ++k) entries_.push_back({i + k, j + k, 1.0});
}

void JacobianWriter::Finish(SparseRows* out) {
  // Stable counting sort by row, then each row by column (insertion: short rows, mostly written
  // in column order already, stable), an entry written twice keeping its last value.
  const int n = static_cast<int>(entries_.size());
  count_.assign(rows_ + 1, 0);
  for (const Entry& e : entries_) ++count_[e.row + 1];
  for (int i = 0; i < rows_; ++i) count_[i + 1] += count_[i];
  start_.assign(count_.begin(), count_.end());
  sorted_.resize(n);
  for (const Entry& e : entries_) sorted_[count_[e.row]++] = e;
  out->cols = cols_;
  out->ptr.resize(rows_ + 1);
  out->col.resize(n);
  out->val.resize(n);
  int w = 0;
  out->ptr[0] = 0;
  for (int i = 0; i < rows_; ++i) {
    const int b = start_[i], e = start_[i + 1];
    for (int k = b + 1; k < e; ++k) {
      if (sorted_[k - 1].col <= sorted_[k].col) continue;
      const Entry x = sorted_[k];
      int m = k;
      for (; m > b && sorted_[m - 1].col > x.col; --m) sorted_[m] = sorted_[m - 1];
      sorted_[m] = x;
    }
    for (int k = b; k < e; ++k) {
      if (k + 1 < e && sorted_[k + 1].col == sorted_[k].col) continue;  // a later write wins
      if (sorted_[k].val == 0.0) continue;
      out->col[w] = sorted_[k].col;
      out->val[w++] = sorted_[k].val;
    }
    out->ptr[i + 1] = w;
  }
  out->col.resize(w);
  out->val.resize(w);
}

}  // namespace vinci::sim::internal
