#include "vinci/sim/solvers/warm_basis.h"

#include <Eigen/OrderingMethods>
#include <Eigen/QR>
#include <Eigen/SparseQR>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "basis_solve.h"
#include "vinci/sim/solvers/lcp_acceptance.h"

namespace vinci::sim {

namespace {

// A symmetric M_BB of at least this many members takes the sparse LDLᵀ: about where it overtakes
// the dense QR on resting k-box stacks (4k normals in the basis; bench/README.md, dense14).
constexpr int kSparseSymmetricWarmBasisMin = 33;

// As lemke.cc: the cap of the ‖M‖∞‖z‖∞ term of the acceptance scale, relative to max(1, ‖q‖∞).
constexpr double kMaxAcceptanceGrowth = 1e3;

double Tolerance(double rtol, double q_norm, double m_norm, double z_norm) {
  const double base = std::max(1.0, q_norm);
  return rtol * std::max(base, std::min(m_norm * z_norm, kMaxAcceptanceGrowth * base));
}

// x.allFinite() in one pass without early exit: x_i · 0 is ±0 for finite x_i and NaN otherwise,
// so the sum of them is 0 iff every entry is finite.
bool AllFinite(const Eigen::VectorXd& x) {
  const double* p = x.data();
  const Eigen::Index n = x.size();
  double acc0 = 0.0, acc1 = 0.0;
  Eigen::Index i = 0;
  for (; i + 1 < n; i += 2) {
    acc0 += p[i] * 0.0;
    acc1 += p[i + 1] * 0.0;
  }
  if (i < n) acc0 += p[i] * 0.0;
  return acc0 + acc1 == 0.0;
}

// Whether every x_i is finite (Σ x_i · 0 = 0); if so, *min = min_i x_i and *max_abs = max_i |x_i|
// (0 for an empty x; exact in any order for finite entries).
bool FiniteMinMaxAbs(const Eigen::VectorXd& x, double* min, double* max_abs) {
  const double* p = x.data();
  const Eigen::Index n = x.size();
  double acc = 0.0, lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  Eigen::Index i = 0;
#ifdef __SSE2__
  __m128d acc2 = _mm_setzero_pd(), lo2 = _mm_set1_pd(lo), hi2 = _mm_setzero_pd();
  const __m128d zero = _mm_setzero_pd(), sign = _mm_set1_pd(-0.0);
  for (; i + 1 < n; i += 2) {
    const __m128d v = _mm_loadu_pd(p + i);
    acc2 = _mm_add_pd(acc2, _mm_mul_pd(v, zero));
    lo2 = _mm_min_pd(lo2, v);
    hi2 = _mm_max_pd(hi2, _mm_andnot_pd(sign, v));
  }
  double a[2], l[2], h[2];
  _mm_storeu_pd(a, acc2);
  _mm_storeu_pd(l, lo2);
  _mm_storeu_pd(h, hi2);
  acc = a[0] + a[1];
  lo = std::min(l[0], l[1]);
  hi = std::max(h[0], h[1]);
#endif
  for (; i < n; ++i) {
    acc += p[i] * 0.0;
    lo = std::min(lo, p[i]);
    hi = std::max(hi, std::abs(p[i]));
  }
  if (acc != 0.0) return false;
  *min = lo;
  *max_abs = hi;
  return true;
}

// Whether every guess_i is finite; if so, in_basis[i] = (guess_i > 0) for every i and the members
// appended to *active in ascending order.
bool FiniteBasis(const Eigen::VectorXd& guess, char* in_basis, std::vector<int>* active) {
  const double* g = guess.data();
  const Eigen::Index n = guess.size();
  double acc = 0.0;
  Eigen::Index i = 0;
#ifdef __SSE2__
  __m128d acc2 = _mm_setzero_pd();
  const __m128d zero = _mm_setzero_pd();
  for (; i + 1 < n; i += 2) {
    const __m128d v = _mm_loadu_pd(g + i);
    acc2 = _mm_add_pd(acc2, _mm_mul_pd(v, zero));
    const int mask = _mm_movemask_pd(_mm_cmpgt_pd(v, zero));
    in_basis[i] = static_cast<char>(mask & 1);
    in_basis[i + 1] = static_cast<char>(mask >> 1);
    if (mask & 1) active->push_back(static_cast<int>(i));
    if (mask & 2) active->push_back(static_cast<int>(i + 1));
  }
  double a[2];
  _mm_storeu_pd(a, acc2);
  acc = a[0] + a[1];
#endif
  for (; i < n; ++i) {
    acc += g[i] * 0.0;
    in_basis[i] = g[i] > 0.0;
    if (g[i] > 0.0) active->push_back(static_cast<int>(i));
  }
  return acc == 0.0;
}

}  // namespace

double SparseLcpMatrix::NormInf() const {
  Eigen::VectorXd row_sum = Eigen::VectorXd::Zero(M_.rows());
  for (Eigen::Index j = 0; j < M_.outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(M_, j); it; ++it)
      row_sum(it.row()) += std::abs(it.value());
  return M_.rows() > 0 ? row_sum.maxCoeff() : 0.0;
}

void SparseLcpMatrix::MultiplyAdd(const Eigen::VectorXd& z, const Eigen::VectorXd& q,
                                  Eigen::VectorXd* w) const {
  *w = q;
  for (Eigen::Index j = 0; j < z.size(); ++j) {
    const double zj = z(j);
    if (zj == 0.0) continue;
    for (Eigen::SparseMatrix<double>::InnerIterator it(M_, j); it; ++it)
      (*w)(it.row()) += zj * it.value();
  }
}

void SparseLcpMatrix::PrincipalBlock(const std::vector<int>& index, Eigen::MatrixXd* out) const {
  const int k = static_cast<int>(index.size());
  std::vector<int> position(M_.rows(), -1);
  for (int a = 0; a < k; ++a) position[index[a]] = a;
  out->setZero(k, k);
  for (int a = 0; a < k; ++a)
    for (Eigen::SparseMatrix<double>::InnerIterator it(M_, index[a]); it; ++it)
      if (const int r = position[it.row()]; r >= 0) (*out)(r, a) = it.value();
}

void LcpMatrixOperator::PrincipalBlockSparse(const std::vector<int>& index,
                                             CompressedColumns* out) const {
  Eigen::MatrixXd block;
  PrincipalBlock(index, &block);
  const int k = static_cast<int>(index.size());
  out->Reset(k);
  for (int j = 0; j < k; ++j) {
    for (int i = 0; i < k; ++i)
      if (block(i, j) != 0.0) {
        out->row.push_back(i);
        out->value.push_back(block(i, j));
      }
    out->col_start[j + 1] = static_cast<int>(out->row.size());
  }
}

void SparseLcpMatrix::PrincipalBlockSparse(const std::vector<int>& index,
                                           CompressedColumns* out) const {
  // Each column's entries in M's row order, mapped to basis positions, then sorted (both
  // index and M's rows ascend in the usual case, and the sort is then a no-op pass).
  const int k = static_cast<int>(index.size());
  std::vector<int> position(M_.rows(), -1);
  for (int a = 0; a < k; ++a) position[index[a]] = a;
  out->Reset(k);
  std::vector<std::pair<int, double>> column;
  for (int a = 0; a < k; ++a) {
    column.clear();
    for (Eigen::SparseMatrix<double>::InnerIterator it(M_, index[a]); it; ++it)
      if (const int r = position[it.row()]; r >= 0) column.emplace_back(r, it.value());
    std::sort(column.begin(), column.end(),
              [](const auto& x, const auto& y) { return x.first < y.first; });
    for (const auto& [r, v] : column) {
      out->row.push_back(r);
      out->value.push_back(v);
    }
    out->col_start[a + 1] = static_cast<int>(out->row.size());
  }
}

bool SolveOnWarmBasis(const LcpMatrixOperator& M, const Eigen::VectorXd& q,
                      const Eigen::VectorXd& guess, const LemkeOptions& options,
                      WarmBasisScratch* s, Eigen::VectorXd* z, SolverReport* report) {
  const Eigen::Index n = q.size();
  if (M.size() != n || guess.size() != n) return false;
  // One pass over q: finite (Σ q_i · 0 = 0), min q and ‖q‖∞; one over the guess: finite and
  // the guessed basis B = {i : guess_i > 0}.
  double q_min = std::numeric_limits<double>::infinity(), q_norm = 0.0;
  if (!FiniteMinMaxAbs(q, &q_min, &q_norm)) return false;
  s->active.clear();
  s->in_basis.resize(static_cast<std::size_t>(n));
  if (!FiniteBasis(guess, s->in_basis.data(), &s->active)) return false;
  auto solved = [&](double residual, double tolerance, const char* message) {
    *report = SolverReport{};
    report->status = SolverStatus::kSolved;
    report->residual = residual;
    report->tolerance = tolerance;
    report->message = message;  // time_s stays 0: this path is not timed (warm_basis.h)
    return true;
  };
  // ‖M‖∞ enters only the acceptance tolerances and scales, where a bound m ≥ ‖M‖∞ serves (an
  // operator that forms M lazily bounds it without forming it).
  double m = M.NormInfBound();
  if (!std::isfinite(m)) m = M.NormInf();
  if (!std::isfinite(m)) return false;  // the dense solver reports it
  if (n == 0 || q_min >= 0.0) {         // LemkeSolver's trivial solution
    z->setZero(n);
    return solved(0.0, options.residual_tolerance, "");
  }

  // M_BB of the guessed basis.
  const int nb = static_cast<int>(s->active.size());
  if (nb == 0) return false;
  s->guess_b.resize(nb);
  s->rhs.resize(nb);
  for (int a = 0; a < nb; ++a) {
    s->guess_b(a) = guess(s->active[a]);
    s->rhs(a) = q(s->active[a]);
  }
  // From kSparseSymmetricWarmBasisMin members a symmetric M_BB = G_Bᵀ M⁻¹ G_B (+ compliance),
  // which is semidefinite, is solved by LDLᵀ with the dependent pivots dropped (their unknowns
  // keep the guess, as kBasisRankTolerance's in the QR); any other by the dense QR up to
  // kDenseWarmBasisMax members, by a sparse QR above.
  bool factored = false;
  if (nb >= kSparseSymmetricWarmBasisMin) {
    CompressedColumns& m_bb = s->m_bb_sparse;
    M.PrincipalBlockSparse(s->active, &m_bb);
    const bool symmetric = M.KnownSymmetricBlock(s->active) || m_bb.IsSymmetric(&s->cursor);
    if (symmetric && s->ldlt.Factorize(m_bb, internal::kBasisRankTolerance)) {
      m_bb.Multiply(s->guess_b, &s->product);
      s->rhs = -(s->product + s->rhs);
      s->ldlt.Solve(s->rhs, &s->z_b);
      factored = true;
    } else if (nb > kDenseWarmBasisMax) {
      m_bb.Multiply(s->guess_b, &s->product);
      s->rhs = -(s->product + s->rhs);
      const Eigen::SparseMatrix<double> s_bb = Eigen::Map<const Eigen::SparseMatrix<double>>(
          nb, nb, static_cast<Eigen::Index>(m_bb.row.size()), m_bb.col_start.data(),
          m_bb.row.data(), m_bb.value.data());
      Eigen::SparseQR<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> qr;
      // Columns whose remaining norm is at most kBasisRankTolerance of the largest column norm
      // are dependent (basis_solve.h): their unknowns keep the guess.
      double max_norm = 0.0;
      for (int j = 0; j < nb; ++j) {
        double sum = 0.0;
        for (int p = m_bb.col_start[j]; p < m_bb.col_start[j + 1]; ++p)
          sum += m_bb.value[p] * m_bb.value[p];
        max_norm = std::max(max_norm, std::sqrt(sum));
      }
      qr.setPivotThreshold(internal::kBasisRankTolerance * max_norm);
      qr.compute(s_bb);
      if (qr.info() != Eigen::Success) return false;
      s->z_b = qr.solve(s->rhs);
      if (qr.info() != Eigen::Success) return false;
      factored = true;
    }
  }
  if (!factored) {
    // As LemkeSolver: column-pivoted Householder QR of the dense M_BB, in the scratch's storage.
    M.PrincipalBlock(s->active, &s->m_bb);
    s->product.noalias() = s->m_bb * s->guess_b;
    s->rhs = -(s->product + s->rhs);
    // A kept QR of an M_BB with the same bits is reused: then only its solve is done (the QR is
    // a function of M_BB's bits, so the result does not depend on which calls came before).
    const auto holds = [&](const WarmBasisScratch::KeptQr& e) {
      return e.valid && e.m_bb.rows() == nb && e.m_bb.cols() == nb &&
             std::memcmp(e.m_bb.data(), s->m_bb.data(), sizeof(double) * nb * nb) == 0;
    };
    int slot = s->kept_last;
    bool factorized = holds(s->kept[slot]);
    if (!factorized) {
      slot = 1 - slot;
      factorized = holds(s->kept[slot]);
    }
    WarmBasisScratch::KeptQr& kept = s->kept[slot];
    s->kept_last = slot;
    if (!factorized) kept.valid = false;  // until kept.m_bb is the block its QR holds
    internal::SolveBasisBlock(s->m_bb, s->rhs, &kept.qr, &s->c, &s->z_b, factorized);
    if (!factorized) {
      kept.m_bb = s->m_bb;
      kept.valid = true;
    }
  }
  s->z_b += s->guess_b;
  if (!AllFinite(s->z_b)) return false;
  // The candidate z (z_B, 0) and w = M z + q, both independent of ‖M‖∞; then the tests, which
  // depend on it only through the tolerances and scales.
  const double z_b_min = s->z_b.minCoeff();
  const double z_b_norm = s->z_b.lpNorm<Eigen::Infinity>();
  s->candidate.setZero(n);
  for (int a = 0; a < nb; ++a) s->candidate(s->active[a]) = s->z_b(a);
  M.MultiplyAdd(s->candidate, q, &s->w);
  const auto min_w_off_basis = [&] {  // min over N of w (NaN skipped)
    double w_n_min = std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < n; ++i)
      if (!s->in_basis[i] && s->w(i) < w_n_min) w_n_min = s->w(i);
    return w_n_min;
  };
  // The candidate's entries off B are +0 and z_B is finite: min(z) < 0 iff min(z_B) < 0, and
  // ‖z‖∞ = max(0, max_B |z_i|) after the clamp. w_N's minimum is the unclamped candidate's.
  const bool clamp = z_b_min < 0.0;
  double w_n_min = clamp ? min_w_off_basis() : 0.0;
  if (clamp) {
    for (int a = 0; a < nb; ++a) {
      double& c = s->candidate(s->active[a]);
      c = std::max(c, 0.0);  // as cwiseMax(0.0): c < 0 → 0, else c
    }
    M.MultiplyAdd(s->candidate, q, &s->w);
  }
  double z_norm = 0.0;
  for (int a = 0; a < nb; ++a) z_norm = std::max(z_norm, std::abs(s->candidate(s->active[a])));
  const double rtol = options.residual_tolerance;
  const auto ratio = [](double x, double scale) { return scale > 0.0 ? x / scale : 0.0; };
  const double s_w = std::max(q_norm, m * z_norm);
  const double s_z = std::max(z_norm, m > 0.0 ? q_norm / m : 0.0);
  // One pass over (z, w): w_N's minimum (unless clamped), LcpResidual, w's finiteness and the
  // scale-aware residual (lcp_acceptance.h) max_i |min(z_i / s_z, w_i / s_w)| (each ratio 0 for
  // a zero scale; it counts only if w and the scales are finite, tested below). For z_i = ±0
  // the term is |w_i / s_w| if w_i < 0, else 0 (min(±0, x ≥ 0) = ±0): the division is formed
  // only then. Each maximum runs over i in order, as separate passes would.
  double w_min = std::numeric_limits<double>::infinity();
  double residual = 0.0, scaled = 0.0, w_zero = 0.0;  // w_zero: Σ w_i · 0 (0 iff w finite)
  const double* cz = s->candidate.data();
  const double* cw = s->w.data();
  const char* in_basis = s->in_basis.data();
  // Off B, z_i = +0: for w_i ≥ 0 or NaN both terms are |min(+0, w_i)| = +0, which leaves the
  // maxima (≥ +0) unchanged, so only w_i < 0 is formed.
  for (Eigen::Index i = 0; i < n; ++i) {
    const double c = cz[i], w = cw[i];
    w_zero += w * 0.0;
    if (!in_basis[i]) {
      if (w < w_min) w_min = w;
      if (w < 0.0) {
        residual = std::max(residual, std::abs(std::min(c, w)));
        scaled = std::max(scaled, std::abs(std::min(c, ratio(w, s_w))));
      }
      continue;
    }
    residual = std::max(residual, std::abs(std::min(c, w)));
    if (c == 0.0) {
      if (w < 0.0) scaled = std::max(scaled, std::abs(std::min(c, ratio(w, s_w))));
    } else {
      scaled = std::max(scaled, std::abs(std::min(ratio(c, s_z), ratio(w, s_w))));
    }
  }
  if (!clamp) w_n_min = w_min;
  const bool w_finite = w_zero == 0.0;
  // The acceptance: z_B ≥ −τ(z_B), w_N ≥ −τ(z_B), LcpResidual ≤ τ(z) and the scale-aware
  // residual.
  const double tolerance = Tolerance(rtol, q_norm, m, z_b_norm);
  if (z_b_min < -tolerance || w_n_min < -tolerance) return false;
  const double tau = Tolerance(rtol, q_norm, m, z_norm);
  if (!(residual <= tau) || !w_finite) return false;
  if (!std::isfinite(s_w) || !std::isfinite(s_z)) return false;
  if (!(scaled <= kLcpAcceptanceTolerance)) return false;
  z->swap(s->candidate);
  // A short message (no heap allocation: within std::string's inline buffer).
  return solved(residual, tau, "warm basis");
}

}  // namespace vinci::sim
