// The active equations of a step at its solution and their factorization K (internal to
// sensitivity.cc): Linearization holds the step model's residual Jacobians, decides which side
// of each complementarity pair is held, and solves K for the derivative columns.
#pragma once

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "sensitivity_internal.h"
#include "vinci/sim/formulations/step_model.h"

namespace vinci::sim::internal {

// A column whose held active set stays feasible (to first order) only for perturbations below
// this (relative to the column variable, at least 1) is flagged: its derivative is that of the
// step's branch, which steps perturbed by any practical amount have left. Happens where K is
// nearly singular and the solver form's small compliances decide the impulse split (a GI sphere
// resting in the groove between two spheres: ∂p_n/∂z_ℓ ~ 1e8, the cone reached at ~1e-11 m).
constexpr double kMinStableRadius = 1e-6;

// The residual derivative of one column: ∂(equality, comp_a, comp_b)/∂(column).
struct ResidualColumn {
  VectorXd eq, a, b;
  bool contact_set_changed = false;
};

// The step's active equations at the linearization point and their factorization.
class Linearization {
 public:
  // `vals` holds the step equations and `J` their Jacobians (by rows) at the linearization point,
  // the first `nz` columns those of the unknowns z. `gi`: the step layout if the model is the
  // geometrically implicit stepper's (its unloaded candidate pairs are pinned, below), else null.
  // `quadratic_from` (≥ 0): the pairs from this one on have a b side quadratic in the impulses
  // (the NCP stepper's cone pairs σ ⊥ μ² p_n² − p_t²/e_t² − p_o²/e_o²); their b is judged active
  // by its first-order distance to the cone's surface, b / max|∂b/∂z| (impulse units, as the
  // linear cone row's), not by its value: at p_n ~ 1e-5 N·s a slack of 0.7 % of μ² p_n² is
  // ~1e-12, below the tolerance set by the velocity rows' residuals. `layout`: the step's unknowns'
  // layout, to find a Stewart–Trinkle-family contact's pairs (HoldUnloadedFriction); null skips
  // that rule.
  Linearization() = default;

