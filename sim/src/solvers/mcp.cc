// Semismooth Newton for box-constrained MCPs on the penalized Fischer–Burmeister reformulation
// (Chen, Chen, Kanzow 2000; box rows as in Billups 1995), with projected iterates, a
// non-monotone Armijo line search (Grippo, Lampariello, Lucidi 1986), a projected-gradient
// fallback and crash/restarts. Reference for the overall scheme: Munson, Facchinei, Ferris,
// Fischer, Kanzow, "The semismooth algorithm for large scale complementarity problems" (2001).
#include "vinci/sim/solvers/mcp.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "mcp_rows.h"
#include "scratch_lease.h"
#include "solver_util.h"
#include "vinci/sim/solvers/lcp_acceptance.h"

namespace vinci::sim {
namespace {

using internal::mcp::CheckProblem;
using internal::mcp::Classify;
using internal::mcp::EvalRow;
using internal::mcp::FbRows;
using internal::mcp::NaturalResidual;
using internal::mcp::ProjectInPlace;
using internal::mcp::RowKind;
using internal::mcp::ScaledResidual;

using SparseMatrixd = Eigen::SparseMatrix<double>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
// Armijo constant of the sufficient-decrease test.
constexpr double kArmijo = 1e-4;
// Backtracking factor and the number of halvings before a line search gives up (2⁻⁴⁰ ≈ 1e-12).
constexpr double kBacktrack = 0.5;
constexpr int kMaxBacktracks = 40;
// Newton direction accepted as a descent direction iff ∇Ψᵀd ≤ −kDescentRho ‖d‖^kDescentP
// (De Luca, Facchinei, Kanzow 1996).
constexpr double kDescentRho = 1e-10;
constexpr double kDescentP = 2.1;
// A stalled attempt: best merit not reduced by this factor within stall_iterations.
constexpr double kStallFactor = 0.9;
// Floor of the Levenberg–Marquardt scale max_i (HᵀH)_ii.
constexpr double kLmFloor = 1e-300;

// Deterministic pseudo-random numbers in [−1, 1] (splitmix64), identical on every platform.
class Perturbation {
 public:
  explicit Perturbation(std::uint64_t seed) : state_(seed) {}
  double Next() {
    std::uint64_t x = (state_ += 0x9E3779B97F4A7C15ull);
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    x ^= x >> 31;
    return 2.0 * (static_cast<double>(x >> 11) * 0x1.0p-53) - 1.0;
  }

