// The dense Lemke solver's warm-start test and its Fischer–Burmeister polish (lemke.h,
// lemke_internal.h).
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "basis_solve.h"
#include "lemke_internal.h"
#include "solver_util.h"
#include "vinci/sim/solvers/fischer_burmeister.h"
#include "vinci/sim/solvers/lcp_acceptance.h"

namespace vinci::sim::internal::lemke {
namespace {

// Solve on a guessed basis: with B = {i : in_basis_i}, z_B solves M_BB z_B = −q_B, accepted
// if z_B ≥ −tol, w_N ≥ −tol and the residual passes. The solve is anchored at the guess,
// z_B = guess_B + δ with M_BB δ = −(M_BB guess_B + q_B) by column-pivoted QR: for a
// nonsingular M_BB this is the same z_B, and for a singular one (degenerate contact LCPs: a
// sliding-speed λ_i whose contact carries no force is not determined by the B rows) the
// undetermined components keep the guessed values instead of being set to zero.
// w = M z + q over the columns with z_j ≠ 0 only (M is finite: ScanMatrix checked it, so the
// skipped terms are exact zeros): O(n · nnz(z)) instead of O(n²) for a warm-start candidate.
void MultiplySkippingZeros(const LcpProblem& problem, const VectorXd& z, VectorXd* w) {
  *w = problem.q;
  for (Eigen::Index j = 0; j < z.size(); ++j)
    if (z(j) != 0.0) w->noalias() += z(j) * problem.M.col(j);
}

// LcpResidual (lcp.h) from a given w = M z + q.
double ResidualOf(const VectorXd& z, const VectorXd& w) {
  double residual = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isnan(w(i)) || std::isnan(z(i))) return std::numeric_limits<double>::quiet_NaN();
    residual = std::max(residual, std::abs(std::min(z(i), w(i))));
  }
  return residual;
}

// TryBasis's buffers, per thread (allocation reuse only: every call overwrites what it reads).
// The basis-size-dependent ones are kept per basis size up to kPerSizeMax, so that a step whose
// basis size changes (a contact starts or stops sliding) reuses the storage of the last solve of
// that size instead of reallocating Eigen's fixed-capacity matrices and its QR.
struct BasisBuffers {
  Eigen::MatrixXd m_bb;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
  VectorXd guess_b, rhs, q_b, delta, z_b, c;
};
constexpr Eigen::Index kPerSizeMax = 64;
struct TryBasisScratch {
  std::vector<Eigen::Index> active;
  std::vector<std::unique_ptr<BasisBuffers>> per_size;  // index: basis size (≤ kPerSizeMax)
  BasisBuffers large;                                   // larger bases share one set
  VectorXd candidate, w, terms;
  std::vector<bool> in_basis;  // TryWarmStart's
  BasisBuffers& For(Eigen::Index nb) {
    if (nb > kPerSizeMax) return large;
    if (per_size.size() <= static_cast<std::size_t>(nb)) per_size.resize(nb + 1);
    std::unique_ptr<BasisBuffers>& b = per_size[static_cast<std::size_t>(nb)];
    if (!b) b = std::make_unique<BasisBuffers>();
    return *b;
  }
};

TryBasisScratch& ThreadTryBasisScratch() {
  thread_local TryBasisScratch scratch;
  return scratch;
}

