// ContactLcpOperator's principal blocks M_BB (dense and compressed) and the W_b G_b columns they
// are formed from; the operator's assembly, products and entries are in sparse_lcp.cc.
#include "sparse_lcp.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "sparse_lcp_kernels.h"

namespace vinci::sim {
namespace internal {

using namespace sparse_lcp_kernels;  // NOLINT(build/namespaces): this library's own kernels

void ContactLcpOperator::EnsureWG(int body, int p) const {
  char& ready = wg_ready_[body][static_cast<std::size_t>(p)];
  if (ready) return;
  // WG = W_b Gb by hand: Eigen's GEMM for a 6 × k product costs more in setup than in flops.
  // Each entry accumulates from 0 over the inner index in order, as GEMM's kernel does (the inner
  // dimension nvb ≤ 6 is below its unrolled depth), so the bits are GEMM's.
  const double* W = a_->M_inv.BlockAt(model_->index(body).v).data();  // nvb × nvb, contiguous
  if (nvb_ == 6)
    BodyBlockTimesColumn<6>(W, split_[body], gcol_[body][static_cast<std::size_t>(p)],
                            WG_[body].col(p).data());
  else
    BlockTimesColumn<3>(W, gcol_[body][static_cast<std::size_t>(p)], WG_[body].col(p).data());
  ready = 1;
}

void ContactLcpOperator::MemberBlock(int body, const int* p, int m, double* out) const {
  if (full_) {
    const MatrixXd& B = blocks_[body];
    for (int x = 0; x < m; ++x)
      for (int y = 0; y < m; ++y) out[static_cast<std::ptrdiff_t>(x) * m + y] = B(p[y], p[x]);
    return;
  }
  for (int x = 0; x < m; ++x) EnsureWG(body, p[x]);
  const std::vector<const double*>& gcol = gcol_[body];
  const MatrixXd& WG = WG_[body];
  for (int x = 0; x < m; ++x)
    for (int y = x; y < m; ++y) {
      // W_b is symmetric, so is the block: its lower triangle, entry (i ≥ j) = g_i · (W_b g_j).
      const int i = std::max(p[x], p[y]), j = std::min(p[x], p[y]);
      const double* g_i = gcol[static_cast<std::size_t>(i)];
      const double value =
          nvb_ == 6 ? LowerEntry<6>(g_i, WG.col(j).data()) : LowerEntry<3>(g_i, WG.col(j).data());
      out[static_cast<std::ptrdiff_t>(x) * m + y] = value;
      out[static_cast<std::ptrdiff_t>(y) * m + x] = value;
    }
}

bool ContactLcpOperator::KnownSymmetricBlock(const std::vector<int>& index) const {
  if (!std::isfinite(norm_bound_) || self_contact_) return false;
  const int s0 = nc_ + nf_;
  for (int i : index)
    if (i >= s0) return false;
  return true;
}

void ContactLcpOperator::SetPositions(const std::vector<int>& index, int n) const {
  if (static_cast<int>(position_.size()) != n) position_.assign(static_cast<std::size_t>(n), -1);
  for (int b = 0; b < static_cast<int>(index.size()); ++b) position_[index[b]] = b;
}

void ContactLcpOperator::ClearPositions(const std::vector<int>& index) const {
  for (int i : index) position_[i] = -1;
}

void ContactLcpOperator::PrincipalBlock(const std::vector<int>& index, MatrixXd* out) const {
  // Entry(index[r], index[b]) for every r, b, assembled per body: O(Σ_body k_body²) rather than
  // O(k²) lookups. Each impulse entry sums at most two body blocks (0 + x + y in either order:
  // the same bits as ImpulseEntry), then the compliance; E, U and −Eᵀ are set directly.
  const int k = static_cast<int>(index.size());
  const int s0 = nc_ + nf_, n = s0 + nc_;
  out->setZero(k, k);
  SetPositions(index, n);
  if (!self_contact_) {
    // Each body's members found from the index (O(|index|), not O(Σ_body k_body)): impulse
    // column j of contact c is column first_[2c + side] + t of each dynamic side's body (t = 0
    // for the normal, 1 + direction for friction). The bodies are taken in ascending order, as
    // dynamic_bodies() lists them; within a body the members' order does not matter (each entry
    // of a body's block is formed from its pair alone and added once).
    const std::size_t nbody = columns_.size();
    if (body_count_.size() != nbody) body_count_.assign(nbody, 0);
    body_begin_.resize(nbody);
    touched_.clear();
    const std::size_t max_members = 2 * static_cast<std::size_t>(k);
    if (member_p_.size() < max_members) member_p_.resize(max_members);
    if (member_r_.size() < max_members) member_r_.resize(max_members);
    const auto for_each_side = [&](auto&& f) {
      for (int b = 0; b < k; ++b) {
        const int j = index[b];
        if (j >= s0) continue;
        const int c = ContactOf(j);
        const int t = j < nc_ ? 0 : 1 + (j - nc_) % nd_;
        const Contact& ct = a_->contacts[c];
        if (first_[2 * c] >= 0) f(ct.body_a, first_[2 * c] + t, b);
        if (first_[2 * c + 1] >= 0) f(ct.body_b, first_[2 * c + 1] + t, b);
      }
    };
    for_each_side([&](int body, int, int) {
      if (body_count_[body]++ == 0) {
        // Insertion by body index (few bodies).
        touched_.push_back(body);
        for (std::size_t q = touched_.size() - 1; q > 0 && touched_[q - 1] > body; --q)
          std::swap(touched_[q - 1], touched_[q]);
      }
    });
    int used = 0;
    for (int body : touched_) {
      body_begin_[body] = used;
      used += body_count_[body];
      body_count_[body] = 0;  // the fill cursor below
    }
    for_each_side([&](int body, int p, int b) {
      const int at = body_begin_[body] + body_count_[body]++;
      member_p_[at] = p;
      member_r_[at] = b;
    });
    for (int body : touched_) {
      const int m = body_count_[body];
      body_count_[body] = 0;
      const int* mp = member_p_.data() + body_begin_[body];
      const int* mr = member_r_.data() + body_begin_[body];
      member_block_.resize(static_cast<std::size_t>(m) * m);
      MemberBlock(body, mp, m, member_block_.data());
      for (int x = 0; x < m; ++x)
        for (int y = 0; y < m; ++y)
          (*out)(mr[y], mr[x]) += member_block_[static_cast<std::size_t>(x) * m + y];
    }
  }
  static const std::vector<int> kNoBodies;
  for (int body : self_contact_ ? model_->dynamic_bodies() : kNoBodies) {
    const std::vector<int>& cols = columns_[body];
    members_.clear();
    for (int p = 0; p < static_cast<int>(cols.size()); ++p)
      if (position_[cols[p]] >= 0) members_.emplace_back(p, position_[cols[p]]);
    const int m = static_cast<int>(members_.size());
    member_p_.resize(static_cast<std::size_t>(m));
    for (int x = 0; x < m; ++x) member_p_[x] = members_[x].first;
    member_block_.resize(static_cast<std::size_t>(m) * m);
    MemberBlock(body, member_p_.data(), m, member_block_.data());
    for (int x = 0; x < m; ++x)
      for (int y = 0; y < m; ++y)
        (*out)(members_[y].second, members_[x].second) +=
            member_block_[static_cast<std::size_t>(x) * m + y];
  }
  for (int b = 0; b < k; ++b) {
    const int j = index[b];
    if (j < nc_ && a_->compliance[j].compliant) (*out)(b, b) += a_->compliance[j].vel_diagonal;
    if (j < s0) continue;
    const int c = j - s0;  // column σ_c: E in the friction rows of contact c
    for (int t = 0; t < nd_; ++t) {
      const int r = position_[nc_ + c * nd_ + t];
      if (r >= 0) (*out)(r, b) = 1.0;
    }
  }
  for (int r = 0; r < k; ++r) {
    const int i = index[r];
    if (i < s0) continue;
    const int c = i - s0;  // row σ_c: U and −Eᵀ
    if (position_[c] >= 0) (*out)(r, position_[c]) = a_->mu[c];
    for (int t = 0; t < nd_; ++t) {
      const int b = position_[nc_ + c * nd_ + t];
      if (b >= 0) (*out)(r, b) = -1.0;
    }
  }
  ClearPositions(index);
}

void ContactLcpOperator::PrincipalBlockSparse(const std::vector<int>& index,
                                              CompressedColumns* out) const {
  // Column b: the basis members of the body blocks of the (at most two) bodies its impulse
  // column touches, summed where both bodies hold the row (0 + x + y, side 0 first: in either
  // order the bits of PrincipalBlock's sum), then the compliance; or the E, U, −Eᵀ entries.
  // Rows sorted per column. Each body's members (sorted by basis position) × members block is
  // formed first (MemberBlock); a column merges its two bodies' member lists.
  const int k = static_cast<int>(index.size());
  const int s0 = nc_ + nf_, n = s0 + nc_;
  SetPositions(index, n);
  const std::size_t num_bodies = columns_.size();
  member_begin_.resize(num_bodies);
  member_count_.resize(num_bodies);
  member_block_begin_.resize(num_bodies);
  member_local_.assign(2 * static_cast<std::size_t>(k), -1);
  // Each basis column is a member of at most two bodies' lists (its contact's dynamic sides).
  const std::size_t max_members = 2 * static_cast<std::size_t>(k);
  if (member_p_.size() < max_members) member_p_.resize(max_members);
  if (member_r_.size() < max_members) member_r_.resize(max_members);
  int used = 0;
  std::size_t block_used = 0;
  for (int body : model_->dynamic_bodies()) {
    const std::vector<int>& cols = columns_[body];
    const int begin = used;
    for (int p = 0; p < static_cast<int>(cols.size()); ++p) {
      const int r = position_[cols[p]];
      if (r < 0) continue;
      // Insertion by basis position (the list is short).
      int q = used++;
      for (; q > begin && member_r_[q - 1] > r; --q) {
        member_p_[q] = member_p_[q - 1];
        member_r_[q] = member_r_[q - 1];
      }
      member_p_[q] = p;
      member_r_[q] = r;
    }
    const int mb = used - begin;
    const std::size_t block_begin = block_used;
    member_begin_[body] = begin;
    member_count_[body] = mb;
    member_block_begin_[body] = block_begin;
    if (mb == 0) continue;
    const int* mp = member_p_.data() + begin;
    for (int x = 0; x < mb; ++x) {
      const int side = a_->contacts[ContactOf(cols[mp[x]])].body_a == body ? 0 : 1;
      member_local_[2 * static_cast<std::size_t>(member_r_[begin + x]) + side] = x;
    }
    block_used += static_cast<std::size_t>(mb) * mb;
    if (member_block_.size() < block_used) member_block_.resize(block_used);  // grows only
    MemberBlock(body, mp, mb, member_block_.data() + block_begin);
  }
  // Reset(k) without emptying row and value first: resized from their previous size, so that
  // a steady step writes over the previous entries instead of refilling them.
  out->n = k;
  out->col_start.resize(static_cast<std::size_t>(k) + 1);
  out->col_start[0] = 0;
  // Written through raw pointers into storage sized by a bound on the entry count (a column of
  // contact c: the members of its at most two bodies, the compliance and σ_c's entry; a σ
  // column: n_d entries), then trimmed.
  std::size_t cap = static_cast<std::size_t>(k) * static_cast<std::size_t>(2 + nd_);
  for (int b = 0; b < k; ++b) {
    const int j = index[b];
    if (j >= s0) continue;
    const int c = ContactOf(j);
    const int bodies[2] = {a_->contacts[c].body_a, a_->contacts[c].body_b};
    for (int side = 0; side < 2; ++side)
      if (first_[2 * c + side] >= 0) cap += static_cast<std::size_t>(member_count_[bodies[side]]);
  }
  out->row.resize(cap);
  out->value.resize(cap);
  int* orow = out->row.data();
  double* oval = out->value.data();
  int size = 0;
  bool ordered = true;  // every column's rows ascending as written
  const auto push = [&](int r, double value) {
    orow[size] = r;
    oval[size] = value;
    ++size;
  };
  for (int b = 0; b < k; ++b) {
    const int j = index[b];
    const int begin = size;
    if (j < s0) {
      const int c = ContactOf(j);
      const int bodies[2] = {a_->contacts[c].body_a, a_->contacts[c].body_b};
      const int* rows[2] = {nullptr, nullptr};
      const double* values[2] = {nullptr, nullptr};
      int count[2] = {0, 0};
      for (int side = 0; side < 2; ++side) {
        if (first_[2 * c + side] < 0) continue;
        const int body = bodies[side];
        count[side] = member_count_[body];
        rows[side] = member_r_.data() + member_begin_[body];
        values[side] = member_block_.data() + member_block_begin_[body] +
                       static_cast<std::ptrdiff_t>(member_local_[2 * b + side]) * count[side];
      }
      int i0 = 0, i1 = 0;
      while (i0 < count[0] || i1 < count[1]) {
        if (i1 == count[1] || (i0 < count[0] && rows[0][i0] < rows[1][i1])) {
          push(rows[0][i0], 0.0 + values[0][i0]);
          ++i0;
        } else if (i0 == count[0] || rows[1][i1] < rows[0][i0]) {
          push(rows[1][i1], 0.0 + values[1][i1]);
          ++i1;
        } else {
          push(rows[0][i0], (0.0 + values[0][i0]) + values[1][i1]);
          ++i0;
          ++i1;
        }
      }
      if (j < nc_ && a_->compliance[j].compliant) {
        int at = -1;
        for (int p = begin; p < size; ++p)
          if (orow[p] == b) at = p;
        if (at < 0) {
          at = size;
          push(b, 0.0 + 0.0);
          if (at > begin && orow[at - 1] > b) ordered = false;
        }
        oval[at] += a_->compliance[j].vel_diagonal;
      }
      if (const int r = position_[s0 + c]; r >= 0) {
        if (size > begin && orow[size - 1] > r) ordered = false;
        push(r, 0.0 + (j < nc_ ? a_->mu[c] : -1.0));
      }
    } else {
      const int c = j - s0;  // column σ_c: E in the friction rows of contact c
      for (int t = 0; t < nd_; ++t)
        if (const int r = position_[nc_ + c * nd_ + t]; r >= 0) {
          if (size > begin && orow[size - 1] > r) ordered = false;
          push(r, 0.0 + 1.0);
        }
    }
    out->col_start[b + 1] = size;
  }
  // Insertion sort of each column's entries by row, if one was written out of order (not when
  // index ascends). The merged body rows ascend by construction.
  for (int b = 0; !ordered && b < k; ++b) {
    const int begin = out->col_start[b], end = out->col_start[b + 1];
    for (int p = begin + 1; p < end; ++p) {
      const int r = orow[p];
      const double v = oval[p];
      int q = p;
      for (; q > begin && orow[q - 1] > r; --q) {
        orow[q] = orow[q - 1];
        oval[q] = oval[q - 1];
      }
      orow[q] = r;
      oval[q] = v;
    }
  }
  out->row.resize(static_cast<std::size_t>(size));
  out->value.resize(static_cast<std::size_t>(size));
  ClearPositions(index);
}

}  // namespace internal
}  // namespace vinci::sim
