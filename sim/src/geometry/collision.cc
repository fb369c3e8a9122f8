// Narrow phase: dispatch, shared contact utilities and the spatial pairs.
//
// Every pair function takes its shapes in a canonical order (lower SpatialRank first) and
// appends contacts with that shape as A; CollideShapes flips the contacts when it swapped.
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "collision_internal.h"

namespace vinci::sim {
namespace collision_internal {

const char* ShapeTypeName(ShapeType t) {
  switch (t) {
    case ShapeType::kHalfSpace:
      return "kHalfSpace";
    case ShapeType::kSphere:
      return "kSphere";
    case ShapeType::kBox:
      return "kBox";
    case ShapeType::kCapsule:
      return "kCapsule";
    case ShapeType::kPolyhedron:
      return "kPolyhedron";
    case ShapeType::kHalfPlane:
      return "kHalfPlane";
    case ShapeType::kDisc:
      return "kDisc";
    case ShapeType::kPolygon:
      return "kPolygon";
    case ShapeType::kSegment:
      return "kSegment";
    case ShapeType::kConcavePolygon:
      return "kConcavePolygon";
    case ShapeType::kEllipsoid:
      return "kEllipsoid";
    case ShapeType::kSuperquadric:
      return "kSuperquadric";
    case ShapeType::kCylinder:
      return "kCylinder";
    case ShapeType::kLens:
      return "kLens";
    case ShapeType::kEllipse:
      return "kEllipse";
    case ShapeType::kSuperellipse:
      return "kSuperellipse";
  }
  return "unknown ShapeType";
}

Vector3d AnyPerpendicular(const Vector3d& u) {
  Eigen::Index i = 0;
  u.cwiseAbs().minCoeff(&i);
  Vector3d e = Vector3d::Zero();
  e[i] = 1.0;
  return u.cross(e).normalized();
}

void FlipContacts(std::vector<ContactPoint>* out, std::size_t begin) {
  for (std::size_t i = begin; i < out->size(); ++i) {
    ContactPoint& c = (*out)[i];
    std::swap(c.p_A_W, c.p_B_W);
    c.n_W = -c.n_W;
    if (c.corner) {
      std::swap(c.p2_A_W, c.p2_B_W);
      c.n2_W = -c.n2_W;
    }
  }
}

void RemoveDuplicateContacts(std::vector<ContactPoint>* out, std::size_t begin, double tol) {
  std::vector<ContactPoint>& v = *out;
  std::size_t kept = begin;
  const bool screen = tol >= 1e-100 && tol <= 1e100;
  for (std::size_t i = begin; i < v.size(); ++i) {
    bool duplicate = false;
    for (std::size_t j = begin; j < kept && !duplicate; ++j) {
      // A coordinate difference above tol rules a pair out without the norms: fl(√fl(Σ x_k²)) ≥
      // |x_0| when x_0² neither under- nor overflows (fl(√fl(x²)) = |x|), so the test fails.
      if (screen && (std::abs(v[i].p_A_W[0] - v[j].p_A_W[0]) > tol ||
                     std::abs(v[i].p_A_W[1] - v[j].p_A_W[1]) > tol ||
                     std::abs(v[i].p_A_W[2] - v[j].p_A_W[2]) > tol))
        continue;
      duplicate =
          (v[i].p_A_W - v[j].p_A_W).norm() <= tol && (v[i].p_B_W - v[j].p_B_W).norm() <= tol;
    }
    if (duplicate) continue;
    if (kept != i) v[kept] = v[i];
    ++kept;
  }
  v.resize(kept);
}

}  // namespace collision_internal

const char* ShapeKeyword(ShapeType t) {
  switch (t) {
    case ShapeType::kHalfSpace:
      return "halfspace";
    case ShapeType::kSphere:
      return "sphere";
    case ShapeType::kBox:
      return "box";
    case ShapeType::kCapsule:
      return "capsule";
    case ShapeType::kPolyhedron:
      return "polyhedron";
    case ShapeType::kHalfPlane:
      return "halfplane";
    case ShapeType::kDisc:
      return "disc";
    case ShapeType::kPolygon:
      return "polygon";
    case ShapeType::kSegment:
      return "segment";
    case ShapeType::kEllipsoid:
      return "ellipsoid";
    case ShapeType::kSuperquadric:
      return "superquadric";
    case ShapeType::kCylinder:
      return "cylinder";
    case ShapeType::kLens:
      return "lens";
    case ShapeType::kEllipse:
      return "ellipse";
    case ShapeType::kSuperellipse:
      return "superellipse";
    case ShapeType::kConcavePolygon:
      return "concave_polygon";
  }
  return "unknown";
}

namespace {

using collision_internal::AnyPerpendicular;
using collision_internal::ClosestParamOnSegment;
using collision_internal::ClosestSegmentSegment;
using collision_internal::HullScratch;
using collision_internal::kAxisParallelSin;
using collision_internal::kEdgeParallelSin;
using collision_internal::kInf;
using collision_internal::kParamEps;
using collision_internal::kRelTol;
using collision_internal::MakePolytope;
using collision_internal::Polytope;
using collision_internal::RemoveDuplicateContacts;
using collision_internal::ShapeTypeName;

using Contacts = std::vector<ContactPoint>;

[[noreturn]] void ThrowPair(const Shape& a, const Shape& b, const char* why) {
  throw std::invalid_argument(std::string("CollideShapes: cannot collide ") +
                              ShapeTypeName(a.type) + " with " + ShapeTypeName(b.type) + " (" +
                              why + ")");
}

// Two spheres (centres cA, cB). `fallback_n` is used when the centres coincide within `tiny`.
void AddSpherePair(const Vector3d& cA, double rA, const Vector3d& cB, double rB,
                   const Vector3d& fallback_n, double tiny, double envelope, Contacts* out) {
  const Vector3d d = cA - cB;
  const double dist = d.norm();
  const Vector3d n = dist > tiny ? Vector3d(d / dist) : fallback_n;
  const double gap = (dist > tiny ? dist : n.dot(d)) - rA - rB;
  if (gap > envelope) return;
  out->push_back({cA - rA * n, cB + rB * n, n, gap});
}

// End points of a capsule's segment in world.
std::pair<Vector3d, Vector3d> CapsuleEnds(const Shape& s, const Isometry3d& X_WS) {
  const Vector3d axis = X_WS.linear().col(2) * s.half_length;
  return {X_WS.translation() - axis, X_WS.translation() + axis};
}

// ---------------------------------------------------------------------------------------------
// Half-space B.

// Ball of radius r at x (r = 0: a vertex) against the half-space with outward unit normal n
// through p.
void BallHalfSpace(const Vector3d& x, double r, const Vector3d& n, const Vector3d& p,
                   double envelope, Contacts* out) {
  const double h = n.dot(x - p);
  const double gap = h - r;
  if (gap > envelope) return;
  out->push_back({x - r * n, x - h * n, n, gap});
}

void SphereHalfSpace(const Shape& a, const Isometry3d& X_WA, const Isometry3d& X_WB,
                     double envelope, Contacts* out) {
  BallHalfSpace(X_WA.translation(), a.radius, X_WB.linear().col(2), X_WB.translation(), envelope,
                out);
}

void CapsuleHalfSpace(const Shape& a, const Isometry3d& X_WA, const Isometry3d& X_WB,
                      double envelope, Contacts* out) {
  const auto [p0, p1] = CapsuleEnds(a, X_WA);
  const Vector3d n = X_WB.linear().col(2);
  BallHalfSpace(p0, a.radius, n, X_WB.translation(), envelope, out);
  if (a.half_length > 0.0) BallHalfSpace(p1, a.radius, n, X_WB.translation(), envelope, out);
}

void PolytopeHalfSpace(const Polytope& A, const Isometry3d& X_WA, const Isometry3d& X_WB,
                       double envelope, Contacts* out) {
  const Vector3d n = X_WB.linear().col(2);
  for (int i = 0; i < A.num_vertices(); ++i) {
    BallHalfSpace(X_WA * A.vertex(i), 0.0, n, X_WB.translation(), envelope, out);
  }
}

// ---------------------------------------------------------------------------------------------
// Sphere A.

void SphereSphere(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                  double envelope, Contacts* out) {
  const double tiny = kRelTol * (a.radius + b.radius);
  AddSpherePair(X_WA.translation(), a.radius, X_WB.translation(), b.radius, Vector3d::UnitZ(), tiny,
                envelope, out);
}

void SphereBox(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
               double envelope, Contacts* out) {
  const Vector3d c_W = X_WA.translation();
  const Matrix3d& R_WB = X_WB.linear();
  const Vector3d c = R_WB.transpose() * (c_W - X_WB.translation());
  const Vector3d& h = b.half_extents;
  const Vector3d q = c.cwiseMax(-h).cwiseMin(h);
  Vector3d n, p_B;
  double dist;
  if (q != c) {  // centre outside: closest point is the clamped point
    const Vector3d d = c - q;
    dist = d.norm();
    n = d / dist;
    p_B = q;
  } else {  // centre inside (or on the surface): leave through the nearest face
    int axis = 0;
    double depth = kInf;
    for (int i = 0; i < 3; ++i) {
      const double di = h[i] - std::abs(c[i]);
      if (di < depth) {
        depth = di;
        axis = i;
      }
    }
    const double sign = c[axis] >= 0.0 ? 1.0 : -1.0;
    n = Vector3d::Zero();
    n[axis] = sign;
    p_B = c;
    p_B[axis] = sign * h[axis];
    dist = -depth;
  }
  const double gap = dist - a.radius;
  if (gap > envelope) return;
  const Vector3d n_W = R_WB * n;
  out->push_back({c_W - a.radius * n_W, X_WB * p_B, n_W, gap});
}

void SphereCapsule(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                   double envelope, Contacts* out) {
  const Vector3d c = X_WA.translation();
  const auto [b0, b1] = CapsuleEnds(b, X_WB);
  const double t = ClosestParamOnSegment(b0, b1, c);
  const double tiny = kRelTol * (a.radius + b.radius + b.half_length);
  AddSpherePair(c, a.radius, b0 + t * (b1 - b0), b.radius, AnyPerpendicular(X_WB.linear().col(2)),
                tiny, envelope, out);
}

// Signed distance from x to a polytope (both in its frame), the closest surface point and the
// outward normal there. Inside: the nearest face plane (exact for convex polytopes).
struct PointQuery {
  double dist;
  Vector3d closest;
  Vector3d normal;
};

// Closest point to x on face f, whose plane x is at signed distance s from.
Vector3d ClosestPointOnFace(const Polytope& P, int f, const Vector3d& x, double s) {
  const Vector3d n = P.face_normal(f);
  const Vector3d y = x - s * n;
  const int m = P.face_size(f);
  bool inside = true;
  for (int k = 0; k < m && inside; ++k) {
    const Vector3d a = P.face_vertex(f, k);
    const Vector3d b = P.face_vertex(f, (k + 1) % m);
    inside = (b - a).cross(y - a).dot(n) >= 0.0;
  }
  if (inside) return y;
  Vector3d best = y;
  double best_d2 = kInf;
  for (int k = 0; k < m; ++k) {
    const Vector3d a = P.face_vertex(f, k);
    const Vector3d b = P.face_vertex(f, (k + 1) % m);
    const Vector3d q = a + ClosestParamOnSegment(a, b, x) * (b - a);
    const double d2 = (x - q).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = q;
    }
  }
  return best;
}

PointQuery PointToPolytope(const Polytope& P, const Vector3d& x) {
  int f_max = 0;
  double s_max = -kInf;
  for (int f = 0; f < P.num_faces(); ++f) {
    const double s = P.face_normal(f).dot(x) - P.face_offset(f);
    if (s > s_max) {
      s_max = s;
      f_max = f;
    }
  }
  if (s_max <= 0.0) {
    const Vector3d n = P.face_normal(f_max);
    return {s_max, x - s_max * n, n};
  }
  // Outside: the closest point lies on a face whose plane separates x.
  Vector3d best = x;
  double best_d2 = kInf;
  for (int f = 0; f < P.num_faces(); ++f) {
    const double s = P.face_normal(f).dot(x) - P.face_offset(f);
    if (s <= 0.0) continue;
    const Vector3d q = ClosestPointOnFace(P, f, x, s);
    const double d2 = (x - q).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = q;
    }
  }
  const double dist = std::sqrt(best_d2);
  return {dist, best, (x - best) / dist};
}

