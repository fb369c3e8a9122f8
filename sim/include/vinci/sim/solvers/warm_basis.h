// Lemke's warm-start test on a sparse LCP matrix: the step of a warm-started simulation whose
// active set did not change costs one sparse solve with the guessed basis block, not a dense
// m × m matrix and a scan of it.
#pragma once

#include <Eigen/QR>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/semidefinite_ldlt.h"

namespace vinci::sim {

/// An LCP matrix M (n × n) given by what the warm-start test needs: products, entries of
/// principal blocks and ‖M‖∞. Lets a caller with structure (the contact LCP: M = Gᵀ W G with a
/// block-diagonal W, plus unit entries) skip forming M.
class LcpMatrixOperator {
 public:
  virtual ~LcpMatrixOperator() = default;
  virtual int size() const = 0;
  /// ‖M‖∞ = max_i Σ_j |M_ij| (+inf or NaN if M has a non-finite entry).
  virtual double NormInf() const = 0;
  /// A bound b ≥ NormInf() (on the value NormInf returns) for an operator that can bound its norm
  /// more cheaply than form it, +inf if it has none; SolveOnWarmBasis scales its tolerances by
  /// it, so it should lie within a small factor of ‖M‖∞. Default: NormInf().
  virtual double NormInfBound() const { return NormInf(); }
  /// *w = M z + q (w sized by the caller's vector; may reallocate).
  virtual void MultiplyAdd(const Eigen::VectorXd& z, const Eigen::VectorXd& q,
                           Eigen::VectorXd* w) const = 0;
  /// *out = M(index, index) (|index| × |index|, dense).
  virtual void PrincipalBlock(const std::vector<int>& index, Eigen::MatrixXd* out) const = 0;
  /// *out = M(index, index) as compressed columns (rows ascending; its pattern may hold zero
  /// entries, and should depend on M's structure only, so that a factorization can keep its
  /// analysis between calls). The default compresses PrincipalBlock's nonzero entries.
  virtual void PrincipalBlockSparse(const std::vector<int>& index, CompressedColumns* out) const;
  /// True if M(index, index) is known, from M's structure, to be symmetric with finite entries
  /// (so that CompressedColumns::IsSymmetric of PrincipalBlockSparse's output would be true);
  /// false if not known. Default: false.
  virtual bool KnownSymmetricBlock(const std::vector<int>& index) const {
    (void)index;
    return false;
  }
};

/// An LcpMatrixOperator over an Eigen sparse matrix (column major); for tests and callers that
/// have M as a sparse matrix.
class SparseLcpMatrix final : public LcpMatrixOperator {
 public:
  explicit SparseLcpMatrix(const Eigen::SparseMatrix<double>& M) : M_(M) {}
  int size() const override { return static_cast<int>(M_.rows()); }
  double NormInf() const override;
  void MultiplyAdd(const Eigen::VectorXd& z, const Eigen::VectorXd& q,
                   Eigen::VectorXd* w) const override;
  void PrincipalBlock(const std::vector<int>& index, Eigen::MatrixXd* out) const override;
  void PrincipalBlockSparse(const std::vector<int>& index, CompressedColumns* out) const override;

 private:
  const Eigen::SparseMatrix<double>& M_;
};

/// Reusable buffers of SolveOnWarmBasis (one per thread or per rollout; they hold no state that
/// changes a result, only allocations kept between calls).
struct WarmBasisScratch {
  std::vector<int> active;
  std::vector<char> in_basis;
  Eigen::VectorXd guess_b, rhs, z_b, w, candidate, product, c;
  Eigen::MatrixXd m_bb;
  /// Dense bases: the QR of each of the last two distinct M_BB, with the M_BB it factorizes. A
  /// resting contact repeats its M_BB's bits every step, a sticking one on an incline every
  /// other step (the pose's round-off settles into a cycle of two).
  struct KeptQr {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
    Eigen::MatrixXd m_bb;  // the M_BB qr holds (if valid)
    bool valid = false;
  };
  std::array<KeptQr, 2> kept;
  int kept_last = 0;              // the entry used last (a new M_BB replaces the other one)
  CompressedColumns m_bb_sparse;  // M_BB of sparse bases
  SemidefiniteLdlt ldlt;          // of m_bb_sparse when it is symmetric
  std::vector<int> cursor;
};

/// Bases with fewer than 33 members (warm_basis.cc) are solved densely, by the
/// column-pivoted QR that LemkeSolver's warm start uses (same bits for the same M_BB). From that
/// size on, a symmetric M_BB (a basis of impulse columns only: resting and sticking contacts) is
/// solved by SemidefiniteLdlt with drop tolerance 1e-10 (its analysis kept between calls while
/// the basis block's pattern is unchanged); any other (or one whose LDLᵀ finds it indefinite) by
/// the dense QR up to kDenseWarmBasisMax members and by a sparse rank-revealing QR
/// (Eigen::SparseQR, COLAMD ordering) above.
inline constexpr int kDenseWarmBasisMax = 48;

/// LemkeSolver's first two stages (lemke.h) on LCP(M, q) with M given as an operator: the
/// trivial solution z = 0 if q ≥ 0, else the warm start from `guess`: B = {i : guess_i > 0},
/// z_B = guess_B + δ with M_BB δ = −(M_BB guess_B + q_B) (anchored at the guess, so a singular
/// M_BB keeps the guessed values in its null space), accepted iff z_B ≥ −τ, w_N ≥ −τ,
/// LcpResidual ≤ τ(z) and the scale-aware residual (lcp_acceptance.h) ≤
/// kLcpAcceptanceTolerance, with τ(z) of `options` (lemke.h) and, in place of ‖M‖∞, the scale
/// m = M.NormInfBound() (M.NormInf() if that is not finite): LemkeSolver's test for an operator
/// whose bound is its norm (SparseLcpMatrix); a bound m ≥ ‖M‖∞ makes the tolerances at most
/// m / ‖M‖∞ times wider. Work: NormInfBound, two products, the |B| × |B|
/// block and its factorization (dense or sparse by size and symmetry, above; a dense block with
/// the same bits as one of the scratch's last two distinct ones reuses its QR) — no pass over a
/// dense n × n matrix. The result does not depend on what the scratch solved before.
///
/// Returns true with *z and *report (kSolved, 0 iterations, residual, tolerance, message as
/// LemkeSolver's; time_s 0: the path is not timed, since one clock read costs 20–100 ns, as
/// much as a tenth of a small warm-started step — time the step instead) if z = 0 or the
/// guessed basis is accepted; false otherwise (then *z and
/// *report are unspecified, and the caller solves the full LCP with LemkeSolver, which repeats
/// the test and goes on to pivot). Also false if q or guess has the wrong size or a
/// non-finite entry. Thread-safe with one scratch per thread.
bool SolveOnWarmBasis(const LcpMatrixOperator& M, const Eigen::VectorXd& q,
                      const Eigen::VectorXd& guess, const LemkeOptions& options,
                      WarmBasisScratch* scratch, Eigen::VectorXd* z, SolverReport* report);

}  // namespace vinci::sim
