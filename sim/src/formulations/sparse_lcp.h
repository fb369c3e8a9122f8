// The Stewart–Trinkle step LCP as a structured operator (internal header): for warm-started
// steps whose guessed basis is accepted (solvers/warm_basis.h), so that a step whose active set
// did not change never forms the dense m × m LCP matrix. Work O(Σ_b k_b²) (k_b: LCP impulse
// columns touching body b) instead of O(m²).
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include "step_record.h"
#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/warm_basis.h"

namespace vinci::sim::internal {

/// Whether every column of a compressed G is one run of n consecutive rows (`whole`), and the
/// row every column's run starts at (`uniform_row`; −1 if they differ or not whole), kept for the
/// last pattern classified: a G with the same outer and inner index arrays (compared bitwise)
/// takes the kept answer, another is classified and kept (storage reused).
struct RunPattern {
  bool whole = false;
  int uniform_row = -1;
  void Classify(const SparseMatrixd& G, int n);

 private:
  std::vector<int> outer_, inner_;
  int n_ = -1;  // −1: nothing kept
};

/// StewartTrinkle::BuildLcp's M for an assembly without joints, corner contacts or support
/// points, z = [p_n; p_f; σ]:
///
///   M = [G_nᵀ W G_n + D_c, G_nᵀ W G_f, 0; G_fᵀ W G_n, G_fᵀ W G_f, E; U, −Eᵀ, 0],
///
/// W = M⁻¹ (block diagonal), D_c the compliant pairs' diagonals (compliance.h). Kept as the
/// Jacobians and one dense block G_bᵀ W_b G_b per body over the impulse columns touching it.
///
/// The body blocks are formed lazily: Build forms ν*, q and a bound on ‖M‖∞ only; a principal
/// block (dense or sparse) forms just the entries it holds (a warm basis of a resting box: 4 of
/// 20 columns); NormInf, Entry and ToSparse form the whole blocks. Every entry has the same bits
/// however it was formed.
class ContactLcpOperator final : public LcpMatrixOperator {
 public:
  /// Builds M, q and ν* = v + W p_ext. Returns false (nothing built) for an assembly with
  /// joints, corner contacts or support points. h and velocity_level as the stepper's
  /// (Anitescu–Potra: no ψ_n/h in q). `a` must outlive the operator's use.
  bool Build(const Scene& model, const StewartTrinkle::Assembly& a, const VectorXd& v, double h,
             bool velocity_level);
  const VectorXd& q() const { return q_; }
  const VectorXd& v_star() const { return v_star_; }

  int size() const override { return m_; }
  double NormInf() const override;
  /// max(max_c (|μ_c| + n_d), the impulse rows' Σ_j |g_i|ᵀ|W_b||g_j|) × (1 + 1e-8) (round-off):
  /// |M_ij| ≤ |g_i|ᵀ|W_b||g_j| summed over a row in O(n_vb) per row, no body block formed; +inf
  /// if not finite. On resting box stacks ≤ 1.61 ‖M‖∞ (bench/README.md).
  double NormInfBound() const override { return norm_bound_; }
  void MultiplyAdd(const VectorXd& z, const VectorXd& q, VectorXd* w) const override;
  void PrincipalBlock(const std::vector<int>& index, MatrixXd* out) const override;
  /// The entries of PrincipalBlock (same bits) on the pattern of M's structure: where two impulse
  /// columns share a body, E, U and −Eᵀ (zeros included). O(Σ_body k_body + |B ∩ body|²).
  void PrincipalBlockSparse(const std::vector<int>& index, CompressedColumns* out) const override;
  /// True for an index of impulse columns only (no σ) when NormInfBound is finite and no
  /// contact has one body on both sides: the block
  /// G_Bᵀ W G_B + D_c is then symmetric bit for bit (each body block is formed symmetric, and an
  /// entry two bodies share is x + y in either order) with finite entries (|M_ij| ≤ the bound).
  bool KnownSymmetricBlock(const std::vector<int>& index) const override;
  /// ν_ℓ+1 = ν* + W (G_n p_n + G_f p_f) for z = [p_n; p_f; σ] into *v1, with the bits of
  /// VelocityAfterWith (stewart_trinkle_internal.h) on this assembly; *impulse and *dv are its
  /// buffers.
  void VelocityAfter(const VectorXd& z, VectorXd* impulse, VectorXd* dv, VectorXd* v1) const;
  /// M_ij.
  double Entry(int i, int j) const;
  /// *out = M as a sparse matrix (column major): the body blocks where two impulse columns share
  /// a body (an entry two bodies share summed in body order, as BuildLcp), D_c, E, U, −Eᵀ.
  /// O(Σ_b k_b²).
  void ToSparse(SparseMatrixd* out) const;

 private:
  int ContactOf(int col) const { return col < nc_ ? col : (col - nc_) / nd_; }
  // Position of impulse column `col` in body's column list, −1 if it does not touch `body`.
  int PositionIn(int col, int body) const;
  double ImpulseEntry(int i, int j) const;
  // position_[index[b]] = b (position_ sized n, all −1 before); ClearPositions undoes it.
  void SetPositions(const std::vector<int>& index, int n) const;
  void ClearPositions(const std::vector<int>& index) const;

  // Forms every body block (once per Build).
  void EnsureBlocks() const;
  // Column p of body's W_b G_b (once per Build).
  void EnsureWG(int body, int p) const;
  // The entries of body's block G_bᵀ W_b G_b at its columns p[0..m) × p[0..m), column major into
  // out (m × m): read from the whole block if formed, else each pair formed once, as EnsureBlocks
  // forms it (the same bits).
  void MemberBlock(int body, const int* p, int m, double* out) const;

