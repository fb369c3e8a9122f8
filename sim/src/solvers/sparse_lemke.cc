// Lemke's method on a sparse LCP matrix (sparse_lemke.h): the dense solver's pivoting rules
// (lemke_internal.h) on a product-form factorization of the basis.
#include "vinci/sim/solvers/sparse_lemke.h"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseLU>
#include <Eigen/SparseQR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "lemke_internal.h"
#include "solver_util.h"
#include "vinci/sim/solvers/lcp_acceptance.h"

namespace vinci::sim {
namespace {

using namespace internal::lemke;  // NOLINT(build/namespaces): the shared constants and helpers
using internal::FormatDouble;
using SpMat = Eigen::SparseMatrix<double>;

// Pivots between refactorizations of B_0 when options.refactor_interval is 0. Each eta factor
// adds O(nnz(d)) ≤ O(n) to a solve; a refactorization costs a sparse LU of the reduced basis.
constexpr int kDefaultRefactorInterval = 40;
// A pivot below this fraction of its column's largest entry is followed by a refactorization
// (the eta factor divides by it).
constexpr double kUnstablePivot = 1e-9;
// A warm basis's column of A(S, S) whose part outside the span of the columns kept before it
// is below this fraction of the largest column norm is dependent (StartBasisRepair).
constexpr double kDependentColumnTol = 1e-10;
// Rounds of StartBasisRepair (each drops at least one column).
constexpr int kRepairRounds = 4;
// The shifted retry (RunSparseLemke with shift): basic values in [−kShiftFeasibility·b, 0)
// (b = max(1, ‖q‖∞)) are set to 0 by a shift of q, and pivots below kShiftPivotFraction of the
// column's largest entry do not block (unless no other entry does). How the two values were
// chosen: bench/README.md, "Sparse Lemke: the shifted retry, step 24 of the gap-dropped pile".
constexpr double kShiftFeasibility = 1e-6;
constexpr double kShiftPivotFraction = 1e-7;
// Principal pivots of PolishTerminalBasis (each one sparse LU of the basis block).
constexpr int kPolishPivots = 32;
// The lexicographic rule reads rows of B⁻¹ (one transposed solve each) while at most this many
// rows are tied, columns of B⁻¹ (one solve each) while more are.
constexpr int kLexRowSolves = 16;

// w_i = i, z_i = n + i, z0 = 2n (as the dense solver).
// The basis B_0 E_1 ⋯ E_k. B_0's columns are e_i (w_i basic), −A_j (z_j basic), −cover (z0).
// Ordering the rows as (R, W) — R the rows whose w is nonbasic, W those whose w is basic — and
// the positions as (P, W's positions), B_0 = [K 0; B_WP I] with K = B_0(R, P) square. So
// B_0 x = a is K x_P = a_R, x_W = a_W − B_WP x_P, and B_0ᵀ y = v is y_W = v_W, Kᵀ y_R = v_P −
// B_WPᵀ y_W: one sparse LU of K (|R| = number of basic z and z0) serves both.
class SparseBasis {
 public:
  SparseBasis(const SpMat& A, const VectorXd& cover) : A_(A), cover_(cover), n_(A.rows()) {}

  // B_0 from the basis (variable per position); drops the eta factors. False if K is singular.
  bool Factor(const std::vector<int>& basis) {
    const int n = static_cast<int>(n_);
    etas_.clear();
    w_position_.assign(n, -1);
    other_position_.clear();
    other_var_.clear();
    for (int k = 0; k < n; ++k) {
      if (basis[k] < n) {
        w_position_[basis[k]] = k;
      } else {
        other_position_.push_back(k);
        other_var_.push_back(basis[k]);
      }
    }
    r_rows_.clear();
    r_index_.assign(n, -1);
    for (int i = 0; i < n; ++i) {
      if (w_position_[i] < 0) {
        r_index_[i] = static_cast<int>(r_rows_.size());
        r_rows_.push_back(i);
      }
    }
    const int m = static_cast<int>(r_rows_.size());
    if (m != static_cast<int>(other_var_.size())) return false;
    if (m == 0) return true;
    triplets_.clear();
    for (int t = 0; t < m; ++t) {
      const int var = other_var_[t];
      if (var < 2 * n) {
        for (SpMat::InnerIterator it(A_, var - n); it; ++it)
          if (const int ri = r_index_[it.row()]; ri >= 0)
            triplets_.emplace_back(ri, t, -it.value());
      } else {
        for (int i : r_rows_)
          if (cover_(i) != 0.0) triplets_.emplace_back(r_index_[i], t, -cover_(i));
      }
    }
    K_.resize(m, m);
    K_.setFromTriplets(triplets_.begin(), triplets_.end());
    K_.makeCompressed();
    lu_.analyzePattern(K_);
    lu_.factorize(K_);
    return lu_.info() == Eigen::Success;
  }

