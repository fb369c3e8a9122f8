// Structured matrices of the step assembly: the block-diagonal generalized mass matrix and the
// sparse constraint Jacobians. Memory and work are O(nv) (mass) and O(nnz) (Jacobians) instead
// of the dense nv × nv and nv × ncols.
#pragma once

#include <Eigen/SparseCore>

#include "vinci/sim/types.h"

namespace vinci::sim {

/// A constraint Jacobian G (nv × columns), column major: each contact or joint column touches
/// the ν blocks of at most two bodies (≤ 12 nonzeros).
using SparseMatrixd = Eigen::SparseMatrix<double>;

/// A square block-diagonal matrix of equal square blocks: the generalized mass matrix M of a
/// scene (and M⁻¹, and the first-order h C), one nvb × nvb block per dynamic body
/// (nvb = VelocitySize(dim)) at the body's ν offset. Stored as nvb × n: O(n) memory.
class BlockDiagonal {
 public:
  BlockDiagonal() = default;
  /// n / block_size zero blocks; n must be a multiple of block_size (≥ 1).
  BlockDiagonal(int n, int block_size) { Resize(n, block_size); }
  /// Resizes to n / block_size zero blocks (keeps the allocation when the size is unchanged).
  void Resize(int n, int block_size);

  int rows() const { return static_cast<int>(blocks_.cols()); }
  int cols() const { return rows(); }
  int block_size() const { return block_size_; }
  int num_blocks() const { return rows() / block_size_; }

  /// The block whose first row and column is `offset` (a multiple of block_size()).
  auto BlockAt(int offset) { return blocks_.middleCols(offset, block_size_); }
  auto BlockAt(int offset) const { return blocks_.middleCols(offset, block_size_); }

  /// This matrix times x (rows() × k): each block times its rows of x.
  template <typename Derived>
  Eigen::Matrix<double, Eigen::Dynamic, Derived::ColsAtCompileTime> operator*(
      const Eigen::MatrixBase<Derived>& x) const {
    Eigen::Matrix<double, Eigen::Dynamic, Derived::ColsAtCompileTime> y(rows(), x.cols());
    for (int o = 0; o < rows(); o += block_size_)
      y.middleRows(o, block_size_).noalias() = BlockAt(o) * x.middleRows(o, block_size_);
    return y;
  }

  /// The dense rows() × cols() matrix (for small dense consumers: Newton Jacobians).
  /// *y = this · x for a vector x (rows() entries), the product operator* forms, into y's
  /// storage (no allocation when y already has rows() entries). y must not alias x.
  void Multiply(const VectorXd& x, VectorXd* y) const {
    y->resize(rows());
    for (int o = 0; o < rows(); o += block_size_)
      BlockMultiply(o, x.data() + o, y->data() + o, /*add=*/false);
  }

  /// y[0..bs) = B x[0..bs) (add: y += B x) for the block B at `offset`, bs = block_size(); y
  /// must not alias x. The operations of Eigen's matrix–vector kernel for
  /// `y.noalias() = BlockAt(offset) * x` (or `+=`), hence its bits: per row, c = 0, c = B_ij x_j +
  /// c for j in order, then y_i = c + y_i (y_i = +0 when assigning) — without its per-call setup.
  void BlockMultiply(int offset, const double* x, double* y, bool add) const {
    const double* B = blocks_.data() + static_cast<Eigen::Index>(offset) * block_size_;
    if (block_size_ == 6) {
      BlockMultiplyN<6>(B, x, y, add);
    } else if (block_size_ == 3) {
      BlockMultiplyN<3>(B, x, y, add);
    } else {
      const int n = block_size_;
      for (int i = 0; i < n; ++i) {
        double c = 0.0;
        for (int j = 0; j < n; ++j) c = B[j * n + i] * x[j] + c;
        y[i] = c + (add ? y[i] : 0.0);
      }
    }
  }

  /// *y = this · x for a matrix x (rows() × k), the product operator* forms, into y's storage (no
  /// allocation when y already has that shape). y must not alias x.
  void Multiply(const MatrixXd& x, MatrixXd* y) const {
    y->resize(rows(), x.cols());
    for (int o = 0; o < rows(); o += block_size_)
      y->middleRows(o, block_size_).noalias() = BlockAt(o) * x.middleRows(o, block_size_);
  }

  MatrixXd ToDense() const;

 private:
  template <int N>
  static void BlockMultiplyN(const double* B, const double* x, double* y, bool add) {
    double c[N];
    for (int i = 0; i < N; ++i) c[i] = 0.0;
    for (int j = 0; j < N; ++j)
#pragma GCC unroll 6
      for (int i = 0; i < N; ++i) c[i] = B[j * N + i] * x[j] + c[i];
    for (int i = 0; i < N; ++i) y[i] = c[i] + (add ? y[i] : 0.0);
  }

  int block_size_ = 1;
  MatrixXd blocks_;  // block_size × n: block i in columns [i·bs, (i + 1)·bs)
};

}  // namespace vinci::sim
