// Lemke's complementary pivoting method with covering vector e (Cottle, Pang & Stone, The
// Linear Complementarity Problem, 1992, §4.4), in revised form: the system
//
//   w − M z − e z0 = q,   w, z, z0 ≥ 0,   wᵀz = 0,
//
// is pivoted on an explicit basis inverse B⁻¹ kept up to date by rank-1 updates (O(n²) per
// pivot) and recomputed from an LU factorization every `refactor_interval` pivots. The
// lexicographic ratio test on the rows of [B⁻¹q, B⁻¹] is the perturbation q + (ε, ε², …)
// and makes the pivot choice unique, so the method cannot cycle.
#include "vinci/sim/lemke.h"

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "solver_util.h"
#include "vinci/sim/fischer_burmeister.h"

namespace vinci::sim {
namespace {

// Ratios within this relative distance of the minimum ratio are ties (degenerate pivots).
// Degenerate basic values carry roundoff of order ε‖B⁻¹‖‖q‖ ≈ 1e-14, which pivots of order
// 1e-3 turn into ratios of 1e-11; 1e-12 missed such ties on a random contact LCP (n = 108)
// and ended on a spurious secondary ray, 1e-10 solved 14 400 random stress problems.
//
// The same constant, times max(1, ‖q‖∞), is also an absolute tolerance on the basic values
// (Harris' two-pass ratio test): row i is a tie if stepping to its ratio leaves no other row
// below −kRatioTieTolerance·max(1, ‖q‖∞). A purely ratio-relative tolerance is not enough:
// on a 10-box stack (tests/data/lcp/box_stack_cold_step425.lcp) ~200 rows, z0 among them,
// blocked at the same ratio 9.81e-3 up to a relative noise of 5e-8 (basic values carry errors
// of ~5e-11, and dividing by pivots of ~0.04 spreads the ratios by 1e-9 > 1e-10); z0 was not
// recognized as blocking, was left at 1e-11 instead of leaving the basis, and the next pivot
// ended on a spurious secondary ray.
constexpr double kRatioTieTolerance = 1e-10;
// Among tied rows, pivots smaller than this fraction of the largest tied pivot are not used
// (unless all are that small). In degenerate steps (ratio 0) the lexicographic rule otherwise
// happily picks a pivot that is pure noise: on a sliding-box LCP
// (tests/data/lcp/incline_sliding_step9744.lcp) it pivoted on d = 1.5e-12 (the M entries that
// are physically zero are ~1e-12 from the contact geometry) next to a tied pivot of 1, which
// scaled B⁻¹ by 1e12 and ended with a residual of 0.54. Skipping a tied row keeps the iterate
// feasible (its value stays within the tie tolerance of 0).
constexpr double kTiePivotFraction = 1e-7;
// Relative tolerance of the lexicographic comparisons of B⁻¹ rows among tied ratios.
constexpr double kLexTieTolerance = 1e-12;
// A secondary-ray iterate is accepted as a solution only if z0 fell below this fraction of its
// initial value (it was driven to 0 by the pivoting, not merely small because q is tiny) and
// the residual passes.
constexpr double kSecondaryRayZ0Fraction = 1e-6;
// Symmetric equilibration sweeps; the loop stops earlier once no scale factor changes.
constexpr int kScalingSweeps = 10;
// Iterative-refinement steps at termination (each O(n²) with the kept inverse), skipped once
// the residual is below kRefineBelow·max(1, ‖q‖∞) (roundoff level of the data).
constexpr int kRefinementSteps = 2;
constexpr double kRefineBelow = 1e-15;
// Cap of the ‖M‖∞‖z‖∞ term of the acceptance scale, relative to max(1, ‖q‖∞). Without a cap
// a huge z would make any residual pass: a regularized retry of an infeasible LCP
// (M = −I, q = −1, ε = 1e-10) returns ‖z‖ ≈ 1e10 with residual 2. The 10-box stack needs
// ‖M‖∞‖z‖∞ ≈ 6–12 next to max(1, ‖q‖∞) = 1.
constexpr double kMaxAcceptanceGrowth = 1e3;
// Retry factors applied to options.regularization.
constexpr double kRegularizationFactors[] = {1.0, 1e3, 1e6};

constexpr double kInf = std::numeric_limits<double>::infinity();

using internal::FormatDouble;

// NaN sorts last: a NaN residual is worse than any number.
double OrInf(double v) { return std::isnan(v) ? kInf : v; }

void ValidateOptions(const LemkeOptions& o) {
  auto fail = [](const std::string& field, double value, const char* expected) {
    throw std::invalid_argument("LemkeOptions." + field + " = " + FormatDouble(value) +
                                "; expected " + expected);
  };
  if (o.max_pivots < 0) fail("max_pivots", o.max_pivots, ">= 0");
  if (!(o.pivot_tolerance >= 0.0) || !std::isfinite(o.pivot_tolerance)) {
    fail("pivot_tolerance", o.pivot_tolerance, "a finite value >= 0");
  }
  if (!(o.residual_tolerance >= 0.0) || !std::isfinite(o.residual_tolerance)) {
    fail("residual_tolerance", o.residual_tolerance, "a finite value >= 0");
  }
  if (!(o.regularization >= 0.0) || !std::isfinite(o.regularization)) {
    fail("regularization", o.regularization, "a finite value >= 0");
  }
  if (o.refactor_interval < 0) fail("refactor_interval", o.refactor_interval, ">= 0");
}

// Power-of-two diagonal D such that D M D has each row and column max-abs within a factor of
// about 4 of 1 (where M has a nonzero there). Symmetric, so copositivity / PSD of M and with
// it Lemke's termination guarantee are preserved; powers of two make the scaling exact.
VectorXd SymmetricScaling(const MatrixXd& M) {
  const Eigen::Index n = M.rows();
  VectorXd d = VectorXd::Ones(n);
  MatrixXd a = M.cwiseAbs();
  VectorXd s(n);
  VectorXd row_max(n), col_max(n);
  for (int sweep = 0; sweep < kScalingSweeps; ++sweep) {
    bool changed = false;
    // Row and column maxima in one column-major pass.
    row_max.setZero();
    for (Eigen::Index j = 0; j < n; ++j) {
      double c = 0.0;
      for (Eigen::Index i = 0; i < n; ++i) {
        const double v = a(i, j);
        c = std::max(c, v);
        row_max(i) = std::max(row_max(i), v);
      }
      col_max(j) = c;
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      const double m = std::max(row_max(i), col_max(i));
      int k = 0;
      if (m > 0.0 && std::isfinite(m)) k = -static_cast<int>(std::trunc(0.5 * std::log2(m)));
      s(i) = std::ldexp(1.0, k);
      changed = changed || k != 0;
    }
    if (!changed) break;
    a.array().colwise() *= s.array();
    a.array().rowwise() *= s.transpose().array();
    d.array() *= s.array();
  }
  return d;
}

struct CoreOutcome {
  SolverStatus status = SolverStatus::kNumericalFailure;
  int pivots = 0;
  std::string message;
  double z0 = 0.0;  // value of the artificial variable z0 in the final iterate (0 if nonbasic)
  double z0_initial = 0.0;  // its value after the initial pivot, −min q
};

// ‖min(z, Mz + q)‖_∞ on the problem being pivoted (possibly scaled), NaN-safe.
double ScaledResidual(const MatrixXd& M, const VectorXd& q, const VectorXd& z, VectorXd* w) {
  w->noalias() = M * z;
  *w += q;
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isnan(z(i)) || std::isnan((*w)(i))) return kInf;
    r = std::max(r, std::abs(std::min(z(i), (*w)(i))));
  }
  return r;
}

