// Kernels of ContactLcpOperator (sparse_lcp.cc, sparse_lcp_blocks.cc; internal header): fixed-size
// body-block products and G x, Gᵀ x over the assembly's compressed Jacobians, each with the
// operation order (hence the bits) stated in its comment.
#pragma once

#include <cmath>
#include <cstddef>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "vinci/sim/formulations/stewart_trinkle.h"

namespace vinci::sim::internal::sparse_lcp_kernels {

// out = W g for an N × N column-major W: every entry accumulated from 0 over the inner index in
// order (the order of Eigen's GEMM kernel at depth N ≤ 6, hence its bits).
template <int N>
void BlockTimesColumn(const double* W, const double* g, double* out) {
  double acc[N];
  for (int i = 0; i < N; ++i) acc[i] = 0.0;
  for (int e = 0; e < N; ++e)
#pragma GCC unroll 6
    for (int i = 0; i < N; ++i) acc[i] += W[e * N + i] * g[e];
  for (int i = 0; i < N; ++i) out[i] = acc[i];
}

// Whether a 6 × 6 column-major W is [diag(W_00, W_11, W_22), 0; 0, J] (a rigid body's M⁻¹ in
// body coordinates: m⁻¹ I and the inverse inertia), every other entry exactly 0.
inline bool IsSplitBlock(const double* W) {
  // Σ |W_ie| over the non-structural entries: 0 iff they all are (NaN and ±inf give no 0).
  double sum = std::abs(W[1]) + std::abs(W[2]) + std::abs(W[6]) + std::abs(W[8]) + std::abs(W[12]) +
               std::abs(W[13]);
  for (int e = 0; e < 3; ++e)
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) sum += std::abs(W[e * 6 + 3 + i]) + std::abs(W[(e + 3) * 6 + i]);
  return sum == 0.0;
}

// BlockTimesColumn<6> for a split W (IsSplitBlock) and a finite g: the terms skipped are
// 0 · g_e = ±0, and adding ±0 to a partial sum leaves it unchanged (the sum starts at +0 and
// round-to-nearest never makes it −0), so the bits are BlockTimesColumn<6>'s.
inline void SplitBlockTimesColumn(const double* W, const double* g, double* out) {
  for (int i = 0; i < 3; ++i) out[i] = 0.0 + W[i * 6 + i] * g[i];
  for (int i = 3; i < 6; ++i)
    out[i] = ((0.0 + W[18 + i] * g[3]) + W[24 + i] * g[4]) + W[30 + i] * g[5];
}

// out = W g for body blocks: split (IsSplitBlock, g finite) or general.
template <int N>
inline void BodyBlockTimesColumn(const double* W, bool split, const double* g, double* out) {
  if constexpr (N == 6) {
    if (split) {
      SplitBlockTimesColumn(W, g, out);
      return;
    }
  }
  BlockTimesColumn<N>(W, g, out);
}

// Entry (i, j), i ≥ j, of a body's block G_bᵀ W_b G_b: g_i · (W_b g_j), N = n_vb rows (the
// one expression every path forms it with, hence the same bits).
template <int N>
inline double LowerEntry(const double* g_i, const double* wg_j) {
  if constexpr (N == 6) {
    using Map6 = Eigen::Map<const Eigen::Matrix<double, 6, 1>>;
    return Map6(g_i).dot(Map6(wg_j));
  } else {
    // Dynamic size (as a MatrixXd column's dot): Eigen's reduction order for that type.
    using MapX = Eigen::Map<const VectorXd>;
    return MapX(g_i, N).dot(MapX(wg_j, N));
  }
}

#ifdef __SSE2__
// |x| per lane (the sign bit cleared: std::abs's bits).
inline __m128d AbsPd(__m128d x) { return _mm_andnot_pd(_mm_set1_pd(-0.0), x); }
#endif