  // (Re)computes everything from `vals`, reusing this object's storage (no result depends on an
  // earlier Compute: every member read later is overwritten or reset here).
  void Compute(const StepResiduals& vals, const SparseJacobians& J, int nz,
               const SensitivityOptions& options, bool smoothed, const StepLayout* gi,
               int quadratic_from = -1, const StepLayout* layout = nullptr) {
    ok_ = false;
    message_.clear();
    degenerate_ = 0;
    deg_.clear();
    pinned_.clear();
    w_ready_ = false;
    const SparseRows& E = J.equality;
    da_ = &J.comp_a;
    db_ = &J.comp_b;
    nz_ = nz;
    const SparseRows &A_ = *da_, &B_ = *db_;
    const int ne = E.rows(), np = A_.rows();
    if (ne + np != nz_) {
      message_ = "the step equations are not square (" + std::to_string(ne) + " equalities + " +
                 std::to_string(np) + " pairs for " + std::to_string(nz_) + " unknowns)";
      return;
    }
    const VectorXd& a = vals.comp_a;
    const VectorXd& b = vals.comp_b;
    const double scale = std::max(a.size() ? a.cwiseAbs().maxCoeff() : 0.0,
                                  b.size() ? b.cwiseAbs().maxCoeff() : 0.0);
    const double tol = options.active_tol * scale + 10.0 * vals.Violation();
    a_ = a;
    b_ = b;
    tol_ = tol;
    b_unit_.assign(static_cast<std::size_t>(np), 1.0);
    for (int i = std::max(quadratic_from, 0); quadratic_from >= 0 && i < np; ++i) {
      const double g = B_.RowMaxAbs(i, nz_);
      if (g > 0.0) b_unit_[static_cast<std::size_t>(i)] = 1.0 / g;
    }
    smoothed_ = smoothed;
    side_.assign(np, 'a');
    weight_a_ = VectorXd::Zero(np);
    weight_b_ = VectorXd::Zero(np);
    double b_max = 0.0;  // max |B| (GI only)
    for (int i = 0; gi && i < np; ++i) b_max = std::max(b_max, B_.RowMaxAbs(i, nz_));
    const double inert_tol = gi ? options.active_tol * std::max(1.0, b_max) : 0.0;
    std::vector<int>& inert = inert_;  // GI pairs whose cone pair is inert
    inert.clear();
    for (int i = 0; i < np; ++i) {
      const double bi = b[i] * b_unit_[static_cast<std::size_t>(i)];
      const bool a0 = a[i] <= tol, b0 = bi <= tol;
      if (gi && !smoothed && a0 && b0 && B_.RowMaxAbs(i, nz_) <= inert_tol) {
        // A GI cone pair (σ, μ² p_n² − ‖p_t‖²) of an unloaded pair, p_n = p_t = 0: b has no
        // first-order variation and the pair's friction rows μ p_n v_t' + σ p_t are 0 = 0 to
        // first order, leaving p_t free in K. The cone with p_n at 0 allows no p_t: the pair is
        // held at dσ = 0 and its friction rows are replaced by dp_t = 0 (below). Not a kink of
        // the solution map where p_n is held at 0 (if p_n is degenerate, its own pair is).
        int col = 0;
        A_.RowMaxAbs(i, nz_, &col);
        const int k = col - gi->sigma();
        if (k >= 0 && k < gi->nc) {
          side_[i] = 'i';
          inert.push_back(k);
          continue;
        }
      }
      if (a0 && b0) {
        ++degenerate_;
        switch (options.degenerate) {
          case DegenerateRule::kDirectional:
            side_[i] = 'd';
            deg_.push_back(i);
            break;
          case DegenerateRule::kHoldA:
            side_[i] = 'a';
            break;
          case DegenerateRule::kHoldB:
            side_[i] = 'b';
            break;
        }
      } else {
        side_[i] = a[i] <= bi ? 'a' : 'b';
      }
    }
    if (layout && !gi && !smoothed && quadratic_from < 0 &&
        options.degenerate == DegenerateRule::kDirectional)
      HoldUnloadedFriction(*layout);
    for (int i = 0; i < np; ++i) {
      if (smoothed) {
        // ∂φ_ε = (1 − a/r) da + (1 − b/r) db,  r = √(a² + b² + 2ε) > 0.
        const double r = std::sqrt(a[i] * a[i] + b[i] * b[i] + 2.0 * options.smoothing);
        weight_a_[i] = 1.0 - a[i] / r;
        weight_b_[i] = 1.0 - b[i] / r;
      } else if (side_[i] == 'b') {
        weight_b_[i] = 1.0;
      } else {
        weight_a_[i] = 1.0;  // held a, or a degenerate pair's λ = da row
      }
    }
    // GI equality rows (geometrically_implicit.h): [dynamics (nv); kinematics (nq); per pair:
    // separation (d), normals (d), A side, B side, friction (d − 1 = nd)]. An inert pair's
    // friction rows are replaced by dp_t = 0.
    pinned_col_.assign(ne, -1);
    for (int k : inert) {
      for (int j = 0; j < gi->nd; ++j) {
        const int row = gi->nv + gi->nq + k * (3 * gi->nd + 4) + 2 * gi->nd + 4 + j;
        if (row >= ne) continue;
        pinned_col_[row] = gi->pf() + k * gi->nd + j;
        pinned_.push_back(row);
      }
    }
    // K by rows: the equalities, then per pair its held row (A's or B's as it is: weights 1 and
    // 0), or the smoothed step's weighted sum.
    K_.Reset(nz_);
    for (int i = 0; i < ne; ++i) {
      if (pinned_col_[i] >= 0) {
        K_.Push(pinned_col_[i], 1.0);
        K_.EndRow();
      } else {
        K_.AppendRow(E, i, nz_);
      }
    }
    for (int i = 0; i < np; ++i) {
      if (!smoothed) {
        K_.AppendRow(weight_a_[i] == 1.0 ? A_ : B_, i, nz_);
        continue;
      }
      const double wa = weight_a_[i], wb = weight_b_[i];
      int ka = A_.ptr[i], kb = B_.ptr[i];
      const int ea = A_.ptr[i + 1], eb = B_.ptr[i + 1];
      while (true) {
        const int ca = ka < ea ? A_.col[ka] : nz_, cb = kb < eb ? B_.col[kb] : nz_;
        const int c = std::min(ca, cb);
        if (c >= nz_) break;
        const double va = ca == c ? A_.val[ka++] : 0.0, vb = cb == c ? B_.val[kb++] : 0.0;
        const double v = wa * va + wb * vb;
        if (v != 0.0) K_.Push(c, v);
      }
      K_.EndRow();
    }
    if (smoothed) deg_.clear();
    // K factored structurally (StructuredSolver): the held impulses and the end positions
    // eliminated, the small core by LU with complete pivoting, which reveals its rank; a
    // singular core (redundant contacts: a box face on a plane, four corners all loaded:
    // impulses not unique; the solutions' state part is still unique where consistent) takes
    // the minimum-norm solution. Partial-pivoting LU, tried earlier for speed, took
    // such a K as regular — its rcond estimate was above a 1e-10 cut-off — and returned wrong
    // state derivatives (SensitivityTest.RedundantRestingContacts…).
    solver_.Compute(K_);
    k_norm_ = 0.0;
    for (double v : K_.val) k_norm_ = std::max(k_norm_, std::abs(v));
    if (!deg_.empty()) {
      const int nd = static_cast<int>(deg_.size());
      BD_.setZero(nd, nz_);
      for (int j = 0; j < nd; ++j)
        for (int k = B_.ptr[deg_[j]]; k < B_.ptr[deg_[j] + 1] && B_.col[k] < nz_; ++k)
          BD_(j, B_.col[k]) = B_.val[k];
      bd_norm_ = BD_.cwiseAbs().rowwise().sum().maxCoeff();
    }
    ne_ = ne;
    ok_ = true;
  }