// Lemke's method on LCP(M, q), q not ≥ 0. Writes the z part of the final iterate (clamped to
// ≥ 0) into *z. kSolved here means only that z0 left the basis.
CoreOutcome RunLemke(const MatrixXd& M, const VectorXd& q, const LemkeOptions& options,
                     VectorXd* z) {
  const int n = static_cast<int>(q.size());
  const int max_pivots = options.max_pivots > 0 ? options.max_pivots : 50 * n + 100;
  const int refactor_interval =
      options.refactor_interval > 0 ? options.refactor_interval : std::max(50, n);
  // Variables: w_i = i, z_i = n + i, z0 = 2n.
  const int kZ0 = 2 * n;
  auto complement = [n](int var) { return var < n ? var + n : var - n; };

  std::vector<int> basis(n);  // variable basic in each row
  for (int i = 0; i < n; ++i) basis[i] = i;
  std::vector<int> ties, kept;
  ties.reserve(n);
  kept.reserve(n);
  MatrixXd binv = MatrixXd::Identity(n, n);
  VectorXd x = q;  // values of the basic variables
  VectorXd d(n), pivot_row(n);
  MatrixXd bmat;  // allocated on the first refactorization
  Eigen::PartialPivLU<MatrixXd> lu;

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
  // Column of the entering variable in B⁻¹ coordinates: d = B⁻¹ a, a ∈ {e_i, −M_i, −e}.
  auto entering_column = [&](int var) {
    if (var < n) {
      d = binv.col(var);
    } else if (var < kZ0) {
      d.noalias() = binv * M.col(var - n);
      d = -d;
    } else {
      d = -binv.rowwise().sum();
    }
  };
  // Pivot on row r: `entering` replaces basis[r]; returns the leaving variable.
  auto pivot = [&](int r, int entering) {
    const double p = d(r);
    pivot_row = binv.row(r).transpose() / p;
    const double xr = x(r) / p;
    binv.noalias() -= d * pivot_row.transpose();
    binv.row(r) = pivot_row.transpose();
    x -= xr * d;
    x(r) = xr;
    const int leaving = basis[r];
    basis[r] = entering;
    return leaving;
  };
  auto refactor = [&]() {
    if (bmat.rows() != n) bmat.resize(n, n);
    for (int k = 0; k < n; ++k) {
      const int var = basis[k];
      if (var < n) {
        bmat.col(k).setZero();
        bmat(var, k) = 1.0;
      } else if (var < kZ0) {
        bmat.col(k) = -M.col(var - n);
      } else {
        bmat.col(k).setConstant(-1.0);
      }
    }
    lu.compute(bmat);
    if (!(lu.rcond() > std::numeric_limits<double>::epsilon())) return false;
    binv = lu.inverse();
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
      const double pivot_tol = options.pivot_tolerance * std::max(1.0, d.cwiseAbs().maxCoeff());
      // Harris' two-pass ratio test: theta is the minimum ratio, theta_max the largest step
      // that keeps every basic value ≥ −tau_x; rows whose ratio is ≤ theta_max are ties.
      double theta = kInf;
      double theta_max = kInf;
      for (int i = 0; i < n; ++i) {
        if (d(i) > pivot_tol) {
          const double xi = std::max(x(i), 0.0);
          theta = std::min(theta, xi / d(i));
          theta_max = std::min(theta_max, (xi + tau_x) / d(i));
        }
      }
      if (theta == kInf) {
        return fail(SolverStatus::kSecondaryRay,
                    "Lemke terminated on a secondary ray at pivot " + std::to_string(out.pivots) +
                        " (entering " +
                        (entering < n ? "w_" + std::to_string(entering)
                                      : "z_" + std::to_string(entering - n)) +
                        "); the LCP may be infeasible");
      }
      const double tie_bound =
          std::max(theta_max, theta + kRatioTieTolerance * std::max(1.0, theta));
      ties.clear();
      r = -1;
      double d_tied_max = 0.0;
      for (int i = 0; i < n; ++i) {
        if (d(i) > pivot_tol && std::max(x(i), 0.0) / d(i) <= tie_bound) {
          ties.push_back(i);
          d_tied_max = std::max(d_tied_max, d(i));
          if (basis[i] == kZ0) r = i;  // z0 blocks: leave now and terminate
        }
      }
      if (r < 0 && ties.size() > 1) {
        // Stability: drop tied pivots that are negligible next to the largest tied one.
        kept.clear();
        for (int i : ties) {
          if (d(i) >= kTiePivotFraction * d_tied_max) kept.push_back(i);
        }
        ties.swap(kept);
      }
      if (r < 0) {
        if (options.lexicographic) {
          for (int k = 0; k < n && ties.size() > 1; ++k) {
            double m = kInf;
            for (int i : ties) m = std::min(m, binv(i, k) / d(i));
            const double tau_k = kLexTieTolerance * std::max(1.0, std::abs(m));
            kept.clear();
            for (int i : ties) {
              if (binv(i, k) / d(i) <= m + tau_k) kept.push_back(i);
            }
            ties.swap(kept);
          }
          r = ties.front();
        } else {
          r = ties.front();  // largest pivot among the ties, for stability
          for (int i : ties) {
            if (d(i) > d(r)) r = i;
          }
        }
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
  VectorXd w(n), z_raw(n), w_raw(n), eq_residual(n), z_try(n);
  double best = ScaledResidual(M, q, *z, &w);
  // Nothing to gain below roundoff level.
  const double refine_below = kRefineBelow * std::max(1.0, q.lpNorm<Eigen::Infinity>());
  for (int step = 0; step < kRefinementSteps && best > refine_below; ++step) {
    // Residual of the basis equations B x = q, i.e. q − (w_B − M z_B).
    z_raw.setZero();
    w_raw.setZero();
    for (int k = 0; k < n; ++k) {
      if (basis[k] < n) {
        w_raw(basis[k]) = x(k);
      } else if (basis[k] < kZ0) {
        z_raw(basis[k] - n) = x(k);
      }
    }
    eq_residual.noalias() = M * z_raw;
    eq_residual += q - w_raw;
    x.noalias() += binv * eq_residual;
    z_try.setZero();
    for (int k = 0; k < n; ++k) {
      if (basis[k] >= n && basis[k] < kZ0) z_try(basis[k] - n) = std::max(x(k), 0.0);
    }
    const double r = ScaledResidual(M, q, z_try, &w);
    if (!(r < best)) break;
    best = r;
    z->swap(z_try);
  }
  out.status = SolverStatus::kSolved;
  return out;
}

// The scale-aware acceptance test of lemke.h:
//   residual ≤ rtol·max(b, min(‖M‖∞‖z‖∞, kMaxAcceptanceGrowth·b)),   b = max(1, ‖q‖∞).
struct Acceptance {
  double rtol = 0.0;
  double q_norm = 0.0;  // ‖q‖∞
  double m_norm = 0.0;  // ‖M‖∞ = max_i Σ_j |M_ij|
  Acceptance(const LcpProblem& problem, double residual_tolerance)
      : rtol(residual_tolerance),
        q_norm(problem.q.lpNorm<Eigen::Infinity>()),
        m_norm(problem.M.rows() > 0 ? problem.M.cwiseAbs().rowwise().sum().maxCoeff() : 0.0) {}
  double For(const VectorXd& z) const {
    const double z_norm = z.size() > 0 ? z.lpNorm<Eigen::Infinity>() : 0.0;
    const double base = std::max(1.0, q_norm);
    return rtol * std::max(base, std::min(m_norm * z_norm, kMaxAcceptanceGrowth * base));
  }
};

struct Attempt {
  SolverStatus status = SolverStatus::kNumericalFailure;
  bool terminated = false;  // z0 left the basis
  int pivots = 0;
  double epsilon = 0.0;    // regularization of this attempt
  double residual = kInf;  // on the original problem
  double tolerance = 0.0;  // acceptance tolerance for this z (Acceptance::For)
  std::string message;
  VectorXd z;
};

// One Lemke run on M + εI (scaled if asked), z and residual reported on the original problem.
Attempt RunAttempt(const LcpProblem& problem, double epsilon, const LemkeOptions& options,
                   const Acceptance& acceptance) {
  MatrixXd m = problem.M;
  if (epsilon > 0.0) m.diagonal().array() += epsilon;
  VectorXd q = problem.q;
  VectorXd scale;
  // Scaled only if some factor differs from 1 (a well-scaled M skips 2n² multiplications).
  bool scaled = false;
  if (options.scale) {
    scale = SymmetricScaling(m);
    scaled = (scale.array() != 1.0).any();
  }
  if (scaled) {
    const Eigen::Index n = m.rows();
    for (Eigen::Index j = 0; j < n; ++j) {
      const double s_j = scale(j);
      for (Eigen::Index i = 0; i < n; ++i) m(i, j) *= scale(i) * s_j;
    }
    q.array() *= scale.array();
  }
  Attempt a;
  a.epsilon = epsilon;
  const CoreOutcome core = RunLemke(m, q, options, &a.z);
  if (scaled) a.z.array() *= scale.array();
  a.pivots = core.pivots;
  a.terminated = core.status == SolverStatus::kSolved;
  a.residual = OrInf(LcpResidual(problem, a.z));
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
        a.residual <= tolerance) {
      a.terminated = true;
      a.status = SolverStatus::kSolved;
      a.message = "accepted the secondary-ray iterate with z0 = " + FormatDouble(z0) +
                  " as a solution (" + core.message + ")";
    }
  }
  if (a.terminated && !(a.residual <= tolerance)) {
    a.status = SolverStatus::kNumericalFailure;
    a.message = "Lemke terminated but the residual " + FormatDouble(a.residual) +
                " exceeds the tolerance " + FormatDouble(tolerance);
  }
  return a;
}