void SpherePolytope(const Shape& a, const Isometry3d& X_WA, const Polytope& B,
                    const Isometry3d& X_WB, double envelope, Contacts* out) {
  const Vector3d c_W = X_WA.translation();
  const Matrix3d& R_WB = X_WB.linear();
  const PointQuery q = PointToPolytope(B, R_WB.transpose() * (c_W - X_WB.translation()));
  const double gap = q.dist - a.radius;
  if (gap > envelope) return;
  const Vector3d n_W = R_WB * q.normal;
  out->push_back({c_W - a.radius * n_W, X_WB * q.closest, n_W, gap});
}

// ---------------------------------------------------------------------------------------------
// Capsule A.

void CapsuleCapsule(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                    double envelope, Contacts* out) {
  const auto [a0, a1] = CapsuleEnds(a, X_WA);
  const auto [b0, b1] = CapsuleEnds(b, X_WB);
  const Vector3d da = a1 - a0;
  const Vector3d db = b1 - b0;
  const double la = da.norm();
  const double lb = db.norm();
  const double tiny = kRelTol * (la + lb + a.radius + b.radius);
  const Vector3d ua = X_WA.linear().col(2);
  const Vector3d ub = X_WB.linear().col(2);
  const Vector3d cross = ua.cross(ub);
  const double sin_angle = cross.norm();
  // Normal used when the axes touch: perpendicular to both axes, pointing from B to A.
  Vector3d fallback = sin_angle > kEdgeParallelSin ? Vector3d(cross / sin_angle)
                                                   : AnyPerpendicular(la > 0.0 ? ua : ub);
  if (fallback.dot(X_WA.translation() - X_WB.translation()) < 0.0) fallback = -fallback;

  if (la > 0.0 && lb > 0.0 && sin_angle < kAxisParallelSin) {
    // Nearly parallel: one contact at each end of the overlap of B's projection onto A.
    const double t0 = ua.dot(b0 - a0);
    const double t1 = ua.dot(b1 - a0);
    const double lo = std::max(0.0, std::min(t0, t1));
    const double hi = std::min(la, std::max(t0, t1));
    if (hi - lo > tiny) {
      for (const double t : {lo, hi}) {
        const Vector3d pa = a0 + t * ua;
        const Vector3d pb = b0 + ClosestParamOnSegment(b0, b1, pa) * db;
        AddSpherePair(pa, a.radius, pb, b.radius, fallback, tiny, envelope, out);
      }
      return;
    }
  }
  double s, t;
  ClosestSegmentSegment(a0, a1, b0, b1, &s, &t);
  AddSpherePair(a0 + s * da, a.radius, b0 + t * db, b.radius, fallback, tiny, envelope, out);
}