// column_sum[r] += Σ_j |g_j(r)| over the k columns g_j (N entries each), j in order (for N = 6
// rows r, r + 1 in the lanes of packed operations: each lane the same sum in the same order).
template <int N>
void AddColumnAbs(const double* const* g, int k, double* column_sum) {
#ifdef __SSE2__
  if constexpr (N == 6) {
    __m128d s01 = _mm_loadu_pd(column_sum), s23 = _mm_loadu_pd(column_sum + 2),
            s45 = _mm_loadu_pd(column_sum + 4);
    for (int j = 0; j < k; ++j) {
      const double* c = g[j];
      s01 = _mm_add_pd(s01, AbsPd(_mm_loadu_pd(c)));
      s23 = _mm_add_pd(s23, AbsPd(_mm_loadu_pd(c + 2)));
      s45 = _mm_add_pd(s45, AbsPd(_mm_loadu_pd(c + 4)));
    }
    _mm_storeu_pd(column_sum, s01);
    _mm_storeu_pd(column_sum + 2, s23);
    _mm_storeu_pd(column_sum + 4, s45);
    return;
  }
#endif
  for (int j = 0; j < k; ++j)
#pragma GCC unroll 6
    for (int r = 0; r < N; ++r) column_sum[r] += std::abs(g[j][r]);
}

// sum + Σ_r |g_r| u_r, r in order.
template <int N>
double AddAbsDot(const double* g, const double* u, double sum) {
#pragma GCC unroll 6
  for (int r = 0; r < N; ++r) sum += std::abs(g[r]) * u[r];
  return sum;
}

// AddAbsDot<6>(g_a, u, sum) and AddAbsDot<6>(g_b, u, sum) into *out_a, *out_b: the two rows in the
// lanes of packed operations (each lane AddAbsDot's operations in its order, so the same bits).
inline void AddAbsDotPair6(const double* g_a, const double* g_b, const double* u, double sum,
                           double* out_a, double* out_b) {
#ifdef __SSE2__
  __m128d acc = _mm_set1_pd(sum);
#pragma GCC unroll 6
  for (int r = 0; r < 6; ++r)
    acc = _mm_add_pd(
        acc, _mm_mul_pd(AbsPd(_mm_loadh_pd(_mm_load_sd(g_a + r), g_b + r)), _mm_set1_pd(u[r])));
  _mm_storel_pd(out_a, acc);
  _mm_storeh_pd(out_b, acc);
#else
  *out_a = AddAbsDot<6>(g_a, u, sum);
  *out_b = AddAbsDot<6>(g_b, u, sum);
#endif
}

// Runs of N consecutive rows in a column's entries [p, end) (the assembly stores each body's
// ν block whole): true if [p, p + N) is one.
template <int N>
inline bool IsRun(const int* inner, int p, int end) {
  return p + N <= end && inner[p + N - 1] == inner[p] + (N - 1);
}

// *out = G x (assign) or *out += G x for a column-major G, as Eigen's `out.noalias() = G * x` /
// `+= G * x` forms it: zeroed (assign), then x_j · column j added in column order (each row of
// a column once, so the order within a column does not matter). With skip_zero, columns with
// x_j = 0 are skipped: the same bits for a finite G (a skipped term is ±0, added to a sum that
// is never −0). N: the ν block size (runs of N rows unrolled).
template <int N, bool kRuns>
void SparseTimesN(const SparseMatrixd& G, const double* x, bool skip_zero, double* o) {
  const int* outer = G.outerIndexPtr();
  const int* inner = G.innerIndexPtr();
  const double* value = G.valuePtr();
  const Eigen::Index cols = G.cols();
  for (Eigen::Index j = 0; j < cols; ++j) {
    if (skip_zero) {  // a run of x_j = 0 passed in a loop of its own
      while (j < cols && x[j] == 0.0) ++j;
      if (j == cols) break;
    }
    const double xj = x[j];
    const int end = outer[j + 1];
    for (int p = outer[j]; p < end;) {
      if (kRuns || IsRun<N>(inner, p, end)) {
        double* out = o + inner[p];
#pragma GCC unroll 6
        for (int i = 0; i < N; ++i) out[i] += value[p + i] * xj;
        p += N;
      } else {
        o[inner[p]] += value[p] * xj;
        ++p;
      }
    }
  }
}