bool Passes(const Attempt& a) { return a.terminated && a.residual <= a.tolerance; }

// Solve on a guessed basis: with B = {i : in_basis_i}, z_B solves M_BB z_B = −q_B, accepted
// if z_B ≥ −tol, w_N ≥ −tol and the residual passes. The solve is anchored at the guess,
// z_B = guess_B + δ with M_BB δ = −(M_BB guess_B + q_B) by column-pivoted QR: for a
// nonsingular M_BB this is the same z_B, and for a singular one (degenerate contact LCPs: a
// sliding-speed λ_i whose contact carries no force is not determined by the B rows) the
// undetermined components keep the guessed values instead of being set to zero.
bool TryBasis(const LcpProblem& problem, const std::vector<bool>& in_basis, const VectorXd& guess,
              const Acceptance& acceptance, VectorXd* z) {
  const Eigen::Index n = problem.q.size();
  std::vector<Eigen::Index> active;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (in_basis[i]) active.push_back(i);
  }
  if (active.empty()) return false;  // z = 0 was already ruled out (q has a negative entry)
  const MatrixXd m_bb = problem.M(active, active);
  const VectorXd guess_b = guess(active);
  const VectorXd rhs = -(m_bb * guess_b + problem.q(active));
  const Eigen::ColPivHouseholderQR<MatrixXd> qr(m_bb);
  const VectorXd z_b = guess_b + qr.solve(rhs);
  if (!z_b.allFinite()) return false;
  const double tolerance = acceptance.For(z_b);
  if (z_b.minCoeff() < -tolerance) return false;
  VectorXd candidate = VectorXd::Zero(n);
  candidate(active) = z_b;
  const VectorXd w = problem.M * candidate + problem.q;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!in_basis[i] && w(i) < -tolerance) return false;
  }
  candidate = candidate.cwiseMax(0.0);
  if (!(LcpResidual(problem, candidate) <= acceptance.For(candidate))) return false;
  *z = std::move(candidate);
  return true;
}