  Linearization(const Linearization&) = delete;  // solver_ points to K_
  Linearization& operator=(const Linearization&) = delete;

  bool ok() const { return ok_; }
  const std::string& message() const { return message_; }
  int degenerate() const { return degenerate_; }
  int nz() const { return nz_; }

  // dz for one residual column (the derivative of the residuals along the column). Returns
  // false if the active system is inconsistent along it; *unsolved is set if the sensitivity
  // LCP could not be solved (the λ = 0 branch is returned).
  bool Solve(const ResidualColumn& r, VectorXd* dz, bool* unsolved) const {
    *unsolved = false;
    VectorXd rhs(nz_);
    rhs.head(ne_) = r.eq;
    rhs.tail(nz_ - ne_) = weight_a_.cwiseProduct(r.a) + weight_b_.cwiseProduct(r.b);
    for (int row : pinned_) rhs[row] = 0.0;
    *dz = solver_.Solve(VectorXd(-rhs));
    VectorXd Kdz;
    solver_.Multiply(*dz, &Kdz);
    const double resid = (Kdz + rhs).cwiseAbs().maxCoeff();
    const double ref = rhs.cwiseAbs().maxCoeff() + k_norm_ * dz->cwiseAbs().maxCoeff();
    if (!std::isfinite(resid) || resid > 1e-6 * ref + 1e-300) return false;
    if (deg_.empty()) return true;
    const int nd = static_cast<int>(deg_.size());
    LcpProblem p;
    p.q.resize(nd);
    for (int j = 0; j < nd; ++j) p.q[j] = db_->RowDot(deg_[j], *dz, nz_) + r.b[deg_[j]];
    // λ = 0 is the solution unless some q_j is negative beyond the round-off of its terms. The
    // solve's error in any entry of dz is relative to ‖dz‖∞ (not to that entry), so B_D dz is
    // round-off up to ‖B_D‖∞ ‖dz‖∞ times the solve's accuracy: a column whose dz lies where B_D
    // does not look (q ~ 1e-19 for ‖dz‖∞ ~ 1e-2, a rolling sphere's) keeps λ = 0.
    const double qscale = bd_norm_ * dz->cwiseAbs().maxCoeff() + r.b.cwiseAbs().maxCoeff();
    if (p.q.minCoeff() >= -1e-10 * qscale) return true;
    if (!w_ready_) {
      // K⁻¹ E_D and the sensitivity LCP's matrix, once per step and only when some column needs
      // them (most columns of a sticking step keep λ = 0).
      MatrixXd ED = MatrixXd::Zero(nz_, nd);
      for (int j = 0; j < nd; ++j) ED(ne_ + deg_[j], j) = 1.0;
      W_ = solver_.Solve(ED);
      lcp_M_ = BD_ * W_;
      w_ready_ = true;
    }
    p.M = lcp_M_;
    VectorXd lambda;
    if (!SolveAtUnitScale(&p, &lambda)) {
      // As posed (a q of round-off size, ‖q‖∞ ~ 1e-20, can be infeasible at unit scale and
      // pass within Lemke's absolute tolerances at its own).
      const SolverReport rep = LemkeSolver().Solve(p, nullptr, &lambda);
      if (rep.status != SolverStatus::kSolved) {
        *unsolved = true;
        return true;
      }
    }
    *dz += W_ * lambda;
    return true;
  }