  // a (indexed by rows) ← B⁻¹ a (indexed by positions).
  void Solve(VectorXd* a) {
    const int m = static_cast<int>(r_rows_.size());
    VectorXd& v = *a;
    if (m > 0) {
      rhs_.resize(m);
      for (int t = 0; t < m; ++t) rhs_(t) = v(r_rows_[t]);
      sol_ = lu_.solve(rhs_);
      // Rows W: x_W = a_W − B_WP x_P (subtracting the P columns' entries everywhere, then
      // reading the W rows only).
      tmp_ = v;
      for (int t = 0; t < m; ++t) {
        const double u = sol_(t);
        if (u == 0.0) continue;
        const int var = other_var_[t];
        if (var < 2 * n_) {
          for (SpMat::InnerIterator it(A_, var - n_); it; ++it) tmp_(it.row()) += u * it.value();
        } else {
          tmp_ += u * cover_;
        }
      }
      for (Eigen::Index i = 0; i < n_; ++i)
        if (w_position_[i] >= 0) v(w_position_[i]) = tmp_(i);
      for (int t = 0; t < m; ++t) v(other_position_[t]) = sol_(t);
    } else {
      tmp_ = v;
      for (Eigen::Index i = 0; i < n_; ++i) v(w_position_[i]) = tmp_(i);
    }
    for (const Eta& e : etas_) {
      const double xr = v(e.row) / e.pivot;
      if (xr != 0.0)
        for (std::size_t s = 0; s < e.index.size(); ++s) v(e.index[s]) -= e.value[s] * xr;
      v(e.row) = xr;
    }
  }

  // *y (indexed by rows) = row `position` of B⁻¹.
  void Row(int position, VectorXd* y) {
    const int m = static_cast<int>(r_rows_.size());
    vpos_.setZero(n_);
    vpos_(position) = 1.0;
    for (auto e = etas_.rbegin(); e != etas_.rend(); ++e) {
      double s = 0.0;
      for (std::size_t k = 0; k < e->index.size(); ++k) s += vpos_(e->index[k]) * e->value[k];
      vpos_(e->row) = (vpos_(e->row) - s) / e->pivot;
    }
    y->setZero(n_);
    for (Eigen::Index i = 0; i < n_; ++i)
      if (w_position_[i] >= 0) (*y)(i) = vpos_(w_position_[i]);
    if (m == 0) return;
    rhs_.resize(m);
    for (int t = 0; t < m; ++t) {
      double r = vpos_(other_position_[t]);
      const int var = other_var_[t];
      // −B_WPᵀ y_W: B's column is −A_j or −cover; y is zero outside W here.
      if (var < 2 * n_) {
        for (SpMat::InnerIterator it(A_, var - n_); it; ++it) r += it.value() * (*y)(it.row());
      } else {
        r += cover_.dot(*y);
      }
      rhs_(t) = r;
    }
    sol_ = lu_.transpose().solve(rhs_);
    for (int t = 0; t < m; ++t) (*y)(r_rows_[t]) = sol_(t);
  }

  // E for a pivot on `row` with entering column d (basis coordinates).
  void AddEta(int row, const VectorXd& d) {
    Eta& e = etas_.emplace_back();
    e.row = row;
    e.pivot = d(row);
    for (Eigen::Index i = 0; i < n_; ++i) {
      if (i != row && d(i) != 0.0) {
        e.index.push_back(static_cast<int>(i));
        e.value.push_back(d(i));
      }
    }
  }
  int etas() const { return static_cast<int>(etas_.size()); }

