// A sparse LDLᵀ factorization of a symmetric positive semidefinite matrix that drops dependent
// pivots, with the symbolic analysis kept while the sparsity pattern does not change: the solve
// of the warm-started contact step whose basis block is singular (a box resting on four
// corners) in O(nnz(L)) work per step.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace vinci::sim {

/// A square n × n sparse matrix as compressed columns: column j's entries are
/// row[col_start[j] .. col_start[j + 1]) with their values, rows ascending, no duplicates.
struct CompressedColumns {
  int n = 0;
  std::vector<int> col_start;  ///< n + 1 offsets
  std::vector<int> row;
  std::vector<double> value;

  /// Empties the matrix and sets its size (storage kept).
  void Reset(int size);
  /// True iff the pattern and the values equal those of the transpose, bit for bit. `cursor`
  /// is scratch (n entries).
  bool IsSymmetric(std::vector<int>* cursor) const;
  /// *y = A x (sized by the call; the sum over column j in row order, columns in order).
  void Multiply(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;
};

/// P A Pᵀ = L D Lᵀ for a symmetric positive semidefinite A (both triangles stored), P a
/// fill-reducing ordering (approximate minimum degree of A's pattern), L unit lower triangular,
/// computed row by row (up-looking) over the elimination tree. A pivot is dropped when its
/// Schur complement is negligible against its own diagonal,
///
///   d_k ≤ drop_tolerance · a_kk   (pivots in elimination order, a_kk = A's diagonal entry),
///
/// which for A = Gᵀ W G (W positive definite) means that column k of G lies in the span of the
/// columns eliminated before it, to a relative angle of √drop_tolerance. A dropped pivot is
/// removed from the factorization (d_k = 0, column k of L zero): the result is the LDLᵀ of A with
/// that row and column deleted, so Solve returns the basic solution x with x_k = 0 on the
/// dropped unknowns and the equations of the kept ones exact (A x = b exactly in exact
/// arithmetic when b is in A's range).
///
/// Reuse: the ordering, the elimination tree and L's pattern are a function of A's pattern
/// only, so Factorize keeps them from the previous call when the pattern (n, col_start, row) is
/// the same, and then only refactorizes numerically. The result is the same, bit for bit, as
/// with a fresh object; a call with the same pattern allocates nothing.
class SemidefiniteLdlt {
 public:
  /// Factorizes A (a symmetric pattern and values; not checked, see CompressedColumns::
  /// IsSymmetric). Returns false if a pivot is negative beyond round-off, d_k < −1e-8 · a_kk
  /// (A is not semidefinite), or not finite; the object then holds no usable factorization.
  bool Factorize(const CompressedColumns& A, double drop_tolerance);
  /// *x with A_RR x_R = b_R on the kept unknowns R and x = 0 on the dropped ones (sized by the
  /// call). Requires a successful Factorize. Uses the object's work storage (one object per
  /// thread).
  void Solve(const Eigen::VectorXd& b, Eigen::VectorXd* x);

  int size() const { return n_; }
  /// Number of kept pivots (A's numerical rank).
  int rank() const { return rank_; }
  /// Whether original unknown i was dropped.
  bool dropped(int i) const { return dropped_[pinv_[i]] != 0; }
  /// Whether the last Factorize kept the previous call's symbolic analysis.
  bool reused_analysis() const { return reused_; }
  /// Entries of L below the diagonal (the fill of the ordering).
  int nonzeros_l() const { return n_ > 0 ? l_start_[n_] : 0; }

 private:
  void Analyze(const CompressedColumns& A);

  int n_ = 0, rank_ = 0;
  bool analyzed_ = false, reused_ = false;
  // The pattern the analysis was made for.
  std::vector<int> pattern_start_, pattern_row_;
  // Symbolic: p_[k] = the original index of pivot k, pinv_ its inverse, parent_ the
  // elimination tree, l_start_ the column offsets of L.
  std::vector<int> p_, pinv_, parent_, l_start_;
  // Numeric: L's row indices and values, D, which pivots were dropped.
  std::vector<int> l_row_, l_count_;
  std::vector<double> l_value_, d_;
  std::vector<char> dropped_;
  // Work arrays.
  std::vector<int> flag_, stack_;
  std::vector<double> y_;
  Eigen::VectorXd work_;
};

}  // namespace vinci::sim