// runs: every column of G is known to be whole runs of nvb rows (no test per run).
inline void SparseTimes(const SparseMatrixd& G, const double* x, bool assign, bool skip_zero,
                        int nvb, bool runs, VectorXd* out) {
  if (assign) out->setZero(G.rows());
  if (!G.isCompressed()) {
    const Eigen::Map<const VectorXd> xv(x, G.cols());
    out->noalias() += G * xv;
  } else if (nvb == 6) {
    if (runs)
      SparseTimesN<6, true>(G, x, skip_zero, out->data());
    else
      SparseTimesN<6, false>(G, x, skip_zero, out->data());
  } else {
    if (runs)
      SparseTimesN<3, true>(G, x, skip_zero, out->data());
    else
      SparseTimesN<3, false>(G, x, skip_zero, out->data());
  }
}

#ifdef __SSE2__
// The single-run path of SparseTransposeTimesN<6> for the leading columns that come in pairs of
// one body (the same first row r): columns j and j + 1 in the two lanes of packed operations,
// each lane the scalar path's operations in its order (tmp = 0, tmp += v_i x_{r+i} for i in
// order, then out_j = (assign ? 0 : out_j) + tmp), so the same bits; x_r..x_{r+5} broadcast once
// per run of one body (once in all if uniform_row ≥ 0: every column starts at that row). Returns
// the first column not done (the caller finishes from there).
// Columns j and j + 1 (six entries each, from `a`) dotted with x_r..x_{r+5} (broadcast in xr),
// into out[j], out[j + 1]: lane-wise tmp = 0, tmp += a_i x_i in order, out = (assign ? 0 :
// out) + tmp.
template <bool assign>
[[gnu::always_inline]] inline void TransposeTimesPair6(const double* a, const __m128d* xr,
                                                       double* out) {
  const double* b = a + 6;
  __m128d tmp = _mm_setzero_pd();
#pragma GCC unroll 6
  for (int i = 0; i < 6; ++i)
    tmp = _mm_add_pd(tmp, _mm_mul_pd(_mm_loadh_pd(_mm_load_sd(a + i), b + i), xr[i]));
  const __m128d base = assign ? _mm_setzero_pd() : _mm_loadu_pd(out);
  _mm_storeu_pd(out, _mm_add_pd(base, tmp));
}

template <bool assign>
inline int PairedTransposeTimes6(const int* inner, const double* value, const double* x, int cols,
                                 int uniform_row, double* out) {
  const auto column = [&](int j) { return value + 6 * static_cast<std::ptrdiff_t>(j); };
  const auto row = [&](int j) { return inner[6 * static_cast<std::ptrdiff_t>(j)]; };
  __m128d xr[6];
  int j = 0;
  if (uniform_row >= 0) {  // every column starts at row uniform_row: no test per pair
    for (int i = 0; i < 6; ++i) xr[i] = _mm_set1_pd(x[uniform_row + i]);
    for (; j + 1 < cols; j += 2) TransposeTimesPair6<assign>(column(j), xr, out + j);
    return j;
  }
  while (j + 1 < cols) {
    const int r = row(j);
    for (int i = 0; i < 6; ++i) xr[i] = _mm_set1_pd(x[r + i]);
    const int done = j;
    for (; j + 1 < cols && row(j) == r && row(j + 1) == r; j += 2)
      TransposeTimesPair6<assign>(column(j), xr, out + j);
    if (j == done) break;  // column j's body differs from column j + 1's: the scalar path
  }
  return j;
}
#endif

