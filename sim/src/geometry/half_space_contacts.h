// The vertex/ball passes against a half-space with the contact handed to a callback (internal
// header): CollideShapes' half-space pairs use them to append ContactPoints, and FindContacts
// writes a box's corners straight into its contact lists. One definition, so the same arithmetic.
#pragma once

#include "vinci/sim/types.h"

namespace vinci::sim::collision_internal {

/// Ball of radius r at x (r = 0: a vertex) against the half-space with outward unit normal n
/// through p: h = n · (x − p), gap = h − r; if gap ≤ envelope, emit(p_A, p_B, gap) with
/// p_A = x − r n, p_B = x − h n (the contact's normal is n).
template <typename Emit>
inline void BallHalfSpaceTo(const Vector3d& x, double r, const Vector3d& n, const Vector3d& p,
                            double envelope, Emit&& emit) {
  const double h = n.dot(x - p);
  const double gap = h - r;
  if (gap > envelope) return;
  emit(Vector3d(x - r * n), Vector3d(x - h * n), gap);
}

/// A box of half extents h at X_WA against the half-space at X_WB (normal X_WB's z axis, through
/// its origin): BallHalfSpaceTo(X_WA v, 0, ...) for the corners v = Polytope(h).vertex(i) in
/// order (bit k of i is the sign of v_k). Eigen's Transform product forms X_WA v = ((R_0 v_0 +
/// R_1 v_1) + R_2 v_2) + t (R_k the columns of X_WA.linear(), t its translation, t · 1 exact);
/// at a corner R_k v_k = ±(R_k h_k) exactly (rounding is symmetric; only a NaN's sign may
/// differ), so the three products and the four sums ±R_0 h_0 ± R_1 h_1 are formed once and each
/// corner adds ±R_2 h_2 and t.
template <typename Emit>
inline void BoxHalfSpaceTo(const Vector3d& h, const Isometry3d& X_WA, const Isometry3d& X_WB,
                           double envelope, Emit&& emit) {
  const Vector3d n = X_WB.linear().col(2);
  const Vector3d p = X_WB.translation();
  const Matrix3d& R = X_WA.linear();
  const Vector3d t = X_WA.translation();
  const Vector3d a0 = R.col(0) * h.x(), a1 = R.col(1) * h.y(), a2 = R.col(2) * h.z();
  const Vector3d na0 = -a0, na1 = -a1, na2 = -a2;
  const Vector3d s01[4] = {na0 + na1, a0 + na1, na0 + a1, a0 + a1};  // ±R_0 v_0 ± R_1 v_1
  for (int i = 0; i < 8; ++i) {
    const Vector3d x = (s01[i & 3] + ((i & 4) ? a2 : na2)) + t;
    BallHalfSpaceTo(x, 0.0, n, p, envelope, emit);
  }
}

}  // namespace vinci::sim::collision_internal