bool TryBasis(const LcpProblem& problem, const std::vector<bool>& in_basis, const VectorXd& guess,
              const Acceptance& acceptance, VectorXd* z, double* residual) {
  TryBasisScratch& s = ThreadTryBasisScratch();
  const Eigen::Index n = problem.q.size();
  std::vector<Eigen::Index>& active = s.active;
  active.clear();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (in_basis[i]) active.push_back(i);
  }
  if (active.empty()) return false;  // z = 0 was already ruled out (q has a negative entry)
  BasisBuffers& b = s.For(static_cast<Eigen::Index>(active.size()));
  Eigen::MatrixXd& m_bb = b.m_bb;
  // M_BB, guess_B and q_B gathered by hand (Eigen's indexed views copy their index vectors).
  const Eigen::Index nb = static_cast<Eigen::Index>(active.size());
  m_bb.resize(nb, nb);
  for (Eigen::Index c = 0; c < nb; ++c)
    for (Eigen::Index r = 0; r < nb; ++r) m_bb(r, c) = problem.M(active[r], active[c]);
  VectorXd& guess_b = b.guess_b;
  guess_b.resize(nb);
  b.q_b.resize(nb);
  for (Eigen::Index r = 0; r < nb; ++r) {
    guess_b(r) = guess(active[r]);
    b.q_b(r) = problem.q(active[r]);
  }
  // rhs = −(M_BB guess_B + q_B): the product, then the sum (Eigen's order for the expression).
  VectorXd& rhs = b.rhs;
  rhs.noalias() = m_bb * guess_b;
  rhs = -(rhs + b.q_b);
  VectorXd& delta = b.delta;
  internal::SolveBasisBlock(m_bb, rhs, &b.qr, &b.c, &delta);
  VectorXd& z_b = b.z_b;
  z_b = guess_b + delta;
  if (!z_b.allFinite()) return false;
  const double tolerance = acceptance.For(z_b);
  if (z_b.minCoeff() < -tolerance) return false;
  VectorXd& candidate = s.candidate;
  candidate.setZero(n);
  for (Eigen::Index r = 0; r < nb; ++r) candidate(active[r]) = z_b(r);
  VectorXd& w = s.w;
  MultiplySkippingZeros(problem, candidate, &w);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!in_basis[i] && w(i) < -tolerance) return false;
  }
  if (candidate.minCoeff() < 0.0) {
    candidate = candidate.cwiseMax(0.0);
    MultiplySkippingZeros(problem, candidate, &w);
  }
  // LcpResidual (from this w) and the scale-aware check (lcp_acceptance.h) of the candidate:
  // LcpScaledResidual's row terms |q_i| + Σ_j |M_ij z_j| over the columns with z_j ≠ 0 only, and
  // ‖M‖∞ from the scan (O(n · nnz(z)), where LcpScaledResidual reads all of M).
  const double r = ResidualOf(candidate, w);
  if (!(r <= acceptance.For(candidate))) return false;
  VectorXd& terms = s.terms;
  terms = problem.q.cwiseAbs();
  for (Eigen::Index j = 0; j < n; ++j)
    if (candidate(j) != 0.0)
      terms.noalias() += std::abs(candidate(j)) * problem.M.col(j).cwiseAbs();
  if (!(internal::ScaledNaturalResidual(candidate, w, nullptr, nullptr, terms, acceptance.m_norm,
                                        acceptance.q_norm) <= kLcpAcceptanceTolerance))
    return false;
  *z = candidate;
  *residual = r;
  return true;
}

}  // namespace

// Warm start: the guessed basis is B = {i : warm_i > 0}.
bool TryWarmStart(const LcpProblem& problem, const VectorXd& warm, const Acceptance& acceptance,
                  VectorXd* z, double* residual) {
  std::vector<bool>& in_basis = ThreadTryBasisScratch().in_basis;
  in_basis.assign(static_cast<std::size_t>(warm.size()), false);
  for (Eigen::Index i = 0; i < warm.size(); ++i) in_basis[i] = warm(i) > 0.0;
  return TryBasis(problem, in_basis, warm, acceptance, z, residual);
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
  // τ overflows on a problem near the largest double (‖q‖∞ ~ 1e308): nothing to polish to.
  if (!std::isfinite(options.tolerance)) return false;
  VectorXd candidate;
  const SolverReport r = FischerBurmeisterSolver(options).Solve(problem, z_lemke, &candidate);
  *iterations = r.iterations;
  *note = r.message;
  if (!candidate.allFinite() || candidate.size() != problem.q.size()) return false;
  candidate = candidate.cwiseMax(0.0);
  if (!(LcpResidual(problem, candidate) <= acceptance.For(candidate))) return false;
  if (!CheckLcpSolution(problem, candidate).empty()) return false;  // lcp_acceptance.h
  *z = std::move(candidate);
  return true;
}

}  // namespace vinci::sim::internal::lemke
