// Lemke's complementary pivoting method with covering vector e (Cottle, Pang & Stone, The
// Linear Complementarity Problem, 1992, §4.4), in revised form: the system
//
//   w − M z − e z0 = q,   w, z, z0 ≥ 0,   wᵀz = 0,
//
// is pivoted on an explicit basis inverse B⁻¹ kept up to date by rank-1 updates (O(n·t) per
// pivot, t ≤ n the columns of B⁻¹ that differ from the identity, see RunLemke) and recomputed
// from an LU factorization every `refactor_interval` pivots. The
// lexicographic ratio test on the rows of [B⁻¹q, B⁻¹] is the perturbation q + (ε, ε², …)
// and makes the pivot choice unique, so the method cannot cycle.
#include "vinci/sim/solvers/lemke.h"

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "lemke_internal.h"
#include "solver_util.h"
#include "vinci/sim/solvers/fischer_burmeister.h"
#include "vinci/sim/solvers/lcp_acceptance.h"

namespace vinci::sim {
namespace {

using namespace internal::lemke;  // NOLINT(build/namespaces): the shared constants and helpers

// Retry factors applied to options.regularization.
constexpr double kRegularizationFactors[] = {1.0, 1e3, 1e6};

using internal::FormatDouble;

// Scratch memory of one solve, reused across solves on the same thread: a cold solve of a
// one-box contact LCP (n = 24, 4 pivots) takes a few µs, of which ~20 small heap allocations
// took a noticeable share. Solve is const and runs concurrently on several threads (field
// computations), hence one workspace per thread (WorkspaceLease); a nested solve on a thread
// whose workspace is in use gets a fresh one. The per-thread workspace keeps the memory of the
// largest LCP solved on its thread (8n² bytes for the basis inverse, 2 MB at n = 500; 24n²
// once a refactorization ran).
struct Workspace {
  // Basis inverse B⁻¹ (n×n). Only the columns flagged in `touched` are stored: an untouched
  // column c is the unit vector e_c of the initial basis B = I (see RunLemke).
  MatrixXd binv;
  std::vector<char> touched;
  std::vector<int> touched_cols;
  MatrixXd bmat;  // basis matrix, for the refactorization
  Eigen::PartialPivLU<MatrixXd> lu;
  VectorXd x, d, col, acc, w, z_raw, w_raw, eq_residual, z_try;
  VectorXd q;                                   // q of the pivoted (scaled) problem
  VectorXd scale, step, row_max, col_max, tmp;  // equilibration
  std::vector<int> basis, ties, kept;
  // The storage of the last solve's output vector, handed to the next solve's first attempt
  // (Solve swaps the caller's previous z buffer in here), so a steady solve allocates no z.
  VectorXd spare_z;
  bool busy = false;
};

class WorkspaceLease {
 public:
  WorkspaceLease() {
    thread_local Workspace per_thread;
    if (per_thread.busy) {
      own_ = std::make_unique<Workspace>();
      ws_ = own_.get();
    } else {
      ws_ = &per_thread;
    }
    ws_->busy = true;
  }
  ~WorkspaceLease() { ws_->busy = false; }
  WorkspaceLease(const WorkspaceLease&) = delete;
  WorkspaceLease& operator=(const WorkspaceLease&) = delete;
  Workspace& get() { return *ws_; }

 private:
  Workspace* ws_ = nullptr;
  std::unique_ptr<Workspace> own_;
};

// Column blocks of Eigen 3.4's dense matrix–vector product y += B v (n×n B, column major): it
// sums the columns of each block in increasing order, starting from 0, and adds the block's
// sum to y. The sparse products below (skipping zero terms, which are exact) sum in the same
// order, so that they give the same bits as the dense products they replace (up to the sign
// of zero): the pivot sequence does not depend on which of the two computed a column.
Eigen::Index GemvBlock(Eigen::Index n) {
  return n < 128 ? n : (n * static_cast<Eigen::Index>(sizeof(double)) < 32000 ? 16 : 4);
}

// The matrix pivoted on, A = D (M + εI) D with D = diag(scale) (scale null: D = I), evaluated
// column by column instead of being copied. Each entry is the product an explicit copy would
// hold, (M_ij + ε δ_ij) · (s_i s_j), exact for power-of-two s.
struct PivotMatrix {
  const MatrixXd* M = nullptr;
  double epsilon = 0.0;
  const VectorXd* scale = nullptr;