 private:
  std::uint64_t state_;
};

// PartialPivLU::rcond() (Eigen's rcond_estimate_helper and rcond_invmatrix_L1_norm_estimate:
// Hager's algorithm with Higham's alternating vector) with its vectors in *v, *sign, *old_sign
// and *tmp: the same operations in the same order, so the same value, without the temporaries
// of each dec.solve. `l1_norm` is the factored matrix's max column sum of |entries| (PartialPivLU
// keeps it privately; the caller forms it by the same expression).
double PartialPivLuRcond(const Eigen::PartialPivLU<MatrixXd>& dec, double l1_norm, VectorXd* v,
                         VectorXd* sign, VectorXd* old_sign, VectorXd* tmp) {
  const Eigen::Index n = dec.rows();
  if (n == 0) return kInf;
  if (l1_norm == 0.0) return 0.0;
  if (n == 1) return 1.0;
  const auto& perm = dec.permutationP().indices();
  const auto& lu = dec.matrixLU();
  // *out = dec.solve(*in) (PartialPivLU::_solve_impl: P b, L⁻¹, U⁻¹); in and out distinct.
  const auto solve = [&](const VectorXd& in, VectorXd* out) {
    out->resize(n);
    for (Eigen::Index i = 0; i < n; ++i) (*out)(perm(i)) = in(i);
    lu.template triangularView<Eigen::UnitLower>().solveInPlace(*out);
    lu.template triangularView<Eigen::Upper>().solveInPlace(*out);
  };
  // *out = dec.adjoint().solve(in) for real scalars (_solve_impl_transposed: U⁻ᵀ, L⁻ᵀ, Pᵀ).
  const auto solve_transposed = [&](const VectorXd& in, VectorXd* out) {
    *tmp = in;
    lu.template triangularView<Eigen::Upper>().transpose().solveInPlace(*tmp);
    lu.template triangularView<Eigen::UnitLower>().transpose().solveInPlace(*tmp);
    out->resize(n);
    for (Eigen::Index i = 0; i < n; ++i) (*out)(i) = (*tmp)(perm(i));
  };
  tmp->resize(n);
  for (Eigen::Index i = 0; i < n; ++i) (*tmp)(i) = 1.0 / static_cast<double>(n);
  solve(*tmp, v);
  double lower_bound = v->lpNorm<1>();
  double old_lower_bound = lower_bound;
  Eigen::Index v_max_abs_index = -1, old_v_max_abs_index = -1;
  for (int k = 0; k < 4; ++k) {
    sign->resize(n);
    for (Eigen::Index i = 0; i < n; ++i) (*sign)(i) = (*v)(i) < 0.0 ? -1.0 : 1.0;
    if (k > 0 && *sign == *old_sign) break;
    solve_transposed(*sign, v);
    v->cwiseAbs().maxCoeff(&v_max_abs_index);
    if (v_max_abs_index == old_v_max_abs_index) break;
    tmp->setZero(n);  // e_j, j = v_max_abs_index
    (*tmp)(v_max_abs_index) = 1.0;
    solve(*tmp, v);
    lower_bound = v->lpNorm<1>();
    if (lower_bound <= old_lower_bound) break;
    *old_sign = *sign;
    old_v_max_abs_index = v_max_abs_index;
    old_lower_bound = lower_bound;
  }
  double alternating_sign = 1.0;
  tmp->resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    (*tmp)(i) = alternating_sign * (1.0 + (static_cast<double>(i) / static_cast<double>(n - 1)));
    alternating_sign = -alternating_sign;
  }
  solve(*tmp, v);
  const double alternate_lower_bound = (2 * v->lpNorm<1>()) / (3 * static_cast<double>(n));
  const double inverse_norm = std::max(lower_bound, alternate_lower_bound);
  return inverse_norm == 0.0 ? 0.0 : (1.0 / inverse_norm) / l1_norm;
}

// The sparse path's matrices, its SparseLU (with the analysis of H's pattern) and H's pattern
// cache: J_F's pattern, where each of its entries lands in H, H's diagonal. Kept between solves:
// the cache is compared with each J_F's pattern before it is used.
struct McpSparseParts {
  SparseMatrixd jfs, hs;
  Eigen::SparseLU<SparseMatrixd, Eigen::COLAMDOrdering<int>> slu;
  std::vector<int> cached_outer, cached_inner, entry_pos, diag_pos;
  bool pattern_valid = false;
};

// The solve's storage: one per thread, reused by every solve of that thread (allocation reuse
// only: every solve sets what it reads; the sparse path's pattern cache is checked).
struct McpScratch {
  std::vector<RowKind> kinds;
  VectorXd F, phi, alpha, beta, grad, dir, rhs, d, jd, zt, Ft, phit, tmp;
  VectorXd z0, zc, best, F0;
  VectorXd rcond_v, rcond_sign, rcond_old_sign, rcond_tmp;
  std::vector<double> merits;
  MatrixXd jf, h;
  Eigen::PartialPivLU<MatrixXd> lu;
  std::unique_ptr<McpSparseParts> sparse;  // made by the first sparse solve
};

// The whole solve: workspace and the steps of the algorithm.
class SemismoothNewton {
 public:
  SemismoothNewton(const McpProblem& problem, const McpOptions& options, McpScratch* s)
      : p_(problem),
        o_(options),
        n_(problem.size()),
        sparse_(options.sparse && static_cast<bool>(problem.sparse_jacobian)),
        s_(*s),
        kinds_(s->kinds),
        F_(s->F),
        phi_(s->phi),
        alpha_(s->alpha),
        beta_(s->beta),
        grad_(s->grad),
        dir_(s->dir),
        rhs_(s->rhs),
        d_(s->d),
        jd_(s->jd),
        zt_(s->zt),
        Ft_(s->Ft),
        phit_(s->phit),
        tmp_(s->tmp),
        jf_(s->jf),
        h_(s->h),
        lu_(s->lu) {
    kinds_.resize(n_);
    for (int i = 0; i < n_; ++i) kinds_[i] = Classify(p_.lower(i), p_.upper(i));
    for (VectorXd* v : {&F_, &phi_, &alpha_, &beta_, &grad_, &dir_, &rhs_, &d_, &jd_, &zt_, &Ft_,
                        &phit_, &tmp_}) {
      v->setZero(n_);
    }
    if (!sparse_) {
      jf_.setZero(n_, n_);
      h_.setZero(n_, n_);
    } else {
      if (!s->sparse) s->sparse = std::make_unique<McpSparseParts>();
      sp_ = s->sparse.get();
    }
  }