// Closest points of two non-parallel lines p0 + s d and q0 + t e.
void LineLineParams(const Vector3d& p0, const Vector3d& d, const Vector3d& q0, const Vector3d& e,
                    double* s, double* t) {
  const Vector3d r = p0 - q0;
  const double aa = d.dot(d), ee = e.dot(e), bb = d.dot(e), cc = d.dot(r), ff = e.dot(r);
  const double denom = aa * ee - bb * bb;
  *s = (bb * ff - cc * ee) / denom;
  *t = (aa * ff - bb * cc) / denom;
}

bool Interior(double t) { return t > kParamEps && t < 1.0 - kParamEps; }

// Capsule A against a box or polyhedron B. Contacts: each end sphere (exact signed distance);
// each vertex and edge of B whose closest point on the axis is interior and which supports B
// in the direction of that point (within the envelope); and, if the axis passes through B
// with both ends outside, the middle of the part inside, pushed out through its nearest face.
void CapsulePolytope(const Shape& a, const Isometry3d& X_WA, const Polytope& B,
                     const Isometry3d& X_WB, double envelope, Contacts* out) {
  const std::size_t begin = out->size();
  const Matrix3d& R_WB = X_WB.linear();
  const Isometry3d X_BW = X_WB.inverse(Eigen::Isometry);
  const auto [a0_W, a1_W] = CapsuleEnds(a, X_WA);
  const Vector3d p0 = X_BW * a0_W;
  const Vector3d p1 = X_BW * a1_W;
  const double r = a.radius;
  const double tiny = kRelTol * (B.radius() + a.half_length + r);
  auto emit = [&](const Vector3d& axis_point, const Vector3d& p_B, const Vector3d& n, double gap) {
    out->push_back({X_WB * (axis_point - r * n), X_WB * p_B, R_WB * n, gap});
  };

  bool end_inside = false;
  for (const Vector3d& p : {p0, p1}) {
    const PointQuery q = PointToPolytope(B, p);
    end_inside = end_inside || q.dist <= 0.0;
    if (q.dist - r <= envelope) emit(p, q.closest, q.normal, q.dist - r);
    if (a.half_length <= 0.0) break;
  }
  if (a.half_length > 0.0) {
    const Vector3d d = p1 - p0;
    const double support_tol = envelope + tiny;
    // Vertices of B against the interior of the axis.
    for (int i = 0; i < B.num_vertices(); ++i) {
      const Vector3d v = B.vertex(i);
      const double t = ClosestParamOnSegment(p0, p1, v);
      if (!Interior(t)) continue;
      const Vector3d w = p0 + t * d - v;
      const double dist = w.norm();
      if (dist - r > envelope || dist <= tiny) continue;
      const Vector3d n = w / dist;
      if (B.MaxDot(n) - n.dot(v) > support_tol) continue;
      emit(p0 + t * d, v, n, dist - r);
    }
    // Edges of B against the interior of the axis.
    B.ForEachEdge([&](const Vector3d& e0, const Vector3d& e1) {
      const Vector3d de = e1 - e0;
      if (d.cross(de).norm() <= kEdgeParallelSin * d.norm() * de.norm()) return;
      double s, t;
      LineLineParams(p0, d, e0, de, &s, &t);
      if (!Interior(s) || !Interior(t)) return;
      const Vector3d ps = p0 + s * d;
      const Vector3d pe = e0 + t * de;
      const Vector3d w = ps - pe;
      const double dist = w.norm();
      if (dist - r > envelope || dist <= tiny) return;
      const Vector3d n = w / dist;
      if (B.MaxDot(n) - n.dot(pe) > support_tol) return;
      emit(ps, pe, n, dist - r);
    });
    // Axis through B with both ends outside (penetration deeper than the radius): clip the axis
    // against B's face planes (Cyrus–Beck).
    if (!end_inside) {
      double t_in = 0.0, t_out = 1.0;
      bool hit = true;
      for (int f = 0; f < B.num_faces() && hit; ++f) {
        const Vector3d n = B.face_normal(f);
        const double num = B.face_offset(f) - n.dot(p0);  // inside where t · (n · d) ≤ num
        const double den = n.dot(d);
        if (den == 0.0) {
          hit = num >= 0.0;
        } else if (den < 0.0) {
          t_in = std::max(t_in, num / den);
        } else {
          t_out = std::min(t_out, num / den);
        }
        hit = hit && t_in <= t_out;
      }
      if (hit) {
        const Vector3d m = p0 + 0.5 * (t_in + t_out) * d;
        const PointQuery q = PointToPolytope(B, m);
        if (q.dist - r <= envelope) emit(m, q.closest, q.normal, q.dist - r);
      }
    }
  }
  RemoveDuplicateContacts(out, begin, tiny);
}

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
  const Matrix3d& R_WQ = X_WQ.linear();
  const int num_faces = Q.num_faces();
  const double support_tol = envelope + tie;
  // min over P of n · y (Q frame).
  auto min_p = [&](const Vector3d& n) { return -P.MaxDot(-(R_PQ * n)) + n.dot(p_QP); };
  auto emit = [&](const Vector3d& x, const Vector3d& y, const Vector3d& n, double gap) {
    const Vector3d n_W = R_WQ * n;
    if (p_is_a) {
      out->push_back({X_WQ * x, X_WQ * y, n_W, gap});
    } else {
      out->push_back({X_WQ * y, X_WQ * x, -n_W, gap});
    }
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
  const Matrix3d& R_WB = X_WB.linear();
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
      const Vector3d pa = a0 + s * da;
      const Vector3d pb = b0 + t * db;
      const Vector3d axis = c / c_norm;
      const double sep = axis.dot(pa - pb);
      // Try the separating orientation first.
      for (const double sign : {sep >= 0.0 ? 1.0 : -1.0, sep >= 0.0 ? -1.0 : 1.0}) {
        const Vector3d n = sign * axis;
        const double gap = sign * sep;
        if (gap > envelope || (gap < 0.0 && gap < face_sep - support_tol)) continue;
        if (B.MaxDot(n) - n.dot(pb) > support_tol) continue;
        const double min_a = -A.MaxDot(-(R_AB * n)) + n.dot(p_BA);
        if (n.dot(pa) - min_a > support_tol) continue;
        out->push_back({X_WB * pa, X_WB * pb, R_WB * n, gap});
        break;
      }
    }
  });
}