// Warm start: the guessed basis is B = {i : warm_i > 0}.
bool TryWarmStart(const LcpProblem& problem, const VectorXd& warm, const Acceptance& acceptance,
                  VectorXd* z) {
  std::vector<bool> in_basis(warm.size());
  for (Eigen::Index i = 0; i < warm.size(); ++i) in_basis[i] = warm(i) > 0.0;
  return TryBasis(problem, in_basis, warm, acceptance, z);
}

// Polish of a terminated Lemke iterate that misses the tolerance by roundoff (a basic w_i left
// slightly negative in a degenerate basis): Fischer–Burmeister Newton started at it. An
// active-set re-solve on B = {i : z_i > 0 or w_i < 0} does not do: on the 10-box stack
// (tests/data/lcp/box_stack_cold_step7724.lcp) M_BB has rank 78 of 168 and every solution
// of the B equations near the iterate has negative components.
// With z_lemke null: Newton from z = 0 (the final fallback).
// `note` receives the Newton report's message (e.g. that its proximal-point fallback ran).
bool PolishTerminalIterate(const LcpProblem& problem, const VectorXd* z_lemke,
                           const Acceptance& acceptance, VectorXd* z, int* iterations,
                           std::string* note) {
  FischerBurmeisterOptions options;
  options.lemke_fallback = false;  // no recursion back into Lemke
  // Stop Newton (and its proximal-point fallback) at Lemke's own acceptance test rather than
  // FB's tighter default: half of τ at the start point (τ(z) changes with ‖z‖; the result is
  // checked against τ of the candidate below). Without this the polish of a pile step spent
  // 400 Newton steps (2.7 s) driving a residual already below τ towards 1e-10.
  const double q_base = std::max(1.0, problem.q.lpNorm<Eigen::Infinity>());
  const double tau_start =
      z_lemke != nullptr ? acceptance.For(*z_lemke) : acceptance.For(VectorXd::Zero(0));
  options.tolerance = std::max(options.tolerance, 0.5 * tau_start / q_base);
  VectorXd candidate;
  const SolverReport r = FischerBurmeisterSolver(options).Solve(problem, z_lemke, &candidate);
  *iterations = r.iterations;
  *note = r.message;
  if (!candidate.allFinite() || candidate.size() != problem.q.size()) return false;
  candidate = candidate.cwiseMax(0.0);
  if (!(LcpResidual(problem, candidate) <= acceptance.For(candidate))) return false;
  *z = std::move(candidate);
  return true;
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
  if (std::string invalid = CheckLcpData(problem); !invalid.empty()) {
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
  const Acceptance acceptance(problem, options_.residual_tolerance);

  // 2. Warm start from a guessed basis.
  if (warm_start != nullptr && warm_start->size() == n &&
      TryWarmStart(problem, *warm_start, acceptance, z)) {
    report.status = SolverStatus::kSolved;
    report.residual = LcpResidual(problem, *z);
    report.tolerance = acceptance.For(*z);
    report.message = "accepted the warm-start basis";
    return finish();
  }

  // 3. Cold Lemke, then 4. regularized retries if that fails.
  Attempt first = RunAttempt(problem, 0.0, options_, acceptance);
  int total_pivots = first.pivots;
  // 3a. A terminated run that misses the tolerance by roundoff: polish its basis (reported).
  std::string polish_note;
  if (first.terminated && !Passes(first) && first.z.allFinite()) {
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
    Attempt u = RunAttempt(problem, 0.0, plain, acceptance);
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
      Attempt a = RunAttempt(problem, factor * options_.regularization, options_, acceptance);
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
  const Attempt& chosen = use_retry ? best : first;
  *z = chosen.z;
  report.iterations = total_pivots;
  // chosen.residual is LcpResidual of this very z (RunAttempt / polish), NaN mapped to ∞.
  report.residual = std::isfinite(chosen.residual) ? chosen.residual : LcpResidual(problem, *z);
  report.regularized = use_retry;
  report.regularization = use_retry ? chosen.epsilon : 0.0;
  report.tolerance = chosen.tolerance;
  const bool passes = chosen.terminated && report.residual <= chosen.tolerance;
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
      report.message = "solved by the Fischer-Burmeister Newton fallback (" +
                       std::to_string(newton_steps) + " Newton steps" +
                       (newton_note.empty() ? "" : "; " + newton_note) +
                       ") after Lemke failed: " + report.message;
    }
  }
  return finish();
}

}  // namespace vinci::sim