  // The sensitivity LCP (M, q) is positively homogeneous in q (λ solves (M, q) iff cλ solves
  // (M, cq), c > 0): solved first at ‖q‖∞ ∈ [1, 2), with c a power of two (exact). Lemke's pivot
  // and tie tolerances are absolute, so at a column's own tiny scale (‖q‖∞ ~ 1e-20) its answer is
  // accurate only to that size and goes to the Fischer–Burmeister polish. No polish, regularized
  // retries or Newton fallback here: on failure *problem is restored and false returned.
  static bool SolveAtUnitScale(LcpProblem* problem, VectorXd* lambda) {
    const double q_norm = problem->q.lpNorm<Eigen::Infinity>();
    if (!(q_norm > 0.0) || !std::isfinite(q_norm)) return false;
    const int exponent = std::ilogb(q_norm);
    problem->q *= std::ldexp(1.0, -exponent);
    LemkeOptions options;
    options.regularization = 0.0;
    options.newton_fallback = false;
    options.polish = false;
    const SolverReport rep = LemkeSolver(options).Solve(*problem, nullptr, lambda);
    problem->q *= std::ldexp(1.0, exponent);
    if (rep.status != SolverStatus::kSolved) return false;
    *lambda *= std::ldexp(1.0, exponent);
    return true;
  }

