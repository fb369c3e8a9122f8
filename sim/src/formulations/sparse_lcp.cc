#include "sparse_lcp.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <utility>

#include "sparse_lcp_kernels.h"

namespace vinci::sim {

namespace internal {

namespace {

using namespace sparse_lcp_kernels;  // NOLINT(build/namespaces): this file's own kernels

// EnsureBlocks sums the rows of up to this many columns per contact (1 + n_d) together.
constexpr int kRowGroupMax = 9;

// The ‖M‖∞ row sums of contact c's 1 + n_d = group rows (normal, then friction directions; E
// starts the friction rows) into sums[0..group), each summed in the order of EnsureBlocks'
// row-by-row loop (the same terms in the same order: the same bits), the rows interleaved. G:
// group as a compile-time constant, or 0.
template <int G>
void ContactRowSums(const StewartTrinkle::Assembly& a, const std::vector<int>& first,
                    const std::vector<std::vector<int>>& columns,
                    const std::vector<MatrixXd>& blocks, int c, int runtime_group, double* sums) {
  const int group = G > 0 ? G : runtime_group;
  const int bodies[2] = {a.contacts[c].body_a, a.contacts[c].body_b};
  double acc[kRowGroupMax];  // local: kept in registers when G is fixed
  acc[0] = 0.0;
  for (int t = 1; t < group; ++t) acc[t] = 1.0;  // E
  // Row p + t of a block is read as column p + t's entries in column jj, i.e. rows p..p+group−1
  // of column jj: contiguous (the blocks are symmetric bit for bit).
  for (int side = 0; side < 2; ++side) {
    if (first[2 * c + side] < 0) continue;
    const int b = bodies[side], other = first[2 * c + 1 - side] >= 0 ? bodies[1 - side] : -1;
    const int p = first[2 * c + side];
    const std::vector<int>& cols = columns[b];
    const int k = static_cast<int>(cols.size());
    const double* B = blocks[b].data() + p;
    if (other < 0) {
      for (int jj = 0; jj < k; ++jj) {
        const double* x = B + static_cast<std::ptrdiff_t>(jj) * k;
        for (int t = 0; t < group; ++t) acc[t] += std::abs(x[t]);
      }
      continue;
    }
    const int p_other = first[2 * c + 1 - side];
    const int k_other = static_cast<int>(blocks[other].rows());
    const double* O = blocks[other].data() + p_other;
    for (int g = 0; g < k / group; ++g) {
      const int cg = cols[g * group];
      const Contact& cj = a.contacts[cg];
      int shared = -1;
      if (cj.body_a == other) shared = first[2 * cg + 0];
      if (cj.body_b == other) shared = first[2 * cg + 1];
      if (shared >= 0 && side == 1) continue;  // summed at side 0
      const int o = g * group;
      if (shared >= 0) {
        for (int u = 0; u < group; ++u) {
          const double* x = B + static_cast<std::ptrdiff_t>(o + u) * k;
          const double* y = O + static_cast<std::ptrdiff_t>(shared + u) * k_other;
          for (int t = 0; t < group; ++t) acc[t] += std::abs(x[t] + y[t]);
        }
      } else {
        for (int u = 0; u < group; ++u) {
          const double* x = B + static_cast<std::ptrdiff_t>(o + u) * k;
          for (int t = 0; t < group; ++t) acc[t] += std::abs(x[t]);
        }
      }
    }
  }
  for (int t = 0; t < group; ++t) sums[t] = acc[t];
}

}  // namespace

void RunPattern::Classify(const SparseMatrixd& G, int n) {
  if (!G.isCompressed()) {
    n_ = -1;
    whole = false;
    uniform_row = -1;
    return;
  }
  const std::size_t no = static_cast<std::size_t>(G.cols()) + 1;
  const std::size_t ni = static_cast<std::size_t>(G.outerIndexPtr()[G.cols()]);
  if (n_ == n && outer_.size() == no && inner_.size() == ni &&
      std::memcmp(outer_.data(), G.outerIndexPtr(), sizeof(int) * no) == 0 &&
      std::memcmp(inner_.data(), G.innerIndexPtr(), sizeof(int) * ni) == 0)
    return;
  n_ = n;
  outer_.assign(G.outerIndexPtr(), G.outerIndexPtr() + no);
  inner_.assign(G.innerIndexPtr(), G.innerIndexPtr() + ni);
  whole = SingleWholeRuns(G, n);
  uniform_row = -1;
  if (whole && G.cols() > 0) {
    uniform_row = inner_[0];
    for (Eigen::Index j = 1; j < G.cols(); ++j)
      if (inner_[static_cast<std::size_t>(n * j)] != uniform_row) {
        uniform_row = -1;
        break;
      }
  }
}

bool ContactLcpOperator::Build(const Scene& model, const StewartTrinkle::Assembly& a,
                               const VectorXd& v, double h, bool velocity_level) {
  if (a.psi_b.size() > 0 || !a.corner_contact.empty() || a.support.columns() > 0 ||
      a.support.points() > 0)
    return false;
  a_ = &a;
  model_ = &model;
  nc_ = static_cast<int>(a.contacts.size());
  nd_ = a.nd;
  nf_ = nc_ * nd_;
  m_ = nc_ + nf_ + nc_;
  const int nc = nc_, nd = nd_, nf = nf_;
  const int nvb = VelocitySize(model.dim);

  v_star_ = v;
  for (int o = 0; o < a.M_inv.rows(); o += nvb)
    a.M_inv.BlockMultiply(o, a.p_ext.data() + o, v_star_.data() + o, /*add=*/true);
  last_z_valid_ = false;

  // The impulse columns touching each dynamic body, and each contact's position in them.
  const std::size_t nbody = model.bodies.size();
  columns_.resize(nbody);
  for (std::vector<int>& cols : columns_) cols.clear();
  first_.assign(2 * static_cast<std::size_t>(nc), -1);
  self_contact_ = false;
  for (int c = 0; c < nc; ++c) {
    const int bodies[2] = {a.contacts[c].body_a, a.contacts[c].body_b};
    self_contact_ = self_contact_ || bodies[0] == bodies[1];
    for (int side = 0; side < 2; ++side) {
      if (model.bodies[bodies[side]].kind != BodyKind::kDynamic) continue;
      std::vector<int>& cols = columns_[bodies[side]];
      const std::size_t at = cols.size();
      first_[2 * c + side] = static_cast<int>(at);
      cols.resize(at + 1 + static_cast<std::size_t>(nd));
      int* out = cols.data() + at;
      out[0] = c;
      const int f0 = nc + c * nd;
      int j = 0;
      for (; j + 4 <= nd; j += 4) {
        out[1 + j] = f0 + j;
        out[2 + j] = f0 + j + 1;
        out[3 + j] = f0 + j + 2;
        out[4 + j] = f0 + j + 3;
      }
      for (; j < nd; ++j) out[1 + j] = f0 + j;
    }
  }
  // Per body: G_b gathered; W_b G_b, the block and ‖M‖∞ are formed on demand (EnsureBlocks,
  // PrincipalBlock). The bound on ‖M‖∞: |(G_bᵀ W_b G_b)_ij| ≤ |g_i|ᵀ |W_b| |g_j|, so a row's sum
  // over j is at most |g_i|ᵀ u_b with u_b = |W_b| Σ_j |g_j| — O(n_vb) per row.
  full_ = false;
  norm_formed_ = false;
  nvb_ = nvb;
  blocks_.resize(nbody);
  Gb_.resize(nbody);
  gcol_.resize(nbody);
  WG_.resize(nbody);
  wg_ready_.resize(nbody);
  bound_u_.resize(nbody);
  split_.resize(nbody);
  bool finite = true;
  // G_n and G_f finite: every stored entry gathered into some G_b, and each G_b's column sums
  // of |entries| finite.
  bool g_finite = true;
  Eigen::Index gathered = 0, gathered_runs = 0;
  // Every column of G_n and G_f one run of n_vb rows (a contact with one dynamic side): a
  // column's block is then at n_vb·col, and it is the body's if its first row is the body's.
  pattern_n_.Classify(a.G_n, nvb);
  pattern_f_.Classify(a.G_f, nvb);
  const bool whole_n = pattern_n_.whole, whole_f = pattern_f_.whole;
  const bool whole = whole_n && whole_f;
  for (int body : model.dynamic_bodies()) {
    const std::vector<int>& cols = columns_[body];
    if (cols.empty()) continue;
    const int o = model.index(body).v, k = static_cast<int>(cols.size());
    // Per body, so that a steady step (same k per body) reuses their storage.
    std::vector<const double*>& gcol = gcol_[body];
    gcol.resize(static_cast<std::size_t>(k));
    MatrixXd& Gb = Gb_[body];
    bool gb_sized = false;
    // Whole runs: the body's columns are groups of one contact's normal c and friction columns
    // c n_d + j (as laid out above), each at n_vb times its column index in G_n or G_f.
    bool found = whole;
    if (whole) {
      const int* inner_n = a.G_n.innerIndexPtr();
      const int* inner_f = a.G_f.innerIndexPtr();
      const double* value_n = a.G_n.valuePtr();
      const double* value_f = a.G_f.valuePtr();
      const double** out = gcol.data();
      for (int g = 0; g < k; g += 1 + nd) {
        const int pn = nvb * cols[g];
        out[g] = value_n + pn;
        found = found && inner_n[pn] == o;
        // The contact's friction columns share its sides (one writer per contact), so each is
        // the body's run iff the first is.
        const int pf = nd > 0 ? nvb * (cols[g + 1] - nc) : 0;
        if (nd > 0) found = found && inner_f[pf] == o;
        for (int j = 0; j < nd; ++j) out[g + 1 + j] = value_f + pf + nvb * j;
      }
      if (found) {
        gathered += static_cast<Eigen::Index>(nvb) * k;
        gathered_runs += static_cast<Eigen::Index>(nvb) * k;
      }
    }
    for (int i = 0; i < (found ? 0 : k); ++i) {
      const SparseMatrixd& G = cols[i] < nc ? a.G_n : a.G_f;
      const int col = cols[i] < nc ? cols[i] : cols[i] - nc;
      // The assembly stores a body's block whole (rows o..o+nvb−1, explicit zeros included, a
      // column's blocks in row order): read in place when found so, else gathered entry by entry.
      if (G.isCompressed()) {
        const int* inner = G.innerIndexPtr();
        const int end = G.outerIndexPtr()[col + 1];
        int p = G.outerIndexPtr()[col];
        // The body's block is the column's first or (a column of two bodies) its second.
        if (p < end && inner[p] != o && p + nvb < end && inner[p + nvb] == o) p += nvb;
        if (p + nvb <= end && inner[p] == o && inner[p + nvb - 1] == o + nvb - 1) {
          gcol[static_cast<std::size_t>(i)] = G.valuePtr() + p;
          gathered += nvb;
          gathered_runs += nvb;
          continue;
        }
      }
      if (!gb_sized) {
        Gb.resize(nvb, k);
        gb_sized = true;
      }
      Gb.col(i).setZero();
      for (SparseMatrixd::InnerIterator it(G, col); it; ++it)
        if (it.row() >= o && it.row() < o + nvb) {
          Gb(it.row() - o, i) = it.value();
          ++gathered;
        }
      gcol[static_cast<std::size_t>(i)] = Gb.col(i).data();
    }
    WG_[body].resize(nvb, k);
    wg_ready_[body].assign(static_cast<std::size_t>(k), 0);
    double column_sum[6] = {0, 0, 0, 0, 0, 0};
    if (nvb == 6)
      AddColumnAbs<6>(gcol.data(), k, column_sum);
    else
      AddColumnAbs<3>(gcol.data(), k, column_sum);
    bool body_g_finite = true;  // every entry of the body's columns finite
    for (int r = 0; r < nvb; ++r) body_g_finite = body_g_finite && std::isfinite(column_sum[r]);
    g_finite = g_finite && body_g_finite;
    const auto W = a.M_inv.BlockAt(o);
    split_[body] = nvb == 6 && body_g_finite && IsSplitBlock(W.data());
    std::array<double, 6>& u = bound_u_[body];
    if (split_[body]) {
      // The terms |W_re| Σ|g_e| = 0 · (finite) = +0 off W's split structure leave the sum (from
      // +0) unchanged: the full loop's bits.
      for (int r = 0; r < 3; ++r) u[r] = 0.0 + std::abs(W(r, r)) * column_sum[r];
      for (int r = 3; r < 6; ++r)
        u[r] = ((0.0 + std::abs(W(r, 3)) * column_sum[3]) + std::abs(W(r, 4)) * column_sum[4]) +
               std::abs(W(r, 5)) * column_sum[5];
      for (int r = 0; r < 6; ++r) finite = finite && std::isfinite(u[r]);
    } else {
      for (int r = 0; r < nvb; ++r) {
        u[r] = 0.0;
        for (int e = 0; e < nvb; ++e) u[r] += std::abs(W(r, e)) * column_sum[e];
        finite = finite && std::isfinite(u[r]);
      }
    }
  }
  // The bound: from the rows (contact normals and friction directions) and the σ rows (whose
  // sums |μ_c| + n_d NormInf adds the same way).
  double hi = 0.0;
  for (int c = 0; c < nc; ++c) {
    const int bodies[2] = {a.contacts[c].body_a, a.contacts[c].body_b};
    // Per dynamic side: its columns' pointers from the contact's normal on, and u_b.
    const double* const* g[2] = {nullptr, nullptr};
    const double* u[2] = {nullptr, nullptr};
    for (int side = 0; side < 2; ++side) {
      if (first_[2 * c + side] < 0) continue;
      g[side] = gcol_[bodies[side]].data() + first_[2 * c + side];
      u[side] = bound_u_[bodies[side]].data();
    }
    if (nvb == 6 && (g[0] == nullptr) != (g[1] == nullptr)) {
      // One dynamic side (a body on the ground): the same sums, in a loop of its own. A row sum
      // is ≥ 0 or NaN, so it is finite iff ≤ DBL_MAX.
      const double* const* gs = g[0] ? g[0] : g[1];
      const double* us = g[0] ? u[0] : u[1];
      double sum = 0.0;
      if (a.compliance[c].compliant) sum += std::abs(a.compliance[c].vel_diagonal);
      sum = AddAbsDot<6>(gs[0], us, sum);  // the normal row
      bool rows_finite = sum <= std::numeric_limits<double>::max();
      hi = std::max(hi, sum);
      int t = 1;  // friction direction t − 1, with E's 1; two rows at a time
      for (; t + 1 <= nd; t += 2) {
        double sum_a, sum_b;
        AddAbsDotPair6(gs[t], gs[t + 1], us, 1.0, &sum_a, &sum_b);
        rows_finite = rows_finite && sum_a <= std::numeric_limits<double>::max() &&
                      sum_b <= std::numeric_limits<double>::max();
        hi = std::max(std::max(hi, sum_a), sum_b);
      }
      for (; t <= nd; ++t) {
        sum = AddAbsDot<6>(gs[t], us, 1.0);
        rows_finite = rows_finite && sum <= std::numeric_limits<double>::max();
        hi = std::max(hi, sum);
      }
      finite = finite && rows_finite;
      continue;
    }
    for (int t = 0; t <= nd; ++t) {    // t = 0: the normal row; 1 + j: friction direction j
      double sum = t > 0 ? 1.0 : 0.0;  // E
      if (t == 0 && a.compliance[c].compliant) sum += std::abs(a.compliance[c].vel_diagonal);
      for (int side = 0; side < 2; ++side) {
        if (!g[side]) continue;
        sum = nvb == 6 ? AddAbsDot<6>(g[side][t], u[side], sum)
                       : AddAbsDot<3>(g[side][t], u[side], sum);
      }
      finite = finite && std::isfinite(sum);
      hi = std::max(hi, sum);
    }
  }
  double sigma = 0.0;
  for (int c = 0; c < nc; ++c) sigma = std::max(sigma, std::abs(a.mu[c]) + nd);  // as NormInf
  norm_bound_ =
      finite ? std::max(sigma, hi * (1.0 + 1e-8)) : std::numeric_limits<double>::infinity();

  const Eigen::Index nnz = a.G_n.nonZeros() + a.G_f.nonZeros();
  g_finite_ = g_finite && gathered == nnz;
  runs_ = gathered_runs == nnz;
  single_n_ = runs_ && whole_n;
  single_f_ = runs_ && whole_f;
  uniform_n_ = single_n_ ? pattern_n_.uniform_row : -1;
  uniform_f_ = single_f_ ? pattern_f_.uniform_row : -1;

  // q as BuildLcp.
  q_.setZero(m_);
  SparseTransposeTimes(a.G_n, v_star_, /*assign=*/true, nvb, runs_, single_n_, q_.data(),
                       uniform_n_);
  q_.head(nc) += a.dpsi_n;
  if (!velocity_level) q_.head(nc) += a.psi_n / h;
  for (int c = 0; c < nc; ++c) {
    const CompliantNormalRow& law = a.compliance[c];
    if (!law.compliant) continue;
    q_[c] = a.G_n.col(c).dot(v_star_) + a.dpsi_n[c] + law.vel_psi * a.psi_n[c] + law.vel_constant;
  }
  SparseTransposeTimes(a.G_f, v_star_, /*assign=*/true, nvb, runs_, single_f_, q_.data() + nc,
                       uniform_f_);
  q_.segment(nc, nf) += a.dpsi_f;
  return true;
}

void ContactLcpOperator::EnsureBlocks() const {
  if (full_) return;
  const StewartTrinkle::Assembly& a = *a_;
  // G_bᵀ W_b G_b per body.
  for (int body : model_->dynamic_bodies()) {
    const std::vector<int>& cols = columns_[body];
    if (cols.empty()) continue;
    const int k = static_cast<int>(cols.size());
    MatrixXd& B = blocks_[body];
    const std::vector<const double*>& gcol = gcol_[body];
    MatrixXd& WG = WG_[body];
    std::vector<char>& ready = wg_ready_[body];
    const double* W = a.M_inv.BlockAt(model_->index(body).v).data();
    for (int j = 0; j < k; ++j) {  // the columns EnsureWG has not formed, as it forms them
      if (ready[static_cast<std::size_t>(j)]) continue;
      if (nvb_ == 6)
        BodyBlockTimesColumn<6>(W, split_[body], gcol[static_cast<std::size_t>(j)],
                                WG.col(j).data());
      else
        BlockTimesColumn<3>(W, gcol[static_cast<std::size_t>(j)], WG.col(j).data());
      ready[static_cast<std::size_t>(j)] = 1;
    }
    B.resize(k, k);
    // The lower triangle, mirrored (as PrincipalBlock's entries).
    if (nvb_ == 6) {
      // LowerEntry<6>'s expression, with the column pointers hoisted.
      using Map6 = Eigen::Map<const Eigen::Matrix<double, 6, 1>>;
      double* Bd = B.data();
      for (int j = 0; j < k; ++j) {
        const Map6 wg(WG.col(j).data());
        double* Bj = Bd + static_cast<std::ptrdiff_t>(j) * k;
        for (int i = j; i < k; ++i)
          Bd[static_cast<std::ptrdiff_t>(i) * k + j] = Bj[i] =
              Map6(gcol[static_cast<std::size_t>(i)]).dot(wg);
      }
    } else {
      for (int j = 0; j < k; ++j)
        for (int i = j; i < k; ++i)
          B(j, i) = B(i, j) = LowerEntry<3>(gcol[static_cast<std::size_t>(i)], WG.col(j).data());
    }
  }
  full_ = true;
}

double ContactLcpOperator::NormInf() const {
  if (norm_formed_) return norm_inf_;
  EnsureBlocks();
  const StewartTrinkle::Assembly& a = *a_;
  const int nc = nc_, nd = nd_, nf = nf_;
  // ‖M‖∞: impulse rows from the body blocks (an entry shared by two dynamic bodies — two
  // contacts between the same pair — summed before its absolute value), plus E, U, −Eᵀ. The
  // columns of body b come in groups of 1 + n_d (one contact's normal and friction columns).
  const int group = 1 + nd;
  norm_inf_ = 0.0;
  const auto add_row_sum = [&](double sum) {
    norm_inf_ = std::max(norm_inf_, sum);
    if (std::isnan(sum)) norm_inf_ = sum;
  };
  // A contact without compliance: its 1 + n_d rows at once (ContactRowSums).
  const bool grouped = group <= kRowGroupMax;
  for (int c = 0; c < (grouped ? nc : 0); ++c) {
    if (a.compliance[c].compliant) continue;
    double sums[kRowGroupMax];
    if (group == 5)
      ContactRowSums<5>(a, first_, columns_, blocks_, c, group, sums);
    else
      ContactRowSums<0>(a, first_, columns_, blocks_, c, group, sums);
    for (int t = 0; t < group; ++t) add_row_sum(sums[t]);
  }
  // Every other row (a compliant contact's, or all if n_d is large).
  for (int r = 0; r < nc + nf; ++r) {
    const int c = ContactOf(r);
    if (grouped && !a.compliance[c].compliant) continue;
    const int bodies[2] = {a.contacts[c].body_a, a.contacts[c].body_b};
    double sum = r >= nc ? 1.0 : 0.0;  // E
    const bool compliant = r < nc && a.compliance[r].compliant;
    for (int side = 0; side < 2; ++side) {
      if (first_[2 * c + side] < 0) continue;
      const int b = bodies[side], other = first_[2 * c + 1 - side] >= 0 ? bodies[1 - side] : -1;
      const int p = PositionIn(r, b), p_other = other >= 0 ? PositionIn(r, other) : -1;
      const std::vector<int>& cols = columns_[b];
      const MatrixXd& B = blocks_[b];
      if (other < 0) {
        // No other dynamic body: row p of B (column p, B symmetric), the same sums in the same
        // order as the general loop below (cols[jj] == r only at jj = p).
        const double* Bp = B.col(p).data();
        const int k = static_cast<int>(cols.size());
        if (compliant) {
          for (int jj = 0; jj < k; ++jj)
            sum += std::abs(jj == p ? Bp[jj] + a.compliance[r].vel_diagonal : Bp[jj]);
        } else {
          for (int jj = 0; jj < k; ++jj) sum += std::abs(Bp[jj]);
        }
        continue;
      }
      // Row p of B and row p_other of the other body's block, read as columns (both blocks are
      // symmetric bit for bit).
      const double* Bp = B.col(p).data();
      const double* Bo = blocks_[other].col(p_other).data();
      const int groups = static_cast<int>(cols.size()) / group;
      for (int g = 0; g < groups; ++g) {
        const int cg = cols[g * group];
        const Contact& cj = a.contacts[cg];
        // Position of contact cj's group in the other body's columns, if it touches it.
        int shared = -1;
        if (cj.body_a == other) shared = first_[2 * cg + 0];
        if (cj.body_b == other) shared = first_[2 * cg + 1];
        if (shared >= 0 && side == 1) continue;  // summed at side 0
        const double* bg = Bp + g * group;
        const int* cols_g = cols.data() + g * group;
        if (shared >= 0) {
          const double* og = Bo + shared;
          for (int t = 0; t < group; ++t) {
            double value = bg[t] + og[t];
            if (compliant && cols_g[t] == r) value += a.compliance[r].vel_diagonal;
            sum += std::abs(value);
          }
        } else if (compliant) {
          for (int t = 0; t < group; ++t) {
            double value = bg[t];
            if (cols_g[t] == r) value += a.compliance[r].vel_diagonal;
            sum += std::abs(value);
          }
        } else {
          for (int t = 0; t < group; ++t) sum += std::abs(bg[t]);
        }
      }
    }
    add_row_sum(sum);
  }
  for (int c = 0; c < nc; ++c) norm_inf_ = std::max(norm_inf_, std::abs(a.mu[c]) + nd);  // σ rows
  norm_formed_ = true;
  return norm_inf_;
}

int ContactLcpOperator::PositionIn(int col, int body) const {
  const int c = ContactOf(col);
  const Contact& ct = a_->contacts[c];
  const int side = ct.body_a == body ? 0 : (ct.body_b == body ? 1 : -1);
  if (side < 0 || first_[2 * c + side] < 0) return -1;
  return first_[2 * c + side] + (col < nc_ ? 0 : 1 + (col - nc_) % nd_);
}

double ContactLcpOperator::ImpulseEntry(int i, int j) const {
  EnsureBlocks();
  const int c = ContactOf(i);
  const Contact& ct = a_->contacts[c];
  double value = 0.0;
  for (int body : {ct.body_a, ct.body_b}) {
    const int pi = PositionIn(i, body);
    if (pi < 0) continue;
    const int pj = PositionIn(j, body);
    if (pj >= 0) value += blocks_[body](pi, pj);
  }
  if (i == j && i < nc_ && a_->compliance[i].compliant) value += a_->compliance[i].vel_diagonal;
  return value;
}

double ContactLcpOperator::Entry(int i, int j) const {
  const int s0 = nc_ + nf_;  // first σ row
  if (i < s0 && j < s0) return ImpulseEntry(i, j);
  if (i < s0) {  // column σ_c: E in the friction rows of contact c
    return i >= nc_ && (i - nc_) / nd_ == j - s0 ? 1.0 : 0.0;
  }
  const int c = i - s0;  // row σ_c: U and −Eᵀ
  if (j == c) return a_->mu[c];
  if (j >= nc_ && j < s0 && (j - nc_) / nd_ == c) return -1.0;
  return 0.0;
}

void ContactLcpOperator::MultiplyAdd(const VectorXd& z, const VectorXd& q, VectorXd* w) const {
  const StewartTrinkle::Assembly& a = *a_;
  const int nc = nc_, nd = nd_, nf = nf_, s0 = nc + nf;
  const int nvb = a.M_inv.block_size();
  SparseTimes(a.G_n, z.data(), /*assign=*/true, g_finite_, nvb, runs_, &impulse_);
  SparseTimes(a.G_f, z.data() + nc, /*assign=*/false, g_finite_, nvb, runs_, &impulse_);
  a.M_inv.Multiply(impulse_, &dv_);
  last_z_ = z;
  last_z_valid_ = true;
  *w = q;
  SparseTransposeTimes(a.G_n, dv_, /*assign=*/false, nvb, runs_, single_n_, w->data(), uniform_n_);
  SparseTransposeTimes(a.G_f, dv_, /*assign=*/false, nvb, runs_, single_f_, w->data() + nc,
                       uniform_f_);
  // E σ: on compressed storage a friction row's w_i = q_i + tmp with tmp summed from +0 (never
  // −0), so w_i is never −0 and w_i + (±0) = w_i: σ_c = ±0 is not added (the same bits).
  const bool skip_zero_sigma = a.G_f.isCompressed();
  double* wd = w->data();
  const double* zd = z.data();
  for (int c = 0; c < nc; ++c) {
    if (a.compliance[c].compliant) wd[c] += a.compliance[c].vel_diagonal * zd[c];
    const double sigma = zd[s0 + c];
    const double* z_f = zd + nc + c * nd;
    double* w_f = wd + nc + c * nd;
    double sum_f = 0.0;
    if (skip_zero_sigma && sigma == 0.0) {
      for (int j = 0; j < nd; ++j) sum_f += z_f[j];
    } else {
      for (int j = 0; j < nd; ++j) {
        w_f[j] += sigma;
        sum_f += z_f[j];
      }
    }
    wd[s0 + c] += a.mu[c] * zd[c] - sum_f;
  }
}

void ContactLcpOperator::VelocityAfter(const VectorXd& z, VectorXd* impulse, VectorXd* dv,
                                       VectorXd* v1) const {
  const StewartTrinkle::Assembly& a = *a_;
  if (last_z_valid_ && last_z_.size() == z.size() &&
      std::memcmp(last_z_.data(), z.data(), sizeof(double) * z.size()) == 0) {
    // MultiplyAdd formed G z and M⁻¹ G z for this z (the warm basis' final candidate).
    *impulse = impulse_;
    *dv = dv_;
  } else {
    SparseTimes(a.G_n, z.data(), /*assign=*/true, g_finite_, nvb_, runs_, impulse);
    SparseTimes(a.G_f, z.data() + nc_, /*assign=*/false, g_finite_, nvb_, runs_, impulse);
    a.M_inv.Multiply(*impulse, dv);
  }
  *v1 = v_star_ + *dv;
}

void ContactLcpOperator::ToSparse(SparseMatrixd* out) const {
  EnsureBlocks();
  const int nc = nc_, nd = nd_, s0 = nc_ + nf_;
  triplets_.clear();
  for (int body : model_->dynamic_bodies()) {
    const std::vector<int>& cols = columns_[body];
    const MatrixXd& B = blocks_[body];
    for (int j = 0; j < static_cast<int>(cols.size()); ++j)
      for (int i = 0; i < static_cast<int>(cols.size()); ++i)
        triplets_.emplace_back(cols[i], cols[j], B(i, j));
  }
  for (int c = 0; c < nc; ++c) {
    if (a_->compliance[c].compliant) triplets_.emplace_back(c, c, a_->compliance[c].vel_diagonal);
    for (int j = 0; j < nd; ++j) {
      triplets_.emplace_back(nc + c * nd + j, s0 + c, 1.0);   // E
      triplets_.emplace_back(s0 + c, nc + c * nd + j, -1.0);  // −Eᵀ
    }
    triplets_.emplace_back(s0 + c, c, a_->mu[c]);  // U
  }
  out->resize(m_, m_);
  // Duplicates (an entry two bodies share) are summed in insertion order: body order.
  out->setFromTriplets(triplets_.begin(), triplets_.end());
}

}  // namespace internal
}  // namespace vinci::sim
