// Narrow phase of box–box pairs: PolytopePolytope's contacts (the same features, the same tests
// and the same arithmetic on every feature that is examined, so the same bits), with the box
// structure used to skip, before any per-feature arithmetic, the features whose tests provably
// fail.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "collision_internal.h"

namespace vinci::sim::collision_internal {

namespace {

using Contacts = std::vector<ContactPoint>;

// The q-th (q = 0..3) corner of a box without bit k, ascending: Polytope::ForEachEdge's start
// corners of the edges along axis k.
// VertexFeatures' inside test e × (y − v0) · n ≥ −envelope |e| on edge k of box face f
// (e = v1 − v0 = ±2h_a e_a, n = ±e_k): the cross product's k-th component is ±fl(e_a w_b) (the
// other products are zeros), |e| = sqrt(fl(e_a²)) = 2h_a, so the test is
// fl(sign · 2h_a · w_b) ≥ −fl(envelope · 2h_a) with w_b = fl(y_b − v0_b), bit for bit; `sign`
// from a unit box (it does not depend on the sizes).
struct FaceEdge {
  int a, b;     // the edge's axis and the third axis
  double sign;  // (e × e_b) · n / |e|
};
struct FaceEdges {
  FaceEdge edge[6][4];
  FaceEdges() {
    const Vector3d one(1.0, 1.0, 1.0);
    const Polytope unit(one);
    for (int f = 0; f < 6; ++f) {
      for (int k = 0; k < 4; ++k) {
        const Vector3d e =
            unit.vertex(kBoxFaceLoops[f][(k + 1) % 4]) - unit.vertex(kBoxFaceLoops[f][k]);
        FaceEdge& fe = edge[f][k];
        fe.a = e[0] != 0.0 ? 0 : (e[1] != 0.0 ? 1 : 2);
        fe.b = 3 - f / 2 - fe.a;
        fe.sign = e.cross(Vector3d::Unit(fe.b)).dot(unit.face_normal(f)) / e.norm();
      }
    }
  }
};
const FaceEdges kFaceEdges;

constexpr int kCorner[3][4] = {{0, 2, 4, 6}, {0, 1, 4, 5}, {0, 1, 2, 3}};
inline int Corner(int k, int q) { return kCorner[k][q]; }

// VertexFeatures (collision_polytope.cc) for two boxes, X_QP = X_WQ⁻¹ X_WP and the corners of P
// in Q's frame, x_Q[i] = X_QP · (corner i of P), formed by the caller.
// A face normal of Q is ±e_k, so n_f · x = ±x_k exactly (the other products are zeros) and
// s_f = ±x_k − h_k. A vertex–edge or vertex–vertex candidate q of Q has q_m = ±h_m exactly on
// every axis m it does not run along, and the computed |x − q| ≥ |x_m − q_m| (rounding is
// monotone and sqrt(fl(a²)) = |a|): a candidate with |x_m − q_m| > envelope on such an axis
// fails the test dist ≤ envelope and is skipped before any arithmetic.
void BoxVertexFeatures(const Polytope& P, const Polytope& Q, const Isometry3d& X_QP,
                       const std::array<Vector3d, 8>& x_Q, const Isometry3d& X_WQ, double envelope,
                       double tie, bool p_is_a, Contacts* out) {
  const Matrix3d R_PQ = X_QP.linear().transpose();
  const Vector3d& p_QP = X_QP.translation();
  const Vector3d& h = Q.half_extents();
  const double support_tol = envelope + tie;
  auto min_p = [&](const Vector3d& n) { return -P.MaxDot(-(R_PQ * n)) + n.dot(p_QP); };
  auto emit = [&](const Vector3d& x, const Vector3d& y, const Vector3d& n, double gap) {
    EmitQFrameContact(X_WQ, p_is_a, x, y, n, gap, out);
  };
  std::array<double, 6> face_min_p;
  std::array<bool, 6> face_min_p_ready{};
  for (int i = 0; i < 8; ++i) {
    const Vector3d& x = x_Q[i];
    std::array<double, 6> dot, s;
    bool far = false;
    for (int k = 0; k < 3; ++k) {
      dot[2 * k] = x[k];
      dot[2 * k + 1] = -x[k];
      s[2 * k] = dot[2 * k] - h[k];
      s[2 * k + 1] = dot[2 * k + 1] - h[k];
      far |= (s[2 * k] > envelope) | (s[2 * k + 1] > envelope);
    }
    if (far) continue;
    int f_max = -1;
    double s_max = -kInf;
    for (int f = 0; f < 6; ++f) {
      if (s[f] > s_max) {
        s_max = s[f];
        f_max = f;
      }
    }
    // Vertex–face.
    int best = -1;
    double best_s = -kInf;
    for (int f = 0; f < 6; ++f) {
      if (s[f] < s_max - support_tol || s[f] <= best_s) continue;
      if (!face_min_p_ready[f]) {
        face_min_p[f] = min_p(Q.face_normal(f));
        face_min_p_ready[f] = true;
      }
      if (dot[f] - face_min_p[f] > support_tol) continue;
      best = f;
      best_s = s[f];
    }
    if (best < 0) {
      best = f_max;
      best_s = s_max;
    }
    const Vector3d n = Q.face_normal(best);
    const Vector3d y = x - best_s * n;
    bool inside = true;
    for (int k = 0; k < 4 && inside; ++k) {
      const FaceEdge& fe = kFaceEdges.edge[best][k];
      const double w = y[fe.b] - ((kBoxFaceLoops[best][k] >> fe.b) & 1 ? h[fe.b] : -h[fe.b]);
      inside = (fe.sign * (2.0 * h[fe.a])) * w >= -envelope * (2.0 * h[fe.a]);
    }
    if (inside) emit(x, y, n, best_s);
    if (s_max <= tie) continue;  // vertex–edge / vertex–vertex only for separated vertices
    // |x_m − c_m| ≤ envelope for the corner c = vertex(j) of Q, per axis m.
    // (Not used for an envelope so small that a² could underflow.)
    std::array<bool, 3> near_lo, near_hi;
    for (int m = 0; m < 3; ++m) {
      near_lo[m] = envelope < 1e-100 || std::abs(x[m] + h[m]) <= envelope;
      near_hi[m] = envelope < 1e-100 || std::abs(x[m] - h[m]) <= envelope;
    }
    const auto near = [&](int j, int m) { return (j >> m) & 1 ? near_hi[m] : near_lo[m]; };
    // Vertex–edge, in Polytope::ForEachEdge's order.
    for (int axis = 0, bit = 1; axis < 3; ++axis, bit <<= 1) {
      const int m1 = (axis + 1) % 3, m2 = (axis + 2) % 3;
      for (int j = 0; j < 8; ++j) {
        if ((j & bit) != 0 || !near(j, m1) || !near(j, m2)) continue;
        const Vector3d e0 = Q.vertex(j), e1 = Q.vertex(j | bit);
        const double t = ClosestParamOnSegment(e0, e1, x);
        if (!Interior(t)) continue;
        const Vector3d q = e0 + t * (e1 - e0);
        const double dist = (x - q).norm();
        if (dist > envelope || dist <= tie) continue;
        const Vector3d nq = (x - q) / dist;
        if (Q.MaxDot(nq) - nq.dot(q) > support_tol || nq.dot(x) - min_p(nq) > support_tol) continue;
        emit(x, q, nq, dist);
      }
    }
    // Vertex–vertex.
    for (int j = 0; j < 8; ++j) {
      if (!near(j, 0) || !near(j, 1) || !near(j, 2)) continue;
      const Vector3d w = Q.vertex(j);
      const double dist = (x - w).norm();
      if (dist > envelope || dist <= tie) continue;
      const Vector3d nq = (x - w) / dist;
      if (Q.MaxDot(nq) - nq.dot(w) > support_tol || nq.dot(x) - min_p(nq) > support_tol) continue;
      emit(x, w, nq, dist);
    }
  }
}

// EdgeEdge (collision_polytope.cc) for two boxes with its pruning on (`cull` finite, sizes in
// range), face_sep, `margin` and `a_B` = X_BA · (corners of A) formed by the caller (a_B as
// EdgeEdge forms its edges' start points). The 4 edges of a box along one axis have the same
// direction vector, bit for bit (corner differences are 0 or 2h exactly), so the direction terms
// are formed once per axis. EdgeEdge skips a pair when the angle test is decided by A's edge alone
// (`decided`, per axis of B) and one edge is far from the other box; here a decided pair is also
// skipped when the two edges' bounding boxes are farther apart than `cull` along an axis (the
// computed tests reject it: as parallel, or by that very bounding-box test, whose operands are
// formed here exactly as there: an edge of B along axis k at corner c spans [−h_k, h_k] on k and is
// the point c_m on the other axes m), and a decided parallel pair is skipped always. So only the
// pairs EdgeEdge examines to the end are formed, with its arithmetic, in its order.
// A pair emits only if, for n = +axis or n = −axis (axis = c/|c|, per pair of axes), B's edge
// passes B.MaxDot(n) − n · p_b ≤ support_tol and A's edge n · p_a − min_A(n) ≤ support_tol. As
// n ⟂ d_a, d_b (to round-off), n · p_b and n · p_a equal n · b0 and n · a0 to within far less than
// `margin`, so a pair failing both orientations with b0, a0 and support_tol + margin is skipped
// (the Gauss-map test of two edges: most pairs of two boxes fail it); likewise a pair whose
// gap n · (p_a − p_b), to within `margin` n · a0 − n · b0, is outside EdgeEdge's window for
// both orientations.
void BoxEdgeEdge(const Polytope& A, const Polytope& B, const Isometry3d& X_BA,
                 const std::array<Vector3d, 8>& a_B, const Isometry3d& X_WB, double envelope,
                 double tie, double face_sep, double cull, double margin, Contacts* out) {
  const Matrix3d R_AB = X_BA.linear().transpose();
  const Matrix3d& R_BA = X_BA.linear();
  const Vector3d& p_BA = X_BA.translation();
  const Vector3d& h_A = A.half_extents();
  const Vector3d& h_B = B.half_extents();
  const double support_tol = envelope + tie;
  // EdgeEdge keeps a gap in [min(0, face_sep − support_tol), envelope].
  const double gap_lo = std::min(0.0, face_sep - support_tol) - margin;
  const double gap_hi = envelope + margin;
  // B's edge directions and lengths, per axis.
  std::array<Vector3d, 3> db_axis;
  std::array<double, 3> length_axis;
  for (int k = 0, bit = 1; k < 3; ++k, bit <<= 1) {
    db_axis[k] = B.vertex(bit) - B.vertex(0);
    length_axis[k] = db_axis[k].norm();
  }
  // n_k · (corner of B − p_BA) for A's axes n_k in B's frame, per corner of B (on first use).
  std::array<Vector3d, 8> t_corner;
  std::array<bool, 8> t_ready{};
  const auto t_of = [&](int j) -> const Vector3d& {
    if (!t_ready[j]) {
      const Vector3d c = B.vertex(j);
      for (int k = 0; k < 3; ++k) {
        const Vector3d n = R_BA.col(k);
        t_corner[j][k] = n.dot(c - p_BA);
      }
      t_ready[j] = true;
    }
    return t_corner[j];
  };
  // EdgeEdge's `far` of B's edge from corner j to corner j | bit.
  const auto far_b = [&](int j, int bit) {
    const Vector3d& t0 = t_of(j);
    const Vector3d& t1 = t_of(j | bit);
    for (int k = 0; k < 3; ++k) {
      if (std::min(t0[k], t1[k]) - h_A[k] > cull || -std::max(t0[k], t1[k]) - h_A[k] > cull)
        return true;
    }
    return false;
  };
  for (int g = 0, bit_a = 1; g < 3; ++g, bit_a <<= 1) {
    const Vector3d da = X_BA.linear() * (A.vertex(bit_a) - A.vertex(0));
    const double da_norm = da.norm();
    const double da_sq = da.squaredNorm();
    std::array<bool, 3> decided{false, false, false}, parallel{false, false, false};
    const bool in_range = da_sq >= 1e-60 && da_sq <= 1e60;
    if (in_range) {
      const Vector3d sq = da.cwiseAbs2();
      const double u[3] = {sq[1] + sq[2], sq[0] + sq[2], sq[0] + sq[1]};
      for (int k = 0; k < 3; ++k) {
        parallel[k] = u[k] <= 0.999e-12 * da_sq;
        decided[k] = u[k] >= 0.2500001 * da_sq || parallel[k];
      }
    }
    const bool all_decided = decided[0] && decided[1] && decided[2];
    // The terms of a pair that depend on the two directions only (EdgeEdge's and LineLineParams'
    // expressions), per axis k of B; `skip`: every pair fails EdgeEdge's angle test.
    struct AxisTerms {
      Vector3d c, axis;
      double c_norm, aa, ee, bb, denom;
      bool wide;  // c_norm² ≥ ¼ |d_a|² |d_b|²: the bounding-box test applies
      bool skip;
      double max_a, axis_p;       // A.MaxDot(±R_AB axis) and axis · p_BA
      std::array<double, 4> d_b;  // axis · b0 for B's edges along k (ForEachEdge order)
      // Bit q (q + 4): B's edge from its q-th corner may pass B's support test with n = +axis
      // (n = −axis).
      int b_support;
    };
    std::array<AxisTerms, 3> terms;
    for (int k = 0; k < 3; ++k) {
      AxisTerms& a = terms[k];
      a.skip = decided[k] && parallel[k];  // EdgeEdge rejects every such pair as parallel
      if (a.skip) continue;
      const Vector3d& db = db_axis[k];
      a.c = da.cross(db);
      a.c_norm = a.c.norm();
      a.skip = a.c_norm <= kEdgeParallelSin * da_norm * length_axis[k];
      if (a.skip) continue;
      a.wide = a.c_norm * a.c_norm >= 0.25 * da_sq * (length_axis[k] * length_axis[k]);
      a.aa = da.dot(da);
      a.ee = db.dot(db);
      a.bb = da.dot(db);
      a.denom = a.aa * a.ee - a.bb * a.bb;
      a.b_support = 0;
      a.axis = a.c / a.c_norm;
      a.max_a = A.MaxDot(-(R_AB * a.axis));
      a.axis_p = a.axis.dot(p_BA);
      const double max_b = B.MaxDot(a.axis);
      for (int q = 0; q < 4; ++q) {
        const double d = a.axis.dot(B.vertex(Corner(k, q)));
        a.d_b[q] = d;
        if (max_b - d <= support_tol + margin) a.b_support |= 1 << q;
        if (max_b + d <= support_tol + margin) a.b_support |= 1 << (q + 4);
      }
    }
    for (int i = 0; i < 8; ++i) {
      if ((i & bit_a) != 0) continue;
      const Vector3d& a0 = a_B[i];
      // Candidates per axis k of B (bit q: B's edge from its q-th corner): the pairs that may
      // pass the support tests and the gap window for n = +axis or n = −axis.
      std::array<int, 3> cand{0, 0, 0};
      for (int k = 0; k < 3; ++k) {
        const AxisTerms& a = terms[k];
        if (a.skip) continue;
        const double d_a = a.axis.dot(a0);
        if (d_a - (-a.max_a + a.axis_p) <= support_tol + margin) {  // A's support, n = +axis
          for (int q = 0; q < 4; ++q) {
            const double gap = d_a - a.d_b[q];
            if ((a.b_support >> q & 1) && gap >= gap_lo && gap <= gap_hi) cand[k] |= 1 << q;
          }
        }
        if (-d_a - (-a.max_a - a.axis_p) <= support_tol + margin) {  // n = −axis
          for (int q = 0; q < 4; ++q) {
            const double gap = a.d_b[q] - d_a;
            if ((a.b_support >> (q + 4) & 1) && gap >= gap_lo && gap <= gap_hi) cand[k] |= 1 << q;
          }
        }
      }
      if ((cand[0] | cand[1] | cand[2]) == 0) continue;
      const Vector3d a_end = a0 + da;
      const Vector3d lo_a = a0.cwiseMin(a_end), hi_a = a0.cwiseMax(a_end);
      bool far_a = false;
      // Bits 2m and 2m + 1: the bounding box of A's edge is within `cull` of the coordinate −h_m
      // and of +h_m on axis m of B; ok_span[m]: of the interval [−h_m, h_m].
      int ok = 0;
      std::array<bool, 3> ok_span{};
      if (in_range) {
        for (int m = 0; m < 3; ++m) {
          const bool below = lo_a[m] - h_B[m] > cull, above = -h_B[m] - hi_a[m] > cull;
          far_a |= below | above;
          ok_span[m] = !(below | above);
          ok |= int(!((lo_a[m] - -h_B[m] > cull) | above)) << (2 * m);
          ok |= int(!(below | (h_B[m] - hi_a[m] > cull))) << (2 * m + 1);
        }
        if (far_a && all_decided) continue;
      }
      for (int k = 0, bit = 1; k < 3; ++k, bit <<= 1) {
        const AxisTerms& a = terms[k];
        if (cand[k] == 0 || (decided[k] && (far_a || !ok_span[k]))) continue;
        const Vector3d& db = db_axis[k];
        const int m1 = k == 0 ? 1 : 0, m2 = k == 2 ? 1 : 2;  // the other axes, m1 < m2
        for (int q = 0; q < 4; ++q) {
          if ((cand[k] >> q & 1) == 0) continue;
          const int j = Corner(k, q);
          if (decided[k] &&
              (!(ok >> (2 * m1 + (q & 1)) & ok >> (2 * m2 + (q >> 1)) & 1) || far_b(j, bit)))
            continue;
          const Vector3d b0 = B.vertex(j);
          if (a.wide) {
            const Vector3d b_end = b0 + db;
            const Vector3d lo_b = b0.cwiseMin(b_end), hi_b = b0.cwiseMax(b_end);
            const Vector3d apart = (lo_a - hi_b).cwiseMax(lo_b - hi_a);
            if (apart.maxCoeff() > cull) continue;
          }
          // LineLineParams(a0, da, b0, db).
          const Vector3d r = a0 - b0;
          const double cc = da.dot(r), ff = db.dot(r);
          const double s = (a.bb * ff - cc * a.ee) / a.denom;
          const double t = (a.aa * ff - a.bb * cc) / a.denom;
          if (!Interior(s) || !Interior(t)) continue;
          EdgeEdgeContact(A, B, R_AB, p_BA, X_WB, a0, da, s, b0, db, t, a.c, a.c_norm, envelope,
                          face_sep, support_tol, out);
        }
      }
    }
  }
}

}  // namespace

void BoxBox(const Polytope& A, const Isometry3d& X_WA, const Polytope& B, const Isometry3d& X_WB,
            double envelope, Contacts* out) {
  const auto box_ok = [](const Polytope& P) {
    const Vector3d& h = P.half_extents();
    return P.is_box() && h.minCoeff() >= 1e-30 && h.maxCoeff() <= 1e30;
  };
  if (!box_ok(A) || !box_ok(B) || !std::isfinite(envelope) || !X_WA.matrix().allFinite() ||
      !X_WB.matrix().allFinite()) {
    PolytopePolytope(A, X_WA, B, X_WB, envelope, out);
    return;
  }
  const double tie = kRelTol * (A.radius() + B.radius());
  const double support_tol = envelope + tie;
  const Isometry3d X_BA = X_WB.inverse(Eigen::Isometry) * X_WA;
  const Matrix3d R_AB = X_BA.linear().transpose();
  const Vector3d& p_BA = X_BA.translation();
  // EdgeEdge's SAT over the face axes and its cull distance (the same expressions).
  // With n = ±e_k, R n = ±(column k of R) exactly, so each MaxDot serves both faces of an axis
  // and n · p = ±p_k: the same values as EdgeEdge's loop over the 12 faces.
  double sep_b = -kInf, sep_a = -kInf;  // over B's faces and over A's faces
  const Matrix3d& R_BA = X_BA.linear();
  for (int k = 0; k < 3; ++k) {  // B's faces: min over A of n_f · y, minus B's support d_f
    const double max_a = A.MaxDot(R_AB.col(k));
    sep_b = std::max(sep_b, -max_a + p_BA[k] - B.half_extents()[k]);
    sep_b = std::max(sep_b, -max_a + -p_BA[k] - B.half_extents()[k]);
  }
  for (int k = 0; k < 3; ++k) {  // A's faces (outward normals ±R_BA e_k in B's frame)
    const Vector3d n_B = R_BA.col(k);
    const double max_b = B.MaxDot(n_B);
    const double d = n_B.dot(p_BA);
    sep_a = std::max(sep_a, -max_b - d - A.half_extents()[k]);
    sep_a = std::max(sep_a, -max_b - -d - A.half_extents()[k]);
  }
  const double face_sep = std::max(sep_b, sep_a);
  const double reach = std::max(envelope, support_tol - face_sep);
  const double cull = reach * (1.0 + 1e-9) + 1e-9 * (A.radius() + B.radius() + p_BA.norm());
  if (!std::isfinite(cull)) {
    PolytopePolytope(A, X_WA, B, X_WB, envelope, out);
    return;
  }
  // Features that cannot give a contact. sep_b is min over A's corners of s_f for a face f of B,
  // which VertexFeatures forms per corner to within round-off (≪ margin): above envelope +
  // margin every corner of A is skipped there; likewise sep_a for B's corners. EdgeEdge keeps a
  // gap ≤ envelope and ≥ min(0, face_sep − support_tol): none if that window is empty (as in
  // the end-of-step penetration check, whose envelope is −max_penetration).
  // `margin`: a round-off allowance (≫ the few ulps of scale by which the pre-tests' values here
  // and in BoxEdgeEdge differ from the values the tests they stand for form).
  const double margin = 1e-10 * (A.radius() + B.radius() + p_BA.norm());
  const bool vertices_a = !(sep_b > envelope + margin);
  const bool vertices_b = !(sep_a > envelope + margin);
  const bool edges = !(envelope < std::min(0.0, face_sep - support_tol));
  if (!vertices_a && !vertices_b && !edges) return;
  const std::size_t begin = out->size();
  std::array<Vector3d, 8> a_B;  // the corners of A in B's frame
  for (int i = 0; i < 8; ++i) a_B[i] = X_BA * A.vertex(i);
  if (vertices_a) BoxVertexFeatures(A, B, X_BA, a_B, X_WB, envelope, tie, /*p_is_a=*/true, out);
  if (vertices_b) {
    const Isometry3d X_AB = X_WA.inverse(Eigen::Isometry) * X_WB;
    std::array<Vector3d, 8> b_A;  // the corners of B in A's frame
    for (int i = 0; i < 8; ++i) b_A[i] = X_AB * B.vertex(i);
    BoxVertexFeatures(B, A, X_AB, b_A, X_WA, envelope, tie, /*p_is_a=*/false, out);
  }
  if (edges) BoxEdgeEdge(A, B, X_BA, a_B, X_WB, envelope, tie, face_sep, cull, margin, out);
  RemoveDuplicateContacts(out, begin, tie);
}

}  // namespace vinci::sim::collision_internal