  // A move of the unknowns within the step's solution set toward its relative interior, or an
  // empty vector. With redundant contacts (K singular) the solver's impulse split is one point of
  // a set of solutions with the same velocities, and it may put a contact exactly at its friction
  // cone edge (a degenerate pair) while a redundant contact is strictly inside its cone: held
  // there, the sensitivity LCP lets the first slide where the true step moves load to the other
  // (docs/sensitivity.md, "Redundant contacts"). Along a null vector n of K (the held rows, the
  // degenerate pairs' a rows included, stay as they are; q_ℓ+1 and ν_ℓ+1 must not move) whose
  // rates B_i n are ≥ 0 on every degenerate pair and > 0 on some, half the step to the first held
  // side that reaches 0 makes those pairs strictly complementary. Greedy over K's null vectors
  // (each direction tried with both signs), the move accumulated. `nx_rows`: the leading unknowns
  // (q_ℓ+1, ν_ℓ+1) that must not move.
  VectorXd InteriorShift(int nx_rows, const VectorXd& z) const {
    if (deg_.empty() || smoothed_ || !solver_.singular()) return VectorXd();
    const MatrixXd N = solver_.NullSpace();
    if (N.cols() == 0) return VectorXd();
    VectorXd shift = VectorXd::Zero(nz_);
    VectorXd a = a_, b = b_;
    std::vector<char> side = side_;
    const double zmax = std::max(1e-300, z.tail(nz_ - nx_rows).cwiseAbs().maxCoeff());
    bool moved = false;
    for (int k = 0; k < N.cols(); ++k) {
      const double nn = N.col(k).cwiseAbs().maxCoeff();
      if (!(nn > 0.0) || N.col(k).head(nx_rows).cwiseAbs().maxCoeff() > 1e-10 * nn) continue;
      // A sign can gain only if the degenerate pairs' rates B_D n are all ≥ −eps along it and
      // some > eps: screened on the degenerate rows alone before the full products below (a
      // resting box's null vectors redistribute normal impulses and move no degenerate pair).
      // Until a move changes which pairs are degenerate (side[]), BD_'s rows are exactly those.
      if (!moved) {
        const VectorXd rd = BD_ * (N.col(k) / nn);
        const double lo = rd.size() ? rd.minCoeff() : 0.0, hi = rd.size() ? rd.maxCoeff() : 0.0;
        if ((hi <= 1e-9 && lo >= -1e-9) || (hi > 1e-9 && lo < -1e-9)) continue;
      }
      for (double sign : {1.0, -1.0}) {
        const VectorXd n = sign * N.col(k) / nn;
        VectorXd ra(side.size()), rb(side.size());
        for (int i = 0; i < static_cast<int>(side.size()); ++i) {
          ra[i] = da_->RowDot(i, n, nz_);
          rb[i] = db_->RowDot(i, n, nz_);
        }
        const double eps = 1e-9;
        int gain = 0;
        bool allowed = true;
        double t = zmax;  // no farther than the impulses' own scale
        for (int i = 0; i < static_cast<int>(side.size()) && allowed; ++i) {
          if (side[i] == 'd') {
            if (std::abs(ra[i]) > eps) allowed = false;  // a_D is held: must not move
            if (rb[i] < -eps) allowed = false;
            if (rb[i] > eps) ++gain;
          } else if (side[i] == 'a') {
            if (rb[i] < -eps) t = std::min(t, b[i] / -rb[i]);
          } else if (side[i] == 'b') {
            if (ra[i] < -eps) t = std::min(t, a[i] / -ra[i]);
          }
        }
        if (!allowed || gain == 0 || !(t > 0.0)) continue;
        t *= 0.5;
        shift += t * n;
        a += t * ra;
        b += t * rb;
        for (int i = 0; i < static_cast<int>(side.size()); ++i)
          if (side[i] == 'd' && rb[i] > eps) side[i] = 'a';
        moved = true;
        break;
      }
    }
    return moved ? shift : VectorXd();
  }

  // The friction pairs of a contact whose normal impulse is held at 0 while its σ > 0 (w_σ =
  // μ p_n − Σ p_f = 0 held; a contact with tangential slip ν_t, σ = max_j(−d_jᵀ ν_t)): the
  // directions attaining that maximum have p_f,j = 0 = w_j and would be taken as degenerate, yet
  // with p_n and every p_f held at 0 the cone row is 0 = 0 and leaves dσ free, so K's minimum-norm
  // solution sets dσ = 0 and the sensitivity LCP sees w_j's rate d_jᵀ dν_t as if σ could not follow
  // it: friction at an unloaded point (∂ν_x/∂ν_x = 0.375 on a box sliding 1 mm above the floor).
  //   Separated (p_n's pair held at p_n = 0, the gap rate > 0): the cone admits no friction for
  //   any small perturbation; the directions are held at dp_f,j = 0 (not degenerate).
  //   Touching and unloaded (p_n's pair degenerate), one direction attaining the maximum: the
  //   contact slides along −d_j if it takes load; w_j = 0 is held (dσ = −d_jᵀ dν_t), p_f,j free,
  //   tied to dp_n by the cone row. Several directions (ν_t bisecting two): left degenerate.
  // Pairs are mapped to contacts through their a sides (p_n, p_f, σ at the StepLayout's columns,
  // the Stewart–Trinkle pair order [p_n; p_f; σ; ...]); any other layout is left as it is.
  void HoldUnloadedFriction(const StepLayout& l) {
    const int nc = l.nc, nd = l.nd, np = static_cast<int>(side_.size());
    if (nc == 0 || nd == 0 || np < nc * (nd + 2)) return;
    const auto unit_at = [&](int pair, int col) {
      const SparseRows& A = *da_;
      int count = 0;
      bool hit = false;
      for (int k = A.ptr[pair]; k < A.ptr[pair + 1]; ++k) {
        if (A.col[k] >= nz_ || A.val[k] == 0.0) continue;
        ++count;
        hit = A.col[k] == col && A.val[k] == 1.0;
      }
      return count == 1 && hit;
    };
    for (int k = 0; k < nc; ++k)
      if (!unit_at(k, l.pn() + k) || !unit_at(nc + nc * nd + k, l.sigma() + k) ||
          !unit_at(nc + k * nd, l.pf() + k * nd))
        return;
    bool changed = false;
    for (int k = 0; k < nc; ++k) {
      const int n = k, f0 = nc + k * nd, s = nc + nc * nd + k;
      if (side_[s] != 'b' || a_[n] > tol_ || (side_[n] != 'a' && side_[n] != 'd')) continue;
      int held = 0;
      for (int i = f0; i < f0 + nd; ++i) held += side_[i] == 'd';
      if (held == 0 || (side_[n] == 'd' && held > 1)) continue;
      for (int i = f0; i < f0 + nd; ++i)
        if (side_[i] == 'd') side_[i] = side_[n] == 'a' ? 'a' : 'b';
      degenerate_ -= held;
      changed = true;
    }
    if (!changed) return;
    deg_.clear();
    for (int i = 0; i < np; ++i)
      if (side_[i] == 'd') deg_.push_back(i);
  }

