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
      y->segment(o, block_size_).noalias() = BlockAt(o) * x.segment(o, block_size_);
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
  int block_size_ = 1;
  MatrixXd blocks_;  // block_size × n: block i in columns [i·bs, (i + 1)·bs)
};

}  // namespace vinci::sim