  SolverReport Run(VectorXd* z, McpSolveStats* stats);

 private:
  enum class Eval { kOk, kNonFinite, kThrew };

  // F (and the Jacobian if `jacobian`) at x into *F (jf_ / sp_->jfs). Catches user exceptions.
  Eval Evaluate(const VectorXd& x, VectorXd* F, bool jacobian);
  // Φ at x from F; with `jacobian` also H (h_ / sp_->hs).
  void Reformulate(const VectorXd& x, const VectorXd& F, VectorXd* phi, bool jacobian);
  void AssembleSparseH();
  // Newton direction into dir_; false if H is singular or the solution is not finite.
  bool NewtonDirection();
  // Levenberg–Marquardt direction (HᵀH + m I) d = −∇Ψ into dir_, m = min(1, ‖Φ‖²) ·
  // max(max_i (HᵀH)_ii, tiny); false if the solve fails or d is not finite.
  bool LevenbergMarquardtDirection();
  // Line search along P[z + t·dir] (newton) or P[z − t·grad]; on success zt_/Ft_/phit_ hold
  // the accepted point. Sets *threw / *message when evaluate throws.
  bool LineSearch(const VectorXd& z, bool newton, double reference, double slope, double t0,
                  bool* threw);
  void RestartPoint(int attempt, const VectorXd& z0, const VectorXd& F0, const VectorXd& best,
                    VectorXd* z);
  // McpScaledResidual at x from F and the Jacobian last evaluated (at x).
  double ScaledAt(const VectorXd& x, const VectorXd& F) const {
    return sparse_ ? ScaledResidual(x, F, p_.lower, p_.upper, nullptr, &sp_->jfs)
                   : ScaledResidual(x, F, p_.lower, p_.upper, &jf_, nullptr);
  }

