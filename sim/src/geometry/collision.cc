// Narrow phase: dispatch, shared contact utilities and the spatial pairs (box / polyhedron pairs:
// collision_polytope.cc).
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
#include "half_space_contacts.h"

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
using collision_internal::Interior;
using collision_internal::kAxisParallelSin;
using collision_internal::kEdgeParallelSin;
using collision_internal::kInf;
using collision_internal::kParamEps;
using collision_internal::kRelTol;
using collision_internal::LineLineParams;
using collision_internal::MakePolytope;
using collision_internal::Polytope;
using collision_internal::PolytopePolytope;
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
// through p (half_space_contacts.h).
void BallHalfSpace(const Vector3d& x, double r, const Vector3d& n, const Vector3d& p,
                   double envelope, Contacts* out) {
  collision_internal::BallHalfSpaceTo(x, r, n, p, envelope,
                                      [&](const Vector3d& p_A, const Vector3d& p_B, double gap) {
                                        out->push_back({p_A, p_B, n, gap});
                                      });
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

// A box of half extents h against the half-space: PolytopeHalfSpace(Polytope(h), ...) bit for bit
// (the same vertices in the same order, the same arithmetic), without building the polytope
// (half_space_contacts.h).
void BoxHalfSpace(const Vector3d& h, const Isometry3d& X_WA, const Isometry3d& X_WB,
                  double envelope, Contacts* out) {
  const Vector3d n = X_WB.linear().col(2);
  collision_internal::BoxHalfSpaceTo(h, X_WA, X_WB, envelope,
                                     [&](const Vector3d& p_A, const Vector3d& p_B, double gap) {
                                       out->push_back({p_A, p_B, n, gap});
                                     });
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
  switch (a.type) {
    case ShapeType::kSphere:
      switch (b.type) {
        case ShapeType::kSphere:
          return SphereSphere(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kCapsule:
          return SphereCapsule(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kBox:
          return SphereBox(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kPolyhedron: {
          HullScratch scratch_b;  // only used by an unprepared polyhedron
          return SpherePolytope(a, X_WA, MakePolytope(b, &scratch_b), X_WB, envelope, out);
        }
        default:
          return SphereHalfSpace(a, X_WA, X_WB, envelope, out);
      }
    case ShapeType::kCapsule:
      if (b.type == ShapeType::kCapsule) return CapsuleCapsule(a, X_WA, b, X_WB, envelope, out);
      if (IsPolytope(b.type)) {
        HullScratch scratch_b;
        return CapsulePolytope(a, X_WA, MakePolytope(b, &scratch_b), X_WB, envelope, out);
      }
      return CapsuleHalfSpace(a, X_WA, X_WB, envelope, out);
    case ShapeType::kBox:
    case ShapeType::kPolyhedron: {
      if (a.type == ShapeType::kBox && b.type == ShapeType::kHalfSpace)
        return BoxHalfSpace(a.half_extents, X_WA, X_WB, envelope, out);
      HullScratch scratch_a, scratch_b;
      const Polytope pa = MakePolytope(a, &scratch_a);
      if (a.type == ShapeType::kBox && b.type == ShapeType::kBox) {
        return collision_internal::BoxBox(pa, X_WA, MakePolytope(b, &scratch_b), X_WB, envelope,
                                          out);
      }
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

bool EnvelopeOnlyFilters(ShapeType a, ShapeType b) {
  // SphereSphere, SphereCapsule, SphereBox, SpherePolytope and the ball/vertex passes of the
  // half-space pairs (BallHalfSpace) each compute a contact and keep it iff gap ≤ envelope.
  const auto ball = [](ShapeType s) {
    return s == ShapeType::kSphere || s == ShapeType::kCapsule || s == ShapeType::kBox ||
           s == ShapeType::kPolyhedron || s == ShapeType::kHalfSpace;
  };
  if (a == ShapeType::kSphere) return ball(b);
  if (b == ShapeType::kSphere) return ball(a);
  if (a == ShapeType::kHalfSpace) return ball(b) && b != ShapeType::kHalfSpace;
  if (b == ShapeType::kHalfSpace) return ball(a) && a != ShapeType::kHalfSpace;
  return false;
}

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