 private:
  struct Eta {
    int row = 0;
    double pivot = 1.0;
    std::vector<int> index;  // nonzeros of d other than the pivot row
    std::vector<double> value;
  };
  const SpMat& A_;
  const VectorXd& cover_;
  Eigen::Index n_;
  std::vector<int> w_position_, other_position_, other_var_, r_rows_, r_index_;
  std::vector<Eigen::Triplet<double>> triplets_;
  SpMat K_;
  Eigen::SparseLU<SpMat, Eigen::COLAMDOrdering<int>> lu_;
  std::vector<Eta> etas_;
  VectorXd rhs_, sol_, tmp_, vpos_;
};

// A warm start's complementary basis {z_i : i ∈ S} ∪ {w_i : i ∉ S} is singular iff A(S, S) is.
// Contact LCPs give such bases readily: the loaded normals of a box resting on four others, or
// of two boxes that touch through eight corners, are linearly dependent, and a factorization
// of a numerically singular K returns basic values of 1e2 where the impulses are 1e-2 (and
// Lemke's first pivots, on entries of 1e17, destroy the eta file). StartBasisRepair makes the
// basis nonsingular while staying complementary: a rank-revealing sparse QR of A(S, S) (its
// columns in COLAMD order, each kept iff its part outside the span of the kept ones exceeds
// kDependentColumnTol of the largest column norm) gives dependent columns j, whose z_j leave for
// w_j; repeated while the principal block of the kept set is itself rank deficient (A need not
// be symmetric). Returns the number of z dropped (0: `basis` unchanged), or −1 if the rounds
// run out. The scratch is the caller's.
struct RepairScratch {
  std::vector<int> set, index;
  std::vector<Eigen::Triplet<double>> triplets;
  SpMat K;
  Eigen::SparseQR<SpMat, Eigen::COLAMDOrdering<int>> qr;
};

int StartBasisRepair(const SpMat& A, std::vector<int>* basis, RepairScratch* s) {
  const int n = static_cast<int>(A.rows());
  int dropped = 0;
  for (int round = 0; round < kRepairRounds; ++round) {
    s->set.clear();
    s->index.assign(n, -1);
    for (int i = 0; i < n; ++i) {
      if ((*basis)[i] == n + i) {
        s->index[i] = static_cast<int>(s->set.size());
        s->set.push_back(i);
      }
    }
    const int m = static_cast<int>(s->set.size());
    if (m == 0) return dropped;
    s->triplets.clear();
    double max_norm = 0.0;
    for (int t = 0; t < m; ++t) {
      double norm2 = 0.0;
      for (SpMat::InnerIterator it(A, s->set[t]); it; ++it) {
        if (const int ri = s->index[it.row()]; ri >= 0) {
          s->triplets.emplace_back(ri, t, it.value());
          norm2 += it.value() * it.value();
        }
      }
      max_norm = std::max(max_norm, std::sqrt(norm2));
    }
    s->K.resize(m, m);
    s->K.setFromTriplets(s->triplets.begin(), s->triplets.end());
    s->K.makeCompressed();
    s->qr.setPivotThreshold(kDependentColumnTol * max_norm);
    s->qr.compute(s->K);
    if (s->qr.info() != Eigen::Success) return -1;
    const int rank = static_cast<int>(s->qr.rank());
    if (rank == m) return dropped;
    // K P = Q R with the rank-deficient columns last: P's entries past the rank.
    const auto& perm = s->qr.colsPermutation().indices();
    for (int k = rank; k < m; ++k) {
      const int i = s->set[perm(k)];
      (*basis)[i] = i;
      ++dropped;
    }
  }
  return -1;
}

struct CoreOutcome {
  SolverStatus status = SolverStatus::kNumericalFailure;
  int pivots = 0;
  std::string message;
  double z0 = 0.0;
  double z0_initial = 0.0;
  std::vector<int> terminal;  // the complementary basis z0 left (kSolved after pivots)
};

// LcpResidual of z for LCP(A, q) with w = A z + q into *w, NaN-safe.
double SparseResidual(const SpMat& A, const VectorXd& q, const VectorXd& z, VectorXd* w) {
  *w = q;
  w->noalias() += A * z;
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isnan(z(i)) || std::isnan((*w)(i))) return kInf;
    r = std::max(r, std::abs(std::min(z(i), (*w)(i))));
  }
  return r;
}