  // out = column j of A.
  void Column(Eigen::Index j, VectorXd* out) const {
    *out = M->col(j);
    if (epsilon > 0.0) (*out)(j) += epsilon;
    if (scale != nullptr) {
      const double s_j = (*scale)(j);
      out->array() *= scale->array() * s_j;
    }
  }
  // out = A z, reading only the columns j with z_j ≠ 0 (z is mostly zero: nonbasic z).
  void Multiply(const VectorXd& z, VectorXd* out, VectorXd* col, VectorXd* acc) const {
    const Eigen::Index n = z.size();
    const Eigen::Index block = GemvBlock(n);
    out->setZero(n);
    for (Eigen::Index j0 = 0; j0 < n; j0 += block) {
      acc->setZero(n);
      bool any = false;
      for (Eigen::Index j = j0; j < std::min(n, j0 + block); ++j) {
        if (z(j) != 0.0) {
          Column(j, col);
          *acc += z(j) * *col;
          any = true;
        }
      }
      if (any) *out += *acc;
    }
  }
};

// One pass over M: false if M has a NaN or ±inf (or a row sum overflows); ‖M‖∞ = max_i Σ_j |M_ij|
// in *m_norm. (The row and column maxima of |M| for the equilibration are left to
// SymmetricScaling, which only the cold path needs: a warm-started step reads M once here.)
bool ScanMatrix(const MatrixXd& M, Workspace* ws, double* m_norm) {
  const Eigen::Index n = M.rows();
  // Row sums of |M| in the order of Eigen 3.4's vectorized M.cwiseAbs().rowwise().sum() (the
  // previous ‖M‖∞): column 0, then groups of four columns summed pairwise, then one by one.
  VectorXd& sum = ws->tmp;
  sum.setZero(n);
  if (n > 0) sum = M.col(0).cwiseAbs();
  const Eigen::Index size4 = (n - 1) & ~Eigen::Index{3};
  Eigen::Index j = 1;
  for (; j < size4; j += 4) {
    sum += (M.col(j).cwiseAbs() + M.col(j + 1).cwiseAbs()) +
           (M.col(j + 2).cwiseAbs() + M.col(j + 3).cwiseAbs());
  }
  for (; j < n; ++j) sum += M.col(j).cwiseAbs();
  *m_norm = n > 0 ? sum.maxCoeff() : 0.0;
  // A NaN or ±inf entry makes its row sum NaN or +inf (the terms are ≥ 0).
  return sum.allFinite();
}

// Power-of-two diagonal D (in ws->scale) such that D A D, A = M + εI, has each row and column
// max-abs within a factor of about 4 of 1 (where A has a nonzero there). Symmetric, so
// copositivity / PSD of A and with it Lemke's termination guarantee are preserved; powers of
// two make the scaling exact. Each sweep reads A once: the maxima of |A_ij| d_i d_j, exact in
// floating point since d is a power of two.
void SymmetricScaling(const MatrixXd& M, double epsilon, Workspace* ws) {
  const Eigen::Index n = M.rows();
  VectorXd& d = ws->scale;
  VectorXd& s = ws->step;
  d.setOnes(n);
  s.resize(n);
  ws->row_max.resize(n);
  ws->col_max.resize(n);
  for (int sweep = 0; sweep < kScalingSweeps; ++sweep) {
    {
      // Row and column maxima in one column-major pass.
      ws->row_max.setZero();
      for (Eigen::Index j = 0; j < n; ++j) {
        if (epsilon > 0.0) {
          ws->tmp = M.col(j).cwiseAbs();
          ws->tmp(j) = std::abs(M(j, j) + epsilon);
          ws->tmp.array() *= d.array() * d(j);
          ws->col_max(j) = ws->tmp.maxCoeff();
          ws->row_max = ws->row_max.cwiseMax(ws->tmp);
        } else {
          const auto a_j = M.col(j).array().abs() * (d.array() * d(j));  // not materialized
          ws->col_max(j) = a_j.maxCoeff();
          ws->row_max = ws->row_max.array().max(a_j).matrix();
        }
      }
    }
    bool changed = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double m = std::max(ws->row_max(i), ws->col_max(i));
      int k = 0;
      if (m > 0.0 && std::isfinite(m)) k = MinusTruncHalfLog2(m);
      s(i) = PowerOfTwo(k);
      changed = changed || k != 0;
    }
    if (!changed) break;
    d.array() *= s.array();
  }
}

struct CoreOutcome {
  SolverStatus status = SolverStatus::kNumericalFailure;
  int pivots = 0;
  std::string message;
  double z0 = 0.0;  // value of the artificial variable z0 in the final iterate (0 if nonbasic)
  double z0_initial = 0.0;  // its value after the initial pivot, −min q
};

// ‖min(z, Az + q)‖_∞ on the problem being pivoted (possibly scaled), NaN-safe.
double ScaledResidual(const PivotMatrix& A, const VectorXd& q, const VectorXd& z, VectorXd* w,
                      VectorXd* col, VectorXd* acc) {
  A.Multiply(z, w, col, acc);
  *w += q;
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isnan(z(i)) || std::isnan((*w)(i))) return kInf;
    r = std::max(r, std::abs(std::min(z(i), (*w)(i))));
  }
  return r;
}

