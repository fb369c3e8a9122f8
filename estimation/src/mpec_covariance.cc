// Standard errors of the MPEC estimator: the Laplace approximation at the solution (the
// reduced-Hessian inverse through a quasi-definite KKT factorization) (mpec_estimator.h).
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "mpec_problem.h"
#include "mumps_ldlt.h"

namespace vinci::estimation {

using mpec_internal::kDefaultSigma;
using mpec_internal::kInf;
using mpec_internal::MumpsLdlt;
using mpec_internal::ParallelFor;
using mpec_internal::ResidualRow;
using mpec_internal::StepBlock;
using sim::Params;
using sim::State;
using sim::VectorXd;

namespace {

// Solves K y = b by GMRES on Kr⁻¹ K y = Kr⁻¹ b (Kr⁻¹ the regularized factorization: its
// eigenvalues cluster at 1 except for K's smallest, so few Krylov steps are needed — plain
// iterative refinement, y ← y + Kr⁻¹ (b − K y), took ~470 steps on the 500-step block at a
// contraction of 0.95; GMRES ~20), from y₀ = Kr⁻¹ b, restarted from the true preconditioned
// residual r = Kr⁻¹ (b − K y) after every cycle while ‖r‖ at least halves. A cycle's own
// (Givens) residual estimate is not ‖r‖: Kr⁻¹ amplifies rounding by ~1/δ, and a cycle that
// estimated 1e-12 of the start could end at a true ‖r‖ of 2e-2 of it, its variance 2% off
// (bench/README.md, push18). true when the best iterate's ‖r‖ (returned in y) is below 1e-12 of
// max(‖r₀‖, ‖Kr⁻¹ b‖), or below kAccepted of it once the restarts stop reducing it; false
// otherwise (the caller then tries a larger δ, whose rounding floor is lower). `max_krylov` > 0
// caps the vectors per cycle (else 200 to 1000 by the basis' memory, ≤ ~400 MB). Deterministic
// (ordered arithmetic only).
template <class Factor>
bool SolveRefined(const sim::SparseMatrixXd& K, const Factor& kr, const VectorXd& b, VectorXd* y,
                  int max_krylov = 0) {
  const int kMaxKrylov = max_krylov > 0
                             ? max_krylov
                             : static_cast<int>(std::clamp<long long>(
                                   50000000LL / std::max<long long>(1, b.size()), 200, 1000));
  constexpr int kMaxCycles = 8;
  // The true ‖r‖ accepted when the restarts stall at rounding level (relative): measured on
  // the noisy 1 mm block logs, iterates with ‖r‖ ≤ 2e-5 had their variance within 2e-4 of the
  // converged value, ‖r‖ = 2e-2 1% off.
  constexpr double kAccepted = 1e-6;
  *y = kr.solve(b);
  if (!y->allFinite()) return false;
  VectorXd r0 = kr.solve(VectorXd(b - K * *y));
  double beta = r0.norm();
  const double scale = std::max(beta, kr.solve(b).norm());
  const double target = 1e-12 * scale;
  if (!(beta > target)) return std::isfinite(beta);
  sim::MatrixXd h = sim::MatrixXd::Zero(kMaxKrylov + 1, kMaxKrylov);
  VectorXd cs(kMaxKrylov), sn(kMaxKrylov), g(kMaxKrylov + 1);
  std::vector<VectorXd> v;
  for (int cycle = 0; cycle < kMaxCycles; ++cycle) {
    v.assign(1, r0 / beta);
    h.setZero();
    // Givens rotations applied to h and to g = β e₁.
    cs.setZero();
    sn.setZero();
    g.setZero();
    g[0] = beta;
    int k = 0;
    bool done = false;
    for (; k < kMaxKrylov && !done; ++k) {
      VectorXd w = kr.solve(VectorXd(K * v[k]));
      if (!w.allFinite()) return false;
      for (int j = 0; j <= k; ++j) {  // modified Gram–Schmidt
        h(j, k) = w.dot(v[j]);
        w -= h(j, k) * v[j];
      }
      h(k + 1, k) = w.norm();
      for (int j = 0; j < k; ++j) {
        const double t = cs[j] * h(j, k) + sn[j] * h(j + 1, k);
        h(j + 1, k) = -sn[j] * h(j, k) + cs[j] * h(j + 1, k);
        h(j, k) = t;
      }
      const double den = std::hypot(h(k, k), h(k + 1, k));
      if (!(den > 0)) break;
      cs[k] = h(k, k) / den;
      sn[k] = h(k + 1, k) / den;
      const double hk1 = h(k + 1, k);
      h(k, k) = den;
      h(k + 1, k) = 0.0;
      g[k + 1] = -sn[k] * g[k];
      g[k] = cs[k] * g[k];
      done = std::abs(g[k + 1]) <= target;
      if (!done && !(hk1 > 0)) break;  // breakdown: the Krylov space is invariant
      if (!done) v.push_back(w / hk1);
    }
    // Back substitution of the k × k upper-triangular system.
    VectorXd c = VectorXd::Zero(k);
    for (int j = k - 1; j >= 0; --j) {
      double t = g[j];
      for (int l = j + 1; l < k; ++l) t -= h(j, l) * c[l];
      c[j] = t / h(j, j);
    }
    VectorXd next = *y;
    for (int j = 0; j < k; ++j) next += c[j] * v[j];
    if (!next.allFinite()) break;
    VectorXd r = kr.solve(VectorXd(b - K * next));
    const double b_next = r.norm();
    if (!(b_next < beta)) break;  // no better than the last iterate: kept
    const bool halved = b_next < 0.5 * beta;
    *y = std::move(next);
    r0 = std::move(r);
    beta = b_next;
    if (!(beta > target) || !halved) break;
  }
  return beta <= kAccepted * scale && y->allFinite();
}

}  // namespace

bool MpecEstimationProblem::ParameterVariances(const VectorXd& x,
                                               const std::vector<PairTreatment>& treatment,
                                               VectorXd* variances) const {
  variances->setConstant(impl_->ntheta, std::numeric_limits<double>::quiet_NaN());
  sim::MatrixXd cov;
  if (!ParameterCovariance(x, treatment, &cov)) return false;
  *variances = cov.diagonal();
  return true;
}

bool MpecEstimationProblem::ParameterCovariance(const VectorXd& x,
                                                const std::vector<PairTreatment>& treatment,
                                                sim::MatrixXd* covariance) const {
  const Impl& I = *impl_;
  covariance->setConstant(I.ntheta, I.ntheta, std::numeric_limits<double>::quiet_NaN());
  std::vector<char> fixed(I.n, 0);
  for (std::size_t k = 0; k < I.pairs.size() && k < treatment.size(); ++k) {
    const auto [a, b] = I.pairs[k];
    const PairTreatment t = treatment[k];
    if (t == PairTreatment::kFirstZero || t == PairTreatment::kBothZero) fixed[a] = 1;
    if (t == PairTreatment::kSecondZero || t == PairTreatment::kBothZero) fixed[b] = 1;
  }
  for (int i = 0; i < I.ntheta; ++i)
    if (x[i] <= I.x_l[i] + 1e-12 || x[i] >= I.x_u[i] - 1e-12) fixed[i] = 1;
  VectorXd J;
  if (!JacobianValues(x, &J)) return false;
  // Unknowns that nothing depends on at x (no objective term, all Jacobian entries zero) are
  // undetermined and irrelevant: left out.
  std::vector<char> used(I.n, 0);
  for (const Entry& h : I.hess) used[h.row] = used[h.col] = 1;
  for (std::size_t e = 0; e < I.jac.size(); ++e)
    if (J[static_cast<int>(e)] != 0.0) used[I.jac[e].col] = 1;
  std::vector<int> map(I.n, -1);
  int nf = 0;
  for (int i = 0; i < I.n; ++i)
    if (!fixed[i] && used[i]) map[i] = nf++;
  std::vector<Eigen::Triplet<double>> tr;
  for (std::size_t e = 0; e < I.hess.size(); ++e) {
    const int r = map[I.hess[e].row], c = map[I.hess[e].col];
    if (r < 0 || c < 0) continue;
    const double h = 0.5 * I.hess_obj[static_cast<int>(e)];
    tr.emplace_back(r, c, h);
    if (r != c) tr.emplace_back(c, r, h);
  }
  for (std::size_t e = 0; e < I.jac.size(); ++e) {
    const int c = map[I.jac[e].col];
    if (c < 0 || J[static_cast<int>(e)] == 0.0) continue;
    tr.emplace_back(nf + I.jac[e].row, c, J[static_cast<int>(e)]);
    tr.emplace_back(c, nf + I.jac[e].row, J[static_cast<int>(e)]);
  }
  // K = [H J_Fᵀ; J_F 0] is indefinite and, in general, singular in harmless directions
  // (unknowns that neither the objective nor the held constraints determine and that θ does
  // not couple to, e.g. equal and opposite friction impulses at a sticking contact). K is
  // equilibrated symmetrically (Ruiz: every row's largest |entry| → 1); the quasi-definite
  // Kr = K + diag(δ I, −δ I) has an LDLᵀ for any ordering; K y = e_θ is then solved by GMRES
  // preconditioned with Kr⁻¹ (SolveRefined), which removes δ's effect (b = e_θ lies in K's
  // range when θ is determined; y's null-space components do not touch y_θ). (Before
  // 2026-11-25: one LDLᵀ of K + diag(1e-9 max H_ii I, −1e-12 I), no refinement: its rounding
  // dominated — on the noise-free 500-step block the s.e. ranged 2e-6 … 1e-3 with the δs and
  // from run to run, at the same active set.)
  const int nk = nf + I.m;
  sim::SparseMatrixXd K(nk, nk);
  K.setFromTriplets(tr.begin(), tr.end());
  K.makeCompressed();
  VectorXd d = VectorXd::Ones(nk);
  for (int pass = 0; pass < 10; ++pass) {
    VectorXd rmax = VectorXd::Zero(nk);
    for (int c = 0; c < K.outerSize(); ++c)
      for (sim::SparseMatrixXd::InnerIterator it(K, c); it; ++it)
        rmax[it.row()] = std::max(rmax[it.row()], std::abs(it.value() * d[it.row()] * d[c]));
    for (int i = 0; i < nk; ++i)
      if (rmax[i] > 0) d[i] /= std::sqrt(rmax[i]);
  }
  sim::SparseMatrixXd Ks = d.asDiagonal() * K * d.asDiagonal();
  // The θ columns of K⁻¹ (as `out`) from the solves K y = e_θ with `factor`: a regularized one
  // (check false) preconditions SolveRefined; a direct one (check true: K's own factorization,
  // pivots set aside) gives y = factor⁻¹ e_θ, accepted if ‖e_θ − K y‖ ≤ kExactResidual ‖e_θ‖, else
  // refined by SolveRefined and accepted within kDirectResidual (its preconditioned residual
  // does not see e_θ's components in the rows of the pivots set aside). A direct solution
  // already within kDirectResidual is refined by at most kShortKrylov steps: at a rounding-level
  // residual the full refinement stagnates (measured on a box sliding down an incline: 1 000
  // Krylov steps, more than half the estimation's time, left the residual 6.7e-12 and y_θ as
  // they were, bench/README.md).
  auto columns = [&](const auto& factor, bool check, sim::MatrixXd* out) {
    constexpr double kExactResidual = 1e-13, kDirectResidual = 1e-8;
    constexpr int kShortKrylov = 50;
    *out = sim::MatrixXd::Constant(I.ntheta, I.ntheta, std::numeric_limits<double>::quiet_NaN());
    for (int i = 0; i < I.ntheta; ++i) {
      const int fi = map[i];
      if (fi < 0) continue;
      VectorXd b = VectorXd::Zero(nk);
      b[fi] = d[fi];
      VectorXd y;
      // A direct factor's own solution first: it usually solves K y = b to rounding.
      double residual = std::numeric_limits<double>::infinity();
      if (check) {
        y = factor.solve(b);
        if (y.allFinite()) residual = (b - Ks * y).norm();
      }
      if (!check || !(residual <= kExactResidual * b.norm())) {
        const bool near = residual <= kDirectResidual * b.norm();
        if (!SolveRefined(Ks, factor, b, &y, near ? kShortKrylov : 0)) return false;
        if (check && !((b - Ks * y).norm() <= kDirectResidual * b.norm())) return false;
      }
      for (int j = 0; j < I.ntheta; ++j)
        if (map[j] >= 0) (*out)(j, i) = d[map[j]] * y[map[j]];
    }
    return true;
  };
  // K itself by MUMPS' LDLᵀ with 2×2 pivots, null pivots set aside (b = e_θ lies in K's range
  // when θ is determined): on a tossed cube's KKT (8 300 rows, 2 126 pivots set aside) its own
  // solve left ‖e_θ − K y‖ at 9e-16 ‖e_θ‖, where the regularized factorization below needed
  // 4 000 Krylov steps (bench/README.md, session 23).
  {
    MumpsLdlt direct;
    sim::MatrixXd out;
    if (direct.Compute(Ks) && columns(direct, true, &out)) {
      *covariance = out;
      return true;
    }
  }
  // Otherwise δ = 1e-8 first; a larger one if the factorization meets a zero pivot or the Krylov
  // solve does not converge (the refinement removes δ's effect either way; a larger δ lowers
  // Kr⁻¹'s rounding floor at the cost of more Krylov steps).
  for (const double delta : {1e-8, 1e-7, 1e-6, 1e-5}) {
    sim::SparseMatrixXd Kr = Ks;
    std::vector<Eigen::Triplet<double>> reg;
    for (int i = 0; i < nk; ++i) reg.emplace_back(i, i, i < nf ? delta : -delta);
    sim::SparseMatrixXd R(nk, nk);
    R.setFromTriplets(reg.begin(), reg.end());
    Kr += R;
    Eigen::SimplicialLDLT<sim::SparseMatrixXd, Eigen::Lower> ldlt;
    ldlt.compute(Kr);
    if (ldlt.info() != Eigen::Success) continue;
    sim::MatrixXd out;
    if (!columns(ldlt, false, &out)) continue;
    *covariance = out;
    return true;
  }
  return false;
}

}  // namespace vinci::estimation