// Lemke on LCP(A, q) from the complementary basis `basis` with covering vector `cover` (B·1 for
// that basis). kSolved means z0 left the basis (or the start basis is feasible).
//
// With `shift` (the retry after a failed run), the path is kept feasible by a bounded
// perturbation of q: a leaving row whose basic value is slightly negative (roundoff on a
// degenerate row; its ratio x_r/d_r would be a large negative step when d_r is noise) and any
// basic value that ends within kShiftFeasibility·b below 0 are set to 0, q_shift += δ·B e_r
// recording it so that refactorizations (x = B⁻¹ q_shift) keep it; entries of d below
// kShiftPivotFraction·‖d‖∞ do not block. The terminal basis is then refined on the true q.
CoreOutcome RunSparseLemke(const SpMat& A, const VectorXd& q, const VectorXd& cover,
                           std::vector<int> basis, const LemkeOptions& options_in, bool shift,
                           VectorXd* z) {
  const int n = static_cast<int>(q.size());
  LemkeOptions options = options_in;
  if (shift) options.pivot_tolerance = std::max(options.pivot_tolerance, kShiftPivotFraction);
  VectorXd q_shift = q;
  const double tau_shift = kShiftFeasibility * std::max(1.0, q.lpNorm<Eigen::Infinity>());
  // q_shift += δ · (B's column at position k), x_k += δ.
  auto shift_row = [&](VectorXd* xv, int k) {
    const double delta = -(*xv)(k);
    const int var = basis[k];
    if (var < n) {
      q_shift(var) += delta;
    } else if (var < 2 * n) {
      for (SpMat::InnerIterator it(A, var - n); it; ++it) q_shift(it.row()) -= delta * it.value();
    } else {
      q_shift -= delta * cover;
    }
    (*xv)(k) = 0.0;
  };
  auto shift_small_negatives = [&](VectorXd* xv) {
    for (int k = 0; k < n; ++k)
      if ((*xv)(k) < 0.0 && (*xv)(k) >= -tau_shift) shift_row(xv, k);
  };
  const int kZ0 = 2 * n;
  const int max_pivots = options.max_pivots > 0 ? options.max_pivots : 50 * n + 100;
  const int refactor_interval =
      options.refactor_interval > 0 ? options.refactor_interval : kDefaultRefactorInterval;
  auto complement = [n](int var) { return var < n ? var + n : var - n; };
  CoreOutcome out;
  VectorXd x = q, d(n), a(n);
  auto extract_z = [&]() {
    z->setZero(n);
    for (int k = 0; k < n; ++k)
      if (basis[k] >= n && basis[k] < kZ0) (*z)(basis[k] - n) = std::max(x(k), 0.0);
  };
  auto fail = [&](SolverStatus status, std::string message) {
    extract_z();
    for (int k = 0; k < n; ++k)
      if (basis[k] == kZ0) out.z0 = std::max(x(k), 0.0);
    out.status = status;
    out.message = std::move(message);
    return out;
  };
  SparseBasis B(A, cover);
  if (!B.Factor(basis)) return fail(SolverStatus::kNumericalFailure, "singular start basis");
  B.Solve(&x);
  if (!x.allFinite()) return fail(SolverStatus::kNumericalFailure, "non-finite start basis");
  // Absolute tolerance on basic values for the ratio ties (see kRatioTieTolerance); a start
  // basis whose values are all above −tau_x is feasible (a degenerate w_i computed as −1e-17).
  const double tau_x = kRatioTieTolerance * std::max(1.0, q.lpNorm<Eigen::Infinity>());
  if (x.minCoeff() >= -tau_x) {
    extract_z();
    out.status = SolverStatus::kSolved;
    return out;
  }

  std::vector<int> ties, kept;
  // Rows of B⁻¹ computed for the lexicographic rule at this pivot, and the last column.
  std::vector<std::pair<int, VectorXd>> rows;
  VectorXd column(n);
  int column_k = -1;
  auto row_of = [&](int i) -> const VectorXd* {
    for (const auto& [position, row] : rows)
      if (position == i) return &row;
    return nullptr;
  };
  auto prepare = [&](const std::vector<int>& tied, int k) {
    if (static_cast<int>(tied.size()) <= kLexRowSolves) {
      for (int i : tied) {
        if (row_of(i) != nullptr) continue;
        rows.emplace_back(i, VectorXd());
        B.Row(i, &rows.back().second);
      }
    } else if (column_k != k) {
      column.setZero(n);
      column(k) = 1.0;
      B.Solve(&column);
      column_k = k;
    }
  };
  auto binv_at = [&](int i, int k) {
    const VectorXd* row = row_of(i);
    return row != nullptr ? (*row)(k) : column(i);
  };
  auto pivot = [&](int r, int entering) {
    if (shift && x(r) < 0.0 && x(r) >= -tau_shift) shift_row(&x, r);
    B.AddEta(r, d);
    const double xr = x(r) / d(r);
    x -= xr * d;
    x(r) = xr;
    const int leaving = basis[r];
    basis[r] = entering;
    if (shift) shift_small_negatives(&x);
    return leaving;
  };

  // Initial pivot: z0 enters (d = B⁻¹(−cover) = −1) in the row of the most negative x_i, the
  // largest index among ties.
  const double x_min = x.minCoeff();
  const double tau = kRatioTieTolerance * std::max(1.0, std::abs(x_min));
  int r = 0;
  for (int i = 0; i < n; ++i)
    if (x(i) <= x_min + tau) r = i;
  d.setConstant(-1.0);
  out.z0_initial = -x_min;
  int leaving = pivot(r, kZ0);
  out.pivots = 1;
  int entering = complement(leaving);
  while (true) {
    if (out.pivots >= max_pivots)
      return fail(SolverStatus::kMaxIterations,
                  "Lemke reached the pivot limit " + std::to_string(max_pivots));
    // d = B⁻¹ a, a = e_i (w_i) or −A_j (z_j).
    d.setZero();
    if (entering < n) {
      d(entering) = 1.0;
    } else {
      for (SpMat::InnerIterator it(A, entering - n); it; ++it) d(it.row()) = -it.value();
    }
    B.Solve(&d);
    if (!d.allFinite())
      return fail(SolverStatus::kNumericalFailure,
                  "non-finite pivot column at pivot " + std::to_string(out.pivots));
    rows.clear();
    column_k = -1;
    r = ChooseLeavingRow(x, d, basis, kZ0, tau_x, options, &ties, &kept, binv_at, prepare);
    if (r < 0 && shift) {  // only noise-level entries block: the plain ratio test
      rows.clear();
      column_k = -1;
      r = ChooseLeavingRow(x, d, basis, kZ0, tau_x, options_in, &ties, &kept, binv_at, prepare);
    }
    if (r < 0)
      return fail(SolverStatus::kSecondaryRay, "Lemke terminated on a secondary ray at pivot " +
                                                   std::to_string(out.pivots) +
                                                   "; the LCP may be infeasible");
    const bool unstable = std::abs(d(r)) < kUnstablePivot * d.cwiseAbs().maxCoeff();
    leaving = pivot(r, entering);
    ++out.pivots;
    if (!std::isfinite(x(r)))
      return fail(SolverStatus::kNumericalFailure,
                  "non-finite basic value at pivot " + std::to_string(out.pivots));
    if (leaving == kZ0) break;
    entering = complement(leaving);
    if (unstable || B.etas() >= refactor_interval) {
      if (!B.Factor(basis))
        return fail(SolverStatus::kNumericalFailure,
                    "singular basis at refactorization after pivot " + std::to_string(out.pivots));
      x = q_shift;
      B.Solve(&x);
      if (shift) shift_small_negatives(&x);
      if (!x.allFinite())
        return fail(SolverStatus::kNumericalFailure,
                    "non-finite basic values after pivot " + std::to_string(out.pivots));
    }
  }

  // z0 left: iterative refinement of B x = q, keeping a step only if the residual improves.
  extract_z();
  VectorXd w, z_raw(n), w_raw(n), eq(n), z_try(n);
  double best = SparseResidual(A, q, *z, &w);
  const double refine_below = kRefineBelow * std::max(1.0, q.lpNorm<Eigen::Infinity>());
  for (int step = 0; step < kRefinementSteps && best > refine_below; ++step) {
    z_raw.setZero();
    w_raw.setZero();
    for (int k = 0; k < n; ++k) {
      if (basis[k] < n) {
        w_raw(basis[k]) = x(k);
      } else if (basis[k] < kZ0) {
        z_raw(basis[k] - n) = x(k);
      }
    }
    eq = q - w_raw;
    eq.noalias() += A * z_raw;
    B.Solve(&eq);
    x += eq;
    z_try.setZero();
    for (int k = 0; k < n; ++k)
      if (basis[k] >= n && basis[k] < kZ0) z_try(basis[k] - n) = std::max(x(k), 0.0);
    const double res = SparseResidual(A, q, z_try, &w);
    if (!(res < best)) break;
    best = res;
    z->swap(z_try);
  }
  out.status = SolverStatus::kSolved;
  out.terminal = basis;
  return out;
}