  // How far along a column (dz its solution, r its residual column) the held active set stays
  // feasible to first order: the smallest t at which a strictly positive side of a held pair
  // (b where a is held at 0, a where b is) reaches 0. +∞ for the smoothed step, and where no
  // positive side decreases. Degenerate pairs are excluded (their side is chosen per column).
  double StableRadius(const ResidualColumn& r, const VectorXd& dz) const {
    double rho = std::numeric_limits<double>::infinity();
    if (smoothed_) return rho;
    for (int i = 0; i < static_cast<int>(side_.size()); ++i) {
      double slack = 0.0, rate = 0.0;
      if (side_[i] == 'a') {
        slack = b_[i] * b_unit_[static_cast<std::size_t>(i)];
        rate = (db_->RowDot(i, dz, nz_) + r.b[i]) * b_unit_[static_cast<std::size_t>(i)];
      } else if (side_[i] == 'b') {
        slack = a_[i];
        rate = da_->RowDot(i, dz, nz_) + r.a[i];
      } else {
        continue;
      }
      if (rate < 0.0 && slack > tol_) rho = std::min(rho, slack / -rate);
    }
    return rho;
  }

 private:
  bool ok_ = false;
  std::string message_;
  int nz_ = 0, ne_ = 0, degenerate_ = 0;
  // The pairs' Jacobians A = ∂comp_a/∂z, B = ∂comp_b/∂z: the leading nz columns of the
  // Jacobians Compute was given (which must outlive this linearization's use; no copy).
  const SparseRows *da_ = nullptr, *db_ = nullptr;
  SparseRows K_;
  MatrixXd BD_;
  double bd_norm_ = 0.0;          // ‖B_D‖∞ (largest absolute row sum)
  mutable MatrixXd W_, lcp_M_;    // K⁻¹ E_D and B_D K⁻¹ E_D, computed on first need
  mutable bool w_ready_ = false;  // W_, lcp_M_ hold this Compute's
  VectorXd weight_a_, weight_b_;
  VectorXd a_, b_;              // the pairs' sides at the linearization point
  double tol_ = 0.0;            // a side at most this is 0 (active)
  std::vector<double> b_unit_;  // per pair, b's factor into the units tol_ applies to
  bool smoothed_ = false;
  std::vector<char> side_;  // per pair: 'a' / 'b' held, 'd' degenerate, 'i' inert GI pair
  std::vector<int> deg_;
  std::vector<int> pinned_;      // equality rows replaced by dp_t = 0 (inert GI pairs)
  std::vector<int> pinned_col_;  // per equality row: its dp_t column if pinned, else −1
  std::vector<int> inert_;       // Compute's storage
  StructuredSolver solver_;      // of K_ (keeps a pointer to it: Linearization is not copied)
  double k_norm_ = 0.0;
};

}  // namespace vinci::sim::internal