  const McpProblem& p_;
  const McpOptions& o_;
  const int n_;
  const bool sparse_;
  McpScratch& s_;
  std::vector<RowKind>& kinds_;
  VectorXd &F_, &phi_, &alpha_, &beta_, &grad_, &dir_, &rhs_, &d_, &jd_, &zt_, &Ft_, &phit_, &tmp_;
  MatrixXd &jf_, &h_;
  Eigen::PartialPivLU<MatrixXd>& lu_;
  McpSparseParts* sp_ = nullptr;  // the sparse path's storage (s_.sparse) when sparse_
  // True iff jf_ / sp_->jfs hold the Jacobian at the last trial point zt_ (else at the iterate).
  bool trial_has_jacobian_ = false;
  McpSolveStats stats_;
  std::string message_;
};

SemismoothNewton::Eval SemismoothNewton::Evaluate(const VectorXd& x, VectorXd* F, bool jacobian) {
  ++stats_.function_evaluations;
  try {
    if (jacobian && !sparse_) {
      p_.evaluate(x, F, &jf_);
    } else {
      p_.evaluate(x, F, nullptr);
      if (jacobian) p_.sparse_jacobian(x, &sp_->jfs);
    }
  } catch (const std::exception& e) {
    message_ = std::string("McpProblem::evaluate threw: ") + e.what();
    return Eval::kThrew;
  } catch (...) {
    message_ = "McpProblem::evaluate threw a non-standard exception";
    return Eval::kThrew;
  }
  if (F->size() != n_) {
    throw std::invalid_argument("McpSolver: evaluate returned F of size " +
                                std::to_string(F->size()) + "; expected " + std::to_string(n_));
  }
  if (jacobian) {
    const Eigen::Index rows = sparse_ ? sp_->jfs.rows() : jf_.rows();
    const Eigen::Index cols = sparse_ ? sp_->jfs.cols() : jf_.cols();
    if (rows != n_ || cols != n_) {
      throw std::invalid_argument("McpSolver: the Jacobian is " + std::to_string(rows) + "x" +
                                  std::to_string(cols) + "; expected " + std::to_string(n_) + "x" +
                                  std::to_string(n_));
    }
  }
  if (!F->allFinite()) return Eval::kNonFinite;
  if (jacobian) {
    if (sparse_) {
      sp_->jfs.makeCompressed();
      for (Eigen::Index k = 0; k < sp_->jfs.nonZeros(); ++k) {
        if (!std::isfinite(sp_->jfs.valuePtr()[k])) return Eval::kNonFinite;
      }
    } else if (!jf_.allFinite()) {
      return Eval::kNonFinite;
    }
  }
  return Eval::kOk;
}

void SemismoothNewton::Reformulate(const VectorXd& x, const VectorXd& F, VectorXd* phi,
                                   bool jacobian) {
  const auto jf_times = [&](const VectorXd& d, VectorXd* out) {
    if (!jacobian) return;  // only the Jacobian depends on the direction
    if (sparse_) {
      out->noalias() = sp_->jfs * d;
    } else {
      out->noalias() = jf_ * d;
    }
  };
  FbRows(kinds_, x, F, p_.lower, p_.upper, o_.lambda, jf_times, phi, &alpha_, &beta_, &d_, &jd_);
  if (!jacobian) return;
  if (sparse_) {
    AssembleSparseH();
  } else {
    // H = diag(beta) J_F + diag(alpha).
    h_.noalias() = beta_.asDiagonal() * jf_;
    h_.diagonal() += alpha_;
  }
}

void SemismoothNewton::AssembleSparseH() {
  const int nnz = static_cast<int>(sp_->jfs.nonZeros());
  const int* outer = sp_->jfs.outerIndexPtr();
  const int* inner = sp_->jfs.innerIndexPtr();
  std::vector<int>&cached_outer = sp_->cached_outer, &cached_inner = sp_->cached_inner;
  std::vector<int>&entry_pos = sp_->entry_pos, &diag_pos = sp_->diag_pos;
  const bool same = sp_->pattern_valid && static_cast<int>(cached_inner.size()) == nnz &&
                    static_cast<int>(cached_outer.size()) == n_ + 1 &&
                    std::equal(outer, outer + n_ + 1, cached_outer.begin()) &&
                    std::equal(inner, inner + nnz, cached_inner.begin());
  if (!same) {
    // H's pattern: J_F's plus the diagonal.
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(nnz + n_);
    for (int j = 0; j < n_; ++j) {
      for (int k = outer[j]; k < outer[j + 1]; ++k) triplets.emplace_back(inner[k], j, 0.0);
      triplets.emplace_back(j, j, 0.0);
    }
    sp_->hs.resize(n_, n_);
    sp_->hs.setFromTriplets(triplets.begin(), triplets.end());
    sp_->hs.makeCompressed();
    const int* houter = sp_->hs.outerIndexPtr();
    const int* hinner = sp_->hs.innerIndexPtr();
    const auto position = [&](int row, int col) {
      return static_cast<int>(
          std::lower_bound(hinner + houter[col], hinner + houter[col + 1], row) - hinner);
    };
    entry_pos.resize(nnz);
    diag_pos.resize(n_);
    for (int j = 0; j < n_; ++j) {
      for (int k = outer[j]; k < outer[j + 1]; ++k) entry_pos[k] = position(inner[k], j);
      diag_pos[j] = position(j, j);
    }
    cached_outer.assign(outer, outer + n_ + 1);
    cached_inner.assign(inner, inner + nnz);
    sp_->pattern_valid = true;
    sp_->slu.analyzePattern(sp_->hs);
  }
  double* values = sp_->hs.valuePtr();
  std::fill(values, values + sp_->hs.nonZeros(), 0.0);
  const double* jv = sp_->jfs.valuePtr();
  for (int j = 0; j < n_; ++j) {
    for (int k = outer[j]; k < outer[j + 1]; ++k) values[entry_pos[k]] += beta_(inner[k]) * jv[k];
    values[diag_pos[j]] += alpha_(j);
  }
}

bool SemismoothNewton::NewtonDirection() {
  rhs_ = -phi_;
  if (sparse_) {
    sp_->slu.factorize(sp_->hs);
    if (sp_->slu.info() != Eigen::Success) return false;
    dir_ = sp_->slu.solve(rhs_);
    if (sp_->slu.info() != Eigen::Success) return false;
  } else {
    // ‖H‖₁ as PartialPivLU::compute forms it (for rcond()).
    const double l1_norm = n_ > 0 ? h_.cwiseAbs().colwise().sum().maxCoeff() : 0.0;
    lu_.compute(h_);
    // PartialPivLU does not detect singularity; reject a numerically singular H.
    const double rcond = PartialPivLuRcond(lu_, l1_norm, &s_.rcond_v, &s_.rcond_sign,
                                           &s_.rcond_old_sign, &s_.rcond_tmp);
    if (!(rcond > 1e-15 * n_)) return false;
    dir_ = lu_.solve(rhs_);
  }
  return dir_.allFinite();
}

bool SemismoothNewton::LevenbergMarquardtDirection() {
  const double phi_norm = phi_.norm();
  if (sparse_) {
    SparseMatrixd hth = sp_->hs.transpose() * sp_->hs;
    double scale = 0.0;
    for (int j = 0; j < n_; ++j) scale = std::max(scale, hth.coeff(j, j));
    const double m = std::min(1.0, phi_norm * phi_norm) * std::max(scale, kLmFloor);
    SparseMatrixd eye(n_, n_);
    eye.setIdentity();
    hth += m * eye;
    Eigen::SimplicialLDLT<SparseMatrixd> ldlt(hth);
    if (ldlt.info() != Eigen::Success) return false;
    dir_ = ldlt.solve(-grad_);
  } else {
    MatrixXd hth = h_.transpose() * h_;
    const double m =
        std::min(1.0, phi_norm * phi_norm) * std::max(hth.diagonal().maxCoeff(), kLmFloor);
    hth.diagonal().array() += m;
    Eigen::LDLT<MatrixXd> ldlt(hth);
    if (ldlt.info() != Eigen::Success) return false;
    dir_ = ldlt.solve(-grad_);
  }
  return dir_.allFinite();
}

bool SemismoothNewton::LineSearch(const VectorXd& z, bool newton, double reference, double slope,
                                  double t0, bool* threw) {
  double t = t0;
  for (int k = 0; k < kMaxBacktracks; ++k, t *= kBacktrack) {
    if (newton) {
      zt_ = z + t * dir_;
    } else {
      zt_ = z - t * grad_;
    }
    ProjectInPlace(p_.lower, p_.upper, &zt_);
    if (zt_ == z) return false;  // the projected path is stuck at z
    // The full Newton step is the one accepted near a solution: evaluate the Jacobian with it
    // so that accepting it costs no second evaluation.
    trial_has_jacobian_ = newton && k == 0;
    const Eval e = Evaluate(zt_, &Ft_, trial_has_jacobian_);
    if (e == Eval::kThrew) {
      *threw = true;
      return false;
    }
    if (e == Eval::kNonFinite) continue;  // backtrack out of trouble
    Reformulate(zt_, Ft_, &phit_, false);
    const double merit = 0.5 * phit_.squaredNorm();
    // Newton: the decrease predicted by the linear model (∇Ψᵀd = −‖Φ‖²) scaled by t;
    // gradient: Armijo along the projected path.
    const double predicted = newton ? t * slope : grad_.dot(zt_ - z);
    if (std::isfinite(merit) && merit <= reference + kArmijo * predicted) return true;
  }
  return false;
}

void SemismoothNewton::RestartPoint(int attempt, const VectorXd& z0, const VectorXd& F0,
                                    const VectorXd& best, VectorXd* z) {
  if (attempt == 1) {
    // Crash point: the projected start shifted toward the bounds F points at.
    *z = z0 - F0;
    ProjectInPlace(p_.lower, p_.upper, z);
    if (*z != z0) return;
  }
  // Perturb the best point, with an amplitude growing with the attempt.
  Perturbation rng(0x5EED0000u + static_cast<std::uint64_t>(attempt));
  const double amplitude = 0.25 * attempt;
  for (int i = 0; i < n_; ++i) {
    (*z)(i) = best(i) + amplitude * (1.0 + std::abs(best(i))) * rng.Next();
  }
  ProjectInPlace(p_.lower, p_.upper, z);
}

SolverReport SemismoothNewton::Run(VectorXd* z, McpSolveStats* stats_out) {
  const auto start = std::chrono::steady_clock::now();
  SolverReport report;
  const VectorXd& l = p_.lower;
  const VectorXd& u = p_.upper;

  VectorXd& z0 = s_.z0;
  z0 = *z;
  ProjectInPlace(l, u, &z0);
  VectorXd& zc = s_.zc;
  zc = z0;
  VectorXd& best = s_.best;
  best = z0;
  double best_residual = kInf;
  double best_merit = kInf;
  VectorXd& F0 = s_.F0;
  std::vector<double>& merits = s_.merits;
  merits.clear();
  merits.reserve(std::max(1, o_.nonmonotone_memory));

  enum class End { kSolved, kBudget, kStalled, kFailure } end = End::kStalled;
  int iterations = 0;
  bool converged = false;     // the last accepted point passes both tests
  bool solved = false;        // `best` passes both tests
  double last_scaled = kNaN;  // scale-aware residual of the last point that passed only the first

  // Evaluates F, J, Φ, H at zc (into F_, phi_, ...) and updates the best point. Returns false
  // (with end/message set) on a numerical failure. `evaluated`: F and J at zc are already in
  // F_ and jf_ / sp_->jfs.
  const auto accept = [&](bool evaluated) {
    if (!evaluated) {
      const Eval e = Evaluate(zc, &F_, true);
      if (e == Eval::kNonFinite) message_ = "non-finite F or Jacobian at an iterate";
      if (e != Eval::kOk) {
        end = End::kFailure;
        return false;
      }
    }
    Reformulate(zc, F_, &phi_, true);
    const double residual = NaturalResidual(zc, F_, l, u);
    // Converged: the absolute stopping test and the scale-aware acceptance test (a problem in
    // small units passes the first long before it is solved).
    converged = residual <= o_.tolerance;
    if (converged) {
      const double scaled = ScaledAt(zc, F_);
      converged = scaled <= kLcpAcceptanceTolerance;
      if (!converged) last_scaled = scaled;
    }
    if (converged || (!solved && residual < best_residual)) {
      best_residual = residual;
      best_merit = 0.5 * phi_.squaredNorm();
      best = zc;
      solved = converged;
    }
    return true;
  };

  int attempt = 0;
  if (accept(false)) {
    F0 = F_;
    for (;; ++attempt) {
      if (attempt > 0) {
        if (attempt > o_.max_restarts) break;
        ++stats_.restarts;
        RestartPoint(attempt, z0, F0, best, &zc);
        if (!accept(false)) break;
      }
      double merit = 0.5 * phi_.squaredNorm();
      merits.assign(1, merit);
      double attempt_best = merit;
      int since_progress = 0;
      bool stalled = false;
      while (true) {
        if (converged) {
          end = End::kSolved;
          break;
        }
        if (iterations >= o_.max_iterations) {
          end = End::kBudget;
          break;
        }
        ++iterations;
        if (sparse_) {
          grad_.noalias() = sp_->hs.transpose() * phi_;
        } else {
          grad_.noalias() = h_.transpose() * phi_;
        }
        const double reference = *std::max_element(merits.begin(), merits.end());
        bool threw = false;
        bool accepted = false;
        if (NewtonDirection()) {
          const double slope = grad_.dot(dir_);
          if (slope <= -kDescentRho * std::pow(dir_.norm(), kDescentP)) {
            accepted = LineSearch(zc, true, reference, slope, 1.0, &threw);
            if (accepted) ++stats_.newton_steps;
          }
        }
        if (!accepted && !threw && o_.levenberg_marquardt && LevenbergMarquardtDirection()) {
          const double slope = grad_.dot(dir_);
          if (slope < 0.0) {
            accepted = LineSearch(zc, true, reference, slope, 1.0, &threw);
            if (accepted) ++stats_.lm_steps;
          }
        }
        if (!accepted && !threw) {
          // Projected gradient; first trial at the Cauchy step of the linearized model.
          if (sparse_) {
            tmp_.noalias() = sp_->hs * grad_;
          } else {
            tmp_.noalias() = h_ * grad_;
          }
          const double gg = grad_.squaredNorm();
          const double hg = tmp_.squaredNorm();
          const double t0 = hg > 0.0 && std::isfinite(gg / hg) ? gg / hg : 1.0;
          accepted = gg > 0.0 && LineSearch(zc, false, reference, 0.0, t0, &threw);
          if (accepted) ++stats_.gradient_steps;
        }
        if (threw) {
          end = End::kFailure;
          break;
        }
        if (!accepted) {
          stalled = true;
          break;
        }
        zc = zt_;
        if (trial_has_jacobian_) F_ = Ft_;
        if (!accept(trial_has_jacobian_)) break;
        merit = 0.5 * phi_.squaredNorm();
        if (static_cast<int>(merits.size()) >= std::max(1, o_.nonmonotone_memory)) {
          merits.erase(merits.begin());
        }
        merits.push_back(merit);
        if (merit < kStallFactor * attempt_best) {
          attempt_best = merit;
          since_progress = 0;
        } else if (++since_progress >= o_.stall_iterations) {
          stalled = true;
          break;
        }
      }
      if (!stalled) break;
      end = End::kStalled;
    }
  }

  *z = best;
  report.iterations = iterations;
  report.residual = best_residual;
  if (!(best_residual < kInf)) {
    report.residual = kNaN;  // no point was ever evaluated successfully
  }
  if (solved) {
    report.status = SolverStatus::kSolved;
    if (stats_.restarts > 0) {
      message_ = "solved after " + std::to_string(stats_.restarts) + " restart(s)";
    }
  } else if (end == End::kBudget) {
    report.status = SolverStatus::kMaxIterations;
    message_ = "iteration limit " + std::to_string(o_.max_iterations) +
               " reached; best natural residual " + std::to_string(best_residual) + " after " +
               std::to_string(stats_.restarts) + " restart(s)";
  } else if (end == End::kStalled) {
    report.status = SolverStatus::kStalled;
    message_ = "stalled at a non-solution (best natural residual " + std::to_string(best_residual) +
               ") after " + std::to_string(stats_.restarts) + " restart(s)";
  } else {
    report.status = SolverStatus::kNumericalFailure;
    if (end != End::kFailure) {
      message_ = "stalled at a non-solution (best natural residual " +
                 std::to_string(best_residual) + ") after " + std::to_string(stats_.restarts) +
                 " restart(s)";
    }
  }
  if (!solved && best_residual <= o_.tolerance)
    message_ += "; the natural residual passed the tolerance but not the scale-aware check (" +
                internal::FormatDouble(last_scaled) + " > " +
                internal::FormatDouble(kLcpAcceptanceTolerance) + ")";
  report.message = message_;
  report.restarts = stats_.restarts;
  stats_.merit = std::isfinite(best_merit) ? best_merit : kNaN;
  if (stats_out != nullptr) *stats_out = stats_;
  report.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace

SolverReport McpSolver::Solve(const McpProblem& problem, VectorXd* z) const {
  return Solve(problem, z, nullptr);
}

SolverReport McpSolver::Solve(const McpProblem& problem, VectorXd* z, McpSolveStats* stats) const {
  if (z == nullptr) throw std::invalid_argument("McpSolver::Solve: z is null");
  CheckProblem(problem, "McpSolver::Solve");
  const int n = problem.size();
  if (z->size() != n) {
    throw std::invalid_argument("McpSolver::Solve: z has size " + std::to_string(z->size()) +
                                " but the problem has size " + std::to_string(n));
  }
  for (int i = 0; i < n; ++i) {
    const double l = problem.lower(i);
    const double u = problem.upper(i);
    if (!(l <= u) || l == kInf || u == -kInf) {
      throw std::invalid_argument("McpSolver::Solve: bounds of row " + std::to_string(i) +
                                  " are [" + std::to_string(l) + ", " + std::to_string(u) +
                                  "]; expected l <= u, l < +inf, u > -inf");
    }
    if (!std::isfinite((*z)(i))) {
      throw std::invalid_argument("McpSolver::Solve: starting point z(" + std::to_string(i) +
                                  ") = " + std::to_string((*z)(i)) + "; expected finite");
    }
  }
  const McpOptions& o = options_;
  // The message is formed only for an invalid option (a valid solve allocates nothing here).
  const auto require = [](bool ok, const auto& what) {
    if (!ok) throw std::invalid_argument("McpSolver: invalid option " + what());
  };
  require(o.max_iterations >= 0, [&] {
    return "max_iterations = " + std::to_string(o.max_iterations) + "; expected >= 0";
  });
  require(o.tolerance >= 0.0,
          [&] { return "tolerance = " + std::to_string(o.tolerance) + "; expected >= 0"; });
  require(o.lambda > 0.0 && o.lambda <= 1.0,
          [&] { return "lambda = " + std::to_string(o.lambda) + "; expected 0 < lambda <= 1"; });
  require(o.nonmonotone_memory >= 1, [&] {
    return "nonmonotone_memory = " + std::to_string(o.nonmonotone_memory) + "; expected >= 1";
  });
  require(o.max_restarts >= 0,
          [&] { return "max_restarts = " + std::to_string(o.max_restarts) + "; expected >= 0"; });
  require(o.stall_iterations >= 1, [&] {
    return "stall_iterations = " + std::to_string(o.stall_iterations) + "; expected >= 1";
  });
  internal::ScratchLease<McpScratch> lease;
  SemismoothNewton solver(problem, options_, &lease.get());
  return solver.Run(z, stats);
}

}  // namespace vinci::sim