// A terminal basis that misses the tolerance on degenerate rows: Lemke's ties (ratios within
// the tie tolerance, and z0 leaving at the end) leave basic values of the order of the tie
// tolerance times |d_i| below 0 (−2e-8 on the 100-box pile, whose pivot columns reach 4e6).
// Principal pivots from it: the most negative basic value's variable leaves for its
// complement (w_i ↔ z_i), the basis refactored and B x = q solved with one refinement step,
// up to kPolishPivots times or until no value is below −tau_x; *z is the iterate (z = max(x, 0)
// on the basic z) with the smallest LcpResidual. Stops at a singular basis. Returns the number
// of principal pivots taken before the best iterate (−1: the terminal basis is singular).
int PolishTerminalBasis(const SpMat& A, const VectorXd& q, std::vector<int> basis, double tau_x,
                        VectorXd* z) {
  const int n = static_cast<int>(q.size());
  const VectorXd cover = VectorXd::Zero(n);  // no z0 in a terminal basis
  SparseBasis B(A, cover);
  VectorXd x(n), e(n), z_raw(n), w_raw(n), candidate(n), w;
  double best = kInf;
  int best_pivots = -1;
  for (int pivots = 0; pivots <= kPolishPivots; ++pivots) {
    if (!B.Factor(basis)) break;
    x = q;
    B.Solve(&x);
    z_raw.setZero();
    w_raw.setZero();
    for (int k = 0; k < n; ++k) (basis[k] < n ? w_raw(basis[k]) : z_raw(basis[k] - n)) = x(k);
    e = q - w_raw;
    e.noalias() += A * z_raw;
    B.Solve(&e);
    x += e;
    candidate.setZero();
    for (int k = 0; k < n; ++k)
      if (basis[k] >= n) candidate(basis[k] - n) = std::max(x(k), 0.0);
    const double residual = SparseResidual(A, q, candidate, &w);
    if (residual < best) {
      best = residual;
      best_pivots = pivots;
      *z = candidate;
    }
    int k = 0;
    if (!(x.minCoeff(&k) < -tau_x)) break;
    basis[k] = basis[k] < n ? basis[k] + n : basis[k] - n;
  }
  return best_pivots;
}