// Lemke's method on LCP(A, q), q not ≥ 0. Writes the z part of the final iterate (clamped to
// ≥ 0) into *z. kSolved here means only that z0 left the basis.
//
// The basis inverse starts as B⁻¹ = I, and a pivot on row r changes only the columns c of B⁻¹
// with B⁻¹_rc ≠ 0 (the update is B⁻¹ −= d (B⁻¹_r· / d_r), then row r = B⁻¹_r· / d_r). So the
// columns never touched by a pivot are still e_c: they are neither stored nor updated, and the
// products with B⁻¹ run over the touched columns only. A solve with p pivots costs O(n·p²)
// instead of O(n²·p) (a one-box LCP: n = 24, p = 4), with the same arithmetic on the touched
// columns; a refactorization makes every column touched.
CoreOutcome RunLemke(const PivotMatrix& A, const VectorXd& q, const LemkeOptions& options,
                     Workspace* ws, VectorXd* z) {
  const int n = static_cast<int>(q.size());
  const int max_pivots = options.max_pivots > 0 ? options.max_pivots : 50 * n + 100;
  const int refactor_interval =
      options.refactor_interval > 0 ? options.refactor_interval : std::max(50, n);
  // Variables: w_i = i, z_i = n + i, z0 = 2n.
  const int kZ0 = 2 * n;
  auto complement = [n](int var) { return var < n ? var + n : var - n; };

  std::vector<int>& basis = ws->basis;  // variable basic in each row
  basis.resize(n);
  for (int i = 0; i < n; ++i) basis[i] = i;
  std::vector<int>& ties = ws->ties;
  std::vector<int>& kept = ws->kept;
  ties.clear();
  kept.clear();
  ties.reserve(n);
  kept.reserve(n);
  MatrixXd& binv = ws->binv;
  if (binv.rows() != n || binv.cols() != n) binv.resize(n, n);
  std::vector<char>& touched = ws->touched;
  std::vector<int>& touched_cols = ws->touched_cols;
  touched.assign(n, 0);
  touched_cols.clear();
  touched_cols.reserve(n);
  VectorXd& x = ws->x;  // values of the basic variables
  x = q;
  VectorXd& d = ws->d;
  VectorXd& col = ws->col;
  VectorXd& acc = ws->acc;
  d.resize(n);
  col.resize(n);

  // Entry (i, k) of B⁻¹.
  auto binv_at = [&](int i, int k) { return touched[k] ? binv(i, k) : (i == k ? 1.0 : 0.0); };
  auto touch = [&](int c) {
    if (touched[c]) return;
    touched[c] = 1;
    touched_cols.push_back(c);
    binv.col(c).setZero();
    binv(c, c) = 1.0;
  };
  // out += B⁻¹ v, in the order of the dense product (GemvBlock).
  const int block = static_cast<int>(GemvBlock(n));
  auto binv_times_add = [&](const VectorXd& v, VectorXd* out) {
    for (int c0 = 0; c0 < n; c0 += block) {
      acc.setZero(n);
      for (int c = c0; c < std::min(n, c0 + block); ++c) {
        if (touched[c]) {
          acc += v(c) * binv.col(c);
        } else {
          acc(c) += v(c);
        }
      }
      *out += acc;
    }
  };

  CoreOutcome out;
  auto extract_z = [&]() {
    z->setZero(n);
    for (int k = 0; k < n; ++k) {
      if (basis[k] >= n && basis[k] < kZ0) (*z)(basis[k] - n) = std::max(x(k), 0.0);
    }
  };
  auto fail = [&](SolverStatus status, std::string message) {
    extract_z();
    for (int k = 0; k < n; ++k) {
      if (basis[k] == kZ0) out.z0 = std::max(x(k), 0.0);
    }
    out.status = status;
    out.message = std::move(message);
    return out;
  };
  // Column of the entering variable in B⁻¹ coordinates: d = B⁻¹ a, a ∈ {e_i, −A_i, −e}.
  auto entering_column = [&](int var) {
    if (var < n) {
      if (touched[var]) {
        d = binv.col(var);
      } else {
        d.setZero();
        d(var) = 1.0;
      }
    } else if (var < kZ0) {
      A.Column(var - n, &col);
      d.setZero();
      binv_times_add(col, &d);
      d = -d;
    } else {
      col.setOnes(n);
      d.setZero();
      binv_times_add(col, &d);
      d = -d;
    }
  };
  // Pivot on row r: `entering` replaces basis[r]; returns the leaving variable. Only the
  // touched columns change (B⁻¹_rc = 0 in an untouched column c ≠ r).
  auto pivot = [&](int r, int entering) {
    const double p = d(r);
    touch(r);
    for (const int c : touched_cols) {
      const double pr = binv(r, c) / p;
      binv.col(c) -= pr * d;
      binv(r, c) = pr;
    }
    const double xr = x(r) / p;
    x -= xr * d;
    x(r) = xr;
    const int leaving = basis[r];
    basis[r] = entering;
    return leaving;
  };
  auto refactor = [&]() {
    MatrixXd& bmat = ws->bmat;
    if (bmat.rows() != n || bmat.cols() != n) bmat.resize(n, n);
    for (int k = 0; k < n; ++k) {
      const int var = basis[k];
      if (var < n) {
        bmat.col(k).setZero();
        bmat(var, k) = 1.0;
      } else if (var < kZ0) {
        A.Column(var - n, &col);
        bmat.col(k) = -col;
      } else {
        bmat.col(k).setConstant(-1.0);
      }
    }
    ws->lu.compute(bmat);
    if (!(ws->lu.rcond() > std::numeric_limits<double>::epsilon())) return false;
    binv = ws->lu.inverse();
    for (int c = 0; c < n; ++c) {
      if (!touched[c]) {
        touched[c] = 1;
        touched_cols.push_back(c);
      }
    }
    x.noalias() = binv * q;
    return binv.allFinite() && x.allFinite();
  };

  // Absolute tolerance on basic values for the ratio ties (see kRatioTieTolerance).
  const double tau_x = kRatioTieTolerance * std::max(1.0, q.lpNorm<Eigen::Infinity>());

  // Initial pivot: z0 enters (d = −e) in the row of the most negative q_i. Among ties the
  // lexicographic rule for d = −e picks the largest index.
  {
    const double q_min = q.minCoeff();
    const double tau = kRatioTieTolerance * std::max(1.0, std::abs(q_min));
    int r = 0;
    for (int i = 0; i < n; ++i) {
      if (q(i) <= q_min + tau) r = i;
    }
    d.setConstant(-1.0);
    out.z0_initial = -q_min;
    int leaving = pivot(r, kZ0);
    out.pivots = 1;
    int entering = complement(leaving);

    while (true) {
      if (out.pivots >= max_pivots) {
        return fail(SolverStatus::kMaxIterations,
                    "Lemke reached the pivot limit " + std::to_string(max_pivots));
      }
      entering_column(entering);
      if (!d.allFinite()) {
        return fail(SolverStatus::kNumericalFailure,
                    "non-finite pivot column at pivot " + std::to_string(out.pivots));
      }
      r = ChooseLeavingRow(x, d, basis, kZ0, tau_x, options, &ties, &kept, binv_at,
                           [](const std::vector<int>&, int) {});
      if (r < 0) {
        return fail(SolverStatus::kSecondaryRay,
                    "Lemke terminated on a secondary ray at pivot " + std::to_string(out.pivots) +
                        " (entering " +
                        (entering < n ? "w_" + std::to_string(entering)
                                      : "z_" + std::to_string(entering - n)) +
                        "); the LCP may be infeasible");
      }
      leaving = pivot(r, entering);
      ++out.pivots;
      if (!std::isfinite(x(r))) {
        return fail(SolverStatus::kNumericalFailure,
                    "non-finite basic value at pivot " + std::to_string(out.pivots));
      }
      if (leaving == kZ0) break;
      entering = complement(leaving);
      if (out.pivots % refactor_interval == 0 && !refactor()) {
        return fail(SolverStatus::kNumericalFailure,
                    "singular basis at refactorization after pivot " + std::to_string(out.pivots));
      }
    }
  }

  // z0 left: complementary basis. Polish x by iterative refinement of B x = q with the kept
  // inverse, keeping a step only if the complementarity residual improves.
  extract_z();
  VectorXd& w = ws->w;
  VectorXd& z_raw = ws->z_raw;
  VectorXd& w_raw = ws->w_raw;
  VectorXd& eq_residual = ws->eq_residual;
  VectorXd& z_try = ws->z_try;
  double best = ScaledResidual(A, q, *z, &w, &col, &acc);
  // Nothing to gain below roundoff level.
  const double refine_below = kRefineBelow * std::max(1.0, q.lpNorm<Eigen::Infinity>());
  for (int step = 0; step < kRefinementSteps && best > refine_below; ++step) {
    // Residual of the basis equations B x = q, i.e. q − (w_B − A z_B).
    z_raw.setZero(n);
    w_raw.setZero(n);
    for (int k = 0; k < n; ++k) {
      if (basis[k] < n) {
        w_raw(basis[k]) = x(k);
      } else if (basis[k] < kZ0) {
        z_raw(basis[k] - n) = x(k);
      }
    }
    A.Multiply(z_raw, &eq_residual, &col, &acc);
    eq_residual += q - w_raw;
    binv_times_add(eq_residual, &x);
    z_try.setZero(n);
    for (int k = 0; k < n; ++k) {
      if (basis[k] >= n && basis[k] < kZ0) z_try(basis[k] - n) = std::max(x(k), 0.0);
    }
    const double r = ScaledResidual(A, q, z_try, &w, &col, &acc);
    if (!(r < best)) break;
    best = r;
    z->swap(z_try);
  }
  out.status = SolverStatus::kSolved;
  return out;
}