// out[j] = column j · x (assign) or out[j] += column j · x, as Eigen's
// `out.noalias() = G.transpose() * x` / `+=` forms it: each dot product summed from 0 over the
// column's entries in order, then added to out[j] (zeroed for assign). N as SparseTimesN.
template <int N, bool kRuns, bool assign>
void SparseTransposeTimesN(const SparseMatrixd& G, const double* x, bool single, int uniform_row,
                           double* out) {
  const int* outer = G.outerIndexPtr();
  const int* inner = G.innerIndexPtr();
  const double* value = G.valuePtr();
  if (kRuns && single) {
    // Every column is one run of N rows (column j at entries N j..N j+N−1): the same sums,
    // without the walk over each column's entries.
    const int cols = static_cast<int>(G.cols());
    int j = 0;
#ifdef __SSE2__
    if constexpr (N == 6)
      j = PairedTransposeTimes6<assign>(inner, value, x, cols, uniform_row, out);
#endif
    for (; j < cols; ++j) {
      const double* v = value + static_cast<std::ptrdiff_t>(N) * j;
      const double* xs = x + inner[static_cast<std::ptrdiff_t>(N) * j];
      double tmp = 0.0;
#pragma GCC unroll 6
      for (int i = 0; i < N; ++i) tmp += v[i] * xs[i];
      out[j] = (assign ? 0.0 : out[j]) + tmp;
    }
    return;
  }
  for (Eigen::Index j = 0; j < G.cols(); ++j) {
    double tmp = 0.0;
    const int end = outer[j + 1];
    for (int p = outer[j]; p < end;) {
      if (kRuns || IsRun<N>(inner, p, end)) {
        const double* xs = x + inner[p];
#pragma GCC unroll 6
        for (int i = 0; i < N; ++i) tmp += value[p + i] * xs[i];
        p += N;
      } else {
        tmp += value[p] * x[inner[p]];
        ++p;
      }
    }
    out[j] = (assign ? 0.0 : out[j]) + tmp;
  }
}

// SparseTransposeTimesN with `assign` chosen at run time.
template <int N, bool kRuns>
inline void SparseTransposeTimesNAssign(const SparseMatrixd& G, const double* x, bool assign,
                                        bool single, int uniform_row, double* out) {
  if (assign)
    SparseTransposeTimesN<N, kRuns, true>(G, x, single, uniform_row, out);
  else
    SparseTransposeTimesN<N, kRuns, false>(G, x, single, uniform_row, out);
}

// single: every column of G is one run of nvb rows (SingleRuns); uniform_row ≥ 0 (with single):
// every column's run starts at that row (RunPattern).
inline void SparseTransposeTimes(const SparseMatrixd& G, const VectorXd& x, bool assign, int nvb,
                                 bool runs, bool single, double* out, int uniform_row = -1) {
  if (!G.isCompressed()) {
    Eigen::Map<VectorXd> ov(out, G.cols());
    if (assign) ov.setZero();
    ov.noalias() += G.transpose() * x;
  } else if (nvb == 6) {
    (runs ? SparseTransposeTimesNAssign<6, true>
          : SparseTransposeTimesNAssign<6, false>)(G, x.data(), assign, single, uniform_row, out);
  } else {
    (runs ? SparseTransposeTimesNAssign<3, true>
          : SparseTransposeTimesNAssign<3, false>)(G, x.data(), assign, single, uniform_row, out);
  }
}

// Whether every column of a compressed G is one run of n consecutive rows (column j at entries
// n j..n j+n−1, rows inner[n j]..inner[n j]+n−1): SingleRuns and IsRun<n> for every column.
inline bool SingleWholeRuns(const SparseMatrixd& G, int n) {
  if (!G.isCompressed()) return false;
  const int* outer = G.outerIndexPtr();
  const int* inner = G.innerIndexPtr();
  const int cols = static_cast<int>(G.cols());
  if (outer[0] != 0) return false;
  for (int j = 0; j < cols; ++j)
    if (outer[j + 1] != n * (j + 1) || inner[n * j + n - 1] != inner[n * j] + (n - 1)) return false;
  return true;
}

}  // namespace vinci::sim::internal::sparse_lcp_kernels