// Row and column maxima of |A| d_i d_j over the nonzeros; the dense SymmetricScaling's sweeps.
void SparseSymmetricScaling(const SpMat& M, VectorXd* scale) {
  const Eigen::Index n = M.rows();
  VectorXd& d = *scale;
  d.setOnes(n);
  VectorXd row_max(n), col_max(n), s(n);
  for (int sweep = 0; sweep < kScalingSweeps; ++sweep) {
    row_max.setZero();
    col_max.setZero();
    for (Eigen::Index j = 0; j < n; ++j) {
      for (SpMat::InnerIterator it(M, j); it; ++it) {
        const double v = std::abs(it.value()) * (d(it.row()) * d(j));
        col_max(j) = std::max(col_max(j), v);
        row_max(it.row()) = std::max(row_max(it.row()), v);
      }
    }
    bool changed = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double m = std::max(row_max(i), col_max(i));
      int k = 0;
      if (m > 0.0 && std::isfinite(m)) k = MinusTruncHalfLog2(m);
      s(i) = PowerOfTwo(k);
      changed = changed || k != 0;
    }
    if (!changed) break;
    d.array() *= s.array();
  }
}

}  // namespace

double SparseLcpScaledResidual(const SpMat& M, const VectorXd& q, const VectorXd& z) {
  const Eigen::Index n = q.size();
  if (M.rows() != n || M.cols() != n || z.size() != n)
    return std::numeric_limits<double>::quiet_NaN();
  if (n == 0) return 0.0;
  if (!z.allFinite()) return kInf;
  VectorXd w = q, terms = q.cwiseAbs(), norms = VectorXd::Zero(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double zj = z(j);
    for (SpMat::InnerIterator it(M, j); it; ++it) {
      w(it.row()) += it.value() * zj;
      norms(it.row()) += std::abs(it.value());
      terms(it.row()) += std::abs(it.value()) * std::abs(zj);
    }
  }
  return internal::ScaledNaturalResidual(z, w, nullptr, nullptr, terms, norms,
                                         q.lpNorm<Eigen::Infinity>());
}