struct Attempt {
  SolverStatus status = SolverStatus::kNumericalFailure;
  bool terminated = false;  // z0 left the basis
  int pivots = 0;
  double epsilon = 0.0;    // regularization of this attempt
  double residual = kInf;  // on the original problem
  double tolerance = 0.0;  // acceptance tolerance for this z (Acceptance::For)
  bool scale_ok = false;   // z passes CheckLcpSolution (lcp_acceptance.h)
  std::string message;
  VectorXd z;
};

// One Lemke run on M + εI (scaled if asked), z and residual reported on the original problem.
Attempt RunAttempt(const LcpProblem& problem, double epsilon, const LemkeOptions& options,
                   const Acceptance& acceptance, Workspace* ws) {
  PivotMatrix m;
  m.M = &problem.M;
  m.epsilon = epsilon;
  // Scaled only if some factor differs from 1 (a well-scaled M skips the multiplications).
  bool scaled = false;
  if (options.scale) {
    SymmetricScaling(problem.M, epsilon, ws);
    scaled = (ws->scale.array() != 1.0).any();
  }
  const VectorXd& scale = ws->scale;
  ws->q = problem.q;
  if (scaled) {
    m.scale = &scale;
    ws->q.array() *= scale.array();
  }
  Attempt a;
  a.epsilon = epsilon;
  a.z.swap(ws->spare_z);  // storage only: RunLemke overwrites z
  const CoreOutcome core = RunLemke(m, ws->q, options, ws, &a.z);
  if (scaled) a.z.array() *= scale.array();
  a.pivots = core.pivots;
  a.terminated = core.status == SolverStatus::kSolved;
  a.residual = OrInf(LcpResidual(problem, a.z));
  // τ has the absolute floor max(1, ‖q‖∞): a problem in small units also needs the shared
  // scale-aware check, or a regularized retry's z = 1e-3 would pass for z = 1.
  a.scale_ok = CheckLcpSolution(problem, a.z).empty();
  a.tolerance = acceptance.For(a.z);
  const double tolerance = a.tolerance;
  a.status = core.status;
  a.message = core.message;
  // A secondary ray reached with z0 ≈ 0 (degenerate problems approach z0 → 0 through ties)
  // leaves an almost-complementary iterate that already solves the LCP: accept it if z0 and
  // the residual on the original problem pass. On the original problem z0 shifts row i of
  // w by z0 / scale_i.
  if (core.status == SolverStatus::kSecondaryRay) {
    const double z0 = scaled ? core.z0 / scale.minCoeff() : core.z0;
    if (core.z0 <= kSecondaryRayZ0Fraction * core.z0_initial && z0 <= tolerance &&
        std::isfinite(a.residual) && a.residual <= tolerance) {
      a.terminated = true;
      a.status = SolverStatus::kSolved;
      a.message = "accepted the secondary-ray iterate with z0 = " + FormatDouble(z0) +
                  " as a solution (" + core.message + ")";
    }
  }
  // An overflowed residual (inf) fails even against an overflowed τ (inf).
  if (a.terminated && !(std::isfinite(a.residual) && a.residual <= tolerance)) {
    a.status = SolverStatus::kNumericalFailure;
    a.message = "Lemke terminated but the residual " + FormatDouble(a.residual) +
                " exceeds the tolerance " + FormatDouble(tolerance);
  } else if (a.terminated && !a.scale_ok) {
    a.status = SolverStatus::kNumericalFailure;
    a.message = "Lemke terminated but " + CheckLcpSolution(problem, a.z);
  }
  return a;
}