namespace vinci::estimation {

std::vector<MpecEstimationProblem::PairTreatment> MpecEstimationProblem::ClassifyPairs(
    const VectorXd& x, double zero_tolerance) const {
  const Impl& I = *impl_;
  std::vector<PairTreatment> t(I.pairs.size(), PairTreatment::kBothZero);
  for (std::size_t k = 0; k < I.pairs.size(); ++k) {
    const auto [a, b] = I.pairs[k];
    const bool za = x[a] <= zero_tolerance, zb = x[b] <= zero_tolerance;
    if (za && zb) {
      // Biactive: the feasible set is locally the union of the two branches; holding both
      // sides (their intersection) can pin θ — measured: a noisy block log with one biactive
      // friction pair gave s.e. 3.3e-10 instead of 9.0e-4 — so neither is held (the relaxed
      // NLP's tangent space, which contains both branches').
      t[k] = PairTreatment::kFree;
    } else if (za) {
      t[k] = PairTreatment::kFirstZero;
    } else if (zb) {
      t[k] = PairTreatment::kSecondZero;
    } else {  // not complementary (an unpolished iterate): the smaller side
      t[k] = x[a] <= x[b] ? PairTreatment::kFirstZero : PairTreatment::kSecondZero;
    }
  }
  return t;
}

}  // namespace vinci::estimation