  const StewartTrinkle::Assembly* a_ = nullptr;
  const Scene* model_ = nullptr;
  int nc_ = 0, nd_ = 0, nf_ = 0, m_ = 0, nvb_ = 0;
  double norm_bound_ = 0.0;
  VectorXd q_, v_star_;
  std::vector<std::vector<int>> columns_;  // per body: the impulse columns touching it
  std::vector<int> first_;                 // per contact and side: its normal's position
  // Per body, column i of its G_b over columns_[body] (n_vb entries): read in place from G_n's or
  // G_f's storage where the assembly holds the body's block whole, else gathered into Gb_.
  std::vector<std::vector<const double*>> gcol_;
  std::vector<MatrixXd> Gb_;  // per body: the gathered columns of G_b (the others unset)
  std::vector<std::array<double, 6>> bound_u_;  // per body: u_b of NormInfBound
  std::vector<char> split_;  // per body: W_b split and G_b finite (SplitBlockTimesColumn applies)
  // Formed on demand (caches of what Build was given: the same values whenever formed).
  bool g_finite_ = false;      // G_n and G_f have finite values only
  bool runs_ = false;          // G_n's and G_f's columns are whole body blocks (runs of nvb_ rows)
  bool self_contact_ = false;  // a contact has the same body on both sides
  bool single_n_ = false, single_f_ = false;  // G_n's / G_f's columns are one run each
  int uniform_n_ = -1, uniform_f_ = -1;   // single_*: the row every column's run starts at, or −1
  RunPattern pattern_n_, pattern_f_;      // G_n's / G_f's, kept between Builds
  mutable bool full_ = false;             // blocks_ formed
  mutable bool norm_formed_ = false;      // norm_inf_ formed
  mutable double norm_inf_ = 0.0;         // ‖M‖∞
  mutable std::vector<MatrixXd> blocks_;  // per body: G_bᵀ W_b G_b over columns_[body]
  mutable std::vector<MatrixXd> WG_;      // per body: W_b G_b
  mutable std::vector<std::vector<char>> wg_ready_;  // per body and column: WG_ column formed
  mutable VectorXd impulse_, dv_;  // MultiplyAdd: G z and M⁻¹ G z for z = last_z_
  mutable VectorXd last_z_;        // the last MultiplyAdd's z (valid since Build if set)
  mutable bool last_z_valid_ = false;
  mutable std::vector<Eigen::Triplet<double>> triplets_;
  // PrincipalBlock: index → basis position, −1 off the index (all −1 between calls, so that a
  // call sets and clears only its index's entries: O(|index|), not O(m)).
  mutable std::vector<int> position_;
  mutable std::vector<std::pair<int, int>> members_;  // PrincipalBlock: (column in body, position)
  // PrincipalBlock without self-contact: per body its member count (0 between calls) and first
  // member in member_p_/member_r_; the bodies with members, ascending.
  mutable std::vector<int> body_count_, body_begin_, touched_;
  // PrincipalBlockSparse, per body: its members' range in member_p_ (column in the body's list)
  // and member_r_ (basis position, ascending), and its members × members block (column major)
  // in member_block_; member_local_[2 b + side]: member b's index among its side's body's.
  // PrincipalBlock uses member_p_ and member_block_ for one body at a time.
  mutable std::vector<int> member_begin_, member_count_, member_p_, member_r_, member_local_;
  mutable std::vector<std::size_t> member_block_begin_;
  mutable std::vector<double> member_block_;
};

/// Buffers kept between steps (allocation reuse only: a step overwrites everything it reads).
struct StepScratch {
  StewartTrinkle::Assembly assembly;  // the step's assembly (AssembleInto)
  StepRecord record;                  // what `assembly` was made from (step_record.h)
  ContactLcpOperator lcp;
  WarmBasisScratch basis;  // bases above kDenseWarmBasisMax members
  // Dense bases, one scratch per basis size: a step whose basis size differs from the previous
  // step's (a contact starts or stops sliding) reuses its size's storage instead of
  // reallocating the QR and the basis block.
  std::vector<std::unique_ptr<WarmBasisScratch>> basis_by_size;
  /// The scratch for the warm basis {i : guess_i > 0}.
  WarmBasisScratch& BasisFor(const VectorXd& guess);
  SparseMatrixd M;                          // the LCP matrix for SolveSparseLemke (sparse_lemke.h)
  LcpProblem dense_lcp;                     // the dense path's LCP (BuildLcpInto)
  StewartTrinkle::JointElimination joints;  // the dense path's joint elimination
  VectorXd gaps, v_l, v_star, z, impulse, product, dv, v1;
};

/// The calling thread's StepScratch if no step holds it (for reading its step record), else null.
const StepScratch* IdleThreadStepScratch();

/// The calling thread's StepScratch for the lifetime of the lease.
class StepScratchLease {
 public:
  StepScratchLease();
  ~StepScratchLease();
  StepScratchLease(const StepScratchLease&) = delete;
  StepScratchLease& operator=(const StepScratchLease&) = delete;
  StepScratch& get() { return *scratch_; }

 private:
  StepScratch* scratch_ = nullptr;
  bool* in_use_ = nullptr;
  std::unique_ptr<StepScratch> own_;
};

}  // namespace vinci::sim::internal
