// Narrow phase of box and polyhedron pairs: vertex features and edge–edge contacts.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "collision_internal.h"

namespace vinci::sim::collision_internal {

namespace {

using Contacts = std::vector<ContactPoint>;

// ---------------------------------------------------------------------------------------------
// Box / polyhedron pairs.

// Vertices of P against the features of Q, in Q's frame; `p_is_a` says whether P is shape A.
// A vertex x that some face plane of Q separates by more than the envelope is skipped.
// Otherwise:
//  * vertex–face: the face f of Q with the largest s_f = n_f · x − d_f among the "support
//    valid" faces whose s_f is within `slop` of the largest — those for which x is a lowest
//    point of P along n_f, within the envelope — or the plain largest s_f if none is valid.
//    The tie-break matters when x lies on an edge or corner of Q (stacked equal boxes, a box
//    sliding off a ledge): there the side faces of Q are (nearly) as separating as the top,
//    but only the top face is a sensible contact normal. The contact is x and its projection
//    onto f, gap s_f, kept if the projection lies within f grown by the envelope.
//  * vertex–edge and vertex–vertex (separated only): the closest point q of an edge or vertex
//    of Q, if q is interior to the edge, Q is supported at q in direction n = (x − q)/|x − q|
//    and P at x in direction −n (within the envelope); gap |x − q|.
void VertexFeatures(const Polytope& P, const Isometry3d& X_WP, const Polytope& Q,
                    const Isometry3d& X_WQ, double envelope, double tie, bool p_is_a,
                    Contacts* out) {
  const Isometry3d X_QP = X_WQ.inverse(Eigen::Isometry) * X_WP;
  const Matrix3d R_PQ = X_QP.linear().transpose();
  const Vector3d& p_QP = X_QP.translation();
  const int num_faces = Q.num_faces();
  const double support_tol = envelope + tie;
  // min over P of n · y (Q frame).
  auto min_p = [&](const Vector3d& n) { return -P.MaxDot(-(R_PQ * n)) + n.dot(p_QP); };
  auto emit = [&](const Vector3d& x, const Vector3d& y, const Vector3d& n, double gap) {
    EmitQFrameContact(X_WQ, p_is_a, x, y, n, gap, out);
  };
  // Per face of Q: n_f · x of the current vertex, and min_p(n_f) (formed once per call, on first
  // use: it does not depend on the vertex).
  thread_local std::vector<double> face_dot, face_min_p;
  thread_local std::vector<char> face_min_p_ready;
  face_dot.resize(static_cast<std::size_t>(num_faces));
  face_min_p.resize(static_cast<std::size_t>(num_faces));
  face_min_p_ready.assign(static_cast<std::size_t>(num_faces), 0);
  int far_face = 0;  // the face that separated the last skipped vertex: tried first
  for (int i = 0; i < P.num_vertices(); ++i) {
    const Vector3d x = X_QP * P.vertex(i);
    // A vertex with some s_f > envelope is skipped (s_max > envelope), whichever face shows it.
    if (num_faces > 0 && Q.face_normal(far_face).dot(x) - Q.face_offset(far_face) > envelope)
      continue;
    int f_max = -1;
    double s_max = -kInf;
    bool far = false;
    for (int f = 0; f < num_faces; ++f) {
      const double dot = Q.face_normal(f).dot(x);
      face_dot[static_cast<std::size_t>(f)] = dot;
      const double s = dot - Q.face_offset(f);
      if (s > envelope) {
        far = true;
        far_face = f;
        break;
      }
      if (s > s_max) {
        s_max = s;
        f_max = f;
      }
    }
    if (far) continue;
    // Vertex–face.
    int best = -1;
    double best_s = -kInf;
    for (int f = 0; f < num_faces; ++f) {
      const std::size_t fi = static_cast<std::size_t>(f);
      const double s = face_dot[fi] - Q.face_offset(f);
      if (s < s_max - support_tol || s <= best_s) continue;
      if (!face_min_p_ready[fi]) {
        face_min_p[fi] = min_p(Q.face_normal(f));
        face_min_p_ready[fi] = 1;
      }
      if (face_dot[fi] - face_min_p[fi] > support_tol) continue;
      best = f;
      best_s = s;
    }
    if (best < 0) {
      best = f_max;
      best_s = s_max;
    }
    const Vector3d n = Q.face_normal(best);
    const Vector3d y = x - best_s * n;
    const int m = Q.face_size(best);
    bool inside = true;
    for (int k = 0; k < m && inside; ++k) {
      const Vector3d v0 = Q.face_vertex(best, k);
      const Vector3d e = Q.face_vertex(best, (k + 1) % m) - v0;
      inside = e.cross(y - v0).dot(n) >= -envelope * e.norm();
    }
    if (inside) emit(x, y, n, best_s);
    if (s_max <= tie) continue;  // vertex–edge / vertex–vertex only for separated vertices
    // Vertex–edge.
    Q.ForEachEdge([&](const Vector3d& e0, const Vector3d& e1) {
      const double t = ClosestParamOnSegment(e0, e1, x);
      if (!Interior(t)) return;
      const Vector3d q = e0 + t * (e1 - e0);
      const double dist = (x - q).norm();
      if (dist > envelope || dist <= tie) return;
      const Vector3d nq = (x - q) / dist;
      if (Q.MaxDot(nq) - nq.dot(q) > support_tol || nq.dot(x) - min_p(nq) > support_tol) return;
      emit(x, q, nq, dist);
    });
    // Vertex–vertex.
    for (int j = 0; j < Q.num_vertices(); ++j) {
      const Vector3d w = Q.vertex(j);
      const double dist = (x - w).norm();
      if (dist > envelope || dist <= tie) continue;
      const Vector3d nq = (x - w) / dist;
      if (Q.MaxDot(nq) - nq.dot(w) > support_tol || nq.dot(x) - min_p(nq) > support_tol) continue;
      emit(x, w, nq, dist);
    }
  }
}

// Edge–edge contacts: for non-parallel edges whose closest points are interior to both, the
// direction n = ±(e_A × e_B) for which A's edge supports A in −n and B's edge supports B in +n
// (within the envelope); gap n · (p_A − p_B). When separated (gap ≥ 0) that gap is the exact
// distance. A penetrating one is kept only if n is (within the envelope) an axis of least
// penetration, i.e. its gap is not below the separation along any face normal of A or B —
// otherwise e.g. a box sunk 1 mm into another would also report its far edges, 2 m deep.
void EdgeEdge(const Polytope& A, const Isometry3d& X_WA, const Polytope& B, const Isometry3d& X_WB,
              double envelope, double tie, Contacts* out) {
  const Isometry3d X_BA = X_WB.inverse(Eigen::Isometry) * X_WA;
  const Matrix3d R_AB = X_BA.linear().transpose();
  const Vector3d& p_BA = X_BA.translation();
  const double support_tol = envelope + tie;
  // Largest separation along a face normal (SAT over the face axes), in B's frame.
  double face_sep = -kInf;
  for (int f = 0; f < B.num_faces(); ++f) {  // min over A of n_f · y, minus B's support d_f
    const Vector3d n = B.face_normal(f);
    face_sep = std::max(face_sep, -A.MaxDot(-(R_AB * n)) + n.dot(p_BA) - B.face_offset(f));
  }
  for (int f = 0; f < A.num_faces(); ++f) {  // the same with A's outward normals (frame A)
    const Vector3d n_A = A.face_normal(f);
    const Vector3d n_B = X_BA.linear() * n_A;
    face_sep = std::max(face_sep, -B.MaxDot(-n_B) - n_B.dot(p_BA) - A.face_offset(f));
  }
  // A contact needs |gap| ≤ reach (gap ≤ envelope if gap ≥ 0, gap ≥ face_sep − support_tol if
  // not), and |gap| = |n · (pa − pb)| with pa, pb on the two segments (interior parameters). For
  // edges at an angle θ with sin θ ≥ 1/2 the computed s and t are within ~1e-13 (scale) of the
  // exact closest points, so |gap| ≥ |pa − pb| − 1e-13 scale ≥ (separation of the segments'
  // bounding boxes) − 1e-13 scale: a pair whose boxes are farther apart than `cull` along an axis
  // cannot give a contact and is skipped before LineLineParams (the margin is 1e4× round-off).
  const double reach = std::max(envelope, support_tol - face_sep);
  const double cull = reach * (1.0 + 1e-9) + 1e-9 * (A.radius() + B.radius() + p_BA.norm());
  // Two boxes: a pair is skipped without forming it if one of its edges is farther than `cull`
  // from the other box (then |gap| > reach by the argument above, had the pair passed the cull)
  // and the computed angle tests are decided by the edge of A alone (parallel: rejected; sin θ ≥
  // 1/2: the argument holds, rejected or culled): B's edges lie
  // along B's axes, so sin² θ = u_k / |d_a|² for B's axis k (u_k: the squared components of d_a
  // off axis k), and the computed tests give "parallel" where u_k ≤ 0.999e-12 |d_a|² and
  // c_norm² ≥ 0.25 |d_a|²|d_b|² where u_k ≥ 0.2500001 |d_a|² (margins ≫ the few ulps of
  // round-off in c, c_norm and the products; the size bounds keep every square normal).
  // An edge of A is far if its bounding box is beyond `cull` from B's ([−h_B, h_B], which holds
  // every edge box of B exactly); an edge of B is far if both its ends lie beyond `cull` outside
  // one face plane of A (n_k · (x − p_BA) ∓ h_A,k, n_k A's axis k in B's frame: a lower bound of
  // the distance to A within ~1e-15 scale, inside the cull margin).
  const auto box_ok = [](const Polytope& P) {
    const Vector3d& h = P.half_extents();
    return P.is_box() && h.minCoeff() >= 1e-30 && h.maxCoeff() <= 1e30;
  };
  const bool prune = box_ok(A) && box_ok(B) && std::isfinite(cull);
  // B's edges (start, direction, length, bounding box, axis, far from A) once, not once per edge
  // of A (the same values).
  struct EdgeB {
    Vector3d b0, db;
    double length;
    Vector3d lo, hi;
    int axis;
    bool far;
  };
  thread_local std::vector<EdgeB> edges_b;
  edges_b.clear();
  B.ForEachEdge([&](const Vector3d& b0, const Vector3d& b1) {
    const Vector3d db = b1 - b0;
    const Vector3d end = b0 + db;
    edges_b.push_back({b0, db, db.norm(), b0.cwiseMin(end), b0.cwiseMax(end), 0, false});
  });
  if (prune) {
    const Matrix3d& R_BA = X_BA.linear();
    const Vector3d& h_A = A.half_extents();
    for (EdgeB& edge : edges_b) {
      const Vector3d b1 = edge.b0 + edge.db;
      edge.axis = edge.db[0] != 0.0 ? 0 : (edge.db[1] != 0.0 ? 1 : 2);
      for (int k = 0; k < 3 && !edge.far; ++k) {
        const Vector3d n = R_BA.col(k);
        const double t0 = n.dot(edge.b0 - p_BA), t1 = n.dot(b1 - p_BA);
        edge.far = std::min(t0, t1) - h_A[k] > cull || -std::max(t0, t1) - h_A[k] > cull;
      }
    }
  }
  const Vector3d& h_B = B.half_extents();
  A.ForEachEdge([&](const Vector3d& a0_A, const Vector3d& a1_A) {
    const Vector3d a0 = X_BA * a0_A;
    const Vector3d da = X_BA.linear() * (a1_A - a0_A);
    const double da_norm = da.norm();
    const Vector3d a_end = a0 + da;
    const Vector3d lo_a = a0.cwiseMin(a_end), hi_a = a0.cwiseMax(a_end);
    const double da_sq = da.squaredNorm();
    bool far_a = false;
    std::array<bool, 3> decided{false, false, false};  // per axis of B: the angle test is decided
    if (prune && da_sq >= 1e-60 && da_sq <= 1e60) {
      const Vector3d sq = da.cwiseAbs2();
      const double u[3] = {sq[1] + sq[2], sq[0] + sq[2], sq[0] + sq[1]};
      for (int k = 0; k < 3; ++k) {
        decided[k] = u[k] >= 0.2500001 * da_sq || u[k] <= 0.999e-12 * da_sq;
        far_a = far_a || lo_a[k] - h_B[k] > cull || -h_B[k] - hi_a[k] > cull;
      }
    }
    for (const EdgeB& edge : edges_b) {
      if ((far_a || edge.far) && decided[edge.axis]) continue;
      const Vector3d& b0 = edge.b0;
      const Vector3d& db = edge.db;
      const Vector3d c = da.cross(db);
      const double c_norm = c.norm();
      if (c_norm <= kEdgeParallelSin * da_norm * edge.length) continue;
      // Separation of the bounding boxes along their farthest-apart axis (a NaN coordinate gives
      // no contact either way).
      const Vector3d apart = (lo_a - edge.hi).cwiseMax(edge.lo - hi_a);
      if (apart.maxCoeff() > cull && c_norm * c_norm >= 0.25 * da_sq * (edge.length * edge.length))
        continue;
      double s, t;
      LineLineParams(a0, da, b0, db, &s, &t);
      if (!Interior(s) || !Interior(t)) continue;
      EdgeEdgeContact(A, B, R_AB, p_BA, X_WB, a0, da, s, b0, db, t, c, c_norm, envelope, face_sep,
                      support_tol, out);
    }
  });
}

}  // namespace

void PolytopePolytope(const Polytope& A, const Isometry3d& X_WA, const Polytope& B,
                      const Isometry3d& X_WB, double envelope, Contacts* out) {
  const std::size_t begin = out->size();
  const double tie = kRelTol * (A.radius() + B.radius());
  VertexFeatures(A, X_WA, B, X_WB, envelope, tie, /*p_is_a=*/true, out);
  VertexFeatures(B, X_WB, A, X_WA, envelope, tie, /*p_is_a=*/false, out);
  EdgeEdge(A, X_WA, B, X_WB, envelope, tie, out);
  RemoveDuplicateContacts(out, begin, tie);
}

}  // namespace vinci::sim::collision_internal