// A residual that overflowed (inf) never passes, even against an overflowed τ.
bool Passes(const Attempt& a) {
  return a.terminated && std::isfinite(a.residual) && a.residual <= a.tolerance && a.scale_ok;
}

}  // namespace

SolverReport LemkeSolver::Solve(const LcpProblem& problem, const VectorXd* warm_start,
                                VectorXd* z) const {
  if (z == nullptr) {
    throw std::invalid_argument("LemkeSolver::Solve: z is null; expected an output vector");
  }
  ValidateOptions(options_);
  const auto start = std::chrono::steady_clock::now();
  SolverReport report;
  auto finish = [&]() {
    report.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
  };

  const Eigen::Index n = problem.q.size();
  WorkspaceLease lease;
  Workspace& ws = lease.get();
  // One pass over M for its finiteness and ‖M‖∞.
  double m_norm = 0.0;
  const bool square = problem.M.rows() == n && problem.M.cols() == n;
  const bool finite = square && ScanMatrix(problem.M, &ws, &m_norm) && problem.q.allFinite();
  // (Finite entries whose row sum overflows pass CheckLcpData, with ‖M‖∞ = inf.)
  if (std::string invalid = finite ? std::string() : CheckLcpData(problem); !invalid.empty()) {
    z->setZero(n);
    report.status = SolverStatus::kInvalidInput;
    report.residual = std::numeric_limits<double>::quiet_NaN();
    report.message = std::move(invalid);
    return finish();
  }

  // 1. Trivial solution.
  if (n == 0 || problem.q.minCoeff() >= 0.0) {
    z->setZero(n);
    report.status = SolverStatus::kSolved;
    report.residual = LcpResidual(problem, *z);
    report.tolerance = options_.residual_tolerance;
    return finish();
  }
  Acceptance acceptance;
  acceptance.rtol = options_.residual_tolerance;
  acceptance.q_norm = problem.q.lpNorm<Eigen::Infinity>();
  acceptance.m_norm = m_norm;

  // 2. Warm start from a guessed basis.
  double warm_residual = kInf;
  if (warm_start != nullptr && warm_start->size() == n &&
      TryWarmStart(problem, *warm_start, acceptance, z, &warm_residual)) {
    report.status = SolverStatus::kSolved;
    report.residual = warm_residual;
    report.tolerance = acceptance.For(*z);
    report.message = "warm basis";  // as SolveOnWarmBasis (warm_basis.cc): no heap allocation
    return finish();
  }

  // 3. Cold Lemke, then 4. regularized retries if that fails.
  Attempt first = RunAttempt(problem, 0.0, options_, acceptance, &ws);
  int total_pivots = first.pivots;
  // 3a. A terminated run that misses the tolerance by roundoff: polish its basis (reported).
  std::string polish_note;
  if (options_.polish && first.terminated && !Passes(first) && first.z.allFinite()) {
    VectorXd polished;
    int newton_steps = 0;
    std::string newton_note;
    if (PolishTerminalIterate(problem, &first.z, acceptance, &polished, &newton_steps,
                              &newton_note)) {
      polish_note = "polished the terminated Lemke iterate (residual " +
                    FormatDouble(first.residual) + ") by " + std::to_string(newton_steps) +
                    " Fischer-Burmeister Newton steps" +
                    (newton_note.empty() ? "" : " (" + newton_note + ")");
      first.z = std::move(polished);
      first.residual = LcpResidual(problem, first.z);
      first.tolerance = acceptance.For(first.z);
      first.scale_ok = true;  // PolishTerminalIterate checked it
      first.status = SolverStatus::kSolved;
      first.message.clear();
    }
  }
  // 3b. Last line of defence before regularizing: one run without scaling (reported).
  std::string unscaled_note;
  bool solved_unscaled = false;
  // Only for a secondary ray or a terminated run with a bad residual (not for the pivot limit).
  if (!Passes(first) && options_.scale &&
      (first.terminated || first.status == SolverStatus::kSecondaryRay)) {
    LemkeOptions plain = options_;
    plain.scale = false;
    Attempt u = RunAttempt(problem, 0.0, plain, acceptance, &ws);
    total_pivots += u.pivots;
    if (Passes(u)) {
      unscaled_note =
          "solved without scaling after the scaled solve failed (" + first.message + ")";
      solved_unscaled = true;
      first = std::move(u);
    } else {
      unscaled_note = "; the retry without scaling failed too (" + u.message + ")";
    }
  }
  Attempt best;
  bool have_retry = false;
  std::string retry_log;
  if (!Passes(first) && options_.regularization > 0.0) {
    for (double factor : kRegularizationFactors) {
      Attempt a = RunAttempt(problem, factor * options_.regularization, options_, acceptance, &ws);
      total_pivots += a.pivots;
      retry_log += (retry_log.empty() ? "" : ", ") + std::string("eps=") + FormatDouble(a.epsilon) +
                   ": " +
                   (a.terminated ? "terminated, residual " + FormatDouble(a.residual)
                                 : std::string(ToString(a.status)));
      const bool terminated = a.terminated;
      const bool better = !have_retry || (Passes(a) && !Passes(best)) ||
                          (!Passes(best) && a.residual < best.residual);
      if (better) {
        best = std::move(a);
        have_retry = true;
      }
      // Stop at the first ε on which Lemke terminates: a larger ε only moves further away
      // from the original problem.
      if (terminated) break;
    }
  }

  // Keep the retry only if it is better than the plain attempt on the original problem.
  const bool use_retry = have_retry && (Passes(best) || best.residual < first.residual);
  Attempt& chosen = use_retry ? best : first;
  z->swap(chosen.z);
  ws.spare_z.swap(chosen.z);  // the caller's previous buffer, for the next solve
  report.iterations = total_pivots;
  // chosen.residual is LcpResidual of this very z (RunAttempt / polish), NaN mapped to ∞.
  report.residual = std::isfinite(chosen.residual) ? chosen.residual : LcpResidual(problem, *z);
  report.regularized = use_retry;
  report.regularization = use_retry ? chosen.epsilon : 0.0;
  report.tolerance = chosen.tolerance;
  const bool passes = Passes(chosen);
  // Passes(chosen) includes the scale-aware check of this very z (RunAttempt, the polish).
  bool checked = passes;
  report.status = passes ? SolverStatus::kSolved : first.status;
  if (report.status == SolverStatus::kSolved && !passes) {
    // RunAttempt turns a terminated-but-inaccurate run into kNumericalFailure.
    throw std::logic_error("LemkeSolver: failed solve reported as kSolved");
  }
  if (passes && !use_retry) {
    report.message = solved_unscaled ? unscaled_note : polish_note;
  } else if (passes) {
    report.message =
        "solved on the regularized problem M + eps*I with eps = " + FormatDouble(chosen.epsilon) +
        " after the plain solve failed (" + first.message + unscaled_note +
        "); residual on the original problem " + FormatDouble(report.residual);
  } else {
    report.message = first.message + unscaled_note;
    if (!retry_log.empty()) {
      report.message +=
          "; regularized retries (" + retry_log + ") did not solve the original " + "problem";
      if (use_retry) {
        report.message +=
            "; returning the retry iterate with eps = " + FormatDouble(chosen.epsilon) +
            " (smallest residual)";
      }
    }
    // Final fallback: Fischer–Burmeister Newton from z = 0 (reported).
    VectorXd z_newton;
    int newton_steps = 0;
    std::string newton_note;
    if (options_.newton_fallback && report.status != SolverStatus::kMaxIterations &&
        PolishTerminalIterate(problem, nullptr, acceptance, &z_newton, &newton_steps,
                              &newton_note)) {
      *z = std::move(z_newton);
      report.status = SolverStatus::kSolved;
      report.residual = LcpResidual(problem, *z);
      report.tolerance = acceptance.For(*z);
      report.regularized = false;
      report.regularization = 0.0;
      report.restarts = 1;
      checked = true;  // PolishTerminalIterate checked z
      report.message = "solved by the Fischer-Burmeister Newton fallback (" +
                       std::to_string(newton_steps) + " Newton steps" +
                       (newton_note.empty() ? "" : "; " + newton_note) +
                       ") after Lemke failed: " + report.message;
    }
  }
  if (!checked) ConfirmSolved(problem, *z, &report);
  return finish();
}

}  // namespace vinci::sim