SolverReport SolveSparseLemke(const SpMat& M, const VectorXd& q, const VectorXd* warm_start,
                              const LemkeOptions& options, VectorXd* z) {
  if (z == nullptr) throw std::invalid_argument("SolveSparseLemke: z is null; expected a vector");
  ValidateOptions(options);
  const auto start = std::chrono::steady_clock::now();
  SolverReport report;
  auto finish = [&]() {
    report.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
  };
  const Eigen::Index n = q.size();
  z->setZero(n);
  // Finiteness and ‖M‖∞ in one pass over the nonzeros.
  VectorXd row_sum = VectorXd::Zero(n);
  bool valid = M.rows() == n && M.cols() == n && q.allFinite();
  if (valid) {
    for (Eigen::Index j = 0; j < n; ++j)
      for (SpMat::InnerIterator it(M, j); it; ++it) {
        valid = valid && std::isfinite(it.value());
        row_sum(it.row()) += std::abs(it.value());
      }
  }
  if (!valid) {
    report.status = SolverStatus::kInvalidInput;
    report.residual = std::numeric_limits<double>::quiet_NaN();
    report.message =
        "SolveSparseLemke: M must be n x n and M, q finite (n = " + std::to_string(n) + ")";
    return finish();
  }
  if (n == 0 || q.minCoeff() >= 0.0) {
    report.status = SolverStatus::kSolved;
    report.tolerance = options.residual_tolerance;
    return finish();
  }
  Acceptance acceptance;
  acceptance.rtol = options.residual_tolerance;
  acceptance.q_norm = q.lpNorm<Eigen::Infinity>();
  acceptance.m_norm = row_sum.maxCoeff();
  if (!std::isfinite(acceptance.m_norm)) {
    report.status = SolverStatus::kNumericalFailure;
    report.message = "the row sums of |M| overflow";
    return finish();
  }

  // The pivoted problem A = D M D, D q (D = I without scaling).
  VectorXd scale = VectorXd::Ones(n);
  if (options.scale) SparseSymmetricScaling(M, &scale);
  const bool scaled = (scale.array() != 1.0).any();
  SpMat A = M;
  VectorXd qs = q;
  if (scaled) {
    for (Eigen::Index j = 0; j < n; ++j)
      for (SpMat::InnerIterator it(A, j); it; ++it)
        it.valueRef() = it.value() * (scale(it.row()) * scale(j));
    qs.array() *= scale.array();
  }

  // One run from `basis` (variables per position) with its covering vector; true if z passes.
  VectorXd cover(n), candidate, w;
  std::string first_message;
  RepairScratch repair;
  // The terminal bases of terminated runs that failed the tests, with their labels.
  std::vector<std::pair<std::vector<int>, const char*>> terminals;
  // True with *z and the report if `zc` (unscaled) passes both tests.
  auto accept = [&](VectorXd& zc, double residual, double tolerance, const std::string& message) {
    if (!(std::isfinite(residual) && residual <= tolerance &&
          SparseLcpScaledResidual(M, q, zc) <= kLcpAcceptanceTolerance))
      return false;
    z->swap(zc);
    report.status = SolverStatus::kSolved;
    report.residual = residual;
    report.tolerance = tolerance;
    report.message = message;
    return true;
  };
  auto run = [&](std::vector<int>& basis, const char* label, bool shift) {
    // (A basis the rounds did not repair is run as it is: its factorization decides.)
    StartBasisRepair(A, &basis, &repair);
    cover.setZero();
    for (Eigen::Index k = 0; k < n; ++k) {
      if (basis[k] < n) {
        cover(basis[k]) += 1.0;
      } else {
        for (SpMat::InnerIterator it(A, basis[k] - n); it; ++it) cover(it.row()) -= it.value();
      }
    }
    const CoreOutcome core = RunSparseLemke(A, qs, cover, basis, options, shift, &candidate);
    report.iterations += core.pivots;
    if (scaled) candidate.array() *= scale.array();
    const double residual = OrInf(SparseResidual(M, q, candidate, &w));
    const double tolerance = acceptance.For(candidate);
    bool terminated = core.status == SolverStatus::kSolved;
    std::string message = core.message;
    if (core.status == SolverStatus::kSecondaryRay) {
      const double z0 = scaled ? core.z0 / scale.minCoeff() : core.z0;
      if (core.z0 <= kSecondaryRayZ0Fraction * core.z0_initial && z0 <= tolerance) {
        terminated = true;
        message = "accepted the secondary-ray iterate with z0 = " + FormatDouble(z0);
      }
    }
    if (terminated && accept(candidate, residual, tolerance, message)) return true;
    if (!core.terminal.empty()) terminals.emplace_back(core.terminal, label);
    // On failure the report and z are those of the run with the smaller residual (a caller may
    // polish that iterate's basis).
    if (first_message.empty() || OrInf(residual) < OrInf(report.residual)) {
      report.status = terminated ? SolverStatus::kNumericalFailure : core.status;
      report.residual = residual;
      report.tolerance = tolerance;
      *z = candidate;
    }
    first_message += std::string(first_message.empty() ? "" : "; ") + label + ": " +
                     (terminated ? "terminated with residual " + FormatDouble(residual) +
                                       " (tolerance " + FormatDouble(tolerance) + ")"
                                 : message);
    return false;
  };

  std::vector<int> basis(n);
  const bool warm_run = warm_start != nullptr && warm_start->size() == n &&
                        warm_start->allFinite() && (warm_start->array() > 0.0).any();
  if (warm_start != nullptr && warm_start->size() == n && warm_start->allFinite() &&
      (warm_start->array() > 0.0).any()) {
    for (Eigen::Index i = 0; i < n; ++i)
      basis[i] = static_cast<int>((*warm_start)(i) > 0.0 ? n + i : i);
    if (run(basis, "from the warm-start basis", false)) {
      report.message = "pivoted from the warm-start basis" +
                       (report.message.empty() ? "" : " (" + report.message + ")");
      return finish();
    }
    // The same (repaired) basis again, the path kept feasible by shifts of q.
    if (run(basis, "shifted from the warm-start basis", true)) {
      report.message = "pivoted from the warm-start basis with shifts of q" +
                       (report.message.empty() ? "" : " (" + report.message + ")");
      return finish();
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) basis[i] = static_cast<int>(i);
  if (run(basis, "cold", false)) return finish();
  if (!warm_run) {  // without a warm start, the shifted retry from the cold basis
    for (Eigen::Index i = 0; i < n; ++i) basis[i] = static_cast<int>(i);
    if (run(basis, "shifted cold", true)) {
      report.message =
          "cold with shifts of q" + (report.message.empty() ? "" : " (" + report.message + ")");
      return finish();
    }
  }
  // Every run failed: principal pivots from the terminal bases (PolishTerminalBasis), in run
  // order. Runs that pass are never polished, so their results are unchanged.
  const double tau_x = kRatioTieTolerance * std::max(1.0, qs.lpNorm<Eigen::Infinity>());
  for (const auto& [terminal, label] : terminals) {
    const int pivots = PolishTerminalBasis(A, qs, terminal, tau_x, &candidate);
    if (pivots < 0) continue;
    report.iterations += pivots;
    if (scaled) candidate.array() *= scale.array();
    const double residual = OrInf(SparseResidual(M, q, candidate, &w));
    if (accept(candidate, residual, acceptance.For(candidate),
               std::to_string(pivots) + " principal pivots from the terminal basis (" + label +
                   "; " + first_message + ")"))
      return finish();
  }
  report.message = "sparse Lemke failed (" + first_message + ")";
  return finish();
}

}  // namespace vinci::sim