void PolytopePolytope(const Polytope& A, const Isometry3d& X_WA, const Polytope& B,
                      const Isometry3d& X_WB, double envelope, Contacts* out) {
  const std::size_t begin = out->size();
  const double tie = kRelTol * (A.radius() + B.radius());
  VertexFeatures(A, X_WA, B, X_WB, envelope, tie, /*p_is_a=*/true, out);
  VertexFeatures(B, X_WB, A, X_WA, envelope, tie, /*p_is_a=*/false, out);
  EdgeEdge(A, X_WA, B, X_WB, envelope, tie, out);
  RemoveDuplicateContacts(out, begin, tie);
}

// ---------------------------------------------------------------------------------------------
// Dispatch.

// Canonical order of the spatial kinds: the lower rank is shape A of a pair function.
int SpatialRank(ShapeType t) {
  switch (t) {
    case ShapeType::kSphere:
      return 0;
    case ShapeType::kCapsule:
      return 1;
    case ShapeType::kBox:
      return 2;
    case ShapeType::kPolyhedron:
      return 3;
    default:
      return 4;  // kHalfSpace
  }
}

bool IsPolytope(ShapeType t) { return t == ShapeType::kBox || t == ShapeType::kPolyhedron; }

// a and b with SpatialRank(a) ≤ SpatialRank(b).
void CollideSpatialOrdered(const Shape& a, const Isometry3d& X_WA, const Shape& b,
                           const Isometry3d& X_WB, double envelope, Contacts* out) {
  HullScratch scratch_a, scratch_b;  // only used by unprepared polyhedra
  switch (a.type) {
    case ShapeType::kSphere:
      switch (b.type) {
        case ShapeType::kSphere:
          return SphereSphere(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kCapsule:
          return SphereCapsule(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kBox:
          return SphereBox(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kPolyhedron:
          return SpherePolytope(a, X_WA, MakePolytope(b, &scratch_b), X_WB, envelope, out);
        default:
          return SphereHalfSpace(a, X_WA, X_WB, envelope, out);
      }
    case ShapeType::kCapsule:
      if (b.type == ShapeType::kCapsule) return CapsuleCapsule(a, X_WA, b, X_WB, envelope, out);
      if (IsPolytope(b.type)) {
        return CapsulePolytope(a, X_WA, MakePolytope(b, &scratch_b), X_WB, envelope, out);
      }
      return CapsuleHalfSpace(a, X_WA, X_WB, envelope, out);
    case ShapeType::kBox:
    case ShapeType::kPolyhedron: {
      const Polytope pa = MakePolytope(a, &scratch_a);
      if (IsPolytope(b.type)) {
        return PolytopePolytope(pa, X_WA, MakePolytope(b, &scratch_b), X_WB, envelope, out);
      }
      return PolytopeHalfSpace(pa, X_WA, X_WB, envelope, out);
    }
    default:
      ThrowPair(a, b, "two half-spaces");
  }
}

}  // namespace

void CollideShapes(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                   double envelope, std::vector<ContactPoint>* out) {
  if (out == nullptr) throw std::invalid_argument("CollideShapes: out is null");
  for (const Shape* s : {&a, &b})
    if (RequiresImplicitContact(s->type))
      throw std::invalid_argument(std::string("CollideShapes: shape '") + s->name +
                                  "': shape type " + ShapeKeyword(s->type) +
                                  " requires formulation: gi (no polygonal contact)");
  if (IsPlanar(a.type) != IsPlanar(b.type)) ThrowPair(a, b, "planar with spatial");
  if (IsPlanar(a.type)) {
    collision_internal::CollidePlanar(a, X_WA, b, X_WB, envelope, out);
    return;
  }
  if (SpatialRank(a.type) <= SpatialRank(b.type)) {
    CollideSpatialOrdered(a, X_WA, b, X_WB, envelope, out);
    return;
  }
  const std::size_t begin = out->size();
  CollideSpatialOrdered(b, X_WB, a, X_WA, envelope, out);
  collision_internal::FlipContacts(out, begin);
}

}  // namespace vinci::sim
