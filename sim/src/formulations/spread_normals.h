// Choosing among the equivalent solutions of a statically indeterminate contact (internal).
//
// When a body pair touches at more points than its normal Jacobian has rank (a box face on a
// face: four corners, rank 3), the step's LCP solution set contains a segment of normal impulses
// p_n + t·n (G_n n = 0) that give the same velocity. Lemke returns a vertex of it: a box carried
// by two diagonally opposite corners, with the other two at w_n = 0 and p_n = 0. The step's
// velocity is the same, but the next step's warm-started basis then enforces w_n = 0 on the
// diagonal only: the unloaded corners are checked with the acceptance tolerance w_n ≥ −τ, so a
// rotation about the diagonal is free up to τ and grows (a stack of boxes is an inverted pendulum
// about each diagonal). Spreading the impulse over all touching contacts keeps every one of them
// in the basis, so the next step holds w_n = 0 on all of them and nothing can rock.
#pragma once

#include <cmath>
#include <vector>

#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim::internal {

/// The contacts whose normal impulse the spreads below may change: rigid, not a corner contact
/// (it carries a second edge row), not sliding (σ_c = 0: μ p_n = Σ p_f must stay exact), and
/// loaded (p_c > 0) or touching (|w_c| ≤ w_tol, w_c = G_n,cᵀ v1 + ∂ψ_c/∂t (+ ψ_c/h unless
/// velocity_level)). Reset marks the step's corner contacts (storage reused: no allocation once
/// sized).
class SpreadEligibility {
 public:
  void Reset(const StewartTrinkle::Assembly& a) {
    nc_ = static_cast<int>(a.contacts.size());
    nf_ = nc_ * a.nd;
    is_corner_.clear();
    if (!a.corner_contact.empty()) {
      is_corner_.assign(nc_, 0);
      for (int c : a.corner_contact) is_corner_[c] = 1;
    }
  }
  bool Eligible(const StewartTrinkle::Assembly& a, const VectorXd& v1, const VectorXd& z, int c,
                double h, bool velocity_level, double w_tol) const {
    if (!is_corner_.empty() && is_corner_[c]) return false;
    if (c < static_cast<int>(a.compliance.size()) && a.compliance[c].compliant) return false;
    if (z[nc_ + nf_ + c] != 0.0) return false;
    if (z[c] > 0.0) return true;
    double w = a.G_n.col(c).dot(v1) + a.dpsi_n[c];
    if (!velocity_level) w += a.psi_n[c] / h;
    return std::abs(w) <= w_tol;
  }

 private:
  int nc_ = 0, nf_ = 0;
  std::vector<char> is_corner_;
};

/// If some of a body pair's touching contacts carry no load, replaces the normal impulses
/// z[0, nc) of the pair's touching contacts by the point of
/// {p' ≥ 0 : G_pair p' = G_pair p} nearest (along the segment from p) to the minimum-norm
/// solution G_pair⁺ G_pair p. Only rigid, non-corner contacts take part whose complementarity
/// the change keeps: those with p_c > 0 or an end-of-step normal row w_c = G_n,cᵀ v1 + ∂ψ_c/∂t
/// (+ ψ_c/h unless velocity_level) with |w_c| ≤ w_tol, no sliding (σ_c = 0), and whose friction
/// row μ p'_c − Σ_j p_f,cj stays ≥ 0. The velocity G p (hence v1 and every other row of w) is
/// unchanged up to round-off: the change lies in the null space of the pair's normal columns
/// (singular values below 1e-10 of the largest). z's layout is the Stewart–Trinkle LCP's
/// [p_n; p_f; σ; ...]. Deterministic; O(contacts).
void SpreadIndeterminateNormals(const Scene& model, const StewartTrinkle::Assembly& a,
                                const VectorXd& v1, double h, bool velocity_level, double w_tol,
                                VectorXd* z);

/// SpreadIndeterminateNormals over the whole contact network instead of one body pair at a
/// time: a box resting on several boxes (a pile) has a load split among whole pairs that G p
/// does not fix, and a pivoting solver returns a vertex with some supporting pairs unloaded;
/// the next step's warm basis (the loaded contacts) then misses some normal directions of the
/// pile (the 100-box pile: rank 296 of 300), the supported box rocks about the loaded ones, and
/// the rocking grows until the basis is refused. If some eligible contact (as
/// SpreadIndeterminateNormals') is unloaded, the eligible normal impulses p are replaced by the
/// solution of
///
///   min ‖p'‖²  s.t.  J p' = J p,  p' ≥ 0,      J = G_n's eligible columns,
///
/// found by an active set: the minimum-norm p' = Jᵀ (J Jᵀ)⁺ J p over the free members (J Jᵀ by
/// SemidefiniteLdlt, drop tolerance 1e-10; rows of J below 1e-8 of the largest row norm, such
/// as a cube's yaw row, left out), members with p' < 0 fixed at 0, re-solved, at most 12 rounds.
/// The loaded members alone are tried first and kept if the optimality conditions hold
/// (p' ≥ 0 on them, (Jᵀy)_i ≤ 1e-9 ‖p‖∞ on the unloaded ones): one factorization on a resting
/// pile. z is left unchanged if no round succeeds, if J (p' − p) exceeds 1e-9 ‖J p‖∞ (so the
/// velocity, and every row of w, is unchanged up to that), or if a friction row μ p'_c − Σ p_f
/// would become negative (or more negative). Work: one sparse LDLᵀ of J Jᵀ (nv × nv, a
/// body-pair block pattern) per round; no allocation once the scratch (per thread) is sized.
void SpreadIndeterminateNormalsGlobally(const Scene& model, const StewartTrinkle::Assembly& a,
                                        const VectorXd& v1, double h, bool velocity_level,
                                        double w_tol, VectorXd* z);

}  // namespace vinci::sim::internal

namespace vinci::sim::internal {

/// The reverse for a pivoting solver's start basis (SolveSparseLemke factors B = {i : z_i > 0}
/// and needs it nonsingular): a copy of the warm start z in which each body pair's loaded
/// normal impulses are cut to an independent subset (the pivot columns of a column-pivoted QR
/// of the pair's normal columns, rank as SpreadIndeterminateNormals'); the others are set to 0.
void IndependentNormalsWarmStart(const Scene& model, const StewartTrinkle::Assembly& a,
                                 const VectorXd& z, VectorXd* out);

}  // namespace vinci::sim::internal
